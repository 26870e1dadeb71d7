//! Reading logs back: `.tlog` records and raw captures, a chunk at a time.

use std::io::{self, Read};

use ferrolink_runtime::mavlink::parser::{Feed, ParsedFrame, Parser};
use ferrolink_runtime::mavlink::{v1, v2, MessageMeta};

/// What a reader found besides the frames it handed out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReadStats {
    /// Frames handed out.
    pub frames: u64,
    /// Of those, frames with ids the table lacks (unchecked; only at record boundaries).
    pub unchecked: u64,
    /// Of those, frames found by searching after damage rather than at a record boundary.
    pub resynced: u64,
    /// Bytes skipped: damage, noise, rejected candidates.
    pub skipped_bytes: u64,
    /// Candidates rejected for a bad checksum while searching.
    pub bad_crc: u64,
    /// Bytes at the end too short for a whole record.
    pub truncated_bytes: u64,
}

/// One frame of a log.
#[derive(Debug, Clone, Copy)]
pub struct Record<'a> {
    /// Its timestamp (`None` in a raw capture).
    pub t_us: Option<u64>,
    /// Where the frame starts in the input.
    pub offset: usize,
    /// The frame.
    pub frame: ParsedFrame<'a>,
}

/// How many bytes a reader asks its input for at a time.
const CHUNK: usize = 1 << 20;

/// The longest record: a timestamp and the longest frame.
const RECORD_MAX: usize = 8 + v2::MAX_FRAME_LEN;

type FrameParser<T> = Parser<{ v2::MAX_FRAME_LEN }, T>;

/// Reads a log from any [`Read`], a chunk at a time, so that a file larger than memory is read
/// in the memory of one chunk: a `.tlog` ([`LogReader::tlog`]) or a raw capture of link bytes
/// ([`LogReader::raw`]).
///
/// In a `.tlog`, a record whose frame is whole and passes its checksum (or has an id the table
/// lacks) is taken as it stands. Anything else is damage: the reader then searches for the next
/// frame that passes its checksum, with the backtracking parser, and takes the 8 bytes before it
/// as its timestamp. In a raw capture, every frame that passes its checksum is taken, in order;
/// ids the table lacks cannot be checked and are skipped (in noise they are mostly false
/// frames). Chunk boundaries change nothing: the frames and counts are those of the whole input
/// read at once.
///
/// ```
/// use ferrolink_io::mavlink::tlog::{LogReader, Writer};
/// use ferrolink_runtime::mavlink::{v2, Header, MessageMeta};
///
/// // HEARTBEAT: id 0, CRC_EXTRA 50, 9 bytes.
/// let table = [MessageMeta {
///     id: 0, crc_extra: 50, min_len: 9, max_len: 9, target_system: None, target_component: None,
/// }];
/// let mut frame = [0u8; v2::MAX_FRAME_LEN];
/// let n = v2::encode_raw(Header::new(0, 1, 1), 0, 50, &[0; 9], &mut frame).unwrap();
/// let mut log = Writer::new(Vec::new());
/// log.write(1_700_000_000_000_000, &frame[..n])?;
/// log.write(1_700_000_000_020_000, &frame[..n])?;
/// let mut bytes = log.get_mut().clone();
/// bytes.extend_from_slice(&[0x55; 3]); // a record cut short
///
/// let mut reader = LogReader::tlog(&bytes[..], &table[..]);
/// let mut times = Vec::new();
/// while reader.next_chunk(|record| times.push(record.t_us))? {}
/// assert_eq!(times, [Some(1_700_000_000_000_000), Some(1_700_000_000_020_000)]);
/// assert_eq!(reader.stats().truncated_bytes, 3);
/// # Ok::<(), std::io::Error>(())
/// ```
pub struct LogReader<R, T> {
    input: R,
    table: T,
    /// Bytes read and not yet consumed: `buf[..end]`; `buf[0]` is at `base` in the input.
    buf: Vec<u8>,
    end: usize,
    base: usize,
    /// The next byte to look at, in `buf`.
    pos: usize,
    eof: bool,
    /// `.tlog`: searching for a frame from `pos` after damage (`Some(fresh)`: whether the
    /// search started at the damaged record, 8 bytes after its start, and has not moved since).
    searching: Option<bool>,
    /// A raw capture's stream parser.
    raw: Option<FrameParser<T>>,
    /// Checks a frame in place: a `.tlog` record's (ids the table lacks pass unchecked), or a
    /// raw capture's frame the stream parser found in its own buffer.
    checker: FrameParser<T>,
    stats: ReadStats,
}

