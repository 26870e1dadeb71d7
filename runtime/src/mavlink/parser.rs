//! A push-style, backtracking stream parser for MAVLink 1 and 2 frames.
//!
//! [`Parser::feed`] takes whatever bytes arrived and returns either "all consumed, no frame yet"
//! or one frame plus the input it has not looked at yet. Frames are zero-copy views: into the
//! input when a whole frame lies inside it, otherwise into the parser's own buffer.
//!
//! The parser backtracks. When a candidate frame is rejected (bad checksum, unknown message id,
//! unknown incompat flags), only its magic byte is dropped and the search restarts at the next
//! byte, including bytes the candidate had claimed. A false magic byte announcing a long payload
//! therefore delays the frames behind it but never loses them; byte-at-a-time parsers that
//! skip a whole claimed length lose every frame hidden inside it.
//!
//! ```
//! use ferrolink_runtime::mavlink::{parser::{Feed, Parser}, MessageMeta};
//!
//! static META: &[MessageMeta] = &[MessageMeta {
//!     id: 0, crc_extra: 50, min_len: 9, max_len: 9,
//!     target_system: None, target_component: None,
//! }];
//! let heartbeat = [
//!     0xfd, 0x09, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00,
//!     0x02, 0x03, 0x51, 0x04, 0x03, 0x7b, 0xae,
//! ];
//! let mut parser: Parser = Parser::new(META);
//!
//! // The frame arrives in two pieces, after some line noise.
//! assert!(matches!(parser.feed(&[0x00, 0xfd, 0x13]), Feed::Consumed));
//! assert!(matches!(parser.feed(&heartbeat[..5]), Feed::Consumed));
//! match parser.feed(&heartbeat[5..]) {
//!     Feed::Frame { frame, remaining } => {
//!         assert_eq!((frame.msg_id(), frame.header().sysid), (0, 1));
//!         assert!(remaining.is_empty());
//!     }
//!     Feed::Consumed => unreachable!(),
//! }
//! assert_eq!(parser.stats().frames, 1);
//! ```

use core::fmt;

use super::frame::{is_magic, AnyFrame};
use super::layout::{body_checksum, Header};
use super::{find_index, v1, v2, Dialect, MessageMeta, UnknownMessageId};
use crate::bump;
use crate::framing::Deframer;

mod stats;
pub use stats::Stats;

pub use crate::framing::Feed;

/// A frame the parser accepted: its checksum matched, unless its id was unknown and the parser
/// passes unknown ids through.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParsedFrame<'p> {
    frame: AnyFrame<&'p [u8]>,
    meta: Option<&'p MessageMeta>,
}

impl<'p> ParsedFrame<'p> {
    /// The frame view (MAVLink 1 or 2).
    #[inline]
    pub fn frame(&self) -> &AnyFrame<&'p [u8]> {
        &self.frame
    }

    /// The MAVLink 2 view, if this is a MAVLink 2 frame (for example to verify its signature).
    #[inline]
    pub fn as_v2(&self) -> Option<&v2::Frame<&'p [u8]>> {
        self.frame.as_v2()
    }

    /// The table entry of the message id, or `None` for an unknown id passed through unchecked.
    #[inline]
    pub fn meta(&self) -> Option<&'p MessageMeta> {
        self.meta
    }

    /// Whether the checksum was verified: false only for unknown ids passed through.
    #[inline]
    pub fn is_checked(&self) -> bool {
        self.meta.is_some()
    }

    /// The sender fields.
    #[inline]
    pub fn header(&self) -> Header {
        self.frame.header()
    }

    /// The message id.
    #[inline]
    pub fn msg_id(&self) -> u32 {
        self.frame.msg_id()
    }

    /// The payload as sent (possibly truncated).
    #[inline]
    pub fn payload(&self) -> &'p [u8] {
        let (bytes, head) = match self.frame {
            AnyFrame::V1(f) => (f.into_inner(), v1::HEADER_LEN),
            AnyFrame::V2(f) => (f.into_inner(), v2::HEADER_LEN),
        };
        let len = usize::from(self.frame.payload_len());
        bytes.get(head..head + len).unwrap_or_default()
    }

    /// The whole frame, signature included.
    #[inline]
    pub fn as_bytes(&self) -> &'p [u8] {
        let bytes = match self.frame {
            AnyFrame::V1(f) => f.into_inner(),
            AnyFrame::V2(f) => f.into_inner(),
        };
        bytes.get(..self.frame.frame_len()).unwrap_or(bytes)
    }

    /// Decodes the payload as a message of dialect `D` (zero-filling a truncated payload).
    #[inline]
    pub fn decode<D: Dialect>(&self) -> Result<D, UnknownMessageId> {
        self.frame.decode()
    }

    /// Decodes like `decode`, into `out` (see [`Dialect::decode_into`]).
    #[inline]
    pub fn decode_into<D: Dialect>(&self, out: &mut D) -> Result<(), UnknownMessageId> {
        self.frame.decode_into(out)
    }
}

