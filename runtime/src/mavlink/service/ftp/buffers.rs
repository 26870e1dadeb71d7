//! The client's buffers: where an upload's bytes come from ([`Source`]), the bytes of a
//! reply ([`Chunk`]), and the byte ranges a read still misses.

use super::MAX_DATA;

/// Where an upload's bytes come from.
pub trait Source {
    /// Fills `buf` with the bytes at `offset`; how many (fewer only at the end).
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> usize;
}

impl Source for [u8] {
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> usize {
        let rest = self.get(offset as usize..).unwrap_or(&[]);
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        n
    }
}

/// Nothing to upload: for the operations that send no file.
impl Source for () {
    fn read(&mut self, _offset: u32, _buf: &mut [u8]) -> usize {
        0
    }
}

/// Up to [`MAX_DATA`] bytes of a reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chunk {
    len: u8,
    data: [u8; MAX_DATA],
}

impl Chunk {
    pub(super) fn new(bytes: &[u8]) -> Self {
        let mut data = [0; MAX_DATA];
        let n = bytes.len().min(MAX_DATA);
        data[..n].copy_from_slice(&bytes[..n]);
        Self { len: n as u8, data }
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        &self.data[..usize::from(self.len)]
    }
}

/// How many separate ranges a read may miss at once.
const GAPS: usize = 64;

/// The byte ranges still missing below the burst's high-water mark, sorted.
#[derive(Debug, Clone, Copy)]
pub(super) struct Gaps {
    ranges: [(u32, u32); GAPS],
    len: usize,
}

impl Gaps {
    pub(super) const fn new() -> Self {
        Self {
            ranges: [(0, 0); GAPS],
            len: 0,
        }
    }

    pub(super) fn as_slice(&self) -> &[(u32, u32)] {
        &self.ranges[..self.len]
    }

    pub(super) fn is_full(&self) -> bool {
        self.len == GAPS
    }

    pub(super) fn missing(&self) -> u32 {
        self.as_slice().iter().map(|(s, e)| e - s).sum()
    }

    /// Adds `[start, end)` above every other range; `false` when full.
    pub(super) fn push(&mut self, start: u32, end: u32) -> bool {
        if self.is_full() {
            return false;
        }
        self.ranges[self.len] = (start, end);
        self.len += 1;
        true
    }

    /// Removes `[start, end)` from the ranges; whether any byte was missing. A range that
    /// would split in two with no room left stays missing whole.
    pub(super) fn fill(&mut self, start: u32, end: u32) -> bool {
        let mut any = false;
        let mut i = 0;
        while i < self.len {
            let (s, e) = self.ranges[i];
            if end <= s || start >= e {
                i += 1;
                continue;
            }
            any = true;
            match (start <= s, end >= e) {
                (true, true) => {
                    self.ranges.copy_within(i + 1..self.len, i);
                    self.len -= 1;
                    continue;
                }
                (true, false) => self.ranges[i].0 = end,
                (false, true) => self.ranges[i].1 = start,
                (false, false) => {
                    // Split in two; with no room for the second, the whole range stays
                    // missing (read again later), never a part of it forgotten.
                    if !self.is_full() {
                        self.ranges[i].1 = start;
                        self.ranges.copy_within(i + 1..self.len, i + 2);
                        self.ranges[i + 1] = (end, e);
                        self.len += 1;
                        i += 1;
                    }
                }
            }
            i += 1;
        }
        any
    }
}
