//! A TosNet node in a real process: it receives frames on its own UDP port and sends to the
//! next node's, one frame per datagram.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use ferrolink_runtime::tosnet::frame::MAX_FRAME_LEN;
use ferrolink_runtime::tosnet::Node;

/// The longest a [`UdpNode::step`] waits for a frame.
const MAX_WAIT: Duration = Duration::from_millis(5);
/// Deadlines closer than this are waited for by polling the socket.
pub const PRECISE_BELOW: Duration = Duration::from_millis(2);
/// The sleep between polls then.
const PRECISE_STEP: Duration = Duration::from_micros(50);

/// A [`Node`] on a UDP socket.
#[derive(Debug)]
pub struct UdpNode {
    node: Node,
    socket: UdpSocket,
    next: SocketAddr,
    epoch: Instant,
    rx: Vec<u8>,
    tx: Vec<u8>,
    /// Frames that could not be sent (the next node's port is closed, for example).
    pub send_errors: u64,
}

impl UdpNode {
    /// Binds `listen` and sends to `next`.
    pub fn bind(node: Node, listen: SocketAddr, next: SocketAddr) -> io::Result<Self> {
        let socket = UdpSocket::bind(listen)?;
        Ok(Self {
            node,
            socket,
            next,
            epoch: Instant::now(),
            rx: vec![0; 65536],
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
        self.socket.local_addr()
    }

    /// Nanoseconds since the node was bound: the node's clock.
    pub fn now(&self) -> u64 {
        u64::try_from(self.epoch.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }

    /// Waits for one frame (or the node's next deadline, at most 5 ms), handles it, then runs
    /// the node's timers.
    ///
    /// A socket's receive timeout only has the kernel's tick as resolution (several ms), so a
    /// deadline closer than [`PRECISE_BELOW`] is waited for with short sleeps and non-blocking
    /// reads instead.
    pub fn step(&mut self) -> io::Result<()> {
        let now = self.now();
        let wait = self
            .node
            .next_deadline()
            .map_or(MAX_WAIT, |t| Duration::from_nanos(t.saturating_sub(now)))
            .min(MAX_WAIT);
        let received = if wait >= PRECISE_BELOW {
            self.socket.set_nonblocking(false)?;
            self.socket
                .set_read_timeout(Some(wait - PRECISE_BELOW / 2))?;
            self.socket.recv(&mut self.rx)
        } else {
            self.socket.set_nonblocking(true)?;
            let got = self.socket.recv(&mut self.rx);
            if got.is_err() && !wait.is_zero() {
                std::thread::sleep(wait.min(PRECISE_STEP));
            }
            got
        };
        match received {
            Ok(len) => {
                let now = self.now();
                if let Some(out) = self.node.receive(&self.rx[..len], now, &mut self.tx) {
                    self.send(out);
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) => {}
            // A closed port downstream comes back as an error on some systems; the watchdog
            // deals with the broken ring.
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {}
            Err(e) => return Err(e),
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
        if self.socket.send_to(&self.tx[..len], self.next).is_err() {
            self.send_errors += 1;
        }
    }
}
