//! A push-style NDLCom stream parser over caller- or const-sized storage.
//!
//! [`Parser::feed`] takes whatever bytes arrived and returns either "all consumed, no frame
//! yet" or one frame plus the input it has not looked at yet, the shape of postcard's
//! `CobsAccumulator`. A frame is a view into the parser's storage (the unescaped header,
//! payload and FCS): nothing is copied out.
//!
//! Rules, from the protocol and from the reference decoder's known weak spots:
//!
//! - every 0x7E restarts the search; a frame cut short by one is counted as
//!   [`Stats::truncated`];
//! - no leading flag is needed, neither before the first frame nor between frames, because the
//!   length field says where a frame ends;
//! - a payload longer than the configured maximum is skipped whole, by its length field, and
//!   counted as [`Stats::oversize`]: its bytes are never read as a header;
//! - 0x7D must be followed by 0x5D or 0x5E; anything else drops the frame
//!   ([`Stats::bad_escape`]) up to the next flag;
//! - a frame whose FCS does not check is counted in [`Stats::crc_failures`].
//!
//! ```
//! use ferrolink_runtime::ndlcom::{parser::{Feed, Parser}, storage_len};
//!
//! let mut parser = Parser::new([0u8; storage_len(16)]);
//! let frame = [126, 1, 0, 0, 0, 154, 31, 126];
//! // Line noise, then the frame in two pieces.
//! assert!(matches!(parser.feed(&[0x55, 0x7e, 1]), Feed::Consumed));
//! assert!(matches!(parser.feed(&frame[..4]), Feed::Consumed));
//! let Feed::Frame { frame: got, remaining } = parser.feed(&frame[4..]) else { panic!() };
//! assert_eq!(got.header().receiver, 1);
//! assert_eq!(remaining, &[126]);
//! assert_eq!(parser.stats().truncated, 2); // the noise, and the frame the first `1` began
//! ```

use super::{Header, ESCAPE, FCS_LEN, FLAG, MAX_PAYLOAD_LEN};
use crate::bump;
use crate::crc::mcrf4xx;
use crate::framing::{wide, Counters, Deframer};
use crate::hdlc::is_special;

/// What a [`Parser`] accepted and dropped so far.
///
/// The counters are `usize`: 64 bits on a PC, one word on a microcontroller, where they wrap
/// (after 4 GiB of bytes) instead of overflowing. A reader that keeps totals takes the counters
/// with [`Parser::take_stats`] and adds them up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Stats {
    /// Frames handed out.
    pub frames: usize,
    /// Bytes fed.
    pub bytes: usize,
    /// Frames whose FCS did not check.
    pub crc_failures: usize,
    /// Frames cut short by a flag (or by the end of input, see [`Parser::finish`]).
    pub truncated: usize,
    /// Frames longer than the configured maximum payload.
    pub oversize: usize,
    /// Frames dropped for an escape byte followed by something other than 0x5D or 0x5E.
    pub bad_escape: usize,
}

impl Stats {
    const ZERO: Stats = Stats {
        frames: 0,
        bytes: 0,
        crc_failures: 0,
        truncated: 0,
        oversize: 0,
        bad_escape: 0,
    };

    /// Frames dropped for any reason but a failed FCS.
    #[inline]
    pub fn dropped(&self) -> usize {
        self.truncated
            .wrapping_add(self.oversize)
            .wrapping_add(self.bad_escape)
    }
}

impl Counters for Stats {
    fn frames(&self) -> u64 {
        wide(self.frames)
    }

    /// Every drop, failed FCS included.
    fn dropped(&self) -> u64 {
        wide(Stats::dropped(self).wrapping_add(self.crc_failures))
    }

    fn each(&self, f: &mut dyn FnMut(&'static str, u64)) {
        f("frames", wide(self.frames));
        f("bytes", wide(self.bytes));
        f("crc_failures", wide(self.crc_failures));
        f("truncated", wide(self.truncated));
        f("oversize", wide(self.oversize));
        f("bad_escape", wide(self.bad_escape));
    }
}

pub use crate::framing::Feed;

/// A received frame whose FCS checked: a view of the unescaped header, payload and FCS.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'p> {
    bytes: &'p [u8],
}

impl<'p> Frame<'p> {
    /// Wraps unescaped `header | payload | fcs` bytes after checking their length and FCS.
    pub fn new_checked(bytes: &'p [u8]) -> Option<Self> {
        let header = Header::parse(bytes)?;
        let len = Header::LEN + usize::from(header.length) + FCS_LEN;
        let bytes = bytes.get(..len)?;
        (mcrf4xx(bytes) == 0).then_some(Frame { bytes })
    }

    /// The header.
    #[inline]
    pub fn header(&self) -> Header {
        Header::parse(self.bytes).unwrap_or_default()
    }