/// Why a candidate was dropped.
#[derive(Debug, Clone, Copy)]
enum Reject {
    BadCrc,
    UnknownId,
    BadFlags,
}

/// Where a message's table entry is: in a dialect's static table (found through its dispatch),
/// or at an index of the parser's own table. A reference into the parser's table is taken only
/// when the frame is handed out, after the parser is done changing its state.
#[derive(Debug, Clone, Copy)]
enum MetaRef {
    Static(&'static MessageMeta),
    At(usize),
}

/// What the bytes of a candidate (starting at its magic byte) say so far.
#[derive(Debug, Clone, Copy)]
enum Eval {
    /// The next decision needs this many candidate bytes.
    NeedMore(usize),
    Reject(Reject),
    Accept {
        len: usize,
        meta: Option<MetaRef>,
    },
}

/// Where an accepted frame lies.
enum Found {
    Buffer(usize, Option<MetaRef>),
    Input(usize, Option<MetaRef>),
}

/// The stream parser, with an internal buffer of `N` bytes for frames split across `feed`
/// calls.
///
/// `N` must be at least [`v2::MAX_FRAME_LEN`] (280, the default); a smaller `N` fails to
/// compile:
///
/// ```compile_fail
/// # use ferrolink_runtime::mavlink::parser::Parser;
/// let p = Parser::<100>::new(&[]);
/// ```
///
/// Unknown message ids are dropped by default, since their checksum cannot be verified without
/// their CRC_EXTRA. [`pass_unknown_ids`](Self::pass_unknown_ids) hands them out unchecked
/// instead, as a router may want. That mode trusts the length byte of any such candidate, so a
/// false magic byte that looks like the header of an unknown message can swallow the frames
/// inside its claimed length.
#[derive(Clone)]
pub struct Parser<const N: usize = { v2::MAX_FRAME_LEN }, T = &'static [MessageMeta]> {
    buf: [u8; N],
    /// The current candidate starts at `buf[start]`; `buf[start..end]` is buffered.
    start: usize,
    end: usize,
    /// Length of the frame handed out from `buf[start..]`, dropped at the next `feed`.
    pending: usize,
    /// How many bytes the candidate at `buf[start]` needs before it is worth judging again (0:
    /// judge it now). Bytes fed one at a time are then only appended.
    need: usize,
    table: T,
    /// The dialect's own id dispatch ([`Dialect::meta_of`], a jump table), if the parser was
    /// made for a dialect; else `table` is searched.
    find: Option<fn(u32) -> Option<&'static MessageMeta>>,
    pass_unknown: bool,
    stats: Stats,
}

