//! Packet counters: the next counter per receiver for outgoing headers, and the expected
//! counter per (sender, receiver) pair for reporting missed packets.
//!
//! Both tables are sized by the address count `A` (a const generic, 256 for every address);
//! addresses at or above `A` are not tracked, which lets a small node spend a few bytes instead
//! of a few hundred.

use super::Header;

/// The next counter per receiver, for the headers a node sends.
///
/// ```
/// use ferrolink_runtime::ndlcom::counters::TxCounters;
///
/// let mut tx = TxCounters::<256>::new();
/// assert_eq!(tx.header(5, 1, 0).counter, 0);
/// assert_eq!(tx.header(5, 1, 0).counter, 1);
/// assert_eq!(tx.header(6, 1, 0).counter, 0);
/// ```
#[derive(Debug, Clone)]
pub struct TxCounters<const A: usize = 256> {
    next: [u8; A],
}

impl<const A: usize> Default for TxCounters<A> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const A: usize> TxCounters<A> {
    /// All counters at 0.
    pub const fn new() -> Self {
        TxCounters { next: [0; A] }
    }

    /// The counter the next frame to `receiver` will carry, without taking it.
    pub fn peek(&self, receiver: u8) -> u8 {
        self.next.get(usize::from(receiver)).copied().unwrap_or(0)
    }

    /// Takes the next counter for `receiver` (always 0 for an untracked receiver).
    pub fn next(&mut self, receiver: u8) -> u8 {
        match self.next.get_mut(usize::from(receiver)) {
            Some(slot) => {
                let counter = *slot;
                *slot = counter.wrapping_add(1);
                counter
            }
            None => 0,
        }
    }

    /// A header for a frame from `sender` to `receiver` with `length` payload bytes, taking the
    /// receiver's next counter.
    pub fn header(&mut self, receiver: u8, sender: u8, length: u8) -> Header {
        Header::new(receiver, sender, self.next(receiver), length)
    }
}

/// What [`MissTracker::observe`] concluded about one frame's counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observation {
    /// The first frame of this pair: nothing to compare with, not a miss.
    First,
    /// The expected counter.
    InOrder,
    /// This many frames were missed before this one.
    Missed(u8),
    /// A counter from the last half-cycle: a duplicate or a frame that overtook another. The
    /// expectation is left as it was.
    Late,
    /// The pair is not tracked (an address at or above `A`).
    Untracked,
}

/// The expected next counter per (sender, receiver) pair: `2 * A * A` bytes (128 KiB for every
/// address, so put it in a `Box` or a static on a PC; a node that only tracks a few addresses
/// picks a small `A`).
#[derive(Debug, Clone)]
pub struct MissTracker<const A: usize = 256> {
    /// `expected[sender][receiver]`: the next counter, or `UNSEEN`.
    expected: [[u16; A]; A],
    missed: u64,
}

const UNSEEN: u16 = u16::MAX;

impl<const A: usize> Default for MissTracker<A> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const A: usize> MissTracker<A> {
    /// No pair seen yet.
    pub const fn new() -> Self {
        MissTracker {
            expected: [[UNSEEN; A]; A],
            missed: 0,
        }
    }

    /// Checks a received header's counter against the pair's expectation and updates it.
    ///
    /// A counter ahead by less than 128 counts the gap as missed; one behind by up to 128 is
    /// [`Observation::Late`].
    pub fn observe(&mut self, header: &Header) -> Observation {
        let slot = self
            .expected
            .get_mut(usize::from(header.sender))
            .and_then(|row| row.get_mut(usize::from(header.receiver)));
        let Some(slot) = slot else {
            return Observation::Untracked;
        };
        let seen = *slot;
        let gap = header.counter.wrapping_sub(seen as u8);
        let observation = if seen == UNSEEN {
            Observation::First
        } else if gap == 0 {
            Observation::InOrder
        } else if gap < 128 {
            self.missed += u64::from(gap);
            Observation::Missed(gap)
        } else {
            return Observation::Late;
        };
        *slot = u16::from(header.counter.wrapping_add(1));
        observation
    }

    /// Frames missed over all pairs so far.
    #[inline]
    pub fn missed(&self) -> u64 {
        self.missed
    }

    /// Forgets every pair, e.g. after a node restarted.
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn h(sender: u8, receiver: u8, counter: u8) -> Header {
        Header::new(receiver, sender, counter, 0)
    }

    #[test]
    fn first_is_not_a_miss_and_gaps_wrap() {
        let mut t = MissTracker::<4>::new();
        assert_eq!(t.observe(&h(1, 2, 250)), Observation::First);
        assert_eq!(t.observe(&h(1, 2, 251)), Observation::InOrder);
        assert_eq!(t.observe(&h(1, 2, 2)), Observation::Missed(6));
        assert_eq!(t.observe(&h(1, 2, 1)), Observation::Late);
        assert_eq!(t.observe(&h(1, 2, 3)), Observation::InOrder);
        assert_eq!(t.observe(&h(2, 1, 9)), Observation::First);
        assert_eq!(t.observe(&h(9, 1, 9)), Observation::Untracked);
        assert_eq!(t.missed(), 6);
    }

    #[test]
    fn tx_counters_wrap_per_receiver() {
        let mut tx = TxCounters::<2>::new();
        for i in 0..=256u32 {
            assert_eq!(u32::from(tx.next(1)), i % 256);
        }
        assert_eq!(tx.next(0), 0);
        assert_eq!(tx.next(7), 0);
        assert_eq!(tx.next(7), 0);
    }
}
