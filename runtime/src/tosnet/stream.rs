//! TosNet frames on a byte stream (a serial link, a pty, TCP), where nothing marks where a frame
//! ends: a DATA frame's length depends on the registers the ring enabled.
//!
//! ```text
//! 0x7E | escape( frame: command, body, CRC-8 ) | 0x7E
//! ```
//!
//! **(project choice)** The original sends frames over Toslink with a line code inside an FPGA;
//! on a byte stream we delimit them as NDLCom does (HDLC-like: 0x7E flags, 0x7D escapes the
//! next byte XOR 0x20). Over UDP a datagram is one frame and needs none of this.
//!
//! Bytes before the first flag are skipped, as after an error: a frame starts at a flag. The
//! parser hands out every frame between two flags, **also one whose CRC fails**: a TosNet
//! node forwards a broken frame (with its CRC spoiled) to keep the cycle going, so it has to see
//! it. Such frames are counted in [`Stats::crc_failures`]. Dropped are frames longer than the
//! parser holds ([`Stats::oversize`]), frames with a bad escape ([`Stats::bad_escape`]) and
//! frames too short to hold a command and a CRC ([`Stats::runts`]).
//!
//! ```
//! use ferrolink_runtime::framing::{Deframer, Feed};
//! use ferrolink_runtime::tosnet::{frame::Repr, stream};
//!
//! let mut frame = [0u8; 8];
//! let n = Repr::Idle { sender: 3 }.emit(&mut frame).unwrap();
//! let mut wire = [0u8; 16];
//! let m = stream::encode(&frame[..n], &mut wire).unwrap();
//!
//! let mut parser = stream::Parser::<64>::new();
//! assert!(matches!(parser.feed(&wire[..2]), Feed::Consumed));
//! let Feed::Frame { frame: got, remaining } = parser.feed(&wire[2..m]) else { panic!() };
//! assert_eq!(Repr::parse(got), Ok(Repr::Idle { sender: 3 }));
//! assert!(remaining.is_empty());
//! ```

use super::frame::{crc_ok, MAX_FRAME_LEN};
use crate::bump;
use crate::framing::{wide, Counters, Deframer, Feed};
use crate::hdlc::{stuff_into, stuffed_len, ESCAPE, FLAG, XOR};

/// The shortest frame: a command byte and the CRC.
const MIN_FRAME_LEN: usize = 2;

/// What a [`Parser`] handed out and dropped so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Stats {
    /// Frames handed out, those with a failed CRC included.
    pub frames: usize,
    /// Bytes fed.
    pub bytes: usize,
    /// Frames handed out whose CRC failed.
    pub crc_failures: usize,
    /// Frames dropped for being longer than the parser holds.
    pub oversize: usize,
    /// Frames dropped for an escape byte followed by something other than 0x5D or 0x5E.
    pub bad_escape: usize,
    /// Frames dropped for being shorter than a command and a CRC, or cut off by
    /// [`Deframer::finish`].
    pub runts: usize,
    /// Bytes skipped outside frames: before the first flag, and after a dropped frame up to
    /// the next flag.
    pub skipped_bytes: usize,
}

impl Counters for Stats {
    fn frames(&self) -> u64 {
        wide(self.frames)
    }

    fn dropped(&self) -> u64 {
        wide(
            self.oversize
                .wrapping_add(self.bad_escape)
                .wrapping_add(self.runts),
        )
    }

    fn each(&self, f: &mut dyn FnMut(&'static str, u64)) {
        f("frames", wide(self.frames));
        f("bytes", wide(self.bytes));
        f("crc_failures", wide(self.crc_failures));
        f("oversize", wide(self.oversize));
        f("bad_escape", wide(self.bad_escape));
        f("runts", wide(self.runts));
        f("skipped_bytes", wide(self.skipped_bytes));
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Collecting the bytes of a frame.
    Collect,
    /// The last byte was an escape.
    Escaped,
    /// Skipping everything up to the next flag (at the start, and after an error).
    Discard,
}

/// The stream parser, holding frames of up to `N` bytes (by default the longest DATA frame).
#[derive(Debug, Clone)]
pub struct Parser<const N: usize = MAX_FRAME_LEN> {
    buf: [u8; N],
    len: usize,
    state: State,
    stats: Stats,
}

impl<const N: usize> Default for Parser<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Parser<N> {
    /// An empty parser.
    pub const fn new() -> Self {
        Parser {
            buf: [0; N],
            len: 0,
            state: State::Discard,
            stats: Stats {
                frames: 0,
                bytes: 0,
                crc_failures: 0,
                oversize: 0,
                bad_escape: 0,
                runts: 0,
                skipped_bytes: 0,
            },
        }
    }

    /// Drops the frame in progress and everything up to the next flag.
    fn discard(&mut self) {
        self.len = 0;
        self.state = State::Discard;
    }
}

impl<const N: usize> Deframer for Parser<N> {
    type Frame<'p> = &'p [u8];
    type Stats = Stats;

    fn feed<'p, 'a: 'p>(&'p mut self, mut input: &'a [u8]) -> Feed<'a, &'p [u8]> {
        while let Some((&b, rest)) = input.split_first() {
            input = rest;
            bump(&mut self.stats.bytes, 1);
            if b == FLAG {
                let len = core::mem::take(&mut self.len);
                let state = core::mem::replace(&mut self.state, State::Collect);
                match (state, len) {
                    (State::Discard, _) | (State::Collect, 0) => {}
                    (State::Escaped, _) => bump(&mut self.stats.bad_escape, 1),
                    (State::Collect, len) if len < MIN_FRAME_LEN => bump(&mut self.stats.runts, 1),
                    (State::Collect, len) => {
                        let frame = self.buf.get(..len).unwrap_or_default();
                        bump(&mut self.stats.frames, 1);
                        if !crc_ok(frame) {
                            bump(&mut self.stats.crc_failures, 1);
                        }
                        return Feed::Frame {
                            frame,
                            remaining: input,
                        };
                    }
                }
                continue;
            }
            let byte = match self.state {
                State::Discard => {
                    bump(&mut self.stats.skipped_bytes, 1);
                    continue;
                }
                State::Collect if b == ESCAPE => {
                    self.state = State::Escaped;
                    continue;
                }
                State::Collect => b,
                State::Escaped if matches!(b ^ XOR, FLAG | ESCAPE) => {
                    self.state = State::Collect;
                    b ^ XOR
                }
                State::Escaped => {
                    bump(&mut self.stats.bad_escape, 1);
                    self.discard();
                    continue;
                }
            };
            match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => {
                    bump(&mut self.stats.oversize, 1);
                    self.discard();
                }
            }
        }
        Feed::Consumed
    }