impl<const N: usize, T: AsRef<[MessageMeta]>> fmt::Debug for Parser<N, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Parser")
            .field("capacity", &N)
            .field("buffered", &self.buffered())
            .field("messages", &self.table.as_ref().len())
            .field("pass_unknown_ids", &self.pass_unknown)
            .field("stats", &self.stats)
            .finish()
    }
}

impl<const N: usize, T: AsRef<[MessageMeta]>> Parser<N, T> {
    const BUFFER_HOLDS_A_FRAME: () = assert!(
        N >= v2::MAX_FRAME_LEN,
        "Parser<N> needs N >= v2::MAX_FRAME_LEN (280)"
    );

    /// A parser checking frames against `table` (sorted by id, as [`Dialect::META`] is): a
    /// dialect's `META`, or a table built at run time and owned by the parser (an
    /// `Arc<[MessageMeta]>`, say, shared with other parsers).
    pub const fn new(table: T) -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::BUFFER_HOLDS_A_FRAME;
        Self {
            buf: [0; N],
            start: 0,
            end: 0,
            pending: 0,
            need: 0,
            table,
            find: None,
            pass_unknown: false,
            stats: Stats {
                frames: 0,
                unchecked: 0,
                garbage_bytes: 0,
                bad_crc: 0,
                unknown_id: 0,
                bad_flags: 0,
            },
        }
    }

    /// Whether frames with unknown message ids are handed out unchecked instead of dropped
    /// (off by default). See the type documentation for the risk.
    pub const fn pass_unknown_ids(mut self, pass: bool) -> Self {
        self.pass_unknown = pass;
        self
    }

    /// Changes whether unknown message ids are handed out unchecked.
    pub fn set_pass_unknown_ids(&mut self, pass: bool) {
        self.pass_unknown = pass;
    }

    /// The message table.
    pub fn table(&self) -> &[MessageMeta] {
        self.table.as_ref()
    }

    /// The counters.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Returns the counters and zeroes them.
    pub fn take_stats(&mut self) -> Stats {
        core::mem::take(&mut self.stats)
    }

    /// Bytes held for an incomplete candidate (not counting a frame already handed out).
    pub fn buffered(&self) -> usize {
        self.end
            .saturating_sub(self.start.saturating_add(self.pending))
    }

    /// Gives up the candidate frame the buffered bytes start with, after the input paused for
    /// longer than a link pauses inside a frame: its start byte is counted as garbage, and the
    /// next `feed` (empty or not) looks for frames in the bytes after it. Returns whether there
    /// was a candidate. See [`Deframer::drain_stalled`], which repeats this until nothing is
    /// buffered.
    ///
    /// A false start (a stray 0xFD or 0xFE, or one inside the tail of a frame joined midway)
    /// claims up to 280 bytes; without this, the frames behind it wait until that many bytes
    /// have come, seconds on a link that carries one heartbeat a second.
    pub fn give_up_stalled(&mut self) -> bool {
        if self.pending > 0 {
            self.start += self.pending;
            self.pending = 0;
        }
        self.need = 0;
        if self.start >= self.end {
            return false;
        }
        bump(&mut self.stats.garbage_bytes, 1);
        self.start += 1;
        true
    }

    /// Drops the buffered bytes (counted as garbage), e.g. after a link reset.
    pub fn reset(&mut self) {
        let buffered = self.buffered();
        bump(&mut self.stats.garbage_bytes, buffered);
        self.start = 0;
        self.end = 0;
        self.pending = 0;
        self.need = 0;
    }

    /// Feeds bytes and returns the first complete frame, if any, with the input after it.
    ///
    /// Call `feed` again with `remaining` until it returns [`Feed::Consumed`]. A frame returned
    /// from the internal buffer stays valid until the next call.
    #[inline]
    pub fn feed<'p, 'a: 'p>(&'p mut self, input: &'a [u8]) -> Feed<'a, ParsedFrame<'p>> {
        // The common cases, inlined into the caller's loop. One more byte for a buffered
        // candidate that stays short of what it needs (a UART fed byte by byte): append it,
        // nothing to judge yet.
        if let ([byte], 0) = (input, self.pending) {
            if self.end - self.start + 1 < self.need && self.push(*byte) {
                return Feed::Consumed;
            }
        }
        // Nothing buffered, and the input starts with a whole frame this parser accepts
        // (frames back to back in a read).
        if input.len() > 1
            && self.pending == 0
            && self.start == self.end
            && input.first().is_some_and(|&b| is_magic(b))
        {
            if let Eval::Accept { len, meta } = self.evaluate(input) {
                self.start = 0;
                self.end = 0;
                self.need = 0;
                let (bytes, remaining) = input.split_at_checked(len).unwrap_or((input, &[]));
                return self.hand_out(bytes, meta, remaining);
            }
        }
        self.feed_any(input)
    }

    /// [`Parser::feed`] in every case: a buffered candidate, garbage, a frame cut off.
    fn feed_any<'p, 'a: 'p>(&'p mut self, mut input: &'a [u8]) -> Feed<'a, ParsedFrame<'p>> {
        if self.pending > 0 {
            self.start += self.pending;
            self.pending = 0;
            self.need = 0;
        }

        let found = 'found: {
            // Buffered candidate first: it came before `input`.
            while self.start < self.end {
                let cand = self.buf.get(self.start..self.end).unwrap_or_default();
                let verdict = if cand.len() < self.need {
                    // Judged before and still short: its first byte is the magic byte it was
                    // judged at.
                    Eval::NeedMore(self.need)
                } else {
                    match cand.iter().position(|&b| is_magic(b)) {
                        Some(0) => {}
                        Some(skip) => {
                            bump(&mut self.stats.garbage_bytes, skip);
                            self.start += skip;
                            self.need = 0;
                            continue;
                        }
                        None => {
                            bump(&mut self.stats.garbage_bytes, cand.len());
                            self.start = self.end;
                            break;
                        }
                    }
                    self.evaluate(cand)
                };
                match verdict {
                    Eval::Accept { len, meta } => {
                        self.pending = len;
                        break 'found Found::Buffer(len, meta);
                    }
                    Eval::Reject(why) => {
                        self.count(why);
                        self.start += 1;
                        self.need = 0;
                    }
                    Eval::NeedMore(need) => {
                        self.need = need;
                        if input.is_empty() {
                            return Feed::Consumed;
                        }
                        let take = need.saturating_sub(cand.len()).min(input.len());
                        self.append(need, input.get(..take).unwrap_or_default());
                        input = input.get(take..).unwrap_or_default();
                        if self.end - self.start < need {
                            // The input ran out first.
                            return Feed::Consumed;
                        }
                    }
                }
            }
            self.start = 0;
            self.end = 0;
            self.need = 0;

            // Nothing buffered: work on the input directly.
            loop {
                match input.iter().position(|&b| is_magic(b)) {
                    Some(skip) => {
                        bump(&mut self.stats.garbage_bytes, skip);
                        input = input.get(skip..).unwrap_or_default();
                    }
                    None => {
                        bump(&mut self.stats.garbage_bytes, input.len());
                        return Feed::Consumed;
                    }
                }
                match self.evaluate(input) {
                    Eval::Accept { len, meta } => break 'found Found::Input(len, meta),
                    Eval::Reject(why) => {
                        self.count(why);
                        input = input.get(1..).unwrap_or_default();
                    }
                    Eval::NeedMore(need) => {
                        // Shorter than the candidate needs, so shorter than a frame: it fits.
                        self.append(input.len(), input);
                        self.need = need;
                        return Feed::Consumed;
                    }
                }
            }
        };

        match found {
            Found::Buffer(len, meta) => {
                self.count_frame(meta.is_none());
                let bytes = self.buf.get(self.start..self.start + len);
                let meta = meta.and_then(|m| self.resolve(m));
                Feed::Frame {
                    frame: ParsedFrame {
                        frame: any_frame(bytes.unwrap_or_default()),
                        meta,
                    },
                    remaining: input,
                }
            }
            Found::Input(len, meta) => {
                let (frame, rest) = input.split_at_checked(len).unwrap_or((input, &[]));
                self.hand_out(frame, meta, rest)
            }
        }
    }

    /// Counts a frame accepted from the input and hands it out.
    #[inline(always)]
    fn hand_out<'p, 'a: 'p>(
        &'p mut self,
        bytes: &'a [u8],
        meta: Option<MetaRef>,
        remaining: &'a [u8],
    ) -> Feed<'a, ParsedFrame<'p>> {
        self.count_frame(meta.is_none());
        let meta = meta.and_then(|m| self.resolve(m));
        Feed::Frame {
            frame: ParsedFrame {
                frame: any_frame(bytes),
                meta,
            },
            remaining,
        }
    }

    #[inline(always)]
    fn count_frame(&mut self, unchecked: bool) {
        bump(&mut self.stats.frames, 1);
        if unchecked {
            bump(&mut self.stats.unchecked, 1);
        }
    }

    /// Judges the one frame that starts at `bytes[0]`, without searching or buffering: for
    /// input whose frame boundaries are known, such as the records of a telemetry log. Counts
    /// nothing. `None` unless a whole frame that this parser would accept starts there.
    pub fn parse_at<'a>(&'a self, bytes: &'a [u8]) -> Option<ParsedFrame<'a>> {
        if !bytes.first().is_some_and(|&b| is_magic(b)) {
            return None;
        }
        let Eval::Accept { len, meta } = self.evaluate(bytes) else {
            return None;
        };
        let frame = any_frame(bytes.get(..len)?);
        let meta = meta.and_then(|m| self.resolve(m));
        Some(ParsedFrame { frame, meta })
    }

    /// Appends `bytes` to the buffered candidate, which will need `need` bytes in all, moving it
    /// to the front of the buffer first if it would not fit.
    fn append(&mut self, need: usize, bytes: &[u8]) {
        if self.start + need > N {
            move_to_front(&mut self.buf, self.start, self.end);
            self.end -= self.start;
            self.start = 0;
        }
        if let [byte] = bytes {
            if self.push(*byte) {
                return;
            }
        }
        match self.buf.get_mut(self.end..self.end + bytes.len()) {
            Some(dst) => {
                dst.copy_from_slice(bytes);
                self.end += bytes.len();
            }
            // Cannot happen (a candidate never needs more than a frame and N holds one); if it
            // did, drop the bytes rather than panic.
            None => bump(&mut self.stats.garbage_bytes, bytes.len()),
        }
    }

    /// Stores one byte behind the buffered bytes, if the buffer has room: one byte at a time (a
    /// UART), without a copy call.
    #[inline(always)]
    fn push(&mut self, byte: u8) -> bool {
        match self.buf.get_mut(self.end) {
            Some(slot) => {
                *slot = byte;
                self.end += 1;
                true
            }
            None => false,
        }
    }

    #[inline]
    fn count(&mut self, why: Reject) {
        match why {
            Reject::BadCrc => bump(&mut self.stats.bad_crc, 1),
            Reject::UnknownId => bump(&mut self.stats.unknown_id, 1),
            Reject::BadFlags => bump(&mut self.stats.bad_flags, 1),
        }
    }

    /// Judges the candidate starting at `c[0]` (a magic byte) as far as its bytes allow.
    #[inline]
    fn evaluate(&self, c: &[u8]) -> Eval {
        if c.first() == Some(&v1::MAGIC) {
            self.evaluate_v1(c)
        } else {
            self.evaluate_v2(c)
        }
    }

    #[inline]
    fn lookup(&self, id: u32) -> Result<Option<(MetaRef, u8)>, Reject> {
        let found = match self.find {
            Some(find) => find(id).map(|m| (MetaRef::Static(m), m.crc_extra)),
            None => {
                let table = self.table.as_ref();
                find_index(table, id).and_then(|i| Some((MetaRef::At(i), table.get(i)?.crc_extra)))
            }
        };
        match found {
            Some(meta) => Ok(Some(meta)),
            None if self.pass_unknown => Ok(None),
            None => Err(Reject::UnknownId),
        }
    }

    /// The table entry `meta` points at.
    #[inline]
    fn resolve(&self, meta: MetaRef) -> Option<&MessageMeta> {
        match meta {
            MetaRef::Static(m) => Some(m),
            MetaRef::At(i) => self.table.as_ref().get(i),
        }
    }

    #[inline]
    fn evaluate_v2(&self, c: &[u8]) -> Eval {
        let (Some(&len), Some(&incompat)) = (c.get(1), c.get(2)) else {
            return Eval::NeedMore(3);
        };
        if incompat & !v2::KNOWN_INCOMPAT_FLAGS != 0 {
            return Eval::Reject(Reject::BadFlags);
        }
        let Some(head) = c.first_chunk::<{ v2::HEADER_LEN }>() else {
            return Eval::NeedMore(v2::HEADER_LEN);
        };
        let meta = match self.lookup(u32::from_le_bytes([head[7], head[8], head[9], 0])) {
            Ok(meta) => meta,
            Err(why) => return Eval::Reject(why),
        };
        let body = v2::HEADER_LEN + usize::from(len);
        let signature = if incompat & v2::INCOMPAT_SIGNED != 0 {
            v2::SIGNATURE_LEN
        } else {
            0
        };
        let total = body + v2::CHECKSUM_LEN + signature;
        let Some(frame) = c.get(..total) else {
            return Eval::NeedMore(total);
        };
        accept_if_crc_matches(frame, body, total, meta)
    }

    #[inline]
    fn evaluate_v1(&self, c: &[u8]) -> Eval {
        let Some(head) = c.first_chunk::<{ v1::HEADER_LEN }>() else {
            return Eval::NeedMore(v1::HEADER_LEN);
        };
        let meta = match self.lookup(u32::from(head[5])) {
            Ok(meta) => meta,
            Err(why) => return Eval::Reject(why),
        };
        // A MAVLink 1 frame carries a known message's base fields alone, never more than its
        // longest payload: one that claims more cannot pass its checksum, so it is refused now
        // rather than after waiting for up to 261 bytes (a stray 0xFE before 0xFD would hold
        // back the frames behind it for as long on a quiet link).
        if let Some((at, _)) = meta {
            if self.resolve(at).is_some_and(|m| head[1] > m.max_len) {
                return Eval::Reject(Reject::BadCrc);
            }
        }
        let body = v1::HEADER_LEN + usize::from(head[1]);
        let total = body + v1::CHECKSUM_LEN;
        let Some(frame) = c.get(..total) else {
            return Eval::NeedMore(total);
        };
        accept_if_crc_matches(frame, body, total, meta)
    }
}

