//! A TosNet node in a real process, on any two links: it reads frames from the previous node on
//! one endpoint and sends to the next node on another.
//!
//! - Over UDP ([`UdpNode`]) each datagram is one frame ([`Datagrams`]).
//! - Over a byte stream (serial devices, ptys, TCP) frames go between flags
//!   ([`ferrolink_runtime::tosnet::stream`]); [`LinkNode::stream`] opens such a node.
//!
//! Both read through the one read loop, [`Framed`].

use std::io;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use ferrolink_runtime::framing::Deframer;
use ferrolink_runtime::tosnet::frame::MAX_FRAME_LEN;
use ferrolink_runtime::tosnet::{stream, Node};

use crate::framed::{Datagrams, Framed};
use crate::link::Endpoint;

/// The longest a [`LinkNode::step`] waits for a frame.
const MAX_WAIT: Duration = Duration::from_millis(5);

/// How a node's links frame TosNet frames.
pub trait Framing: Deframer + Send + 'static {
    /// A parser for a new peer.
    fn new() -> Self;
    /// Puts `frame` on the wire into `wire`.
    fn wrap(frame: &[u8], wire: &mut Vec<u8>);
}

impl Framing for Datagrams {
    fn new() -> Self {
        Datagrams::default()
    }

    fn wrap(frame: &[u8], wire: &mut Vec<u8>) {
        wire.clear();
        wire.extend_from_slice(frame);
    }
}

impl Framing for stream::Parser {
    fn new() -> Self {
        stream::Parser::new()
    }

    fn wrap(frame: &[u8], wire: &mut Vec<u8>) {
        wire.resize(stream::encoded_len(frame), 0);
        let n = stream::encode(frame, wire).unwrap_or(0);
        wire.truncate(n);
    }
}

/// A [`Node`] on two links of the link layer: `prev` brings the previous node's frames,
/// `next` takes this node's to the next.
#[derive(Debug)]
pub struct LinkNode<F: Framing> {
    node: Node,
    prev: Framed<F>,
    next: Framed<F>,
    epoch: Instant,
    tx: Vec<u8>,
    wire: Vec<u8>,
    /// Frames that could not be sent (the next node's port is closed, for example).
    pub send_errors: u64,
}

/// A TosNet node on UDP: one frame per datagram.
pub type UdpNode = LinkNode<Datagrams>;

impl UdpNode {
    /// Binds `listen` (every datagram arriving there is a frame) and sends to `next`.
    pub fn bind(node: Node, listen: SocketAddr, next: SocketAddr) -> io::Result<Self> {
        LinkNode::open(
            node,
            &Endpoint::UdpIn(listen.ip().to_string(), listen.port()),
            &Endpoint::UdpOut(next.ip().to_string(), next.port()),
        )
    }
}

impl LinkNode<stream::Parser> {
    /// A node on byte streams: `prev` and `next` are serial devices, ptys or TCP endpoints.
    pub fn stream(node: Node, prev: &Endpoint, next: &Endpoint) -> io::Result<Self> {
        LinkNode::open(node, prev, next)
    }
}

impl<F> LinkNode<F>
where
    F: Framing,
    for<'p> F: Deframer<Frame<'p> = &'p [u8]>,
{
    /// Opens both links.
    pub fn open(node: Node, prev: &Endpoint, next: &Endpoint) -> io::Result<Self> {
        Ok(LinkNode {
            node,
            prev: Framed::open(prev, F::new)?,
            next: Framed::open(next, F::new)?,
            epoch: Instant::now(),
            tx: vec![0; MAX_FRAME_LEN],
            wire: Vec::with_capacity(2 * MAX_FRAME_LEN),
            send_errors: 0,
        })
    }

    /// The node.
    pub fn node(&self) -> &Node {
        &self.node
    }

    /// The node, to write and commit.
    pub fn node_mut(&mut self) -> &mut Node {
        &mut self.node
    }

    /// The address the node listens on (UDP).
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.prev
            .local_addr()
            .ok_or_else(|| io::Error::from(io::ErrorKind::AddrNotAvailable))
    }

    /// Nanoseconds since the node was opened: the node's clock.
    pub fn now(&self) -> u64 {
        u64::try_from(self.epoch.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }

    /// Waits for frames (or the node's next deadline, at most 5 ms), handles them, then runs
    /// the node's timers.
    pub fn step(&mut self) -> io::Result<()> {
        let now = self.now();
        let wait = self
            .node
            .next_deadline()
            .map_or(MAX_WAIT, |t| Duration::from_nanos(t.saturating_sub(now)))
            .min(MAX_WAIT);
        // Learn the next node's link (a peer appears when it is connected), ignore what it says.
        self.next.poll(|_, _| {})?;
        let (node, tx, epoch) = (&mut self.node, &mut self.tx, self.epoch);
        let (next, wire, errors) = (&self.next, &mut self.wire, &mut self.send_errors);
        self.prev.wait(Some(wait), |_, frame| {
            let now = u64::try_from(epoch.elapsed().as_nanos()).unwrap_or(u64::MAX);
            if let Some(out) = node.receive(frame, now, tx) {
                send(next, wire, errors, &tx[..out]);
            }
        })?;
        loop {
            let now = self.now();
            let Some(out) = self.node.poll(now, &mut self.tx) else {
                break;
            };
            send(
                &self.next,
                &mut self.wire,
                &mut self.send_errors,
                &self.tx[..out],
            );
        }
        Ok(())
    }

    /// Steps for `duration`.
    pub fn run_for(&mut self, duration: Duration) -> io::Result<()> {
        let end = Instant::now() + duration;
        while Instant::now() < end {
            self.step()?;
        }
        Ok(())
    }
}

/// Sends one frame to the next node. A closed link downstream is no reason to stop: the
/// watchdog deals with the broken ring.
fn send<F: Framing>(next: &Framed<F>, wire: &mut Vec<u8>, errors: &mut u64, frame: &[u8]) {
    F::wrap(frame, wire);
    if next.send(wire).is_err() {
        *errors += 1;
    }
}
