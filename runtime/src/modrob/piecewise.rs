//! Piecewise transmission: a byte array (a module's info text) in numbered 7-byte chunks.
//!
//! CAN-1 does not carry the array's length, and the last chunk is padded with zeros, so the
//! length is the chunks' bytes without the trailing zeros. Info texts therefore hold no NUL
//! byte (the generator checks), and an array is at most 255 chunks (1785 bytes).
//!
//! [`Sender`] cuts an array into chunk messages; [`Reassembler`] puts one module's array back
//! together in a caller-sized buffer (`CAP` bytes inside the struct, no allocation).
//!
//! # Reassembly
//!
//! The wire carries neither a transfer id nor the array's length, only the chunk number and
//! the chunk count, so the receiver decides from those two what is a new transfer. The rules:
//!
//! - a chunk is placed by its number (`number * 7` in the buffer), whatever order it comes in,
//!   and marked in a 256-bit received map; [`Progress::Complete`] is reported when every
//!   number `0..chunks` is marked, so an array can be incomplete but never mis-assembled;
//! - a chunk whose number is below the highest one received in the transfer is *reordered*:
//!   placed all the same, flagged in [`Outcome::reordered`] and counted;
//! - a chunk number `>= chunks`, or a count of 0, is [`Progress::OutOfRange`] and changes
//!   nothing;
//! - a new transfer begins with a chunk whose count differs from the current transfer's, or
//!   with chunk 0 when chunk 0 was already received (modules send their array from chunk 0,
//!   so that is a restart). If the current transfer was incomplete it is abandoned and
//!   reported in [`Outcome::lost`] with how many chunks it missed; the chunk then starts the
//!   new transfer, which may itself complete (a one-chunk array);
//! - a chunk received again with the same bytes is a [`Progress::Duplicate`] and changes
//!   nothing; with other bytes it is a [`Progress::Conflict`]: no one can tell which version is
//!   right, so the transfer is dropped;
//! - once complete, the array stays readable ([`Reassembler::text`]) while the module repeats
//!   it unchanged (identical chunks are duplicates); any chunk that differs, or has another
//!   count, begins the next transfer;
//! - array bytes beyond `CAP` must be zero (the padding of the last chunk): a chunk carrying a
//!   non-zero byte there is [`Progress::TooLong`] and the transfer is dropped, so a `CAP`
//!   need not be a multiple of 7;
//! - the completed array is the chunks' bytes without trailing zeros.
//!
//! Chunks lost in the middle of a transfer show in [`Reassembler::missing`] while it is under
//! way, and in [`Outcome::lost`] when the next transfer starts.
//!
//! ```
//! use ferrolink_runtime::modrob::piecewise::{Progress, Reassembler, Sender};
//!
//! let mut sender = Sender::new(7, b"drive, front left");
//! sender.restart();
//! let mut chunks: Vec<_> = core::iter::from_fn(|| sender.next_chunk()).collect();
//! chunks.swap(0, 2); // out of order: placed by number all the same
//! let mut receiver = Reassembler::<64>::new(7);
//! assert!(matches!(receiver.push_message(&chunks[0]).progress, Progress::Pending { received: 1, chunks: 3 }));
//! assert!(receiver.push_message(&chunks[1]).complete().is_none());
//! let last = receiver.push_message(&chunks[2]);
//! assert!(last.reordered);
//! assert_eq!(last.complete(), Some(&b"drive, front left"[..]));
//! assert_eq!(receiver.stats().reordered, 2);
//! ```

use super::message::{Message, CHUNK_LEN};

/// The longest array that fits 255 chunks.
pub const MAX_LEN: usize = CHUNK_LEN * u8::MAX as usize;

/// How many chunks `len` bytes take (at least one: an empty array is one zero chunk).
pub const fn chunk_count(len: usize) -> usize {
    if len == 0 {
        1
    } else {
        len.div_ceil(CHUNK_LEN)
    }
}

/// Cuts one array into chunk messages, one per call to [`Sender::next_chunk`].
#[derive(Debug, Clone)]
pub struct Sender<'a> {
    module: u16,
    data: &'a [u8],
    next: usize,
    chunks: usize,
}

impl<'a> Sender<'a> {
    /// A sender of `data` from module `module`; `data` is cut at [`MAX_LEN`] bytes. It starts
    /// finished: call [`Sender::restart`] to send.
    pub fn new(module: u16, data: &'a [u8]) -> Self {
        let data = &data[..data.len().min(MAX_LEN)];
        let chunks = chunk_count(data.len());
        Self {
            module,
            data,
            next: chunks,
            chunks,
        }
    }

