//! A bridge: a [`Router`] with a parser and an output queue per interface, forwarding either
//! store & forward or cut-through, chosen per interface pair.
//!
//! - **Store & forward** (the default): a frame is parsed whole, its FCS checked, the routing
//!   table updated, and the frame re-encoded (escaped again; its checked FCS is kept, so no CRC
//!   is computed) into the queue of every interface it goes to. A frame that does not fit a
//!   queue is not queued at all and is counted in that interface's
//!   [`IfaceStats::queue_overflows`]: nothing is dropped silently, nothing is sent half.
//! - **Cut-through**: as soon as the receiver byte of a frame is in, the frame's bytes are
//!   streamed to the outputs the table names, so each hop adds a few byte times instead of a
//!   whole frame. An output only takes a cut-through stream when it is idle; otherwise that
//!   output gets the frame store & forward. A broken frame passes (the next hop drops it), a
//!   frame that stalls longer than the byte timeout is cut off with a flag so it cannot block
//!   the output, and the routing table learns only once the FCS checked.
//!
//! A frame is forwarded in the modes that held when its receiver byte came in: changing a
//! pair's mode while a frame is arriving takes effect with the next frame. A frame whose first
//! bytes arrived store & forward finishes store & forward (those bytes were not kept for a
//! stream), and a frame already streaming keeps streaming to its outputs until it ends. Once a
//! frame's FCS checked, where it goes (locally, into which queues) and what the table learns
//! follow from its own header, as in store & forward.
//!
//! The bridge does no I/O: feed it received bytes with [`Bridge::receive`], call
//! [`Bridge::poll`] with the time now and then, and pull bytes to send with
//! [`Bridge::transmit`]. Frames for the node itself (own ids and broadcasts) come back through
//! the `on_local` callback, and [`Bridge::send`] sends the node's own frames.
//!
//! ```
//! use ferrolink_runtime::ndlcom::{bridge::{Bridge, Mode}, encode, storage_len, Header};
//!
//! // 2 interfaces, payloads up to 64 bytes, 256-byte queues.
//! let mut bridge = Bridge::<2, { storage_len(64) }, 256>::new();
//! bridge.router_mut().add_own_id(1);
//! bridge.set_mode(0, 1, Mode::CutThrough);
//!
//! let mut frame = [0u8; 32];
//! let n = encode(&Header::new(7, 9, 0, 2), &[0xab, 0xcd], &mut frame).unwrap();
//! // The first two bytes (flag, receiver) are enough to start sending on interface 1.
//! bridge.receive(0, &frame[..2], 0, |_| {});
//! let mut out = [0u8; 32];
//! assert_eq!(bridge.transmit(1, &mut out), 2);
//! bridge.receive(0, &frame[2..n], 20, |_| {});
//! let m = bridge.transmit(1, &mut out[2..]);
//! assert_eq!(&out[..2 + m], &frame[..n]);
//! assert_eq!(bridge.router().lookup(9), Some(0)); // learned once the FCS checked
//! ```

use super::counters::TxCounters;
use super::encode::assemble;
use super::parser::{Feed, Frame, Parser};
use super::router::{Decision, Ports, Router};
use super::{storage_len, EncodeError, Header, FLAG, MAX_PAYLOAD_LEN};
use crate::hdlc::{stuff_frame, stuffed_len};

/// How frames from one interface are forwarded to another.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// Receive whole, check, re-encode.
    #[default]
    StoreForward,
    /// Start sending once the receiver byte is known.
    CutThrough,
}

