//! A deterministic discrete-event simulation of NDLCom bridges joined by UART links, shared by
//! `tests/ndlcom_sim.rs` (router scenarios, ping timing) and `examples/ndlcom_timing.rs`.
//!
//! - A node is a [`Bridge`] of any size behind the [`Node`] trait, with an [`App`] on top that
//!   logs the frames for the node, tracks missed packets and answers pings.
//! - A link is two lines, one per direction (full duplex, point to point). A line sends one byte
//!   at a time, 10 bits per byte (8N1), so a byte takes `10 / baud` seconds; it pulls the next
//!   byte from [`Bridge::transmit`] whenever it is idle, so a sender with bytes waiting sends
//!   them back to back. A byte reaches the other end ([`Bridge::receive`]) when its transmission
//!   ends.
//! - Time is integer nanoseconds. The byte time is rounded to the nearest nanosecond (10851 ns
//!   at 921600 Bd instead of 10850.69 ns: 0.003 % slow); the bridges get microseconds, rounded
//!   down.
//! - Events are ordered by (time, sequence number), so a run is fully deterministic. Whenever a
//!   node's state changes, its idle lines are offered bytes at once: a byte that arrives at the
//!   instant an outgoing line falls idle goes out without a gap, whichever event runs first.
//! - Faults on a line drop or corrupt bytes in flight, addressed by frame number on that line.
#![allow(dead_code)]

use std::any::Any;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::fmt::{self, Write as _};
use std::ops::RangeInclusive;

use ferrolink_runtime::ndlcom::bridge::{Bridge, IfaceStats, Mode};
use ferrolink_runtime::ndlcom::counters::{MissTracker, Observation};
use ferrolink_runtime::ndlcom::parser::Frame;
use ferrolink_runtime::ndlcom::{encoded_len, storage_len, Header, FLAG};

/// The PING message id of our dictionaries: the first payload byte of a ping.
pub const PING: u8 = 4;
/// The PING layout: id, `time_usec` (8), `seq` (4), `target_system`, `target_component`.
pub const PING_MIN_LEN: usize = 15;
/// Offset of PING's `target_system`: 0 in a request, the requester's id in the answer.
const PING_TARGET: usize = 13;

/// A ping request of `len` payload bytes (at least [`PING_MIN_LEN`]; the rest is zeros).
pub fn ping_payload(seq: u32, time_us: u64, len: usize) -> Vec<u8> {
    assert!(len >= PING_MIN_LEN, "a PING payload has at least 15 bytes");
    let mut p = vec![0u8; len];
    p[0] = PING;
    p[1..9].copy_from_slice(&time_us.to_le_bytes());
    p[9..13].copy_from_slice(&seq.to_le_bytes());
    p
}

/// Whether a payload is a ping request (PING with `target_system` 0).
pub fn is_ping_request(payload: &[u8]) -> bool {
    payload.len() >= PING_MIN_LEN && payload[0] == PING && payload[PING_TARGET] == 0
}

/// Whether a payload is a ping answer (PING with `target_system` set).
pub fn is_ping_answer(payload: &[u8]) -> bool {
    payload.len() >= PING_MIN_LEN && payload[0] == PING && payload[PING_TARGET] != 0
}

/// The answer to a ping request: the same payload, `target_system` naming the requester.
pub fn ping_answer(request: &[u8], requester: u8) -> Vec<u8> {
    let mut answer = request.to_vec();
    answer[PING_TARGET] = requester;
    answer
}

/// The `seq` field of a ping.
pub fn ping_seq(payload: &[u8]) -> u32 {
    u32::from_le_bytes(payload[9..13].try_into().expect("a PING payload"))
}

/// Nanoseconds one byte takes at `baud` with 8N1 framing (10 bits), rounded.
pub fn byte_ns(baud: u32) -> u64 {
    let baud = u64::from(baud);
    (10_000_000_000 + baud / 2) / baud
}

