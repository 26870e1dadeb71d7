//! An in-process TosNet ring on a virtual clock: nodes joined by simulated links with a bit
//! rate and a per-node delay, for tests, the cycle-rate model and what-if runs.
//!
//! Timing, per link and frame of `L` bytes at bit rate `B`, node delay `d`:
//!
//! - **cut-through** (the FPGA original): a node relays a frame's first byte `d` after it
//!   arrived and the frame takes `8 L / B` on the wire, so one cycle of `i` nodes takes
//!   `i d + 8 L / B`: the model's formula, with `L = 4 + 32 r`;
//! - **store & forward** (software nodes on a real link): a node starts sending `d` after the
//!   whole frame is in, so a cycle takes `i (d + 8 L / B)`.
//!
//! A frame a node starts itself (the master's next DATA, a setup step, anything from a poll)
//! leaves `d` after the node decided to send it. A link sends one frame at a time.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use ferrolink_runtime::tosnet::frame::MAX_FRAME_LEN;
use ferrolink_runtime::tosnet::{Node, Role};

/// How frames cross a link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Forwarding {
    /// Relay while receiving, as the FPGA does.
    CutThrough,
    /// Receive whole, then send, as a software node does.
    StoreAndForward,
}

/// The links' timing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkModel {
    /// Bits per second.
    pub bitrate: f64,
    /// Node-to-node delay in ns.
    pub node_delay_ns: u64,
    /// Cut-through or store & forward.
    pub forwarding: Forwarding,
}

impl Default for LinkModel {
    /// The paper's figures: 10 Mbit/s, 5.46 µs per node, cut-through.
    fn default() -> Self {
        Self {
            bitrate: ferrolink_runtime::tosnet::PAPER_BITRATE,
            node_delay_ns: ferrolink_runtime::tosnet::PAPER_NODE_DELAY_NS as u64,
            forwarding: Forwarding::CutThrough,
        }
    }
}

impl LinkModel {
    /// Time on the wire for `len` bytes.
    pub fn airtime_ns(&self, len: usize) -> u64 {
        (len as f64 * 8.0 * 1e9 / self.bitrate).round() as u64
    }
}

pub use ferrolink_runtime::tosnet::model_rate;

#[derive(Debug, PartialEq, Eq, PartialOrd, Ord)]
enum What {
    /// A frame's last byte reaches node `to`.
    Deliver {
        to: usize,
        started: u64,
        frame: Vec<u8>,
    },
    /// Node `node`'s poll deadline (stale if the node's deadline moved).
    Poll { node: usize },
}

/// A ring of [`Node`]s on a virtual clock.
#[derive(Debug)]
pub struct Ring {
    /// The nodes, by index.
    pub nodes: Vec<Node>,
    next: Vec<Option<usize>>,
    alive: Vec<bool>,
    link_free: Vec<u64>,
    poll_at: Vec<Option<u64>>,
    corrupt: Vec<usize>,
    model: LinkModel,
    now: u64,
    seq: u64,
    queue: BinaryHeap<Reverse<(u64, u64, What)>>,
    out: Vec<u8>,
    /// Frames lost because they were sent into a dead node or a missing link.
    pub lost: u64,
}

impl Ring {
    /// `nodes` joined in a ring in the order given.
    pub fn new(nodes: Vec<Node>, model: LinkModel) -> Self {
        let n = nodes.len();
        let mut ring = Self {
            next: (0..n).map(|i| Some((i + 1) % n)).collect(),
            alive: vec![true; n],
            link_free: vec![0; n],
            poll_at: vec![None; n],
            corrupt: vec![0; n],
            nodes,
            model,
            now: 0,
            seq: 0,
            queue: BinaryHeap::new(),
            out: vec![0; MAX_FRAME_LEN],
            lost: 0,
        };
        for i in 0..n {
            ring.schedule_poll(i);
        }
        ring
    }

    /// The virtual time in ns.
    pub fn now(&self) -> u64 {
        self.now
    }

    /// The link model.
    pub fn model(&self) -> LinkModel {
        self.model
    }