    /// The payload.
    #[inline]
    pub fn payload(&self) -> &'p [u8] {
        let end = self.bytes.len().saturating_sub(FCS_LEN);
        self.bytes.get(Header::LEN..end).unwrap_or_default()
    }

    /// The FCS as received.
    #[inline]
    pub fn fcs(&self) -> u16 {
        match self.bytes {
            [.., lo, hi] => u16::from_le_bytes([*lo, *hi]),
            _ => 0,
        }
    }

    /// The unescaped `header | payload | fcs` bytes.
    #[inline]
    pub fn as_bytes(&self) -> &'p [u8] {
        self.bytes
    }
}

/// The parser's state. `Collect` is the zero tag, so a parser whose fields are all zero is a
/// fresh one (see [`Parser::zeroed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
enum State {
    /// Collecting a frame into the storage.
    Collect,
    /// Collecting; the last byte was 0x7D.
    Escaped,
    /// Skipping an oversize frame: this many unescaped bytes are left.
    Skip { left: u16, escaped: bool },
    /// Dropping bytes up to the next flag.
    Discard,
}

/// The push parser. `S` is its storage: `[u8; N]` for a const size, or `&mut [u8]`.
///
/// The storage holds one unescaped frame, so `storage_len(max_payload)` bytes
/// ([`storage_len`](super::storage_len)) accept payloads up to `max_payload`. Besides the
/// storage, a parser holds 32 bytes on a 32-bit microcontroller.
#[derive(Debug, Clone)]
pub struct Parser<S> {
    buf: S,
    /// Unescaped bytes of the current frame in `buf`.
    len: usize,
    /// A maximum payload set below what the storage holds, if any.
    limit: Option<u8>,
    state: State,
    stats: Stats,
}

impl<const N: usize> Parser<[u8; N]> {
    /// A parser over its own zeroed storage, as a `const fn`. Every byte of it is zero, so a
    /// `static` parser lives in `.bss` and costs no flash for an initial image.
    pub const fn zeroed() -> Self {
        Parser {
            buf: [0; N],
            len: 0,
            limit: None,
            state: State::Collect,
            stats: Stats::ZERO,
        }
    }
}

impl<S: AsRef<[u8]> + AsMut<[u8]>> Parser<S> {
    /// A parser accepting the largest payload `storage` can hold (at most 255 bytes).
    pub fn new(storage: S) -> Self {
        Parser {
            buf: storage,
            len: 0,
            limit: None,
            state: State::Collect,
            stats: Stats::ZERO,
        }
    }

    /// Lowers the largest accepted payload (it never exceeds what the storage holds).
    pub fn set_max_payload(&mut self, max: usize) {
        self.limit = Some(u8::try_from(max).unwrap_or(u8::MAX));
    }

    /// The largest accepted payload.
    #[inline]
    pub fn max_payload(&self) -> usize {
        let cap = self
            .buf
            .as_ref()
            .len()
            .saturating_sub(Header::LEN + FCS_LEN)
            .min(MAX_PAYLOAD_LEN);
        self.limit.map_or(cap, |limit| usize::from(limit).min(cap))
    }

    /// Unescaped bytes the current frame needs in all: the header, then the header's length
    /// plus the payload and FCS.
    #[inline]
    fn need(&self) -> usize {
        match self.buf.as_ref().get(3) {
            Some(&length) if self.len >= Header::LEN => Header::LEN + usize::from(length) + FCS_LEN,
            _ => Header::LEN,
        }
    }

    /// Counters since creation (or the last [`take_stats`](Self::take_stats)).
    #[inline]
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Returns the counters and zeroes them.
    pub fn take_stats(&mut self) -> Stats {
        core::mem::take(&mut self.stats)
    }

    /// Whether the parser is inside a frame (it has bytes of one it has neither handed out
    /// nor dropped yet).
    #[inline]
    pub fn in_frame(&self) -> bool {
        match self.state {
            State::Collect => self.len > 0,
            State::Escaped => true,
            State::Skip { .. } | State::Discard => false,
        }
    }

    /// The receiver of the frame being received, once its first byte is in.
    #[inline]
    pub fn pending_receiver(&self) -> Option<u8> {
        if self.len > 0 && matches!(self.state, State::Collect | State::Escaped) {
            self.buf.as_ref().first().copied()
        } else {
            None
        }
    }

    /// Ends the input: a frame in progress is dropped and counted as truncated. Call this at
    /// the end of a capture, or after a link's byte-level timeout.
    pub fn finish(&mut self) {
        if self.in_frame() {
            bump(&mut self.stats.truncated, 1);
        }
        self.restart();
    }

    /// Drops the frame in progress (counted as truncated) and every byte up to the next flag:
    /// for a link that stalled or went down mid-frame, whose next bytes are not a frame start.
    pub fn abort(&mut self) {
        self.finish();
        self.state = State::Discard;
    }

    fn restart(&mut self) {
        self.len = 0;
        self.state = State::Collect;
    }

