//! What a link lets through: id sets, filters and the link configuration.

use core::fmt;

use super::SecretKey;

/// A set of byte values (system or component ids).
#[derive(Clone, Copy, PartialEq, Eq, Default)]
pub struct ByteSet([u64; 4]);

impl ByteSet {
    /// The empty set.
    pub const EMPTY: Self = Self([0; 4]);

    /// Adds `value`.
    pub fn insert(&mut self, value: u8) {
        if let Some(word) = self.0.get_mut(usize::from(value >> 6)) {
            *word |= 1 << (value & 63);
        }
    }

    /// Whether `value` is in the set.
    pub fn contains(&self, value: u8) -> bool {
        self.0
            .get(usize::from(value >> 6))
            .is_some_and(|word| word & (1 << (value & 63)) != 0)
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.0 == [0; 4]
    }
}

impl fmt::Debug for ByteSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_set()
            .entries((0..=u8::MAX).filter(|&v| self.contains(v)))
            .finish()
    }
}

impl FromIterator<u8> for ByteSet {
    fn from_iter<I: IntoIterator<Item = u8>>(iter: I) -> Self {
        let mut set = Self::EMPTY;
        for v in iter {
            set.insert(v);
        }
        set
    }
}

/// How many message ids one [`IdSet`] holds.
pub const ID_SET_CAPACITY: usize = 32;

/// A small set of message ids.
#[derive(Clone, Copy, PartialEq, Eq, Default)]
pub struct IdSet {
    ids: [u32; ID_SET_CAPACITY],
    len: u8,
}

impl IdSet {
    /// The empty set.
    pub const EMPTY: Self = Self {
        ids: [0; ID_SET_CAPACITY],
        len: 0,
    };

    /// Adds `id`; gives it back when the set is full.
    pub fn insert(&mut self, id: u32) -> Result<(), u32> {
        if self.contains(id) {
            return Ok(());
        }
        match self.ids.get_mut(usize::from(self.len)) {
            Some(slot) => {
                *slot = id;
                self.len += 1;
                Ok(())
            }
            None => Err(id),
        }
    }

    /// Whether `id` is in the set.
    pub fn contains(&self, id: u32) -> bool {
        self.as_slice().contains(&id)
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The ids, in insertion order.
    pub fn as_slice(&self) -> &[u32] {
        self.ids.get(..usize::from(self.len)).unwrap_or_default()
    }
}

impl fmt::Debug for IdSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_set().entries(self.as_slice()).finish()
    }
}

/// Allow and block lists for one direction of a link. An empty allow list allows everything; a
/// frame passes when every non-empty allow list has it and no block list does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Filter {
    /// Message ids to let through (empty: all).
    pub allow_msg: IdSet,
    /// Message ids to stop.
    pub block_msg: IdSet,
    /// Source systems to let through (empty: all).
    pub allow_src_sys: ByteSet,
    /// Source systems to stop.
    pub block_src_sys: ByteSet,
    /// Source components to let through (empty: all).
    pub allow_src_comp: ByteSet,
    /// Source components to stop.
    pub block_src_comp: ByteSet,
}

impl Filter {
    /// A filter that lets everything through.
    pub const OPEN: Self = Self {
        allow_msg: IdSet::EMPTY,
        block_msg: IdSet::EMPTY,
        allow_src_sys: ByteSet::EMPTY,
        block_src_sys: ByteSet::EMPTY,
        allow_src_comp: ByteSet::EMPTY,
        block_src_comp: ByteSet::EMPTY,
    };

    /// Whether a frame with this message id from this source passes.
    pub fn passes(&self, msg_id: u32, sysid: u8, compid: u8) -> bool {
        (self.allow_msg.is_empty() || self.allow_msg.contains(msg_id))
            && !self.block_msg.contains(msg_id)
            && (self.allow_src_sys.is_empty() || self.allow_src_sys.contains(sysid))
            && !self.block_src_sys.contains(sysid)
            && (self.allow_src_comp.is_empty() || self.allow_src_comp.contains(compid))
            && !self.block_src_comp.contains(compid)
    }
}

/// What a link lets through, as the router asks it: [`Filter`] (allow and block lists, about
/// 400 bytes a direction) or [`NoFilter`] (nothing stopped, no bytes), picked by the router's
/// type, so a small device that filters nothing stores and runs no filter code.
pub trait LinkFilter: Clone + Default + PartialEq + fmt::Debug {
    /// Whether a frame with this message id from this source passes.
    fn passes(&self, msg_id: u32, sysid: u8, compid: u8) -> bool;
}

impl LinkFilter for Filter {
    #[inline]
    fn passes(&self, msg_id: u32, sysid: u8, compid: u8) -> bool {
        Filter::passes(self, msg_id, sysid, compid)
    }
}

/// A filter that lets everything through and takes no space.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NoFilter;

impl LinkFilter for NoFilter {
    #[inline(always)]
    fn passes(&self, _: u32, _: u8, _: u8) -> bool {
        true
    }
}

/// How one link behaves. `Rules` is the filter type of the router it is opened on.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LinkConfig<Rules = Filter> {
    /// What the link may deliver.
    pub inbound: Rules,
    /// What may be sent on the link.
    pub outbound: Rules,
    /// Links with the same non-zero group are redundant paths to the same place: they share
    /// routes, and a frame from one is never sent to another.
    pub group: u8,
    /// Drop frames whose exact bytes were seen within this window (0: off).
    pub dedup_window_us: u64,
    /// Do not send frames on this link that were received longer ago than this (0: no bound).
    pub max_delay_us: u64,
    /// Accept only frames signed with this key (unsigned, badly signed and replayed frames are
    /// dropped).
    pub require_signing: Option<SecretKey>,
    /// Drop frames whose message id is missing from the table. By default they are passed
    /// through, unchecked (their checksum needs the CRC_EXTRA the table lacks), as broadcasts;
    /// they never teach a route.
    pub drop_unknown_ids: bool,
    /// Each [`Router::receive`](super::Router::receive) on this link is one datagram: a frame
    /// never spans two, and bytes of a frame cut off at a datagram's end are dropped (counted in
    /// [`LinkCounters::truncated_datagrams`](super::LinkCounters::truncated_datagrams) and the
    /// garbage bytes). For UDP peers and other links that deliver whole messages.
    pub datagrams: bool,
    /// The link is sent every frame the router takes in, whatever its target (its outbound
    /// filter still applies), as mavlink-router's sniffer is: for a monitor, such as a web API
    /// that shows every system.
    pub sniffer: bool,
}