/// Counters of one interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct IfaceStats {
    /// Bytes received.
    pub rx_bytes: u64,
    /// Intact frames received.
    pub rx_frames: u64,
    /// Bytes handed out by [`Bridge::transmit`].
    pub tx_bytes: u64,
    /// Frames queued (store & forward) or started (cut-through) on this interface.
    pub tx_frames: u64,
    /// Frames received whose FCS did not check.
    pub crc_failures: u64,
    /// Frames received and dropped: cut short, oversize, bad escape.
    pub dropped: u64,
    /// Frames that did not fit this interface's queue, or overran its cut-through stream.
    pub queue_overflows: u64,
    /// Frames sent on this interface cut-through.
    pub cut_through: u64,
    /// Cut-through frames from this interface cut off by the byte timeout.
    pub timeouts: u64,
}

/// A byte FIFO of `Q` bytes.
#[derive(Debug, Clone)]
struct Ring<const Q: usize> {
    buf: [u8; Q],
    head: usize,
    len: usize,
}

impl<const Q: usize> Ring<Q> {
    const fn new() -> Self {
        Ring {
            buf: [0; Q],
            head: 0,
            len: 0,
        }
    }

    fn free(&self) -> usize {
        Q - self.len
    }

    fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends `bytes` if they all fit; returns whether they did.
    fn push(&mut self, bytes: &[u8]) -> bool {
        if bytes.len() > self.free() {
            return false;
        }
        for &b in bytes {
            if let Some(slot) = self.buf.get_mut((self.head + self.len) % Q) {
                *slot = b;
            }
            self.len += 1;
        }
        true
    }

    fn pop(&mut self, out: &mut [u8]) -> usize {
        let n = out.len().min(self.len);
        for slot in out.iter_mut().take(n) {
            *slot = self.buf.get(self.head).copied().unwrap_or(0);
            self.head = (self.head + 1) % Q;
        }
        self.len -= n;
        n
    }
}

#[derive(Debug, Clone)]
struct Output<const Q: usize> {
    /// Whole frames, store & forward.
    queue: Ring<Q>,
    /// The cut-through frame being streamed; served before `queue`.
    stream: Ring<Q>,
    /// The input streaming into `stream`.
    owner: Option<usize>,
    /// A flag must close `stream` once there is room for it.
    close_pending: bool,
    stats: IfaceStats,
}

impl<const Q: usize> Output<Q> {
    const fn new() -> Self {
        Output {
            queue: Ring::new(),
            stream: Ring::new(),
            owner: None,
            close_pending: false,
            stats: IfaceStats {
                rx_bytes: 0,
                rx_frames: 0,
                tx_bytes: 0,
                tx_frames: 0,
                crc_failures: 0,
                dropped: 0,
                queue_overflows: 0,
                cut_through: 0,
                timeouts: 0,
            },
        }
    }

    fn streaming(&self) -> bool {
        self.owner.is_some() || self.close_pending || !self.stream.is_empty()
    }

    /// Ends the stream with a flag (now, or once the ring has room) and frees the output.
    fn close(&mut self) {
        if !self.stream.push(&[FLAG]) {
            self.close_pending = true;
        }
        self.owner = None;
    }

    /// Queues a whole unescaped frame (`len` bytes once escaped), or counts an overflow.
    fn enqueue(&mut self, frame: &[u8], len: usize) {
        if self.queue.free() < len {
            self.stats.queue_overflows += 1;
            return;
        }
        let queue = &mut self.queue;
        stuff_frame(frame, |run| {
            queue.push(run);
        });
        self.stats.tx_frames += 1;
    }
}

#[derive(Debug, Clone)]
struct Input<const P: usize> {
    parser: Parser<[u8; P]>,
    /// Time of the last byte, microseconds.
    last_us: u64,
    /// Where the current frame goes in all, once its receiver byte is in.
    plan: Option<Decision>,
    /// The outputs the current frame is streamed to.
    streams: Ports,
    /// Raw bytes of the current frame before the decision: at most an escaped receiver.
    prefix: [u8; 2],
    prefix_len: usize,
    timeouts: u64,
}

impl<const P: usize> Input<P> {
    fn new() -> Self {
        Input {
            parser: Parser::new([0; P]),
            last_us: 0,
            plan: None,
            streams: Ports::NONE,
            prefix: [0; 2],
            prefix_len: 0,
            timeouts: 0,
        }
    }