/// The view of an accepted frame, by its magic byte.
#[inline(always)]
fn any_frame(bytes: &[u8]) -> AnyFrame<&[u8]> {
    match bytes.first() {
        Some(&v1::MAGIC) => AnyFrame::V1(v1::Frame::new_unchecked(bytes)),
        _ => AnyFrame::V2(v2::Frame::new_unchecked(bytes)),
    }
}

/// Moves `buf[start..end]` to the front, in pieces no longer than `start`, so that each piece's
/// source and destination are apart: copies, never an overlapping move, whose `memmove` would
/// add 1.5 kB to a microcontroller's flash next to the `memcpy` it has anyway.
fn move_to_front(buf: &mut [u8], start: usize, end: usize) {
    if start == 0 {
        return;
    }
    let mut from = start;
    while from < end {
        let n = start.min(end - from);
        let (head, tail) = buf.split_at_mut(from.min(buf.len()));
        match (head.get_mut(from - start..from - start + n), tail.get(..n)) {
            (Some(dst), Some(src)) => dst.copy_from_slice(src),
            _ => return,
        }
        from += n;
    }
}

/// Checks the checksum of a complete candidate `frame` (header of `head_len` bytes, body of
/// `body` bytes) if its message is known.
#[inline]
fn accept_if_crc_matches(
    frame: &[u8],
    body: usize,
    total: usize,
    meta: Option<(MetaRef, u8)>,
) -> Eval {
    let Some((at, crc_extra)) = meta else {
        return Eval::Accept {
            len: total,
            meta: None,
        };
    };
    let sent = match frame.get(body..body + 2) {
        Some(&[lo, hi]) => u16::from_le_bytes([lo, hi]),
        _ => return Eval::Reject(Reject::BadCrc),
    };
    if body_checksum(frame.get(..body).unwrap_or_default(), crc_extra) == sent {
        Eval::Accept {
            len: total,
            meta: Some(at),
        }
    } else {
        Eval::Reject(Reject::BadCrc)
    }
}