    /// Changes the sending module's MI (for chunks not sent yet).
    pub fn set_module(&mut self, module: u16) {
        self.module = module;
    }

    /// Sends the array again from chunk 0.
    pub fn restart(&mut self) {
        self.next = 0;
    }

    /// Whether every chunk has been handed out.
    pub fn is_done(&self) -> bool {
        self.next >= self.chunks
    }

    /// The number of chunks of the array.
    pub fn chunks(&self) -> u8 {
        self.chunks as u8
    }

    /// The next chunk, or `None` once the last one was handed out.
    pub fn next_chunk(&mut self) -> Option<Message> {
        if self.is_done() {
            return None;
        }
        let start = self.next * CHUNK_LEN;
        let part = self.data.get(start..).unwrap_or(&[]);
        let part = &part[..part.len().min(CHUNK_LEN)];
        let mut data = [0u8; CHUNK_LEN];
        data[..part.len()].copy_from_slice(part);
        let chunk = self.next as u8;
        self.next += 1;
        Some(Message::Piecewise {
            module: self.module,
            chunk,
            chunks: self.chunks as u8,
            data,
        })
    }
}

/// Words of the received map: one bit per chunk number 0..=255.
const MAP_WORDS: usize = 8;

/// What a [`Reassembler`] saw so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ReassemblyStats {
    /// Arrays completed.
    pub completed: u32,
    /// Transfers abandoned incomplete because a new one began.
    pub lost: u32,
    /// Chunks that arrived after a higher-numbered chunk of their transfer.
    pub reordered: u32,
    /// Chunks received again with other bytes (each drops its transfer).
    pub conflicts: u32,
    /// Chunks received again with the same bytes.
    pub duplicates: u32,
    /// Chunks numbered at or beyond their count, or with a count of 0.
    pub out_of_range: u32,
    /// Chunks with non-zero bytes beyond the buffer (each drops its transfer).
    pub too_long: u32,
}

/// A transfer abandoned incomplete because a new one began.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Lost {
    /// Its chunk count.
    pub chunks: u8,
    /// Chunks of it that arrived.
    pub received: u16,
    /// Chunks of it that never arrived.
    pub missing: u16,
}

/// What one chunk did to the current transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress<'a> {
    /// The chunk was placed; the array is not complete yet.
    Pending {
        /// Distinct chunks received in this transfer.
        received: u16,
        /// The transfer's chunk count.
        chunks: u8,
    },
    /// The chunk completed the array: every chunk `0..chunks` arrived, with the same bytes
    /// each time it arrived. The array without its trailing zeros.
    Complete(&'a [u8]),
    /// The chunk was received before with the same bytes; nothing changed.
    Duplicate {
        /// Its number.
        chunk: u8,
    },
    /// The chunk number is not below the chunk count (or the count is 0); nothing changed.
    OutOfRange {
        /// Its number.
        chunk: u8,
        /// The count it carried.
        chunks: u8,
    },
    /// The chunk was received before with other bytes; the transfer was dropped.
    Conflict {
        /// Its number.
        chunk: u8,
        /// The transfer's chunk count.
        chunks: u8,
    },
    /// The chunk has non-zero bytes beyond the buffer; the transfer was dropped.
    TooLong {
        /// Its number.
        chunk: u8,
        /// The transfer's chunk count.
        chunks: u8,
    },
    /// Not a piecewise chunk of this reassembler's module.
    Ignored,
}

/// The result of [`Reassembler::push`]: what the chunk did, and what it ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[must_use = "the array may be complete, or a transfer lost"]
pub struct Outcome<'a> {
    /// What the chunk did to the transfer it belongs to.
    pub progress: Progress<'a>,
    /// The previous transfer, if this chunk began a new one while it was incomplete.
    pub lost: Option<Lost>,
    /// Whether the chunk arrived after a higher-numbered chunk of its transfer (it was placed
    /// by its number all the same).
    pub reordered: bool,
}

impl<'a> Outcome<'a> {
    /// The array, if this chunk completed it.
    pub fn complete(&self) -> Option<&'a [u8]> {
        match self.progress {
            Progress::Complete(data) => Some(data),
            _ => None,
        }
    }

    fn new(progress: Progress<'a>, lost: Option<Lost>) -> Self {
        Outcome {
            progress,
            lost,
            reordered: false,
        }
    }
}

