//! Routing: the paper's Algorithm 1 over a learned table of address -> interface.
//!
//! The network is an acyclic graph of point-to-point links. For every frame that arrives
//! intact on interface `origin`:
//!
//! 1. if the receiver is one of the node's own ids or the broadcast address, it is delivered
//!    locally; otherwise the table learns `sender -> origin`;
//! 2. unless the receiver is one of the node's own ids, the frame is forwarded: on the learned
//!    interface, or on every interface but `origin` if the route is unknown or the frame is a
//!    broadcast.
//!
//! On top of that, as in the reference bridge: *mirror* interfaces receive a copy of every
//! frame and never teach the table; *internal* ids are pinned to an interface and learning
//! never moves them; an interface's routes can be invalidated when its link goes down. A frame
//! is never sent back where it came from.
//!
//! ```
//! use ferrolink_runtime::ndlcom::{router::Router, Header};
//!
//! let mut router = Router::<3>::new();
//! router.add_own_id(1);
//! // 9 talks to 7 through interface 0: unknown destination, flood to 1 and 2.
//! let d = router.route(0, &Header::new(7, 9, 0, 0));
//! assert!(!d.local);
//! assert_eq!(d.forward.iter().collect::<Vec<_>>(), [1, 2]);
//! // 7 answers through interface 2: 9 is known by now.
//! let d = router.route(2, &Header::new(9, 7, 0, 0));
//! assert_eq!(d.forward.iter().collect::<Vec<_>>(), [0]);
//! assert_eq!(router.lookup(7), Some(2));
//! ```

use super::{Header, BROADCAST};

/// A set of interface indices (0..32).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Ports(pub u32);

impl Ports {
    /// No interface.
    pub const NONE: Ports = Ports(0);

    /// Only interface `i` (empty if `i >= 32`).
    #[inline]
    pub const fn one(i: usize) -> Ports {
        if i < 32 {
            Ports(1 << i)
        } else {
            Ports(0)
        }
    }

    /// Interfaces `0..n`.
    #[inline]
    pub const fn all(n: usize) -> Ports {
        if n >= 32 {
            Ports(u32::MAX)
        } else {
            Ports((1 << n) - 1)
        }
    }

    /// Whether `i` is in the set.
    #[inline]
    pub const fn contains(self, i: usize) -> bool {
        i < 32 && self.0 & (1 << i) != 0
    }

    /// The set without `i`.
    #[inline]
    pub const fn without(self, i: usize) -> Ports {
        Ports(self.0 & !Ports::one(i).0)
    }

    /// The union.
    #[inline]
    pub const fn with(self, other: Ports) -> Ports {
        Ports(self.0 | other.0)
    }

    /// The set without any of `other`.
    #[inline]
    pub const fn without_all(self, other: Ports) -> Ports {
        Ports(self.0 & !other.0)
    }

    /// Whether the set is empty.
    #[inline]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The indices, ascending.
    pub fn iter(self) -> impl Iterator<Item = usize> {
        let mut bits = self.0;
        core::iter::from_fn(move || {
            (bits != 0).then(|| {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                i
            })
        })
    }
}

/// Where a frame goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decision {
    /// Deliver to this node (own id or broadcast).
    pub local: bool,
    /// Send on these interfaces (mirrors included).
    pub forward: Ports,
}

/// A set of 256 addresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct AddrSet([u32; 8]);

impl AddrSet {
    fn insert(&mut self, a: u8) {
        if let Some(w) = self.0.get_mut(usize::from(a >> 5)) {
            *w |= 1 << (a & 31);
        }
    }
    fn remove(&mut self, a: u8) {
        if let Some(w) = self.0.get_mut(usize::from(a >> 5)) {
            *w &= !(1 << (a & 31));
        }
    }
    fn contains(&self, a: u8) -> bool {
        self.0
            .get(usize::from(a >> 5))
            .is_some_and(|w| w & (1 << (a & 31)) != 0)
    }
}

/// A table entry is the interface index plus one, so that 0 (unknown) lets a router live in
/// zero-initialised memory (`.bss`) instead of costing a flash image.
const UNKNOWN: u8 = 0;

/// The routing state of a node with `N` interfaces (at most 32) and a table of `A` addresses
/// (256 for all; ids at or above `A` are always flooded), packed into `T` bytes.
///
/// An entry holds the interface index plus one (0: unknown) in `8 * T / A` bits. The default,
/// `T = A`, gives each entry a byte. A node with few interfaces can pack its table tighter:
/// `Router<2, 256, 64>` keeps two-interface routes in 2 bits each, 64 bytes for all 256
/// addresses. `T` must be `A`, `A / 2`, `A / 4` or `A / 8`, with entries wide enough for the
/// values `0..=N`; anything else fails to compile.
///
/// ```compile_fail
/// # use ferrolink_runtime::ndlcom::router::Router;
/// // 2-bit entries hold 0..=3: too narrow for 4 interfaces.
/// let r = Router::<4, 256, 64>::new();
/// ```
#[derive(Debug, Clone)]
pub struct Router<const N: usize, const A: usize = 256, const T: usize = A> {
    table: [u8; T],
    own: AddrSet,
    internal: AddrSet,
    mirrors: Ports,
}