impl<const N: usize> Parser<N> {
    /// A parser for dialect `D`, looking ids up through the dialect's own dispatch.
    pub const fn for_dialect<D: Dialect>() -> Self {
        let mut parser = Self::new(D::META);
        parser.find = Some(D::meta_of);
        parser
    }
}

impl<const N: usize, T: AsRef<[MessageMeta]> + 'static> Parser<N, T> {
    /// Feeds bytes and calls `on_frame` for every frame they complete; returns how many.
    pub fn feed_all(&mut self, input: &[u8], on_frame: impl FnMut(ParsedFrame<'_>)) -> usize {
        Deframer::feed_all(self, input, on_frame)
    }
}

impl<const N: usize, T: AsRef<[MessageMeta]>> Deframer for Parser<N, T> {
    type Frame<'p>
        = ParsedFrame<'p>
    where
        T: 'p;
    type Stats = Stats;

    #[inline]
    fn feed<'p, 'a: 'p>(&'p mut self, input: &'a [u8]) -> Feed<'a, ParsedFrame<'p>> {
        Parser::feed(self, input)
    }

    /// Frames back to back with nothing buffered, the common case of a read, are judged in
    /// place and handed to `on_frame` in one loop, without a `Feed` per frame; anything else
    /// goes through `feed`. A single byte (a UART's) goes straight to `feed`.
    fn feed_all(&mut self, mut input: &[u8], mut on_frame: impl FnMut(ParsedFrame<'_>)) -> usize {
        let mut n = 0;
        loop {
            if input.len() > 1 && self.pending == 0 && self.start == self.end {
                while let Some(&magic) = input.first() {
                    if !is_magic(magic) {
                        break;
                    }
                    let Eval::Accept { len, meta } = self.evaluate(input) else {
                        break;
                    };
                    self.count_frame(meta.is_none());
                    let (bytes, rest) = input.split_at_checked(len).unwrap_or((input, &[]));
                    on_frame(ParsedFrame {
                        frame: any_frame(bytes),
                        meta: meta.and_then(|m| self.resolve(m)),
                    });
                    input = rest;
                    n += 1;
                }
            }
            match Parser::feed(self, input) {
                Feed::Frame { frame, remaining } => {
                    on_frame(frame);
                    input = remaining;
                    n += 1;
                }
                Feed::Consumed => return n,
            }
        }
    }

    fn stats(&self) -> &Stats {
        &self.stats
    }

    fn take_stats(&mut self) -> Stats {
        core::mem::take(&mut self.stats)
    }

    /// Drops a frame in progress, counted as garbage bytes.
    fn finish(&mut self) {
        self.reset();
    }

    fn give_up_stalled(&mut self) -> bool {
        Parser::give_up_stalled(self)
    }
}

#[cfg(test)]
mod tests;