    fn stats(&self) -> &Stats {
        &self.stats
    }

    fn take_stats(&mut self) -> Stats {
        core::mem::take(&mut self.stats)
    }

    fn finish(&mut self) {
        if self.len > 0 || self.state == State::Escaped {
            bump(&mut self.stats.runts, 1);
        }
        self.len = 0;
        self.state = State::Discard;
    }
}

/// Bytes `frame` takes on a stream, flags included.
pub fn encoded_len(frame: &[u8]) -> usize {
    stuffed_len(frame)
}

/// Writes `frame` (as [`Repr::emit`](super::frame::Repr::emit) or a node wrote it) between
/// flags into `out` and returns the length; `None` if `out` is too small.
pub fn encode(frame: &[u8], out: &mut [u8]) -> Option<usize> {
    stuff_into(frame, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tosnet::frame::{seal, seal_broken};
    use std::vec::Vec;

    fn wire(frames: &[&[u8]]) -> Vec<u8> {
        let mut out = Vec::new();
        for frame in frames {
            let mut buf = [0u8; 64];
            let n = encode(frame, &mut buf).unwrap();
            out.extend_from_slice(&buf[..n]);
        }
        out
    }

    fn sealed(body: &[u8], broken: bool) -> Vec<u8> {
        let mut frame = [body, &[0]].concat();
        if broken {
            seal_broken(&mut frame);
        } else {
            seal(&mut frame);
        }
        frame
    }

    fn parse_in_chunks(bytes: &[u8], chunk: usize) -> (Vec<Vec<u8>>, Stats) {
        let mut parser = Parser::<16>::new();
        let mut got = Vec::new();
        for piece in bytes.chunks(chunk) {
            parser.feed_all(piece, |f| got.push(f.to_vec()));
        }
        (got, *Deframer::stats(&parser))
    }

    #[test]
    fn every_frame_in_every_chunk_size_with_flags_and_escapes_inside() {
        let a = sealed(&[0x03], false);
        let b = sealed(&[0xC0, 2, FLAG, ESCAPE, FLAG], false);
        let broken = sealed(&[0x31], true);
        let stream = wire(&[&a, &b, &broken]);
        for chunk in 1..=stream.len() {
            let (got, stats) = parse_in_chunks(&stream, chunk);
            assert_eq!(got, [a.clone(), b.clone(), broken.clone()], "chunk {chunk}");
            assert_eq!((stats.frames, stats.crc_failures), (3, 1));
            assert_eq!(stats.bytes, stream.len());
        }
    }

    #[test]
    fn drops_are_counted_and_the_next_frame_survives() {
        let good = sealed(&[0x03], false);
        let mut stream = Vec::new();
        stream.extend_from_slice(&[1, 2, 3]); // noise before the first flag
        stream.extend_from_slice(&[FLAG, 7, FLAG]); // runt
        stream.extend_from_slice(&[FLAG, 1, ESCAPE, 0x00, 2, 3, FLAG]); // bad escape
        stream.extend_from_slice(&[FLAG]);
        stream.extend_from_slice(&[9; 20]); // longer than 16
        stream.extend_from_slice(&wire(&[&good]));
        stream.extend_from_slice(&[FLAG, 1, 2, ESCAPE, FLAG]); // escape then flag
        let (got, stats) = parse_in_chunks(&stream, 3);
        assert_eq!(got, [good]);
        assert_eq!((stats.runts, stats.bad_escape, stats.oversize), (1, 2, 1));
        assert_eq!(Counters::dropped(&stats), 4);
        // The noise, the bad escape's tail, and the oversize frame's bytes past the 17th.
        assert_eq!(stats.skipped_bytes, 3 + 2 + 3);
    }

    #[test]
    fn finish_counts_a_frame_in_progress() {
        let mut parser = Parser::<16>::new();
        assert!(matches!(parser.feed(&[FLAG, 1, 2]), Feed::Consumed));
        parser.finish();
        assert_eq!(Deframer::stats(&parser).runts, 1);
        assert!(matches!(parser.feed(&[3, 4, FLAG]), Feed::Consumed));
        assert_eq!(Deframer::stats(&parser).skipped_bytes, 2);
        assert!(matches!(parser.feed(&[5, 6, FLAG]), Feed::Frame { .. }));
    }
}