    /// Adds a node, not yet linked: give it a place with [`link`](Self::link).
    pub fn add(&mut self, node: Node) -> usize {
        self.nodes.push(node);
        self.next.push(None);
        self.alive.push(true);
        self.link_free.push(0);
        self.poll_at.push(None);
        self.corrupt.push(0);
        let i = self.nodes.len() - 1;
        self.schedule_poll(i);
        i
    }

    /// Rewires node `from`'s output to node `to` (a fibre replugged).
    pub fn link(&mut self, from: usize, to: usize) {
        self.next[from] = Some(to);
    }

    /// Switches node `i` off: frames sent to it are lost and it does nothing.
    pub fn kill(&mut self, i: usize) {
        self.alive[i] = false;
    }

    /// Flips a bit in each of the next `count` DATA frames node `i` sends.
    pub fn corrupt_data_from(&mut self, i: usize, count: usize) {
        self.corrupt[i] = count;
    }

    /// The index of the current master, if one is running.
    pub fn master(&self) -> Option<usize> {
        self.nodes
            .iter()
            .position(|n| n.status().role == Role::Master)
    }

    /// Runs until virtual time `until` (ns).
    pub fn run_until(&mut self, until: u64) {
        while let Some(Reverse((t, _, _))) = self.queue.peek() {
            if *t > until {
                break;
            }
            let Some(Reverse((t, _, what))) = self.queue.pop() else {
                break;
            };
            self.now = t;
            match what {
                What::Deliver { to, started, frame } => {
                    if !self.alive[to] {
                        self.lost += 1;
                        continue;
                    }
                    let mut out = std::mem::take(&mut self.out);
                    let sent = self.nodes[to].receive_timed(&frame, started, t, &mut out);
                    if let Some(len) = sent {
                        let relay = self.nodes[to].status().role != Role::Master;
                        let head = match (self.model.forwarding, relay) {
                            (Forwarding::CutThrough, true) => started,
                            _ => t,
                        };
                        self.send(to, head, out[..len].to_vec());
                    }
                    self.out = out;
                    self.drain_polls(to);
                }
                What::Poll { node } => {
                    if self.poll_at[node] != Some(t) || !self.alive[node] {
                        continue;
                    }
                    self.poll_at[node] = None;
                    self.drain_polls(node);
                }
            }
        }
        self.now = self.now.max(until);
    }

    /// Runs for `ns` more.
    pub fn run_for(&mut self, ns: u64) {
        self.run_until(self.now + ns);
    }

    fn drain_polls(&mut self, i: usize) {
        let mut out = std::mem::take(&mut self.out);
        while let Some(len) = self.nodes[i].poll(self.now, &mut out) {
            self.send(i, self.now, out[..len].to_vec());
        }
        self.out = out;
        self.schedule_poll(i);
    }

    /// Node `from` sends `frame`, whose first byte it got (or decided to send) at `head`.
    fn send(&mut self, from: usize, head: u64, mut frame: Vec<u8>) {
        let Some(to) = self.next[from] else {
            self.lost += 1;
            return;
        };
        if self.corrupt[from] > 0 && frame.first().map(|b| b >> 4) == Some(0xA) {
            self.corrupt[from] -= 1;
            if let Some(b) = frame.get_mut(3) {
                *b ^= 0x10;
            }
        }
        let start = (head + self.model.node_delay_ns).max(self.link_free[from]);
        let end = start + self.model.airtime_ns(frame.len());
        self.link_free[from] = end;
        self.push(
            end,
            What::Deliver {
                to,
                started: start,
                frame,
            },
        );
    }

    fn schedule_poll(&mut self, i: usize) {
        let Some(t) = self.nodes[i].next_deadline() else {
            return;
        };
        let t = t.max(self.now);
        if self.poll_at[i].is_some_and(|p| p <= t) {
            return;
        }
        self.poll_at[i] = Some(t);
        self.push(t, What::Poll { node: i });
    }

    fn push(&mut self, t: u64, what: What) {
        self.seq += 1;
        self.queue.push(Reverse((t, self.seq, what)));
    }
}