    /// Whether the per-byte (cut-through) path holds state about the current frame: its
    /// prefix or its plan. Such a frame must finish on that path, whatever the modes are now.
    fn in_flight(&self) -> bool {
        self.plan.is_some() || self.prefix_len > 0
    }

    fn reset_frame(&mut self) {
        self.plan = None;
        self.streams = Ports::NONE;
        self.prefix_len = 0;
    }
}

/// A bridge with `N` interfaces, `P` bytes of parser storage per interface
/// ([`storage_len`](super::storage_len) of the largest payload), two `Q`-byte queues per
/// interface (store & forward, cut-through) and a routing table of `A` addresses.
#[derive(Debug, Clone)]
pub struct Bridge<const N: usize, const P: usize, const Q: usize, const A: usize = 256> {
    router: Router<N, A>,
    inputs: [Input<P>; N],
    outputs: [Output<Q>; N],
    cut_through: [Ports; N],
    timeout_us: u64,
    counters: TxCounters<A>,
    deliver_all: bool,
}

impl<const N: usize, const P: usize, const Q: usize, const A: usize> Default
    for Bridge<N, P, Q, A>
{
    fn default() -> Self {
        Self::new()
    }
}

/// Queues an unescaped `header | payload | fcs` frame on every output in `ports`. A received
/// frame keeps its checked FCS, so forwarding it computes no CRC.
fn enqueue<const Q: usize>(outputs: &mut [Output<Q>], frame: &[u8], ports: Ports) {
    if ports.is_empty() {
        return;
    }
    let len = stuffed_len(frame);
    for o in ports.iter() {
        if let Some(out) = outputs.get_mut(o) {
            out.enqueue(frame, len);
        }
    }
}

impl<const N: usize, const P: usize, const Q: usize, const A: usize> Bridge<N, P, Q, A> {
    /// All interfaces store & forward, every route unknown, a 1 ms byte timeout.
    pub fn new() -> Self {
        Bridge {
            router: Router::new(),
            inputs: core::array::from_fn(|_| Input::new()),
            outputs: core::array::from_fn(|_| Output::new()),
            cut_through: [Ports::NONE; N],
            timeout_us: 1000,
            counters: TxCounters::new(),
            deliver_all: false,
        }
    }

    /// The routing state.
    #[inline]
    pub fn router(&self) -> &Router<N, A> {
        &self.router
    }

    /// The routing state, to set own ids, mirrors, pinned and seeded routes.
    #[inline]
    pub fn router_mut(&mut self) -> &mut Router<N, A> {
        &mut self.router
    }

    /// Chooses how frames arriving on `from` are forwarded to `to`, from the next frame on: a
    /// frame arriving on `from` meanwhile finishes in the mode it began in.
    pub fn set_mode(&mut self, from: usize, to: usize, mode: Mode) {
        if let Some(set) = self.cut_through.get_mut(from) {
            *set = match mode {
                Mode::CutThrough => set.with(Ports::one(to)),
                Mode::StoreForward => set.without(to),
            };
        }
    }

    /// The forwarding mode from `from` to `to`.
    pub fn mode(&self, from: usize, to: usize) -> Mode {
        match self.cut_through.get(from) {
            Some(set) if set.contains(to) => Mode::CutThrough,
            _ => Mode::StoreForward,
        }
    }

    /// How long a cut-through frame may stall between two bytes before it is cut off.
    pub fn set_byte_timeout_us(&mut self, us: u64) {
        self.timeout_us = us;
    }

    /// Hands every intact frame to `on_local`, not only the node's own: for monitors, loggers
    /// and missed-packet statistics. Whether a frame is for the node is
    /// [`Router::is_own`] of its receiver, or a broadcast.
    pub fn set_deliver_all(&mut self, all: bool) {
        self.deliver_all = all;
    }