/// Reassembles the piecewise array of one module into `CAP` bytes; see the
/// [module documentation](self) for the rules.
#[derive(Debug, Clone)]
pub struct Reassembler<const CAP: usize> {
    module: u16,
    buf: [u8; CAP],
    /// One bit per chunk number received in the current transfer.
    received: [u32; MAP_WORDS],
    /// Distinct chunks in `received`.
    count: u16,
    /// The current transfer's chunk count; 0 when there is none.
    chunks: u8,
    /// The highest chunk number received in the current transfer.
    highest: u8,
    /// The array's length once complete.
    complete: Option<usize>,
    stats: ReassemblyStats,
}

impl<const CAP: usize> Reassembler<CAP> {
    /// A reassembler of the array of module `module`, with no transfer under way.
    pub const fn new(module: u16) -> Self {
        Reassembler {
            module,
            buf: [0; CAP],
            received: [0; MAP_WORDS],
            count: 0,
            chunks: 0,
            highest: 0,
            complete: None,
            stats: ReassemblyStats {
                completed: 0,
                lost: 0,
                reordered: 0,
                conflicts: 0,
                duplicates: 0,
                out_of_range: 0,
                too_long: 0,
            },
        }
    }

    /// The module whose chunks [`Reassembler::push_message`] takes.
    #[inline]
    pub fn module(&self) -> u16 {
        self.module
    }

    /// Follows another module, dropping the transfer under way (counters are kept).
    pub fn set_module(&mut self, module: u16) {
        self.module = module;
        self.clear();
    }

    /// Drops the transfer under way, or the completed array, without counting it lost.
    pub fn clear(&mut self) {
        self.received = [0; MAP_WORDS];
        self.count = 0;
        self.chunks = 0;
        self.highest = 0;
        self.complete = None;
    }

    /// The counters.
    #[inline]
    pub fn stats(&self) -> &ReassemblyStats {
        &self.stats
    }

    /// The current transfer's chunk count, or `None` when there is no transfer.
    pub fn chunks(&self) -> Option<u8> {
        (self.chunks != 0).then_some(self.chunks)
    }

    /// Distinct chunks received in the current transfer.
    #[inline]
    pub fn received(&self) -> u16 {
        self.count
    }

    /// How many chunks of the current transfer have not arrived (0 when there is none).
    pub fn missing_count(&self) -> u16 {
        u16::from(self.chunks) - self.count
    }