impl<const N: usize, const A: usize, const T: usize> Default for Router<N, A, T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const A: usize, const T: usize> Router<N, A, T> {
    /// Bits per table entry.
    const BITS: usize = match (8 * T).checked_div(A) {
        Some(bits) => bits,
        None => 8,
    };

    const CHECK: () = {
        assert!(N <= 32, "a router has at most 32 interfaces");
        assert!(
            matches!(Self::BITS, 1 | 2 | 4 | 8) && T * 8 == A * Self::BITS,
            "a router's table packs A entries into T bytes: T is A, A/2, A/4 or A/8"
        );
        assert!(
            N < 1 << Self::BITS,
            "a router's table entries (8 * T / A bits) are too narrow for N interfaces"
        );
    };

    /// Every route unknown, no own ids, no mirrors. All zero bytes: a `static` router lives in
    /// `.bss`.
    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CHECK;
        Router {
            table: [UNKNOWN; T],
            own: AddrSet([0; 8]),
            internal: AddrSet([0; 8]),
            mirrors: Ports::NONE,
        }
    }

    /// Where entry `id` lies: its byte, its shift in the byte, and the entry mask.
    #[inline]
    fn slot(id: u8) -> Option<(usize, u32, u8)> {
        let id = usize::from(id);
        let bit = id * Self::BITS;
        let mask = ((1u16 << Self::BITS) - 1) as u8;
        (id < A).then_some((bit / 8, (bit % 8) as u32, mask))
    }

    /// The raw entry of `id` (interface plus one, or `UNKNOWN`).
    #[inline]
    fn entry(&self, id: u8) -> u8 {
        Self::slot(id)
            .and_then(|(at, shift, mask)| Some((self.table.get(at)? >> shift) & mask))
            .unwrap_or(UNKNOWN)
    }

    fn set_entry(&mut self, id: u8, entry: u8) {
        if let Some((at, shift, mask)) = Self::slot(id) {
            if let Some(byte) = self.table.get_mut(at) {
                *byte = (*byte & !(mask << shift)) | ((entry & mask) << shift);
            }
        }
    }

    /// Frames to `id` are for this node.
    pub fn add_own_id(&mut self, id: u8) {
        self.own.insert(id);
    }

    /// Whether `id` is one of this node's ids.
    #[inline]
    pub fn is_own(&self, id: u8) -> bool {
        self.own.contains(id)
    }

    /// Marks interface `i` as a mirror: it gets a copy of every frame and teaches nothing.
    pub fn set_mirror(&mut self, i: usize, mirror: bool) {
        self.mirrors = if mirror {
            self.mirrors.with(Ports::one(i))
        } else {
            self.mirrors.without(i)
        };
    }

    /// The mirror interfaces.
    #[inline]
    pub fn mirrors(&self) -> Ports {
        self.mirrors
    }

    /// Pins `id` to interface `i` for good: learning never moves it and invalidation keeps it.
    pub fn pin(&mut self, id: u8, i: usize) {
        self.set(id, i);
        self.internal.insert(id);
    }

    /// Sets a route that learning may later change (a pre-seeded route).
    pub fn seed(&mut self, id: u8, i: usize) {
        if !self.internal.contains(id) {
            self.set(id, i);
        }
    }

    fn set(&mut self, id: u8, i: usize) {
        // N is at most 32, and entries are wide enough for it, so `i + 1` fits.
        if i < N {
            self.set_entry(id, (i + 1) as u8);
        }
    }

    /// Forgets `id`'s route unless it is pinned.
    pub fn forget(&mut self, id: u8) {
        if !self.internal.contains(id) {
            self.set_entry(id, UNKNOWN);
        }
    }

    /// Unpins `id` (its route stays until learning or invalidation changes it).
    pub fn unpin(&mut self, id: u8) {
        self.internal.remove(id);
    }

    /// Forgets every unpinned route through interface `i`, e.g. when its link went down.
    pub fn invalidate(&mut self, i: usize) {
        for id in 0..=u8::MAX {
            if usize::from(self.entry(id)) == i.wrapping_add(1) && !self.internal.contains(id) {
                self.set_entry(id, UNKNOWN);
            }
        }
    }

    /// The interface `id` was learned on, if any.
    #[inline]
    pub fn lookup(&self, id: u8) -> Option<usize> {
        match self.entry(id) {
            UNKNOWN => None,
            entry => Some(usize::from(entry) - 1),
        }
    }

    /// Every known route, as (address, interface).
    pub fn routes(&self) -> impl Iterator<Item = (u8, usize)> + '_ {
        (0..=u8::MAX).filter_map(|id| self.lookup(id).map(|i| (id, i)))
    }

    /// Step 1's learning alone: `sender -> origin`, unless the origin is a mirror or the
    /// sender is pinned or one of this node's ids.
    pub fn learn(&mut self, origin: usize, sender: u8) {
        if !self.mirrors.contains(origin) && !self.internal.contains(sender) && !self.is_own(sender)
        {
            self.set(sender, origin);
        }
    }

    /// Where a frame to `receiver` arriving on `origin` goes, without learning: what a
    /// cut-through bridge needs as soon as the receiver byte is in.
    pub fn decide(&self, origin: usize, receiver: u8) -> Decision {
        let local = receiver == BROADCAST || self.is_own(receiver);
        let targets = if self.is_own(receiver) {
            Ports::NONE
        } else {
            match self.lookup(receiver) {
                Some(dest) if receiver != BROADCAST => Ports::one(dest),
                _ => Ports::all(N),
            }
        };
        Decision {
            local,
            forward: targets.with(self.mirrors).without(origin),
        }
    }

    /// Algorithm 1 for a frame that arrived intact on `origin`: learns, then decides.
    pub fn route(&mut self, origin: usize, header: &Header) -> Decision {
        let local = header.receiver == BROADCAST || self.is_own(header.receiver);
        if !local {
            self.learn(origin, header.sender);
        }
        self.decide(origin, header.receiver)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ports(d: Decision) -> std::vec::Vec<usize> {
        d.forward.iter().collect()
    }

    #[test]
    fn own_and_broadcast() {
        let mut r = Router::<3>::new();
        r.add_own_id(4);
        let d = r.route(1, &Header::new(4, 9, 0, 0));
        assert!(d.local);
        assert!(d.forward.is_empty());
        // Frames for us teach nothing (Algorithm 1, step 1).
        assert_eq!(r.lookup(9), None);
        let d = r.route(1, &Header::new(BROADCAST, 9, 0, 0));
        assert!(d.local);
        assert_eq!(ports(d), [0, 2]);
    }

    #[test]
    fn mirrors_copy_and_teach_nothing() {
        let mut r = Router::<4>::new();
        r.set_mirror(3, true);
        r.seed(7, 1);
        assert_eq!(ports(r.route(0, &Header::new(7, 8, 0, 0))), [1, 3]);
        let d = r.route(3, &Header::new(8, 5, 0, 0));
        assert_eq!(ports(d), [0]);
        assert_eq!(r.lookup(5), None);
        assert_eq!(r.lookup(8), Some(0));
    }

    #[test]
    fn pinned_ids_survive_learning_and_invalidation() {
        let mut r = Router::<3>::new();
        r.pin(20, 2);
        r.route(0, &Header::new(1, 20, 0, 0));
        assert_eq!(r.lookup(20), Some(2));
        r.route(0, &Header::new(1, 21, 0, 0));
        r.invalidate(2);
        r.invalidate(0);
        assert_eq!(r.lookup(20), Some(2));
        assert_eq!(r.lookup(21), None);
    }

    #[test]
    fn packed_tables_route_like_byte_tables() {
        // One scripted history on a byte table and on every packing narrow enough for 3
        // interfaces (4 bits, 2 bits) and for 1 (1 bit).
        fn history<const N: usize, const T: usize>() -> std::vec::Vec<Option<usize>> {
            let mut r = Router::<N, 256, T>::new();
            let mut seed = 0x1234_5678u32;
            for _ in 0..2000 {
                seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                let [a, b, c, d] = seed.to_le_bytes();
                let origin = usize::from(c) % N;
                match d % 16 {
                    0 => r.invalidate(origin),
                    1 => r.pin(a, origin),
                    2 => r.unpin(a),
                    3 => r.forget(a),
                    _ => {
                        r.route(origin, &Header::new(a, b, 0, 0));
                    }
                }
            }
            (0..=u8::MAX).map(|id| r.lookup(id)).collect()
        }
        assert_eq!(history::<3, 256>(), history::<3, 128>());
        assert_eq!(history::<3, 256>(), history::<3, 64>());
        assert_eq!(history::<1, 256>(), history::<1, 32>());
        assert!(history::<3, 64>().iter().filter(|r| r.is_some()).count() > 100);
        assert_eq!(core::mem::size_of::<Router<2, 256, 64>>(), 64 + 2 * 32 + 4);
    }

    #[test]
    fn never_back_to_origin_and_small_tables_flood() {
        let mut r = Router::<2, 16>::new();
        r.seed(5, 0);
        assert!(r.route(0, &Header::new(5, 6, 0, 0)).forward.is_empty());
        r.route(1, &Header::new(9, 200, 0, 0));
        assert_eq!(r.lookup(200), None);
        assert_eq!(ports(r.route(0, &Header::new(200, 9, 0, 0))), [1]);
    }
}