    /// Counters of interface `i`.
    pub fn stats(&self, i: usize) -> IfaceStats {
        let (Some(input), Some(output)) = (self.inputs.get(i), self.outputs.get(i)) else {
            return IfaceStats::default();
        };
        let parsed = input.parser.stats();
        IfaceStats {
            rx_bytes: parsed.bytes as u64,
            rx_frames: parsed.frames as u64,
            crc_failures: parsed.crc_failures as u64,
            dropped: parsed.dropped() as u64,
            timeouts: input.timeouts,
            ..output.stats
        }
    }

    /// Bytes waiting to be sent on interface `i`.
    pub fn pending(&self, i: usize) -> usize {
        self.outputs.get(i).map_or(0, |o| {
            o.queue.len + o.stream.len + usize::from(o.close_pending)
        })
    }

    /// Forgets the routes through interface `i` and drops its partial input, e.g. when its link
    /// went down.
    pub fn link_down(&mut self, i: usize) {
        self.router.invalidate(i);
        self.cut_off(i);
    }

    /// Sends a frame of this node's own from `sender` to `receiver`, taking the receiver's next
    /// counter, on the interfaces the routing table names. Returns those interfaces; an
    /// interface whose queue is full counts an overflow.
    pub fn send(
        &mut self,
        receiver: u8,
        sender: u8,
        parts: &[&[u8]],
    ) -> Result<Ports, EncodeError> {
        let len: usize = parts.iter().map(|p| p.len()).sum();
        let length = u8::try_from(len).map_err(|_| EncodeError::PayloadTooLong { len })?;
        let mut frame = [0u8; storage_len(MAX_PAYLOAD_LEN)];
        let n = assemble(
            &Header::new(receiver, sender, self.counters.peek(receiver), length),
            parts,
            &mut frame,
        )?;
        self.counters.next(receiver);
        let ports = self.router.decide(usize::MAX, receiver).forward;
        enqueue(&mut self.outputs, frame.get(..n).unwrap_or_default(), ports);
        Ok(ports)
    }

    /// Pulls up to `out.len()` bytes to send on interface `i`; returns how many.
    pub fn transmit(&mut self, i: usize, out: &mut [u8]) -> usize {
        let Some(output) = self.outputs.get_mut(i) else {
            return 0;
        };
        let mut n = 0;
        if output.streaming() {
            n = output.stream.pop(out);
            if output.close_pending && output.stream.is_empty() {
                if let Some(slot) = out.get_mut(n) {
                    *slot = FLAG;
                    n += 1;
                    output.close_pending = false;
                }
            }
        }
        if !output.streaming() {
            n += output.queue.pop(out.get_mut(n..).unwrap_or_default());
        }
        output.stats.tx_bytes += n as u64;
        n
    }

    /// When [`poll`](Self::poll) next has something to do: the time a cut-through frame in
    /// flight would have stalled longer than the byte timeout, the earliest of them; `None`
    /// while none is in flight, so that a program driving the bridge can sleep until it has
    /// input.
    pub fn next_poll_us(&self) -> Option<u64> {
        self.inputs
            .iter()
            .filter(|input| !input.streams.is_empty())
            .map(|input| {
                input
                    .last_us
                    .saturating_add(self.timeout_us)
                    .saturating_add(1)
            })
            .min()
    }

    /// Cuts off cut-through frames that stalled longer than the byte timeout.
    pub fn poll(&mut self, now_us: u64) {
        for i in 0..N {
            let stalled = self.inputs.get(i).is_some_and(|input| {
                !input.streams.is_empty() && now_us.saturating_sub(input.last_us) > self.timeout_us
            });
            if stalled {
                if let Some(input) = self.inputs.get_mut(i) {
                    input.timeouts += 1;
                }
                self.cut_off(i);
            }
        }
    }

