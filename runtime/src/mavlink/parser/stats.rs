//! What a MAVLink stream parser counts.

use crate::framing::{wide, Counters};

/// What a [`Parser`] accepted and dropped so far. The counters are `usize`: 64 bits on a PC,
/// one word on a microcontroller, where they wrap instead of overflowing.
///
/// Every byte fed is accounted for exactly once:
/// `fed = garbage_bytes + rejected() + (bytes of frames handed out) + Parser::buffered()`,
/// because a rejected candidate costs exactly its magic byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Stats {
    /// Frames handed out, unchecked ones included.
    pub frames: usize,
    /// Frames with an unknown message id handed out unchecked
    /// (see [`Parser::pass_unknown_ids`]).
    pub unchecked: usize,
    /// Bytes skipped while searching for a magic byte.
    pub garbage_bytes: usize,
    /// Candidates dropped for a checksum mismatch.
    pub bad_crc: usize,
    /// Candidates dropped for a message id missing from the table.
    pub unknown_id: usize,
    /// MAVLink 2 candidates dropped for unknown incompat flags.
    pub bad_flags: usize,
}

impl Stats {
    /// All dropped candidates.
    #[inline]
    pub fn rejected(&self) -> usize {
        self.bad_crc
            .wrapping_add(self.unknown_id)
            .wrapping_add(self.bad_flags)
    }
}

impl Counters for Stats {
    fn frames(&self) -> u64 {
        wide(self.frames)
    }

    fn dropped(&self) -> u64 {
        wide(self.rejected())
    }

    fn each(&self, f: &mut dyn FnMut(&'static str, u64)) {
        f("frames", wide(self.frames));
        f("unchecked", wide(self.unchecked));
        f("garbage_bytes", wide(self.garbage_bytes));
        f("bad_crc", wide(self.bad_crc));
        f("unknown_id", wide(self.unknown_id));
        f("bad_flags", wide(self.bad_flags));
    }
}
