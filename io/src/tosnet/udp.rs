//! A TosNet node in a real process: it receives frames on its own UDP port and sends to the
//! next node's, one frame per datagram.

use std::io;
use std::net::SocketAddr;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use ferrolink_runtime::tosnet::frame::MAX_FRAME_LEN;
use ferrolink_runtime::tosnet::Node;

use crate::link::{self, Handle, Sender};

/// The longest a [`UdpNode::step`] waits for a frame.
const MAX_WAIT: Duration = Duration::from_millis(5);

/// A [`Node`] on a UDP endpoint of the [`link`] layer.
#[derive(Debug)]
pub struct UdpNode {
    node: Node,
    handle: Handle,
    frames: mpsc::Receiver<Vec<u8>>,
    next: Sender,
    epoch: Instant,
    tx: Vec<u8>,
    /// Frames that could not be sent (the next node's port is closed, for example).
    pub send_errors: u64,
}

impl UdpNode {
    /// Binds `listen` and sends to `next`.
    pub fn bind(node: Node, listen: SocketAddr, next: SocketAddr) -> io::Result<Self> {
        let (handle, frames) = link::datagrams(listen)?;
        let next = handle
            .sender_to(next)
            .ok_or_else(|| io::Error::other("a UDP endpoint sends anywhere"))?;
        Ok(Self {
            node,
            handle,
            frames,
            next,
            epoch: Instant::now(),
            tx: vec![0; MAX_FRAME_LEN],
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

    /// The address the node listens on.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.handle
            .local_addr()
            .ok_or_else(|| io::Error::from(io::ErrorKind::AddrNotAvailable))
    }

    /// Nanoseconds since the node was bound: the node's clock.
    pub fn now(&self) -> u64 {
        u64::try_from(self.epoch.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }

    /// Waits for one frame (or the node's next deadline, at most 5 ms), handles it, then runs
    /// the node's timers.
    pub fn step(&mut self) -> io::Result<()> {
        let now = self.now();
        let wait = self
            .node
            .next_deadline()
            .map_or(MAX_WAIT, |t| Duration::from_nanos(t.saturating_sub(now)))
            .min(MAX_WAIT);
        match self.frames.recv_timeout(wait) {
            Ok(frame) => {
                let now = self.now();
                if let Some(out) = self.node.receive(&frame, now, &mut self.tx) {
                    self.send(out);
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(io::Error::other("the node's UDP endpoint stopped reading"));
            }
        }
        loop {
            let now = self.now();
            let Some(out) = self.node.poll(now, &mut self.tx) else {
                break;
            };
            self.send(out);
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

    fn send(&mut self, len: usize) {
        // A closed port downstream is no reason to stop: the watchdog deals with the broken
        // ring.
        if self.next.send(&self.tx[..len]).is_err() {
            self.send_errors += 1;
        }
    }
}
