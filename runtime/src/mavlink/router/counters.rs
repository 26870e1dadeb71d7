//! What the router counts: drops by reason, per link, per source and for the router as a whole.

/// Why a frame was not forwarded anywhere, or not to some link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum DropReason {
    /// The link requires signing and the frame was not signed.
    Unsigned,
    /// The link requires signing and the signature was wrong, or the frame a replay.
    BadSignature,
    /// The same bytes came within the deduplication window.
    Duplicate,
    /// The inbound filter stopped it.
    FilteredIn,
    /// Its target system was seen on no other link.
    NoRoute,
    /// Every link it would go to stopped it with an outbound filter or delay bound.
    FilteredOut,
}

/// Drop counters, by [`DropReason`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Drops {
    /// [`DropReason::Unsigned`].
    pub unsigned: u64,
    /// [`DropReason::BadSignature`].
    pub bad_signature: u64,
    /// [`DropReason::Duplicate`].
    pub duplicate: u64,
    /// [`DropReason::FilteredIn`].
    pub filtered_in: u64,
    /// [`DropReason::NoRoute`].
    pub no_route: u64,
    /// Copies not sent on this link because of its outbound filter (counted on the link that
    /// would have sent).
    pub filtered_out: u64,
    /// Copies not sent on this link because they were older than its delay bound.
    pub late: u64,
}

impl Drops {
    pub(super) fn count(&mut self, why: DropReason) {
        match why {
            DropReason::Unsigned => self.unsigned += 1,
            DropReason::BadSignature => self.bad_signature += 1,
            DropReason::Duplicate => self.duplicate += 1,
            DropReason::FilteredIn => self.filtered_in += 1,
            DropReason::NoRoute => self.no_route += 1,
            DropReason::FilteredOut => {}
        }
    }

    /// Every frame dropped on the way in (not the per-copy outbound counts).
    pub fn inbound(&self) -> u64 {
        self.unsigned + self.bad_signature + self.duplicate + self.filtered_in + self.no_route
    }
}

impl core::ops::AddAssign<&Drops> for Drops {
    fn add_assign(&mut self, o: &Drops) {
        self.unsigned += o.unsigned;
        self.bad_signature += o.bad_signature;
        self.duplicate += o.duplicate;
        self.filtered_in += o.filtered_in;
        self.no_route += o.no_route;
        self.filtered_out += o.filtered_out;
        self.late += o.late;
    }
}

/// Sums counters: a daemon keeps the totals of links that closed.
impl core::ops::AddAssign<&LinkCounters> for LinkCounters {
    fn add_assign(&mut self, o: &LinkCounters) {
        self.rx_frames += o.rx_frames;
        self.rx_bytes += o.rx_bytes;
        self.tx_frames += o.tx_frames;
        self.tx_bytes += o.tx_bytes;
        self.unchecked += o.unchecked;
        self.crc_failures += o.crc_failures;
        self.garbage_bytes += o.garbage_bytes;
        self.truncated_datagrams += o.truncated_datagrams;
        self.drops += &o.drops;
    }
}

/// Counters of one link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinkCounters {
    /// Frames received (passed their checksum, or unknown ids passed through).
    pub rx_frames: u64,
    /// Bytes of those frames.
    pub rx_bytes: u64,
    /// Frames routed out on this link.
    pub tx_frames: u64,
    /// Bytes of those frames.
    pub tx_bytes: u64,
    /// Frames with unknown ids received (forwarded unchecked).
    pub unchecked: u64,
    /// Candidates that failed their checksum.
    pub crc_failures: u64,
    /// Bytes the parser skipped: noise, rejected candidates, and what was left of frames cut
    /// off at a datagram's end.
    pub garbage_bytes: u64,
    /// Datagrams that ended inside a frame (on links of datagrams): the piece was dropped, not
    /// joined with the next datagram.
    pub truncated_datagrams: u64,
    /// Drops, by reason.
    pub drops: Drops,
}

/// Counters of one source (system, component), over every link: sequence loss is counted per
/// source, so several systems sharing a link do not blur each other's figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SourceCounters {
    /// System id.
    pub sysid: u8,
    /// Component id.
    pub compid: u8,
    /// Frames received from the source (after inbound checks).
    pub rx_frames: u64,
    /// Bytes of those frames.
    pub rx_bytes: u64,
    /// Copies of its frames sent out.
    pub tx_frames: u64,
    /// Frames missing by the sequence numbers.
    pub lost: u64,
    /// The last sequence number seen.
    pub last_seq: u8,
    /// When the source was last heard, in the caller's microseconds.
    pub last_seen_us: u64,
}

/// Counters of the router as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RouterCounters {
    /// Routes forgotten to make room for a new one: the learning link's own oldest once it holds
    /// its share of the table, else the oldest of a link holding more than its share.
    pub routes_evicted: u64,
    /// Routes forgotten because they aged out.
    pub routes_expired: u64,
    /// Sources forgotten to make room for a new one.
    pub sources_evicted: u64,
}

/// How many frames of a source went missing between sequence numbers `last` and `seq`: `None`
/// for a step back (reordering, or a duplicate), which is no loss. A jump of 128 or more counts
/// as a step back, since the 8-bit sequence cannot tell the two apart.
pub fn sequence_gap(last: u8, seq: u8) -> Option<u8> {
    let gap = seq.wrapping_sub(last.wrapping_add(1));
    (gap < 128).then_some(gap)
}