    /// Feeds bytes and returns the first complete frame, if any, with the input after it.
    ///
    /// Call `feed` again with `remaining` until it returns [`Feed::Consumed`]. The frame stays
    /// valid until the next call.
    pub fn feed<'p, 'a: 'p>(&'p mut self, mut input: &'a [u8]) -> Feed<'a, Frame<'p>> {
        while let Some((&b, rest)) = input.split_first() {
            if b == FLAG {
                bump(&mut self.stats.bytes, 1);
                self.finish();
                input = rest;
                continue;
            }
            match self.state {
                State::Collect if b != ESCAPE => {
                    // Copy the run of plain bytes up to what the frame needs next, in one pass
                    // that stops at a special byte (and so never becomes a `memcpy` call,
                    // which a microcontroller would pay for in flash).
                    let want = self.need() - self.len;
                    let free = self.buf.as_mut().get_mut(self.len..).unwrap_or_default();
                    let mut taken = 0;
                    for (slot, &byte) in free.iter_mut().zip(input).take(want) {
                        if is_special(byte) {
                            break;
                        }
                        *slot = byte;
                        taken += 1;
                    }
                    if taken == 0 && free.is_empty() {
                        // Storage smaller than a header (under `storage_len(0)` bytes): the
                        // frame cannot be held, so its bytes are dropped up to the next flag.
                        bump(&mut self.stats.oversize, 1);
                        self.len = 0;
                        self.state = State::Discard;
                        continue;
                    }
                    bump(&mut self.stats.bytes, taken);
                    self.len += taken;
                    input = input.get(taken..).unwrap_or_default();
                    if self.complete() {
                        return self.hand_out(input);
                    }
                }
                State::Collect => {
                    bump(&mut self.stats.bytes, 1);
                    self.state = State::Escaped;
                    input = rest;
                }
                State::Escaped => {
                    bump(&mut self.stats.bytes, 1);
                    input = rest;
                    if b == 0x5d || b == 0x5e {
                        self.state = State::Collect;
                        if let Some(slot) = self.buf.as_mut().get_mut(self.len) {
                            *slot = b ^ 0x20;
                        }
                        self.len += 1;
                        if self.complete() {
                            return self.hand_out(input);
                        }
                    } else {
                        bump(&mut self.stats.bad_escape, 1);
                        self.len = 0;
                        self.state = State::Discard;
                    }
                }
                State::Skip { left, escaped } => {
                    bump(&mut self.stats.bytes, 1);
                    input = rest;
                    let (left, escaped) = match (escaped, b == ESCAPE) {
                        (false, true) => (left, true),
                        _ => (left.saturating_sub(1), false),
                    };
                    self.state = if left == 0 {
                        State::Collect
                    } else {
                        State::Skip { left, escaped }
                    };
                }
                State::Discard => {
                    // Up to the next flag, which the top of the loop handles.
                    let skip = input.iter().position(|&b| b == FLAG).unwrap_or(input.len());
                    bump(&mut self.stats.bytes, skip);
                    input = input.get(skip..).unwrap_or_default();
                }
            }
        }
        Feed::Consumed
    }

    /// Called after bytes were added: skips an oversize frame once its header is in, and checks
    /// a complete frame. Returns true if a valid frame is complete.
    fn complete(&mut self) -> bool {
        if self.len == Header::LEN {
            let length = self.buf.as_ref().get(3).copied().unwrap_or(0);
            if usize::from(length) > self.max_payload() {
                bump(&mut self.stats.oversize, 1);
                self.len = 0;
                self.state = State::Skip {
                    left: u16::from(length) + FCS_LEN as u16,
                    escaped: false,
                };
                return false;
            }
        }
        if self.len < Header::LEN || self.len != self.need() {
            return false;
        }
        let ok = self
            .buf
            .as_ref()
            .get(..self.len)
            .is_some_and(|frame| mcrf4xx(frame) == 0);
        if ok {
            bump(&mut self.stats.frames, 1);
        } else {
            bump(&mut self.stats.crc_failures, 1);
            self.restart();
        }
        ok
    }

    fn hand_out<'p, 'a: 'p>(&'p mut self, remaining: &'a [u8]) -> Feed<'a, Frame<'p>> {
        let len = self.len;
        self.restart();
        let bytes = self.buf.as_ref().get(..len).unwrap_or_default();
        Feed::Frame {
            frame: Frame { bytes },
            remaining,
        }
    }
}

impl<S: AsRef<[u8]> + AsMut<[u8]> + 'static> Parser<S> {
    /// Feeds bytes and calls `on_frame` for every frame they complete; returns how many.
    pub fn feed_all(&mut self, input: &[u8], on_frame: impl FnMut(Frame<'_>)) -> usize {
        Deframer::feed_all(self, input, on_frame)
    }
}

/// A parser on storage it owns (an array, a `Box<[u8]>`) is a [`Deframer`]; one on borrowed
/// storage has the same methods but not the trait.
impl<S: AsRef<[u8]> + AsMut<[u8]> + 'static> Deframer for Parser<S> {
    type Frame<'p> = Frame<'p>;
    type Stats = Stats;

    #[inline]
    fn feed<'p, 'a: 'p>(&'p mut self, input: &'a [u8]) -> Feed<'a, Frame<'p>> {
        Parser::feed(self, input)
    }

    fn stats(&self) -> &Stats {
        &self.stats
    }

    fn take_stats(&mut self) -> Stats {
        core::mem::take(&mut self.stats)
    }

    fn finish(&mut self) {
        Parser::finish(self);
    }
}