/// What the simulator needs of a node; every [`Bridge`] is one.
pub trait Node: fmt::Debug {
    /// The interface count `N`.
    fn interfaces(&self) -> usize;
    /// [`Bridge::receive`].
    fn receive(&mut self, i: usize, bytes: &[u8], now_us: u64, on_local: &mut dyn FnMut(Frame<'_>));
    /// [`Bridge::transmit`].
    fn transmit(&mut self, i: usize, out: &mut [u8]) -> usize;
    /// [`Bridge::poll`].
    fn poll(&mut self, now_us: u64);
    /// [`Bridge::send`] of one payload.
    fn send(&mut self, receiver: u8, sender: u8, payload: &[u8]);
    /// Whether `id` is one of the node's own ids.
    fn is_own(&self, id: u8) -> bool;
    /// The routing table entry for `id`.
    fn lookup(&self, id: u8) -> Option<usize>;
    /// [`Bridge::stats`].
    fn stats(&self, i: usize) -> IfaceStats;
    /// [`Bridge::pending`].
    fn pending(&self, i: usize) -> usize;
    /// Sets `mode` for every pair of distinct interfaces.
    fn set_mode_all(&mut self, mode: Mode);
    /// The bridge itself, for [`Sim::bridge_mut`].
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<const N: usize, const P: usize, const Q: usize, const A: usize> Node for Bridge<N, P, Q, A> {
    fn interfaces(&self) -> usize {
        N
    }

    fn receive(
        &mut self,
        i: usize,
        bytes: &[u8],
        now_us: u64,
        on_local: &mut dyn FnMut(Frame<'_>),
    ) {
        Bridge::receive(self, i, bytes, now_us, on_local);
    }

    fn transmit(&mut self, i: usize, out: &mut [u8]) -> usize {
        Bridge::transmit(self, i, out)
    }

    fn poll(&mut self, now_us: u64) {
        Bridge::poll(self, now_us);
    }

    fn send(&mut self, receiver: u8, sender: u8, payload: &[u8]) {
        Bridge::send(self, receiver, sender, &[payload]).expect("payload of at most 255 bytes");
    }

    fn is_own(&self, id: u8) -> bool {
        self.router().is_own(id)
    }

    fn lookup(&self, id: u8) -> Option<usize> {
        self.router().lookup(id)
    }

    fn stats(&self, i: usize) -> IfaceStats {
        Bridge::stats(self, i)
    }

    fn pending(&self, i: usize) -> usize {
        Bridge::pending(self, i)
    }

    fn set_mode_all(&mut self, mode: Mode) {
        for from in 0..N {
            for to in (0..N).filter(|&to| to != from) {
                self.set_mode(from, to, mode);
            }
        }
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// A bridge with payloads up to 255 bytes, `N` interfaces, `Q`-byte queues and own id `id`.
pub fn bridge<const N: usize, const Q: usize>(id: u8) -> Bridge<N, { storage_len(255) }, Q> {
    let mut b = Bridge::new();
    b.router_mut().add_own_id(id);
    b
}

/// A frame an [`App`] got: addressed to one of its node's ids, or a broadcast.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Received {
    /// When the frame was complete (its last FCS byte was in), nanoseconds.
    pub at_ns: u64,
    pub header: Header,
    pub payload: Vec<u8>,
    /// What the missed-packet tracker made of its counter.
    pub observation: Observation,
}

/// The application of a node: logs its frames, tracks missed packets, answers pings.
#[derive(Debug)]
pub struct App {
    /// Answer ping requests addressed to one of the node's ids.
    pub answer_pings: bool,
    pub received: Vec<Received>,
    pub misses: Box<MissTracker>,
}

impl App {
    fn new() -> Self {
        App {
            answer_pings: true,
            received: Vec::new(),
            misses: Box::new(MissTracker::new()),
        }
    }

    /// Ping answers received, in order.
    pub fn answers(&self) -> impl Iterator<Item = &Received> + '_ {
        self.received.iter().filter(|r| is_ping_answer(&r.payload))
    }
}

/// Counters of one line (one direction of a link).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LineStats {
    /// Bytes sent, lost ones included.
    pub bytes: u64,
    /// Frames started (opening flags).
    pub frames: u64,
    /// Bytes lost in flight.
    pub lost: u64,
    /// Bytes corrupted in flight.
    pub corrupted: u64,
    /// When the first byte started, nanoseconds.
    pub first_start_ns: Option<u64>,
    /// When the last byte was delivered, nanoseconds.
    pub last_delivery_ns: Option<u64>,
}

/// Something that happens to bytes in flight on one line. Frames are counted per line from 0 by
/// their opening flags; offset 0 is the opening flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Every byte of the frame, flags included, is lost: the receiver never sees a trace of it.
    DropFrame { frame: u64 },
    /// One byte of the frame is XORed with `xor`.
    Corrupt { frame: u64, offset: usize, xor: u8 },
}

/// Index of a node in a [`Sim`].
pub type NodeId = usize;
/// Index of a line in a [`Sim`].
pub type LineId = usize;

#[derive(Debug)]
struct Line {
    from: (NodeId, usize),
    to: (NodeId, usize),
    byte_ns: u64,
    busy: bool,
    /// Between an opening and a closing flag.
    in_frame: bool,
    /// The frame being sent and the offset of the last byte in it.
    frame: u64,
    offset: usize,
    faults: Vec<Fault>,
    stats: LineStats,
}

impl Line {
    /// Places byte `b` in the line's frames: (frame number, offset), or `None` between frames.
    fn locate(&mut self, b: u8) -> Option<(u64, usize)> {
        if !self.in_frame {
            if b != FLAG {
                return None;
            }
            self.in_frame = true;
            self.frame = self.stats.frames;
            self.stats.frames += 1;
            self.offset = 0;
        } else {
            self.offset += 1;
            if b == FLAG {
                self.in_frame = false;
            }
        }
        Some((self.frame, self.offset))
    }
}

#[derive(Debug)]
struct Station {
    node: Box<dyn Node>,
    app: App,
    /// The outgoing line of each interface, if connected.
    lines: Vec<Option<LineId>>,
    /// A poll is due at this time (the byte timeout after the last byte in).
    poll_due_ns: u64,
    poll_scheduled: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Event {
    /// A byte's transmission on `line` ended; it reaches the other end unless it was lost.
    Sent { line: LineId, byte: u8, lost: bool },
    /// Time for a node's byte timeout check.
    Poll { node: NodeId },
}

/// The simulated network.
#[derive(Debug)]
pub struct Sim {
    now_ns: u64,
    seq: u64,
    events: BinaryHeap<Reverse<(u64, u64, Event)>>,
    nodes: Vec<Station>,
    lines: Vec<Line>,
    /// Nodes are polled this long after their last received byte: just over the bridges'
    /// default 1 ms byte timeout.
    pub poll_after_ns: u64,
    /// [`Sim::run`] panics after this many events: a frame circulating forever ends the test.
    pub max_events: u64,
}

impl Default for Sim {
    fn default() -> Self {
        Self::new()
    }
}

impl Sim {
    pub fn new() -> Self {
        Sim {
            now_ns: 0,
            seq: 0,
            events: BinaryHeap::new(),
            nodes: Vec::new(),
            lines: Vec::new(),
            poll_after_ns: 1_001_000,
            max_events: 10_000_000,
        }
    }

    /// Adds a node; its app answers pings.
    pub fn add(&mut self, node: impl Node + 'static) -> NodeId {
        let n = node.interfaces();
        self.nodes.push(Station {
            node: Box::new(node),
            app: App::new(),
            lines: vec![None; n],
            poll_due_ns: 0,
            poll_scheduled: false,
        });
        self.nodes.len() - 1
    }

    /// Links interface `ia` of `a` and interface `ib` of `b` at `baud`; returns the lines
    /// a -> b and b -> a.
    pub fn connect(
        &mut self,
        a: NodeId,
        ia: usize,
        b: NodeId,
        ib: usize,
        baud: u32,
    ) -> (LineId, LineId) {
        let mut line = |from: (NodeId, usize), to: (NodeId, usize)| {
            let slot = &mut self.nodes[from.0].lines[from.1];
            assert!(slot.is_none(), "interface {from:?} is already connected");
            *slot = Some(self.lines.len());
            self.lines.push(Line {
                from,
                to,
                byte_ns: byte_ns(baud),
                busy: false,
                in_frame: false,
                frame: 0,
                offset: 0,
                faults: Vec::new(),
                stats: LineStats::default(),
            });
            self.lines.len() - 1
        };
        (line((a, ia), (b, ib)), line((b, ib), (a, ia)))
    }

    /// The line from `a` to `b`.
    pub fn line(&self, a: NodeId, b: NodeId) -> LineId {
        self.lines
            .iter()
            .position(|l| l.from.0 == a && l.to.0 == b)
            .expect("the nodes are linked")
    }

    /// Adds a fault to a line.
    pub fn fault(&mut self, line: LineId, fault: Fault) {
        self.lines[line].faults.push(fault);
    }

    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    pub fn node(&self, n: NodeId) -> &dyn Node {
        &*self.nodes[n].node
    }

    /// The bridge of node `n` as its concrete type, e.g. to reach its router.
    pub fn bridge_mut<B: 'static>(&mut self, n: NodeId) -> &mut B {
        self.nodes[n]
            .node
            .as_any_mut()
            .downcast_mut()
            .expect("the node's bridge type")
    }

    pub fn app(&self, n: NodeId) -> &App {
        &self.nodes[n].app
    }

    pub fn app_mut(&mut self, n: NodeId) -> &mut App {
        &mut self.nodes[n].app
    }

    pub fn line_stats(&self, line: LineId) -> LineStats {
        self.lines[line].stats
    }

    /// Sets `mode` for every pair of interfaces of every node.
    pub fn set_mode_all(&mut self, mode: Mode) {
        for station in &mut self.nodes {
            station.node.set_mode_all(mode);
        }
    }

    /// Counters of every interface of every node, summed.
    pub fn totals(&self) -> IfaceStats {
        let mut t = IfaceStats::default();
        for station in &self.nodes {
            for i in 0..station.node.interfaces() {
                let s = station.node.stats(i);
                t.rx_bytes += s.rx_bytes;
                t.rx_frames += s.rx_frames;
                t.tx_bytes += s.tx_bytes;
                t.tx_frames += s.tx_frames;
                t.crc_failures += s.crc_failures;
                t.dropped += s.dropped;
                t.queue_overflows += s.queue_overflows;
                t.cut_through += s.cut_through;
                t.timeouts += s.timeouts;
            }
        }
        t
    }

    /// Frames started on all lines.
    pub fn frames_on_lines(&self) -> u64 {
        self.lines.iter().map(|l| l.stats.frames).sum()
    }

    /// Bytes waiting in all queues.
    pub fn pending(&self) -> usize {
        self.nodes
            .iter()
            .map(|s| {
                (0..s.node.interfaces())
                    .map(|i| s.node.pending(i))
                    .sum::<usize>()
            })
            .sum()
    }

    /// Node `n` sends a frame now.
    pub fn send(&mut self, n: NodeId, receiver: u8, sender: u8, payload: &[u8]) {
        self.nodes[n].node.send(receiver, sender, payload);
        self.kick(n);
    }

    /// Node `n` sends a ping request of `len` payload bytes from `sender` to `receiver` now;
    /// returns its payload.
    pub fn ping(&mut self, n: NodeId, sender: u8, receiver: u8, seq: u32, len: usize) -> Vec<u8> {
        let payload = ping_payload(seq, self.now_ns / 1000, len);
        self.send(n, receiver, sender, &payload);
        payload
    }

    /// Runs until nothing is left to happen; returns the number of events.
    pub fn run(&mut self) -> u64 {
        self.run_until(u64::MAX)
    }

    /// Runs the events up to `until_ns` (inclusive); returns their number.
    pub fn run_until(&mut self, until_ns: u64) -> u64 {
        let mut count = 0;
        while let Some(&Reverse((at, _, event))) = self.events.peek() {
            if at > until_ns {
                break;
            }
            self.events.pop();
            count += 1;
            assert!(
                count <= self.max_events,
                "the network did not settle after {count} events"
            );
            self.now_ns = at;
            match event {
                Event::Sent { line, byte, lost } => self.sent(line, byte, lost),
                Event::Poll { node } => self.poll(node),
            }
        }
        if until_ns != u64::MAX {
            self.now_ns = self.now_ns.max(until_ns);
        }
        count
    }

    fn schedule(&mut self, at_ns: u64, event: Event) {
        self.seq += 1;
        self.events.push(Reverse((at_ns, self.seq, event)));
    }

    /// Starts a byte on every idle line of node `n` that has one to send.
    fn kick(&mut self, n: NodeId) {
        for i in 0..self.nodes[n].lines.len() {
            let Some(l) = self.nodes[n].lines[i] else {
                continue;
            };
            if self.lines[l].busy {
                continue;
            }
            let mut byte = [0u8];
            if self.nodes[n].node.transmit(i, &mut byte) == 0 {
                continue;
            }
            let now = self.now_ns;
            let line = &mut self.lines[l];
            line.busy = true;
            line.stats.bytes += 1;
            line.stats.first_start_ns.get_or_insert(now);
            let mut lost = false;
            let mut b = byte[0];
            if let Some((frame, offset)) = line.locate(b) {
                for fault in &line.faults {
                    match *fault {
                        Fault::DropFrame { frame: f } if f == frame => lost = true,
                        Fault::Corrupt {
                            frame: f,
                            offset: o,
                            xor,
                        } if f == frame && o == offset => {
                            b ^= xor;
                            line.stats.corrupted += 1;
                        }
                        _ => {}
                    }
                }
            }
            if lost {
                line.stats.lost += 1;
            }
            let at = now + line.byte_ns;
            self.schedule(
                at,
                Event::Sent {
                    line: l,
                    byte: b,
                    lost,
                },
            );
        }
    }

    fn sent(&mut self, l: LineId, byte: u8, lost: bool) {
        let line = &mut self.lines[l];
        line.busy = false;
        let (from, (to, iface)) = (line.from.0, line.to);
        if !lost {
            line.stats.last_delivery_ns = Some(self.now_ns);
            self.deliver(to, iface, byte);
        }
        self.kick(from);
    }

    fn deliver(&mut self, n: NodeId, iface: usize, byte: u8) {
        let now = self.now_ns;
        let station = &mut self.nodes[n];
        let mut local = Vec::new();
        station.node.receive(iface, &[byte], now / 1000, &mut |f| {
            local.push((f.header(), f.payload().to_vec()));
        });
        for (header, payload) in local {
            let observation = station.app.misses.observe(&header);
            let answer = (station.app.answer_pings
                && station.node.is_own(header.receiver)
                && is_ping_request(&payload))
            .then(|| ping_answer(&payload, header.sender));
            station.app.received.push(Received {
                at_ns: now,
                header,
                payload,
                observation,
            });
            if let Some(answer) = answer {
                station.node.send(header.sender, header.receiver, &answer);
            }
        }
        station.poll_due_ns = now + self.poll_after_ns;
        if !station.poll_scheduled {
            station.poll_scheduled = true;
            let due = station.poll_due_ns;
            self.schedule(due, Event::Poll { node: n });
        }
        self.kick(n);
    }

    fn poll(&mut self, n: NodeId) {
        let now = self.now_ns;
        let station = &mut self.nodes[n];
        if station.poll_due_ns > now {
            let due = station.poll_due_ns;
            self.schedule(due, Event::Poll { node: n });
            return;
        }
        station.poll_scheduled = false;
        station.node.poll(now / 1000);
        self.kick(n);
    }
}

// ---------------------------------------------------------------------------------------------
// Ping round trips against the spec's timing model.
//
// "Hops" n is the number of forwarding bridges between the pinging and the answering node; the
// ping crosses n + 1 links. That is the only reading under which the spec's worked figures come
// out: store & forward sends a frame once per link, (n + 1) * t_trans = n * t_forward + t_trans
// one way, and 2 * 4 * 306.0 + 2 * 306.0 = 3060 us for 4 hops. Likewise cut-through with 4
// hops: 2 * 4 * 3 * 10.85 + 2 * 306.0 = 872.5 us.
// ---------------------------------------------------------------------------------------------

/// The UART rate of the timing table.
pub const TIMING_BAUD: u32 = 921_600;
/// The ping payload length of the timing table.
pub const TIMING_PAYLOAD: usize = 20;

/// One simulated ping round trip.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rtt {
    pub hops: usize,
    pub mode: Mode,
    /// From the first byte of the ping starting on the wire to the last byte of the answer
    /// (its closing flag) being received.
    pub measured_ns: u64,
    /// From the same start to the answer's frame being complete at the pinging node (its last
    /// FCS byte in): what the application sees.
    pub decoded_ns: u64,
    /// Encoded lengths of the ping and of its answer, flags included.
    pub ping_len: usize,
    pub answer_len: usize,
    /// The simulated byte time.
    pub byte_ns: u64,
}

/// Pings across `hops` bridges, all forwarding `mode`, every link at `baud`.
pub fn ping_rtt(hops: usize, mode: Mode, baud: u32, payload_len: usize) -> Rtt {
    const PINGER: u8 = 1;
    const TARGET: u8 = 2;
    let mut sim = Sim::new();
    let pinger = sim.add(bridge::<1, 1024>(PINGER));
    let mut prev = (pinger, 0);
    for k in 0..hops {
        let relay = sim.add(bridge::<2, 1024>(10 + k as u8));
        sim.connect(prev.0, prev.1, relay, 0, baud);
        prev = (relay, 1);
    }
    let target = sim.add(bridge::<1, 1024>(TARGET));
    sim.connect(prev.0, prev.1, target, 0, baud);
    sim.set_mode_all(mode);

    let request = sim.ping(pinger, PINGER, TARGET, 1, payload_len);
    sim.run();

    let answers: Vec<_> = sim.app(pinger).answers().cloned().collect();
    assert_eq!(answers.len(), 1, "one answer");
    assert_eq!(answers[0].payload, ping_answer(&request, PINGER));
    let out = sim.line_stats(sim.line(pinger, pinger + 1));
    let back = sim.line_stats(sim.line(pinger + 1, pinger));
    let start = out.first_start_ns.expect("the ping went out");
    let ping_len = encoded_len(
        &Header::new(TARGET, PINGER, 0, payload_len as u8),
        &[&request],
    );
    let answer_len = encoded_len(
        &Header::new(PINGER, TARGET, 0, payload_len as u8),
        &[&answers[0].payload],
    );
    Rtt {
        hops,
        mode,
        measured_ns: back.last_delivery_ns.expect("the answer came back") - start,
        decoded_ns: answers[0].at_ns - start,
        ping_len,
        answer_len,
        byte_ns: byte_ns(baud),
    }
}

/// t_byte of the spec's model, microseconds: 10 bits per byte.
pub fn model_byte_us(baud: u32) -> f64 {
    10e6 / f64::from(baud)
}

/// The model's average encoded length: 2 + (1 + 2/256) * (4 + payload + 2).
pub fn model_encoded_len(payload_len: usize) -> f64 {
    2.0 + (1.0 + 2.0 / 256.0) * (4 + payload_len + 2) as f64
}

/// The spec's ideal ping response, microseconds: 2 * n * t_forward + 2 * t_trans, with
/// t_forward = 3 * t_byte (cut-through) or t_trans (store & forward).
pub fn model_us(hops: usize, mode: Mode, baud: u32, payload_len: usize) -> f64 {
    let t_byte = model_byte_us(baud);
    let t_trans = t_byte * model_encoded_len(payload_len);
    let t_forward = match mode {
        Mode::CutThrough => 3.0 * t_byte,
        Mode::StoreForward => t_trans,
    };
    2.0 * hops as f64 * t_forward + 2.0 * t_trans
}

/// What this bridge does, in byte times, for a ping of `lp` and an answer of `la` encoded bytes
/// (receiver ids that need no escaping):
///
/// - a frame is complete, and handed on or answered, when its last FCS byte is in: the length
///   field says where it ends, so nobody waits for the closing flag (l - 1 byte times after the
///   frame started arriving);
/// - store & forward: each bridge starts the frame on its next link l - 1 byte times after it
///   started arriving, so one way takes (n + 1) * (l - 1) byte times to the frame being
///   complete, plus the closing flag for the last byte of the answer:
///   (n + 1) * (lp - 1) + (n + 1) * (la - 1) + 1;
/// - cut-through: a bridge decides once the flag and the receiver byte are in and starts the
///   outgoing frame (flag, receiver, then every byte as it arrives) right then, 2 byte times
///   after the incoming frame started: 2n + (lp - 1) + 2n + la = 4n + lp + la - 1.
pub fn predicted_byte_times(hops: usize, mode: Mode, lp: usize, la: usize) -> u64 {
    let n = hops as u64;
    let (lp, la) = (lp as u64, la as u64);
    match mode {
        Mode::CutThrough => 4 * n + lp + la - 1,
        Mode::StoreForward => (n + 1) * (lp - 1) + (n + 1) * (la - 1) + 1,
    }
}

/// One row of the timing table.
#[derive(Debug, Clone, Copy)]
pub struct TimingRow {
    pub hops: usize,
    pub model_ct_us: f64,
    pub ct: Rtt,
    pub model_sf_us: f64,
    pub sf: Rtt,
}

/// Simulates both modes for every hop count.
pub fn timing_rows(baud: u32, payload_len: usize, hops: RangeInclusive<usize>) -> Vec<TimingRow> {
    hops.map(|n| TimingRow {
        hops: n,
        model_ct_us: model_us(n, Mode::CutThrough, baud, payload_len),
        ct: ping_rtt(n, Mode::CutThrough, baud, payload_len),
        model_sf_us: model_us(n, Mode::StoreForward, baud, payload_len),
        sf: ping_rtt(n, Mode::StoreForward, baud, payload_len),
    })
    .collect()
}

fn us(ns: u64) -> f64 {
    ns as f64 / 1000.0
}

/// The rows as a Markdown table.
pub fn timing_markdown(baud: u32, payload_len: usize, rows: &[TimingRow]) -> String {
    let mut s = String::new();
    let (lp, la) = rows
        .first()
        .map_or((0, 0), |r| (r.ct.ping_len, r.ct.answer_len));
    let _ = writeln!(
        s,
        "Ping round trip over n bridges (n + 1 links) at {baud} Bd, {payload_len}-byte payload \
         (ping {lp} B, answer {la} B encoded; the model averages {:.1} B), from the ping's first \
         byte on the wire to the answer's last byte received. Model: 2·n·t_forward + 2·t_trans.",
        model_encoded_len(payload_len)
    );
    s.push('\n');
    s.push_str(
        "| n | model CT (µs) | measured CT (µs) | Δ CT | model S&F (µs) | measured S&F (µs) | Δ S&F |\n",
    );
    s.push_str("|---:|---:|---:|---:|---:|---:|---:|\n");
    for r in rows {
        let (ct, sf) = (us(r.ct.measured_ns), us(r.sf.measured_ns));
        let _ = writeln!(
            s,
            "| {} | {:.1} | {:.1} | {:+.1} % | {:.1} | {:.1} | {:+.1} % |",
            r.hops,
            r.model_ct_us,
            ct,
            100.0 * (ct - r.model_ct_us) / r.model_ct_us,
            r.model_sf_us,
            sf,
            100.0 * (sf - r.model_sf_us) / r.model_sf_us,
        );
    }
    s
}
