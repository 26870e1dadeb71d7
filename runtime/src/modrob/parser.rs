//! A push-style UART.B-1 / SPI-1 stream parser in 14 bytes of storage.
//!
//! [`Parser::feed`] takes whatever bytes arrived and returns either "all consumed, no message
//! yet" or one message plus the input it has not looked at yet, the shape of postcard's
//! `CobsAccumulator`.
//!
//! The format has no escaping, so a 0x5A inside a message looks like a start. Rules:
//!
//! - bytes before a 0x5A are dropped;
//! - a candidate is accepted only if its length nibble is 6 or 8 ([`Stats::bad_length`]
//!   otherwise) and its CRC matches ([`Stats::crc_failures`] otherwise);
//! - after a rejected candidate the search restarts at the byte after its 0x5A, so a real
//!   message that starts inside a false candidate is still found;
//! - a message whose CRC matches but which carries reserved values is counted in
//!   [`Stats::decode_errors`] and skipped whole.
//!
//! Every byte fed ends up in a handed-out message, in [`Stats::dropped`], or still in the
//! parser ([`Parser::pending`]).
//!
//! A false start never holds back the message behind it, so the parser keeps
//! [`Deframer::give_up_stalled`]'s default: a false candidate claims at most 14 bytes, the
//! shortest message is 12, and a false start is at least two bytes (a 0x5A and a length nibble
//! of 6 or 8), so the message's own bytes complete the false candidate, whose CRC then fails.
//! Only noise at the very end of a burst waits in the parser for the next bytes.
//!
//! ```
//! use ferrolink_runtime::modrob::{parser::{Feed, Parser}, uart, Message};
//!
//! let message = Message::Publication { module: 1, variable: 2, value: 0.5 };
//! let mut frame = [0u8; uart::MAX_FRAME_LEN];
//! let n = uart::encode(&message, &mut frame).unwrap();
//! let mut parser = Parser::new();
//! assert!(matches!(parser.feed(&[0x00, 0x5a, 0xff]), Feed::Consumed)); // noise
//! assert!(matches!(parser.feed(&frame[..4]), Feed::Consumed));
//! let Feed::Frame { frame: got, remaining } = parser.feed(&frame[4..n]) else { panic!() };
//! assert_eq!(got, message);
//! assert!(remaining.is_empty());
//! assert_eq!(parser.stats().bad_length, 1);
//! assert_eq!(parser.stats().dropped, 3);
//! ```

use super::message::Message;
use super::uart::{self, Crc8, HEAD_LEN, MAX_FRAME_LEN, SYNC};
use crate::framing::{Counters, Deframer};

/// What a [`Parser`] accepted and dropped so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Stats {
    /// Messages handed out.
    pub frames: u64,
    /// Bytes fed.
    pub bytes: u64,
    /// Candidates whose CRC did not match.
    pub crc_failures: u64,
    /// Candidates whose length nibble was neither 6 nor 8.
    pub bad_length: u64,
    /// Messages whose CRC matched but which were not valid ModRob-1 (reserved values).
    pub decode_errors: u64,
    /// Bytes not handed out in a message: noise, rejected candidates' first bytes, messages
    /// with reserved values, and what [`Parser::finish`] discarded.
    pub dropped: u64,
}

impl Counters for Stats {
    fn frames(&self) -> u64 {
        self.frames
    }

    /// Candidates rejected and messages with reserved values (the bytes they cost are in
    /// [`Stats::dropped`]).
    fn dropped(&self) -> u64 {
        self.crc_failures + self.bad_length + self.decode_errors
    }

    fn each(&self, f: &mut dyn FnMut(&'static str, u64)) {
        f("frames", self.frames);
        f("bytes", self.bytes);
        f("crc_failures", self.crc_failures);
        f("bad_length", self.bad_length);
        f("decode_errors", self.decode_errors);
        f("dropped_bytes", self.dropped);
    }
}

pub use crate::framing::Feed;

/// The push parser: a 14-byte buffer, the CRC to check with, and counters.
#[derive(Debug, Clone)]
pub struct Parser {
    buf: [u8; MAX_FRAME_LEN],
    /// Bytes of the current candidate in `buf`; `buf[0]` is 0x5A when non-zero.
    len: usize,
    crc: &'static Crc8,
    stats: Stats,
}

impl Default for Parser {
    fn default() -> Self {
        Parser::new()
    }
}

/// What the buffered candidate turned out to be.
enum Verdict {
    /// More bytes are needed.
    Incomplete,
    /// A message of this many bytes.
    Message(Message, usize),
    /// Valid CRC, invalid content: skip this many bytes.
    Invalid(usize),
    /// Not a message: search again from the byte after the 0x5A.
    Rejected,
}

impl Parser {
    /// A parser checking CRC-8/SMBUS.
    pub const fn new() -> Self {
        Parser::with_crc(&uart::SMBUS)
    }