    /// The numbers of the chunks of the current transfer that have not arrived, ascending.
    pub fn missing(&self) -> impl Iterator<Item = u8> + '_ {
        (0..self.chunks).filter(move |&chunk| !self.has(chunk))
    }

    /// Whether the current transfer is complete.
    #[inline]
    pub fn is_complete(&self) -> bool {
        self.complete.is_some()
    }

    /// The completed array, until a chunk begins the next transfer.
    pub fn text(&self) -> Option<&[u8]> {
        self.complete.map(|len| &self.buf[..len])
    }

    /// Takes a message: a piecewise chunk of this reassembler's module goes to
    /// [`Reassembler::push`], anything else is [`Progress::Ignored`].
    pub fn push_message(&mut self, message: &Message) -> Outcome<'_> {
        match *message {
            Message::Piecewise {
                module,
                chunk,
                chunks,
                ref data,
            } if module == self.module => self.push(chunk, chunks, data),
            _ => Outcome::new(Progress::Ignored, None),
        }
    }

    /// Takes chunk `chunk` of a `chunks`-chunk array (the module is not checked).
    pub fn push(&mut self, chunk: u8, chunks: u8, data: &[u8; CHUNK_LEN]) -> Outcome<'_> {
        if chunk >= chunks {
            self.stats.out_of_range += 1;
            return Outcome::new(Progress::OutOfRange { chunk, chunks }, None);
        }
        let mut lost = None;
        if self.chunks != 0 {
            let same_transfer = self.chunks == chunks;
            let have = self.has(chunk);
            if self.complete.is_some() {
                if same_transfer && self.same_bytes(chunk, data) {
                    self.stats.duplicates += 1;
                    return Outcome::new(Progress::Duplicate { chunk }, None);
                }
                self.clear();
            } else if !same_transfer || (chunk == 0 && have) {
                self.stats.lost += 1;
                lost = Some(Lost {
                    chunks: self.chunks,
                    received: self.count,
                    missing: self.missing_count(),
                });
                self.clear();
            } else if have {
                if self.same_bytes(chunk, data) {
                    self.stats.duplicates += 1;
                    return Outcome::new(Progress::Duplicate { chunk }, None);
                }
                self.stats.conflicts += 1;
                self.clear();
                return Outcome::new(Progress::Conflict { chunk, chunks }, None);
            }
        }
        let start = usize::from(chunk) * CHUNK_LEN;
        let fits = data
            .iter()
            .enumerate()
            .all(|(i, &byte)| byte == 0 || start + i < CAP);
        if !fits {
            self.stats.too_long += 1;
            self.clear();
            return Outcome::new(Progress::TooLong { chunk, chunks }, lost);
        }
        let reordered = self.count > 0 && chunk < self.highest;
        if let Some(room) = self.buf.get_mut(start..) {
            let n = room.len().min(CHUNK_LEN);
            room[..n].copy_from_slice(&data[..n]);
        }
        self.chunks = chunks;
        self.received[usize::from(chunk / 32)] |= 1 << (chunk % 32);
        self.count += 1;
        self.highest = self.highest.max(chunk);
        if reordered {
            self.stats.reordered += 1;
        }
        let progress = if self.count == u16::from(chunks) {
            let end = (usize::from(chunks) * CHUNK_LEN).min(CAP);
            let len = self.buf[..end]
                .iter()
                .rposition(|&byte| byte != 0)
                .map_or(0, |last| last + 1);
            self.complete = Some(len);
            self.stats.completed += 1;
            Progress::Complete(&self.buf[..len])
        } else {
            Progress::Pending {
                received: self.count,
                chunks,
            }
        };
        Outcome {
            progress,
            lost,
            reordered,
        }
    }

    fn has(&self, chunk: u8) -> bool {
        self.received[usize::from(chunk / 32)] & 1 << (chunk % 32) != 0
    }

    /// Whether `data` equals chunk `chunk` as stored: the same bytes inside the buffer and
    /// zeros beyond it (what a placed chunk has there).
    fn same_bytes(&self, chunk: u8, data: &[u8; CHUNK_LEN]) -> bool {
        let start = usize::from(chunk) * CHUNK_LEN;
        data.iter()
            .enumerate()
            .all(|(i, &byte)| self.buf.get(start + i).map_or(byte == 0, |&b| b == byte))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_and_pads() {
        let mut s = Sender::new(9, b"0123456789");
        assert!(s.is_done());
        s.restart();
        let a = s.next_chunk().unwrap();
        let b = s.next_chunk().unwrap();
        assert_eq!(s.next_chunk(), None);
        assert_eq!(
            a,
            Message::Piecewise {
                module: 9,
                chunk: 0,
                chunks: 2,
                data: *b"0123456"
            }
        );
        assert_eq!(
            b,
            Message::Piecewise {
                module: 9,
                chunk: 1,
                chunks: 2,
                data: *b"789\0\0\0\0"
            }
        );
    }

    #[test]
    fn empty_and_longest() {
        let mut s = Sender::new(1, b"");
        s.restart();
        assert_eq!(s.chunks(), 1);
        assert!(s.next_chunk().is_some() && s.next_chunk().is_none());
        let long = [b'x'; MAX_LEN + 10];
        let mut s = Sender::new(1, &long);
        s.restart();
        assert_eq!(s.chunks(), 255);
        assert_eq!((0..300).filter_map(|_| s.next_chunk()).count(), 255);
    }

    fn chunks_of(text: &[u8]) -> std::vec::Vec<(u8, u8, [u8; CHUNK_LEN])> {
        let mut s = Sender::new(1, text);
        s.restart();
        core::iter::from_fn(|| s.next_chunk())
            .map(|m| match m {
                Message::Piecewise {
                    chunk,
                    chunks,
                    data,
                    ..
                } => (chunk, chunks, data),
                _ => unreachable!(),
            })
            .collect()
    }

    #[test]
    fn reassembles_in_order() {
        let text = b"a module that drives one wheel";
        let mut r = Reassembler::<64>::new(1);
        let parts = chunks_of(text);
        for (i, (chunk, chunks, data)) in parts.iter().enumerate() {
            let out = r.push(*chunk, *chunks, data);
            assert!(!out.reordered && out.lost.is_none());
            if i + 1 < parts.len() {
                assert_eq!(
                    out.progress,
                    Progress::Pending {
                        received: i as u16 + 1,
                        chunks: 5
                    }
                );
            } else {
                assert_eq!(out.complete(), Some(&text[..]));
            }
        }
        assert_eq!(r.text(), Some(&text[..]));
        assert_eq!(r.stats().completed, 1);
        // The module repeats it unchanged: duplicates, the text stays.
        for (chunk, chunks, data) in &parts {
            assert_eq!(
                r.push(*chunk, *chunks, data).progress,
                Progress::Duplicate { chunk: *chunk }
            );
        }
        assert_eq!(r.text(), Some(&text[..]));
    }

    #[test]
    fn empty_array_and_other_modules() {
        let mut r = Reassembler::<8>::new(3);
        let other = Message::Piecewise {
            module: 4,
            chunk: 0,
            chunks: 1,
            data: [1; 7],
        };
        assert_eq!(r.push_message(&other).progress, Progress::Ignored);
        let publication = Message::Publication {
            module: 3,
            variable: 0,
            value: 1.0,
        };
        assert_eq!(r.push_message(&publication).progress, Progress::Ignored);
        let empty = Message::Piecewise {
            module: 3,
            chunk: 0,
            chunks: 1,
            data: [0; 7],
        };
        assert_eq!(r.push_message(&empty).complete(), Some(&[][..]));
    }

    #[test]
    fn restart_reports_the_lost_transfer() {
        let mut r = Reassembler::<64>::new(1);
        let parts = chunks_of(b"0123456789abcdefghij"); // 3 chunks
        let _ = r.push(parts[0].0, parts[0].1, &parts[0].2);
        assert_eq!(r.missing().collect::<std::vec::Vec<_>>(), [1, 2]);
        let out = r.push(parts[0].0, parts[0].1, &parts[0].2);
        assert_eq!(
            out.lost,
            Some(Lost {
                chunks: 3,
                received: 1,
                missing: 2
            })
        );
        assert!(matches!(
            out.progress,
            Progress::Pending { received: 1, .. }
        ));
        // A new count that completes at once still reports the old transfer.
        let out = r.push(0, 1, b"short\0\0");
        assert_eq!(out.lost.map(|l| l.missing), Some(2));
        assert_eq!(out.complete(), Some(&b"short"[..]));
        assert_eq!(r.stats().lost, 2);
    }

    #[test]
    fn capacity_counts_bytes_not_chunks() {
        // 10 bytes in 2 chunks fit 10 bytes of buffer: the padding lies beyond it.
        let mut r = Reassembler::<10>::new(1);
        let parts = chunks_of(b"0123456789");
        let _ = r.push(parts[0].0, parts[0].1, &parts[0].2);
        let out = r.push(parts[1].0, parts[1].1, &parts[1].2);
        assert_eq!(out.complete(), Some(&b"0123456789"[..]));
        let mut r = Reassembler::<9>::new(1);
        let _ = r.push(parts[0].0, parts[0].1, &parts[0].2);
        let out = r.push(parts[1].0, parts[1].1, &parts[1].2);
        assert_eq!(
            out.progress,
            Progress::TooLong {
                chunk: 1,
                chunks: 2
            }
        );
        assert_eq!(r.chunks(), None);
        assert_eq!(r.stats().too_long, 1);
    }

    #[test]
    fn conflict_and_out_of_range() {
        let mut r = Reassembler::<64>::new(1);
        assert_eq!(
            r.push(2, 2, &[1; 7]).progress,
            Progress::OutOfRange {
                chunk: 2,
                chunks: 2
            }
        );
        assert_eq!(
            r.push(0, 0, &[1; 7]).progress,
            Progress::OutOfRange {
                chunk: 0,
                chunks: 0
            }
        );
        let _ = r.push(0, 3, &[1; 7]);
        let _ = r.push(1, 3, &[2; 7]);
        assert_eq!(
            r.push(1, 3, &[2; 7]).progress,
            Progress::Duplicate { chunk: 1 }
        );
        assert_eq!(
            r.push(1, 3, &[3; 7]).progress,
            Progress::Conflict {
                chunk: 1,
                chunks: 3
            }
        );
        assert_eq!(r.chunks(), None);
        let s = r.stats();
        assert_eq!((s.out_of_range, s.duplicates, s.conflicts), (2, 1, 1));
    }
}