impl<T: AsRef<[MessageMeta]> + Clone> LogReader<std::fs::File, T> {
    /// Opens the log at `path`: a raw capture when `raw`, else a `.tlog`. The error names the
    /// file.
    pub fn open(path: &std::path::Path, table: T, raw: bool) -> io::Result<Self> {
        let file = std::fs::File::open(path)
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
        Ok(Self::new_kind(file, table, raw))
    }
}

impl<R, T> std::fmt::Debug for LogReader<R, T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogReader")
            .field("raw", &self.raw.is_some())
            .field("offset", &(self.base + self.pos))
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<R: Read, T: AsRef<[MessageMeta]> + Clone> LogReader<R, T> {
    /// A reader of a `.tlog`: records of an 8-byte big-endian timestamp and a frame.
    pub fn tlog(input: R, table: T) -> Self {
        Self::new(input, table, None)
    }

    /// A reader of a raw capture of link bytes.
    pub fn raw(input: R, table: T) -> Self {
        let parser = FrameParser::new(table.clone());
        Self::new(input, table, Some(parser))
    }

    /// A reader of either kind: a raw capture when `raw`, else a `.tlog`.
    pub fn new_kind(input: R, table: T, raw: bool) -> Self {
        match raw {
            true => Self::raw(input, table),
            false => Self::tlog(input, table),
        }
    }

    fn new(input: R, table: T, raw: Option<FrameParser<T>>) -> Self {
        LogReader {
            input,
            checker: FrameParser::new(table.clone()).pass_unknown_ids(raw.is_none()),
            table,
            buf: vec![0; CHUNK + RECORD_MAX],
            end: 0,
            base: 0,
            pos: 0,
            eof: false,
            searching: None,
            raw,
            stats: ReadStats::default(),
        }
    }

    /// What the reader found so far.
    pub fn stats(&self) -> ReadStats {
        self.stats
    }

    /// Reads the next chunk of the input and calls `on_record` for each frame it completes, in
    /// order. `Ok(false)` once the input is done (its end counted in [`LogReader::stats`]).
    pub fn next_chunk(&mut self, on_record: impl FnMut(Record<'_>)) -> io::Result<bool> {
        if self.eof && self.pos >= self.end {
            return Ok(false);
        }
        // Keep what is not consumed, and the 8 bytes before it: a frame found by searching
        // takes them as its timestamp. (At most a record and 8 bytes are ever left.)
        let keep = self.pos.saturating_sub(8);
        self.buf.copy_within(keep..self.end, 0);
        self.base += keep;
        self.pos -= keep;
        self.end -= keep;
        let n = loop {
            match self.input.read(&mut self.buf[self.end..]) {
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                other => break other?,
            }
        };
        self.end += n;
        self.eof = n == 0;
        if self.raw.is_some() {
            self.raw_chunk(on_record);
        } else {
            self.tlog_chunk(on_record);
        }
        Ok(true)
    }

    /// Reads the whole input, calling `on_record` for every frame.
    pub fn read_all(&mut self, mut on_record: impl FnMut(Record<'_>)) -> io::Result<ReadStats> {
        while self.next_chunk(&mut on_record)? {}
        Ok(self.stats)
    }

    fn raw_chunk(&mut self, mut on_record: impl FnMut(Record<'_>)) {
        let Some(parser) = self.raw.as_mut() else {
            return;
        };
        let data = &self.buf[..self.end];
        // Where a slice of `data` starts in the input.
        let at = |part: &[u8]| self.base + (part.as_ptr() as usize - data.as_ptr() as usize);
        let mut input = &data[self.pos..];
        let mut copy = [0u8; v2::MAX_FRAME_LEN];
        loop {
            let (len, remaining) = match parser.feed(input) {
                Feed::Consumed => break,
                Feed::Frame { frame, remaining } => {
                    let bytes = frame.as_bytes();
                    if input.as_ptr_range().contains(&bytes.as_ptr()) {
                        self.stats.frames += 1;
                        on_record(Record {
                            t_us: None,
                            offset: at(bytes),
                            frame,
                        });
                        input = remaining;
                        continue;
                    }
                    // From the parser's own buffer, with bytes it still holds after it: where
                    // it starts is known once the parser is asked how many.
                    copy[..bytes.len()].copy_from_slice(bytes);
                    (bytes.len(), remaining)
                }
            };
            input = remaining;
            let offset = at(input) - parser.buffered() - len;
            if let Some(frame) = self.checker.parse_at(&copy[..len]) {
                self.stats.frames += 1;
                on_record(Record {
                    t_us: None,
                    offset,
                    frame,
                });
            }
        }
        self.pos = self.end;
        let p = parser.stats();
        self.stats.bad_crc = p.bad_crc as u64;
        self.stats.skipped_bytes = (p.garbage_bytes + p.rejected()) as u64;
        if self.eof {
            self.stats.truncated_bytes = parser.buffered() as u64;
        }
    }

    fn tlog_chunk(&mut self, mut on_record: impl FnMut(Record<'_>)) {
        let aligned = &self.checker;
        let data = &self.buf[..self.end];
        let stats = &mut self.stats;
        let mut pos = self.pos;
        while pos < data.len() {
            let left = data.len() - pos;
            if let Some(fresh) = self.searching {
                // Searching after damage: every frame that can start here is whole in `data`,
                // unless the input goes on.
                if !self.eof && left < v2::MAX_FRAME_LEN {
                    break;
                }
                let body = &data[pos..];
                let mut search = FrameParser::new(self.table.as_ref());
                let found = match search.feed(body) {
                    Feed::Frame { frame, remaining } => {
                        let end = data.len() - remaining.len();
                        let start = end - frame.as_bytes().len();
                        on_record(Record {
                            t_us: timestamp(data, start),
                            offset: self.base + start,
                            frame,
                        });
                        Some((start, end))
                    }
                    Feed::Consumed => None,
                };
                stats.bad_crc += search.stats().bad_crc as u64;
                // The candidate the search holds, incomplete: where the next chunk goes on.
                let held = search.buffered();
                match found {
                    Some((start, end)) => {
                        stats.skipped_bytes += (start - pos) as u64;
                        stats.frames += 1;
                        stats.resynced += 1;
                        pos = end;
                        self.searching = None;
                    }
                    None if self.eof => {
                        // Nothing more: the rest is damage, or a record cut off at the end.
                        if fresh
                            && body.len() < v2::MAX_FRAME_LEN
                            && body
                                .first()
                                .is_some_and(|&b| b == v1::MAGIC || b == v2::MAGIC)
                        {
                            stats.truncated_bytes += (left + 8) as u64;
                        } else {
                            stats.skipped_bytes += left as u64;
                        }
                        pos = data.len();
                    }
                    None => {
                        // Every candidate before the one held was judged (and counted once);
                        // that one may end in the next chunk.
                        let next = data.len() - held;
                        stats.skipped_bytes += (next - pos) as u64;
                        pos = next;
                        self.searching = Some(false);
                    }
                }
                continue;
            }
            if !self.eof && left < RECORD_MAX {
                break;
            }
            let Some(body) = data.get(pos + 8..) else {
                stats.truncated_bytes += left as u64;
                pos = data.len();
                break;
            };
            if let Some(frame) = aligned.parse_at(body) {
                stats.frames += 1;
                stats.unchecked += u64::from(!frame.is_checked());
                on_record(Record {
                    t_us: timestamp(data, pos + 8),
                    offset: self.base + pos + 8,
                    frame,
                });
                pos += 8 + frame.as_bytes().len();
                continue;
            }
            // Damage: search from the byte after this record's timestamp.
            pos += 8;
            self.searching = Some(true);
        }
        self.pos = pos;
    }
}

/// The big-endian timestamp in the 8 bytes before `at`.
fn timestamp(data: &[u8], at: usize) -> Option<u64> {
    let bytes = data.get(at.checked_sub(8)?..at)?;
    Some(u64::from_be_bytes(bytes.try_into().ok()?))
}

/// Reads a `.tlog` held in memory, calling `on_record` for every frame in order, as
/// [`LogReader::tlog`] does.
pub fn read_tlog(
    data: &[u8],
    table: &[MessageMeta],
    on_record: impl FnMut(Record<'_>),
) -> ReadStats {
    let mut reader = LogReader::tlog(data, table);
    // Reading from memory cannot fail.
    reader.read_all(on_record).unwrap_or(reader.stats)
}

/// Reads a raw capture of link bytes held in memory, as [`LogReader::raw`] does.
pub fn read_raw(
    data: &[u8],
    table: &[MessageMeta],
    on_record: impl FnMut(Record<'_>),
) -> ReadStats {
    let mut reader = LogReader::raw(data, table);
    reader.read_all(on_record).unwrap_or(reader.stats)
}