    /// A parser checking another CRC, e.g. `static CRC: Crc8 = Crc8::new(&crc::CRC_8_AUTOSAR);`.
    pub const fn with_crc(crc: &'static Crc8) -> Self {
        Parser {
            buf: [0; MAX_FRAME_LEN],
            len: 0,
            crc,
            stats: Stats {
                frames: 0,
                bytes: 0,
                crc_failures: 0,
                bad_length: 0,
                decode_errors: 0,
                dropped: 0,
            },
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

    /// Bytes of a possible message held in the parser.
    #[inline]
    pub fn pending(&self) -> usize {
        self.len
    }

    /// Ends the input: bytes of a message in progress are dropped (and counted).
    pub fn finish(&mut self) {
        self.stats.dropped += self.len as u64;
        self.len = 0;
    }

    /// Feeds bytes and returns the first complete message, if any, with the input after it.
    ///
    /// Call `feed` again with `remaining` until it returns [`Feed::Consumed`].
    pub fn feed<'a>(&mut self, mut input: &'a [u8]) -> Feed<'a, Message> {
        loop {
            if self.len == 0 {
                // Searching: skip to the next 0x5A.
                let skip = input.iter().position(|&b| b == SYNC).unwrap_or(input.len());
                self.stats.bytes += skip as u64;
                self.stats.dropped += skip as u64;
                input = input.get(skip..).unwrap_or_default();
                let Some((&sync, rest)) = input.split_first() else {
                    return Feed::Consumed;
                };
                self.stats.bytes += 1;
                self.buf[0] = sync;
                self.len = 1;
                input = rest;
            }
            // Take up to what the candidate needs next.
            let need = match uart::frame_len(&self.buf[..self.len]) {
                Ok(n) => n,
                Err(_) => HEAD_LEN,
            };
            let take = need.saturating_sub(self.len).min(input.len());
            let (run, rest) = input.split_at(take);
            if let Some(dst) = self.buf.get_mut(self.len..self.len + take) {
                dst.copy_from_slice(run);
            }
            self.len += take;
            self.stats.bytes += take as u64;
            input = rest;
            if let Some(message) = self.settle() {
                return Feed::Frame {
                    frame: message,
                    remaining: input,
                };
            }
            if input.is_empty() {
                return Feed::Consumed;
            }
        }
    }

    /// Feeds bytes and calls `on_message` for every message they complete; returns how many.
    pub fn feed_all(&mut self, input: &[u8], on_message: impl FnMut(Message)) -> usize {
        Deframer::feed_all(self, input, on_message)
    }

    /// Judges the buffered candidate, re-scanning after rejections, until it needs more bytes
    /// or yields a message.
    fn settle(&mut self) -> Option<Message> {
        loop {
            match self.judge() {
                Verdict::Incomplete => return None,
                Verdict::Message(message, n) => {
                    self.stats.frames += 1;
                    self.consume(n);
                    return Some(message);
                }
                Verdict::Invalid(n) => {
                    self.stats.decode_errors += 1;
                    self.stats.dropped += n as u64;
                    self.consume(n);
                }
                Verdict::Rejected => {
                    // Re-scan from the byte after this candidate's 0x5A.
                    self.stats.dropped += 1;
                    self.consume(1);
                }
            }
            if self.len == 0 {
                return None;
            }
        }
    }

    fn judge(&mut self) -> Verdict {
        let bytes = self.buf.get(..self.len).unwrap_or_default();
        let need = match uart::frame_len(bytes) {
            Ok(n) => n,
            Err(uart::FrameError::BadLength { .. }) => {
                self.stats.bad_length += 1;
                return Verdict::Rejected;
            }
            Err(uart::FrameError::Truncated { .. }) => return Verdict::Incomplete,
            Err(_) => return Verdict::Rejected,
        };
        match uart::decode_with(bytes, self.crc) {
            Ok(message) => Verdict::Message(message, need),
            Err(uart::FrameError::Truncated { .. }) => Verdict::Incomplete,
            Err(uart::FrameError::Decode(_)) => Verdict::Invalid(need),
            Err(_) => {
                self.stats.crc_failures += 1;
                Verdict::Rejected
            }
        }
    }

    /// Drops the first `n` buffered bytes and every byte before the next 0x5A (counted as
    /// dropped), keeping the rest at the front.
    fn consume(&mut self, n: usize) {
        let n = n.min(self.len);
        let rest = self.buf.get(n..self.len).unwrap_or_default();
        let skip = rest.iter().position(|&b| b == SYNC).unwrap_or(rest.len());
        self.stats.dropped += skip as u64;
        self.buf.copy_within(n + skip..self.len, 0);
        self.len -= n + skip;
    }
}

impl Deframer for Parser {
    type Frame<'p> = Message;
    type Stats = Stats;

    #[inline]
    fn feed<'p, 'a: 'p>(&'p mut self, input: &'a [u8]) -> Feed<'a, Message> {
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