    /// Drops input `i`'s partial frame and closes its streams.
    fn cut_off(&mut self, i: usize) {
        let Some(input) = self.inputs.get_mut(i) else {
            return;
        };
        for o in input.streams.iter() {
            if let Some(out) = self.outputs.get_mut(o) {
                out.close();
            }
        }
        input.parser.abort();
        input.reset_frame();
    }

    /// Feeds bytes received on interface `i` at time `now_us`; frames for this node are handed
    /// to `on_local`.
    pub fn receive(
        &mut self,
        i: usize,
        bytes: &[u8],
        now_us: u64,
        mut on_local: impl FnMut(Frame<'_>),
    ) {
        let cut_through = self.cut_through.get(i).copied().unwrap_or_default();
        let Bridge {
            router,
            inputs,
            outputs,
            deliver_all,
            ..
        } = self;
        let deliver_all = *deliver_all;
        let Some(input) = inputs.get_mut(i) else {
            return;
        };
        input.last_us = now_us;
        let mut rest = bytes;
        while let Some((&b, tail)) = rest.split_first() {
            if cut_through.is_empty() && !input.in_flight() {
                // Store & forward only, and no frame begun on the per-byte path: whole slices
                // through the parser.
                while let Feed::Frame { frame, remaining } = input.parser.feed(rest) {
                    let header = frame.header();
                    let decision = router.route(i, &header);
                    if decision.local || deliver_all {
                        on_local(frame);
                    }
                    enqueue(outputs, frame.as_bytes(), decision.forward);
                    rest = remaining;
                }
                return;
            }
            // A cut-through output, or a frame begun here while there was one: byte by byte,
            // so that the frame's plan and streams end with the frame.
            receive_byte(
                router,
                input,
                outputs,
                (i, b),
                cut_through,
                deliver_all,
                &mut on_local,
            );
            rest = tail;
        }
    }
}

/// One byte into an input with cut-through outputs.
fn receive_byte<const N: usize, const P: usize, const Q: usize, const A: usize>(
    router: &mut Router<N, A>,
    input: &mut Input<P>,
    outputs: &mut [Output<Q>; N],
    (i, b): (usize, u8),
    cut_through: Ports,
    deliver_all: bool,
    on_local: &mut impl FnMut(Frame<'_>),
) {
    let streams = input.streams;
    let stream = |outputs: &mut [Output<Q>; N], bytes: &[u8], close: bool| {
        for o in streams.iter() {
            if let Some(out) = outputs.get_mut(o) {
                if !out.stream.push(bytes) {
                    out.stats.queue_overflows += 1;
                    out.close();
                } else if close {
                    out.close();
                }
            }
        }
    };
    if b == FLAG {
        stream(outputs, &[], true);
        input.reset_frame();
        let _ = input.parser.feed(&[FLAG]);
        return;
    }
    // Whether this path saw the current frame from its first byte: a frame the parser is in
    // without a prefix kept here began on the store & forward path.
    let seen_from_start = input.prefix_len > 0 || !input.parser.in_frame();
    let complete = match input.parser.feed(&[b]) {
        Feed::Frame { frame, .. } => {
            stream(outputs, &[b], true);
            // The FCS checked: learn, deliver and queue by the frame's own header, as store &
            // forward does. The plan made from the receiver byte only chose the streams.
            let decision = router.route(i, &frame.header());
            if decision.local || deliver_all {
                on_local(frame);
            }
            enqueue(
                outputs,
                frame.as_bytes(),
                decision.forward.without_all(streams),
            );
            true
        }
        Feed::Consumed => false,
    };
    if complete {
        input.reset_frame();
        return;
    }
    if !input.parser.in_frame() {
        // Dropped (FCS, escape, oversize): what was streamed passes, cut off.
        stream(outputs, &[b], true);
        input.reset_frame();
    } else if input.plan.is_some() {
        stream(outputs, &[b], false);
        for o in streams.iter() {
            if outputs.get(o).is_some_and(|out| out.owner != Some(i)) {
                input.streams = input.streams.without(o);
            }
        }
    } else {
        if let Some(slot) = input.prefix.get_mut(input.prefix_len) {
            *slot = b;
            input.prefix_len += 1;
        }
        let Some(receiver) = input.parser.pending_receiver() else {
            return;
        };
        let plan = router.decide(i, receiver);
        input.plan = Some(plan);
        if !seen_from_start {
            // Its first bytes were not kept for a stream (it began store & forward): it
            // finishes store & forward, and cut-through starts with the next frame.
            return;
        }
        let prefix = input.prefix.get(..input.prefix_len).unwrap_or_default();
        for o in plan.forward.iter().filter(|&o| cut_through.contains(o)) {
            let Some(out) = outputs.get_mut(o) else {
                continue;
            };
            if out.streaming() || !out.queue.is_empty() {
                continue; // busy: this output gets the frame store & forward
            }
            if out.stream.free() > prefix.len() {
                out.stream.push(&[FLAG]);
                out.stream.push(prefix);
                out.owner = Some(i);
                out.stats.tx_frames += 1;
                out.stats.cut_through += 1;
                input.streams = input.streams.with(Ports::one(o));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ndlcom::{encode, storage_len, MAX_FRAME_LEN};
    use std::vec::Vec;

    type B = Bridge<3, { storage_len(255) }, 600>;

    fn frame(r: u8, s: u8, c: u8, payload: &[u8]) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(
            &Header::new(r, s, c, payload.len() as u8),
            payload,
            &mut buf,
        )
        .unwrap();
        buf[..n].to_vec()
    }

    fn drain(b: &mut B, i: usize) -> Vec<u8> {
        let mut out = [0u8; 2048];
        let n = b.transmit(i, &mut out);
        out[..n].to_vec()
    }

    #[test]
    fn store_and_forward_floods_then_learns() {
        let mut b = B::new();
        b.router_mut().add_own_id(1);
        let f = frame(7, 9, 0, &[1, 2, 3]);
        b.receive(0, &f, 0, |_| panic!("not for us"));
        assert_eq!(drain(&mut b, 1), f);
        assert_eq!(drain(&mut b, 2), f);
        assert!(drain(&mut b, 0).is_empty());
        let back = frame(9, 7, 0, &[]);
        b.receive(2, &back, 0, |_| {});
        assert_eq!(drain(&mut b, 0), back);
        assert!(drain(&mut b, 1).is_empty());
        assert_eq!(b.stats(0).rx_frames, 1);
        assert_eq!(b.stats(1).tx_frames, 1);
        assert_eq!(b.stats(0).tx_bytes, back.len() as u64);
    }

    #[test]
    fn local_frames_and_own_sends() {
        let mut b = B::new();
        b.router_mut().add_own_id(1);
        let mut got = Vec::new();
        b.receive(2, &frame(1, 5, 3, &[42]), 0, |f| {
            got.push((f.header(), f.payload().to_vec()))
        });
        b.receive(2, &frame(0xff, 5, 4, &[43]), 0, |f| {
            got.push((f.header(), f.payload().to_vec()))
        });
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].1, [42]);
        // The broadcast went on, the frame for us did not.
        assert_eq!(drain(&mut b, 0), frame(0xff, 5, 4, &[43]));
        // Nothing learned from frames for us; an own send to 5 floods.
        assert_eq!(b.send(5, 1, &[&[9]]), Ok(Ports(0b111)));
        assert_eq!(drain(&mut b, 2), frame(5, 1, 0, &[9]));
        b.send(5, 1, &[&[9]]).unwrap();
        assert_eq!(drain(&mut b, 2), frame(5, 1, 1, &[9]));
    }

    #[test]
    fn full_queue_counts_and_never_sends_half() {
        let mut b = Bridge::<2, { storage_len(255) }, 300>::new();
        let big = frame(7, 9, 0, &[0x7e; 200]); // 411 bytes encoded
        b.receive(0, &big, 0, |_| {});
        let small = frame(7, 9, 1, &[1; 100]);
        b.receive(0, &small, 0, |_| {});
        b.receive(0, &small, 0, |_| {});
        let s = b.stats(1);
        assert_eq!((s.tx_frames, s.queue_overflows), (2, 1));
        let mut out = [0u8; 1024];
        let n = b.transmit(1, &mut out);
        assert_eq!(&out[..n], [small.clone(), small].concat());
    }

    #[test]
    fn cut_through_streams_and_learns_after_fcs() {
        let mut b = B::new();
        b.set_mode(0, 1, Mode::CutThrough);
        b.router_mut().seed(7, 1);
        let f = frame(7, 9, 0, &[0x7d, 1, 2, 3]);
        b.receive(0, &f[..3], 0, |_| {});
        assert_eq!(drain(&mut b, 1), f[..3]);
        assert_eq!(b.router().lookup(9), None, "no learning before the FCS");
        b.receive(0, &f[3..f.len() - 1], 10, |_| {});
        assert_eq!(b.router().lookup(9), Some(0));
        // The frame is closed as soon as it is complete; the incoming closing flag adds nothing.
        b.receive(0, &f[f.len() - 1..], 10, |_| {});
        assert_eq!(drain(&mut b, 1), f[3..]);
        assert_eq!(b.stats(1).cut_through, 1);
    }

    #[test]
    fn cut_through_passes_broken_frames_and_learns_nothing() {
        let mut b = B::new();
        b.set_mode(0, 1, Mode::CutThrough);
        b.set_mode(0, 2, Mode::CutThrough);
        let mut f = frame(7, 9, 0, &[1, 2, 3]);
        f[6] ^= 1;
        b.receive(0, &f, 0, |_| {});
        assert_eq!(drain(&mut b, 1), f);
        assert_eq!(drain(&mut b, 2), f);
        assert_eq!(b.router().lookup(9), None);
        assert_eq!(b.stats(0).crc_failures, 1);
    }

    #[test]
    fn stalled_cut_through_is_cut_off() {
        let mut b = B::new();
        b.set_mode(0, 1, Mode::CutThrough);
        b.set_byte_timeout_us(100);
        b.router_mut().seed(7, 1);
        let f = frame(7, 9, 0, &[1, 2, 3, 4]);
        assert_eq!(b.next_poll_us(), None);
        b.receive(0, &f[..5], 0, |_| {});
        assert_eq!(b.next_poll_us(), Some(101));
        // Meanwhile a frame from interface 2 must wait: it is queued store & forward.
        let g = frame(7, 8, 0, &[5]);
        b.receive(2, &g, 50, |_| {});
        assert_eq!(b.next_poll_us(), Some(101));
        b.poll(100);
        assert_eq!(drain(&mut b, 1), f[..5]);
        b.poll(101);
        assert_eq!(b.stats(0).timeouts, 1);
        assert_eq!(b.next_poll_us(), None);
        assert_eq!(drain(&mut b, 1), [&[FLAG][..], &g].concat());
        // The rest of the stalled frame is not forwarded.
        b.receive(0, &f[5..], 300, |_| {});
        assert!(drain(&mut b, 1).is_empty());
    }

    #[test]
    fn busy_output_falls_back_to_store_and_forward() {
        let mut b = B::new();
        b.set_mode(0, 1, Mode::CutThrough);
        b.set_mode(2, 1, Mode::CutThrough);
        b.router_mut().seed(7, 1);
        let f = frame(7, 9, 0, &[1, 2, 3]);
        let g = frame(7, 8, 0, &[4, 5]);
        // Interleaved arrival: f streams, g must wait and arrive whole after it.
        for k in 0..f.len().max(g.len()) {
            if let Some(x) = f.get(k) {
                b.receive(0, &[*x], k as u64, |_| {});
            }
            if let Some(x) = g.get(k) {
                b.receive(2, &[*x], k as u64, |_| {});
            }
        }
        let sent = drain(&mut b, 1);
        assert_eq!(sent, [f.clone(), g.clone()].concat());
        assert_eq!(b.stats(1).cut_through, 1);
    }

    /// Cut-through -> store & forward in mid-frame: the broadcast's plan and stream end with the
    /// broadcast, and are not applied to the next frame (once: found by `ndlcom_bridge`).
    #[test]
    fn plan_of_a_cut_off_frame_does_not_leak_into_the_next() {
        let mut b = B::new();
        b.router_mut().add_own_id(1);
        b.set_mode(0, 2, Mode::CutThrough);
        let bc = frame(0xff, 9, 0, &[1, 2]);
        b.receive(0, &bc[..3], 0, |_| panic!("incomplete"));
        b.set_mode(0, 2, Mode::StoreForward);
        // A frame for 7 cuts the broadcast short and straddles the switch back.
        let f = frame(7, 8, 0, &[0x21]);
        let mut local = Vec::new();
        b.receive(0, &f[..f.len() - 2], 1, |fr| local.push(fr.header()));
        b.set_mode(0, 2, Mode::CutThrough);
        b.receive(0, &f[f.len() - 2..], 2, |fr| local.push(fr.header()));
        assert!(local.is_empty(), "not for this node: {local:?}");
        assert_eq!(
            b.router().lookup(8),
            Some(0),
            "learned from the frame's own header"
        );
        // Output 2: the broadcast's stream cut off by the flag, then the frame for 7 whole.
        assert_eq!(drain(&mut b, 2), [&bc[..3], &[FLAG][..], &f].concat());
        assert_eq!(drain(&mut b, 1), f);
        assert_eq!(b.stats(0).dropped, 1);
    }

    /// Store & forward -> cut-through in mid-frame: the frame's first bytes were not kept, so it
    /// finishes store & forward; cut-through starts with the next frame.
    #[test]
    fn frame_begun_store_and_forward_finishes_store_and_forward() {
        let mut b = B::new();
        b.router_mut().seed(7, 1);
        let f = frame(7, 9, 0, &[1, 2, 3]);
        b.receive(0, &f[..2], 0, |_| {}); // flag and receiver
        b.set_mode(0, 1, Mode::CutThrough);
        b.receive(0, &f[2..4], 1, |_| {});
        assert!(
            drain(&mut b, 1).is_empty(),
            "no stream without the frame's first bytes"
        );
        b.receive(0, &f[4..], 2, |_| {});
        assert_eq!(drain(&mut b, 1), f);
        assert_eq!(b.stats(1).cut_through, 0);
        assert_eq!(b.router().lookup(9), Some(0));
        b.receive(0, &f[..3], 3, |_| {});
        assert_eq!(drain(&mut b, 1), f[..3]);
        assert_eq!(b.stats(1).cut_through, 1);
    }

    /// Cut-through -> store & forward in mid-frame, frame intact: the stream already begun
    /// carries the whole frame, once; the next frame goes store & forward.
    #[test]
    fn frame_begun_cut_through_finishes_cut_through() {
        let mut b = B::new();
        b.router_mut().seed(7, 1);
        b.set_mode(0, 1, Mode::CutThrough);
        let f = frame(7, 9, 0, &[1, 2, 3]);
        b.receive(0, &f[..3], 0, |_| {});
        b.set_mode(0, 1, Mode::StoreForward);
        b.receive(0, &f[3..], 1, |_| {});
        assert_eq!(drain(&mut b, 1), f);
        assert_eq!(b.stats(1).cut_through, 1);
        assert_eq!(b.stats(1).tx_frames, 1, "not queued a second time");
        b.receive(0, &f[..3], 2, |_| {});
        assert!(drain(&mut b, 1).is_empty(), "store & forward now");
        b.receive(0, &f[3..], 3, |_| {});
        assert_eq!(drain(&mut b, 1), f);
    }
}
