//! The MAVLink routing rules, exact and allocation-free: what an embedded radio runs between two
//! UARTs and what the `ferrolink mavlink router` daemon runs between sockets.
//!
//! A [`Router`] has `LINKS` link slots. Each open link has its own stream [`Parser`], so bytes are
//! fed per link with [`Router::receive`], which hands out every frame the link delivered together
//! with the links it goes to ([`Routed::to`], a bitmask) or why it goes nowhere. The caller sends
//! [`Routed::bytes`], unchanged, to every link in the mask.
//!
//! The rules (mavlink.io "Routing", made exact):
//!
//! - **Learning.** A link learns (system, component) pairs only from frames that passed their
//!   checksum, or from unknown ids passed through unchecked, and only after its inbound checks
//!   (signing, duplicates, inbound filter). Bad frames never teach a route.
//! - **Never back.** A frame never goes back to the link it came from, nor to a link of the same
//!   group (redundant links to the same place).
//! - **Broadcast.** A frame without a target field, with `target_system` 0, or with an unknown id
//!   goes to every other link.
//! - **Addressed.** With `target_component` non-zero and the exact pair seen, the frame goes to
//!   the links where that pair was seen; otherwise to every link where `target_system` was seen.
//!   A target seen nowhere gets nothing, and the frame counts as [`DropReason::NoRoute`].
//! - **Groups.** Links with the same non-zero [`LinkConfig::group`] share their routes: a frame
//!   routed to one of them goes to all of them.
//! - **Filters** allow or block by message id, source system and source component, inbound
//!   ([`LinkConfig::inbound`]) and outbound ([`LinkConfig::outbound`]).
//! - **Duplicates.** A link with a [`LinkConfig::dedup_window_us`] drops a frame whose exact bytes
//!   were seen (on any link) within the window: redundant radios deliver each frame twice.
//! - **Late frames.** A link with a [`LinkConfig::max_delay_us`] is not sent frames that were
//!   received longer ago than that (a backlog of stale telemetry on a slow link).
//! - **Signing at the edge.** A link with [`LinkConfig::require_signing`] drops unsigned frames,
//!   bad signatures and replays. Signed frames are always forwarded untouched; the router never
//!   signs anything, so traffic from an untrusted link is never made trusted. Replays are told
//!   by the spec's key, (link id, system, component) with its last timestamp, kept per signing
//!   key: every link with the same key shares it, and it outlives them, so a frame replayed
//!   from a new port or connection, or into another link that takes the same key, is still a
//!   replay.
//! - **Bounded storage.** Routes age out after [`Router::set_route_ttl_us`] (10 s by default;
//!   their slots are freed at most every 100 ms while routing, and on [`Router::expire`]). A
//!   full route or source table evicts its oldest entry, counts it, and keeps working.
//!
//! ```
//! use ferrolink_runtime::mavlink::router::{LinkConfig, Router};
//! use ferrolink_runtime::mavlink::MessageMeta;
//!
//! static META: &[MessageMeta] = &[MessageMeta {
//!     id: 0, crc_extra: 50, min_len: 9, max_len: 9,
//!     target_system: None, target_component: None,
//! }];
//! let heartbeat = [
//!     0xfd, 0x09, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00,
//!     0x02, 0x03, 0x51, 0x04, 0x03, 0x7b, 0xae,
//! ];
//! let mut router: Router<4> = Router::new(META);
//! let uart_a = router.open_link(LinkConfig::default()).unwrap();
//! let uart_b = router.open_link(LinkConfig::default()).unwrap();
//! router.receive(uart_a, &heartbeat, 0, 0, |routed| {
//!     assert_eq!(routed.to, 1 << uart_b); // a broadcast: every other link
//!     assert_eq!(routed.bytes, &heartbeat[..]);
//! });
//! assert_eq!(router.routes().next().map(|r| (r.sysid, r.compid, r.link)), Some((1, 1, uart_a)));
//! ```

use super::parser::{Feed, ParsedFrame, Parser, Stats as ParserStats};
use super::signing::{timestamp_from_unix_micros, SecretKey, Verifier, VerifyError};
use super::{v2, MessageMeta};
use core::fmt;

mod counters;
mod filter;

pub use counters::{sequence_gap, DropReason, Drops, LinkCounters, RouterCounters, SourceCounters};
pub use filter::{ByteSet, Filter, IdSet, LinkConfig, LinkFilter, NoFilter, ID_SET_CAPACITY};

/// A set of links, bit `i` for link `i`.
pub type LinkMask = u64;

/// The most links a router can have (the width of [`LinkMask`]).
pub const MAX_LINKS: usize = 64;

/// How long a learned route lives without traffic by default: 10 s.
pub const DEFAULT_ROUTE_TTL_US: u64 = 10_000_000;

/// Signing streams each link with [`LinkConfig::require_signing`] remembers.
pub const SIGNING_STREAMS: usize = 8;

/// A learned route: `(sysid, compid)` was heard on `link`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Route {
    /// System id.
    pub sysid: u8,
    /// Component id.
    pub compid: u8,
    /// The link.
    pub link: usize,
    /// When it was last heard there.
    pub last_seen_us: u64,
}

/// One frame a link delivered and what the router decided.
#[derive(Debug, Clone, Copy)]
pub struct Routed<'a> {
    /// The link it came from.
    pub from: usize,
    /// The frame as received, signature included: forward exactly these bytes.
    pub bytes: &'a [u8],
    /// The parsed frame.
    pub frame: ParsedFrame<'a>,
    /// The links to send it to (empty when dropped).
    pub to: LinkMask,
    /// Why it goes nowhere, if it was dropped as a whole.
    pub dropped: Option<DropReason>,
}

#[derive(Debug, Clone, Default)]
struct Link<Rules> {
    open: bool,
    config: LinkConfig<Rules>,
    /// Its entry in [`State::signing`], when it requires signing.
    signing: Option<u8>,
    counters: LinkCounters,
    /// The link whose every send reaches this one too (see [`Router::reached_through`]).
    reached_through: Option<u8>,
}

#[derive(Debug, Clone, Copy, Default)]
struct Seen {
    key: u32,
    at_us: u64,
    used: bool,
}

/// The router: `LINKS` links, `ROUTES` routes, `SOURCES` sources and `DEDUP` remembered frames
/// for deduplication, with links filtered by `Rules` ([`Filter`], or [`NoFilter`] for a device
/// that filters nothing).
///
/// The defaults suit a small radio; [`Daemon`] names the PC daemon's sizes. `LINKS` is at most
/// [`MAX_LINKS`]; a larger `LINKS` fails to compile:
///
/// ```compile_fail
/// # use ferrolink_runtime::mavlink::router::Router;
/// let r: Router<65> = Router::new(&[]);
/// ```
#[derive(Clone)]
pub struct Router<
    const LINKS: usize = 4,
    const ROUTES: usize = 32,
    const SOURCES: usize = 32,
    const DEDUP: usize = 64,
    Rules = Filter,
    Table = &'static [MessageMeta],
> {
    /// Each link's parser holds a clone of the table (a reference or a shared pointer).
    table: Table,
    parsers: [Parser<{ v2::MAX_FRAME_LEN }, Table>; LINKS],
    /// Parser counters already added to the link counters.
    parsed: [ParserStats; LINKS],
    state: State<LINKS, ROUTES, SOURCES, DEDUP, Rules>,
}

impl<
        const LINKS: usize,
        const ROUTES: usize,
        const SOURCES: usize,
        const DEDUP: usize,
        Rules: fmt::Debug,
        Table: AsRef<[MessageMeta]>,
    > fmt::Debug for Router<LINKS, ROUTES, SOURCES, DEDUP, Rules, Table>
{
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Router")
            .field("messages", &self.table.as_ref().len())
            .field("parsers", &self.parsers)
            .field("state", &self.state)
            .finish()
    }
}

/// The sizes of the router daemon on a PC: every link slot, 512 routes, 256 sources and 256
/// remembered frames.
pub type Daemon<Table = &'static [MessageMeta]> = Router<MAX_LINKS, 512, 256, 256, Filter, Table>;

/// Everything but the parsers, so a frame borrowed from a parser can be routed in place.
#[derive(Debug, Clone)]
struct State<
    const LINKS: usize,
    const ROUTES: usize,
    const SOURCES: usize,
    const DEDUP: usize,
    Rules,
> {
    links: [Link<Rules>; LINKS],
    /// Replay states: one per signing key, kept after its links close. There is always a
    /// free or unused entry for a link being opened, since fewer than `LINKS` are open then.
    signing: [Option<Verifier<SIGNING_STREAMS>>; LINKS],
    routes: [Option<Route>; ROUTES],
    /// Every route is in `routes[..routes_end]`: the scans for each frame stop there, not at
    /// `ROUTES`.
    routes_end: usize,
    sources: [Option<SourceCounters>; SOURCES],
    seen: [Seen; DEDUP],
    seen_next: usize,
    route_ttl_us: u64,
    /// The links that are reached through another ([`Router::reached_through`]): routing
    /// looks for them only when a frame would go to one of them.
    reached: LinkMask,
    /// The open links with [`LinkConfig::sniffer`] set.
    sniffers: LinkMask,
    /// When routes were last checked for their age (they are, at most every 100 ms).
    expired_at_us: u64,
    counters: RouterCounters,
}

/// How often routing looks for routes that aged out.
const EXPIRE_EVERY_US: u64 = 100_000;

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

impl<
        const LINKS: usize,
        const ROUTES: usize,
        const SOURCES: usize,
        const DEDUP: usize,
        Rules: LinkFilter,
        Table: AsRef<[MessageMeta]> + Clone,
    > Router<LINKS, ROUTES, SOURCES, DEDUP, Rules, Table>
{
    const LINKS_FIT_THE_MASK: () = assert!(LINKS <= MAX_LINKS, "Router<LINKS> needs LINKS <= 64");

    /// A router checking frames against `table` (sorted by id, as a dialect's `META` is, or
    /// built at run time and shared, as an `Arc<[MessageMeta]>`), with no links open.
    pub fn new(table: Table) -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::LINKS_FIT_THE_MASK;
        Self {
            parsers: core::array::from_fn(|_| Parser::new(table.clone())),
            parsed: [ParserStats::default(); LINKS],
            table,
            state: State {
                links: core::array::from_fn(|_| Link::default()),
                signing: core::array::from_fn(|_| None),
                routes: [None; ROUTES],
                routes_end: 0,
                sources: [None; SOURCES],
                seen: [Seen::default(); DEDUP],
                seen_next: 0,
                route_ttl_us: DEFAULT_ROUTE_TTL_US,
                reached: 0,
                sniffers: 0,
                expired_at_us: 0,
                counters: RouterCounters::default(),
            },
        }
    }

    /// The message table.
    pub fn table(&self) -> &[MessageMeta] {
        self.table.as_ref()
    }

    /// How long a route lives without traffic (0: forever).
    pub fn set_route_ttl_us(&mut self, ttl: u64) {
        self.state.route_ttl_us = ttl;
    }

    /// Opens a link in the first free slot and returns its index, or `None` when all `LINKS` are in
    /// use. Its counters start at zero; a link that requires signing joins the replay state of
    /// its key.
    pub fn open_link(&mut self, config: LinkConfig<Rules>) -> Option<usize> {
        let index = self.state.links.iter().position(|l| !l.open)?;
        let parser = self.parsers.get_mut(index)?;
        *parser = Parser::new(self.table.clone()).pass_unknown_ids(!config.drop_unknown_ids);
        *self.parsed.get_mut(index)? = ParserStats::default();
        let signing = config
            .require_signing
            .as_ref()
            .and_then(|key| self.state.signing_entry(key));
        if config.sniffer {
            self.state.sniffers |= 1 << index;
        }
        *self.state.links.get_mut(index)? = Link {
            open: true,
            signing,
            config,
            counters: LinkCounters::default(),
            reached_through: None,
        };
        Some(index)
    }

    /// Says that everything sent on link `by` reaches link `link` too: `by` sends to a
    /// broadcast address or a multicast group, and `link` is one host there, heard on its own.
    /// A frame that would go to both goes only to `by` (a host never gets it twice), a frame for
    /// a system behind `link` alone goes to `link`, and nothing from `link` goes back to `by`
    /// (the host is not sent its own frames). Undone when either link closes.
    pub fn reached_through(&mut self, link: usize, by: usize) {
        let state = &mut self.state;
        if link == by || !state.links.get(by).is_some_and(|l| l.open) {
            return;
        }
        if let Some(l) = state.links.get_mut(link).filter(|l| l.open) {
            l.reached_through = u8::try_from(by).ok();
            state.reached |= 1 << link;
        }
    }

    /// Closes link `index`: its routes are forgotten and its parser's buffer dropped. Its
    /// counters stay readable until the slot is opened again.
    pub fn close_link(&mut self, index: usize) {
        if let Some(parser) = self.parsers.get_mut(index) {
            parser.reset();
        }
        self.sync_parser_counters(index);
        if let Some(link) = self.state.links.get_mut(index) {
            link.open = false;
            link.reached_through = None;
        }
        let state = &mut self.state;
        state.reached &= !(1 << index);
        state.sniffers &= !(1 << index);
        for (i, link) in state.links.iter_mut().enumerate() {
            if link.reached_through == u8::try_from(index).ok() {
                link.reached_through = None;
                state.reached &= !(1 << i);
            }
        }
        for slot in state.routes.iter_mut().take(state.routes_end) {
            if slot.is_some_and(|r| r.link == index) {
                *slot = None;
            }
        }
        state.trim_routes();
    }

    /// Whether link `index` is open.
    pub fn is_open(&self, index: usize) -> bool {
        self.state.links.get(index).is_some_and(|l| l.open)
    }

    /// The configuration of link `index`.
    pub fn link_config(&self, index: usize) -> Option<&LinkConfig<Rules>> {
        self.state.links.get(index).map(|l| &l.config)
    }

    /// The counters of link `index`.
    pub fn link_counters(&self, index: usize) -> Option<&LinkCounters> {
        self.state.links.get(index).map(|l| &l.counters)
    }

    /// The router's own counters.
    pub fn counters(&self) -> &RouterCounters {
        &self.state.counters
    }

    /// The sources heard so far.
    pub fn sources(&self) -> impl Iterator<Item = &SourceCounters> + '_ {
        self.state.sources.iter().flatten()
    }

    /// The routes learned and not yet freed: routing frees aged-out routes at most every 100 ms,
    /// [`Router::expire`] at once.
    pub fn routes(&self) -> impl Iterator<Item = &Route> + '_ {
        self.state
            .routes
            .iter()
            .take(self.state.routes_end)
            .flatten()
    }

    /// Forgets routes not heard for longer than the route lifetime.
    pub fn expire(&mut self, now_us: u64) {
        self.state.expire(now_us);
    }

    /// Feeds bytes that arrived on link `from` at `rx_us` and calls `on_frame` for every frame
    /// they complete, with the routing decision. `now_us` is the current time in the same
    /// microseconds (for delay bounds and route ages; signing checks read `rx_us` as Unix time).
    /// Bytes for a closed or unknown link are ignored.
    pub fn receive(
        &mut self,
        from: usize,
        bytes: &[u8],
        rx_us: u64,
        now_us: u64,
        mut on_frame: impl FnMut(Routed<'_>),
    ) {
        if !self.is_open(from) {
            return;
        }
        let Some(parser) = self.parsers.get_mut(from) else {
            return;
        };
        let mut input = bytes;
        while let Feed::Frame { frame, remaining } = parser.feed(input) {
            input = remaining;
            let (to, dropped) = self.state.decide(from, &frame, rx_us, now_us);
            on_frame(Routed {
                from,
                bytes: frame.as_bytes(),
                frame,
                to,
                dropped,
            });
        }
        if let Some(link) = self.state.links.get_mut(from) {
            if link.config.datagrams && parser.buffered() > 0 {
                // The datagram ended inside a frame: drop the piece (as garbage bytes).
                link.counters.truncated_datagrams += 1;
                parser.reset();
            }
        }
        self.sync_parser_counters(from);
    }

    /// Link `from` has been quiet for longer than a link pauses inside a frame: what its parser
    /// holds is judged now, and every complete frame behind a false start is routed as
    /// [`receive`](Self::receive) routes it (see [`Parser::give_up_stalled`]).
    pub fn receive_stalled(
        &mut self,
        from: usize,
        rx_us: u64,
        now_us: u64,
        mut on_frame: impl FnMut(Routed<'_>),
    ) {
        while self.is_open(from)
            && self
                .parsers
                .get_mut(from)
                .is_some_and(|p| p.give_up_stalled())
        {
            self.receive(from, &[], rx_us, now_us, &mut on_frame);
        }
    }

    /// Adds what the parser of link `index` counted since the last time to its counters.
    fn sync_parser_counters(&mut self, index: usize) {
        let (Some(parser), Some(parsed), Some(link)) = (
            self.parsers.get(index),
            self.parsed.get_mut(index),
            self.state.links.get_mut(index),
        ) else {
            return;
        };
        let now = *parser.stats();
        let c = &mut link.counters;
        // The parser's counters are words that wrap; the differences are what was new.
        let dropped = |s: &ParserStats| s.garbage_bytes.wrapping_add(s.rejected());
        c.crc_failures += now.bad_crc.wrapping_sub(parsed.bad_crc) as u64;
        c.garbage_bytes += dropped(&now).wrapping_sub(dropped(parsed)) as u64;
        *parsed = now;
    }
}

impl<
        const LINKS: usize,
        const ROUTES: usize,
        const SOURCES: usize,
        const DEDUP: usize,
        Rules: LinkFilter,
    > State<LINKS, ROUTES, SOURCES, DEDUP, Rules>
{
    /// The replay state for a new link checking `key`: the one of the links with the same key
    /// (kept since the last of them closed, too), else a free entry, else one no open link
    /// uses.
    fn signing_entry(&mut self, key: &SecretKey) -> Option<u8> {
        let (signing, links) = (&self.signing, &self.links);
        let key_of = |i: usize| signing.get(i).and_then(Option::as_ref).map(Verifier::key);
        let unused = |i: &usize| {
            !links
                .iter()
                .any(|l| l.open && l.signing == u8::try_from(*i).ok())
        };
        let i = (0..LINKS)
            .find(|&i| key_of(i) == Some(key))
            .or_else(|| (0..LINKS).find(|&i| key_of(i).is_none()))
            .or_else(|| (0..LINKS).find(unused))?;
        let entry = self.signing.get_mut(i)?;
        if entry.as_ref().map(Verifier::key) != Some(key) {
            *entry = Some(Verifier::new(key.clone()));
        }
        u8::try_from(i).ok()
    }

    /// The signing checks of link `from`, when it requires signing.
    fn check_signature(
        &mut self,
        from: usize,
        frame: &ParsedFrame<'_>,
        rx_us: u64,
    ) -> Result<(), DropReason> {
        let Some(i) = self.links.get(from).and_then(|l| l.signing) else {
            return Ok(());
        };
        let Some(Some(verifier)) = self.signing.get_mut(usize::from(i)) else {
            return Ok(());
        };
        let Some(v2) = frame.as_v2() else {
            return Err(DropReason::Unsigned);
        };
        match verifier.verify(v2, timestamp_from_unix_micros(rx_us)) {
            Ok(()) => Ok(()),
            Err(VerifyError::Unsigned) => Err(DropReason::Unsigned),
            Err(_) => Err(DropReason::BadSignature),
        }
    }

    fn expire(&mut self, now_us: u64) {
        if self.route_ttl_us == 0 {
            return;
        }
        self.expired_at_us = now_us;
        for slot in self.routes.iter_mut().take(self.routes_end) {
            if slot.is_some_and(|r| now_us.saturating_sub(r.last_seen_us) > self.route_ttl_us) {
                *slot = None;
                self.counters.routes_expired += 1;
            }
        }
        self.trim_routes();
    }

    /// Moves [`State::routes_end`] back over the free slots at the end, after routes were
    /// forgotten.
    fn trim_routes(&mut self) {
        while self.routes_end > 0
            && self
                .routes
                .get(self.routes_end - 1)
                .is_some_and(Option::is_none)
        {
            self.routes_end -= 1;
        }
        debug_assert!(self.routes_end_holds());
    }

    /// Whether every route is in `routes[..routes_end]`.
    fn routes_end_holds(&self) -> bool {
        self.routes
            .iter()
            .skip(self.routes_end)
            .all(Option::is_none)
    }

    /// Applies the rules to one frame from link `from`.
    fn decide(
        &mut self,
        from: usize,
        frame: &ParsedFrame<'_>,
        rx_us: u64,
        now_us: u64,
    ) -> (LinkMask, Option<DropReason>) {
        let header = frame.header();
        let bytes = frame.as_bytes();
        let len = bytes.len() as u64;
        let Some(link) = self.links.get_mut(from) else {
            return (0, None);
        };
        link.counters.rx_frames += 1;
        link.counters.rx_bytes += len;
        if !frame.is_checked() {
            link.counters.unchecked += 1;
        }
        let dedup_window = link.config.dedup_window_us;
        let passes_in = link
            .config
            .inbound
            .passes(frame.msg_id(), header.sysid, header.compid);
        if let Err(why) = self.check_signature(from, frame, rx_us) {
            return self.drop_frame(from, why);
        }
        if dedup_window > 0 && self.is_duplicate(bytes, rx_us, dedup_window) {
            return self.drop_frame(from, DropReason::Duplicate);
        }
        if !passes_in {
            return self.drop_frame(from, DropReason::FilteredIn);
        }

        // Only what is proven teaches: a checksum checked against the table, or a signature
        // verified on a link that requires one. A frame with an unknown id is forwarded, but
        // its sender fields could be noise.
        let proven = frame.is_checked() || link_signs(&self.links, from);
        if proven {
            self.count_source(header.sysid, header.compid, header.seq, len, rx_us);
            self.learn(header.sysid, header.compid, from, rx_us);
        }
        if now_us.abs_diff(self.expired_at_us) >= EXPIRE_EVERY_US {
            self.expire(now_us);
        }

        let candidates = match target(frame) {
            None | Some((0, _)) => self.open_mask(),
            Some((sysid, compid)) => self.links_for(sysid, compid, now_us),
        };
        let mut candidates = candidates & !((1 << from) | self.group_mask(from));
        if (candidates | (1 << from)) & self.reached != 0 {
            candidates = self.without_reached(from, candidates);
        }
        candidates |= self.sniffers & !(1 << from);
        if candidates == 0 {
            return self.drop_frame(from, DropReason::NoRoute);
        }
        let mut to: LinkMask = 0;
        let age = now_us.saturating_sub(rx_us);
        let mut rest = candidates;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let Some(link) = self.links.get_mut(i) else {
                continue;
            };
            let config = &link.config;
            if !config
                .outbound
                .passes(frame.msg_id(), header.sysid, header.compid)
            {
                link.counters.drops.filtered_out += 1;
                continue;
            }
            if config.max_delay_us > 0 && age > config.max_delay_us {
                link.counters.drops.late += 1;
                continue;
            }
            link.counters.tx_frames += 1;
            link.counters.tx_bytes += len;
            to |= 1 << i;
        }
        if let Some(source) = self.source_mut(header.sysid, header.compid) {
            source.tx_frames += u64::from(to.count_ones());
        }
        if to == 0 {
            return (0, Some(DropReason::FilteredOut));
        }
        (to, None)
    }

    fn drop_frame(&mut self, from: usize, why: DropReason) -> (LinkMask, Option<DropReason>) {
        if let Some(link) = self.links.get_mut(from) {
            link.counters.drops.count(why);
        }
        (0, Some(why))
    }

    /// Whether these exact bytes were seen within `window`; remembers them if not.
    fn is_duplicate(&mut self, bytes: &[u8], now_us: u64, window: u64) -> bool {
        let key = CRC32.checksum(bytes);
        let hit = self
            .seen
            .iter()
            .any(|s| s.used && s.key == key && now_us.saturating_sub(s.at_us) <= window);
        if !hit && DEDUP > 0 {
            if let Some(slot) = self.seen.get_mut(self.seen_next % DEDUP) {
                *slot = Seen {
                    key,
                    at_us: now_us,
                    used: true,
                };
            }
            self.seen_next = (self.seen_next + 1) % DEDUP;
        }
        hit
    }

    /// `candidates` less the links reached through another candidate, and less the link
    /// `from` is reached through.
    fn without_reached(&self, from: usize, candidates: LinkMask) -> LinkMask {
        let through = |i: usize| {
            self.links
                .get(i)
                .and_then(|l| l.reached_through)
                .map_or(0, |by| 1 << by)
        };
        let mut out = candidates & !through(from);
        let mut rest = candidates & self.reached;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            if candidates & through(i) != 0 {
                out &= !(1 << i);
            }
        }
        out
    }

    fn open_mask(&self) -> LinkMask {
        self.links
            .iter()
            .enumerate()
            .filter(|(_, l)| l.open)
            .fold(0, |m, (i, _)| m | (1 << i))
    }

    /// The open links in `index`'s group (none for group 0).
    fn group_mask(&self, index: usize) -> LinkMask {
        let group = match self.links.get(index) {
            Some(l) if l.config.group != 0 => l.config.group,
            _ => return 0,
        };
        self.links
            .iter()
            .enumerate()
            .filter(|(_, l)| l.open && l.config.group == group)
            .fold(0, |m, (i, _)| m | (1 << i))
    }

    /// The links a frame for `(sysid, compid)` goes to, groups expanded. Routes that aged out
    /// count as gone even before their slots are cleared.
    fn links_for(&self, sysid: u8, compid: u8, now_us: u64) -> LinkMask {
        let mut exact: LinkMask = 0;
        let mut system: LinkMask = 0;
        let live = |r: &&Route| {
            self.route_ttl_us == 0 || now_us.saturating_sub(r.last_seen_us) <= self.route_ttl_us
        };
        for r in self
            .routes
            .iter()
            .take(self.routes_end)
            .flatten()
            .filter(live)
        {
            if r.sysid == sysid {
                system |= 1 << r.link;
                if r.compid == compid {
                    exact |= 1 << r.link;
                }
            }
        }
        let mask = if compid != 0 && exact != 0 {
            exact
        } else {
            system
        };
        (0..LINKS)
            .filter(|i| mask & (1 << i) != 0)
            .fold(mask, |m, i| m | self.group_mask(i))
    }

    fn learn(&mut self, sysid: u8, compid: u8, link: usize, now_us: u64) {
        if let Some(route) = self
            .routes
            .iter_mut()
            .take(self.routes_end)
            .flatten()
            .find(|r| (r.sysid, r.compid, r.link) == (sysid, compid, link))
        {
            route.last_seen_us = now_us;
            return;
        }
        let route = Route {
            sysid,
            compid,
            link,
            last_seen_us: now_us,
        };
        if let Some((at, free)) = self
            .routes
            .iter_mut()
            .enumerate()
            .find(|(_, s)| s.is_none())
        {
            *free = Some(route);
            self.routes_end = self.routes_end.max(at + 1);
            debug_assert!(self.routes_end_holds());
            return;
        }
        // The table is full. Each open link's share is an equal part of it: a link at its share
        // makes room among its own routes, so one link's flood of (spoofed) sources never
        // pushes out another link's; a link below its share takes the place of the oldest route
        // of a link above its own.
        let share = (ROUTES / (self.open_mask().count_ones() as usize).max(1)).max(1);
        let mut held = [0usize; LINKS];
        for r in self.routes.iter().flatten() {
            if let Some(n) = held.get_mut(r.link) {
                *n += 1;
            }
        }
        let mine = held.get(link).copied().unwrap_or(0);
        let victim = self
            .routes
            .iter_mut()
            .filter(|s| {
                s.is_some_and(|r| {
                    if mine >= share {
                        r.link == link
                    } else {
                        held.get(r.link).is_some_and(|&n| n > share)
                    }
                })
            })
            .min_by_key(|s| s.map_or(0, |r| r.last_seen_us));
        if let Some(victim) = victim {
            *victim = Some(route);
            self.counters.routes_evicted += 1;
        }
    }

    fn source_mut(&mut self, sysid: u8, compid: u8) -> Option<&mut SourceCounters> {
        self.sources
            .iter_mut()
            .flatten()
            .find(|s| (s.sysid, s.compid) == (sysid, compid))
    }

    fn count_source(&mut self, sysid: u8, compid: u8, seq: u8, len: u64, now_us: u64) {
        if let Some(source) = self.source_mut(sysid, compid) {
            if let Some(gap) = sequence_gap(source.last_seq, seq) {
                source.lost += u64::from(gap);
                source.last_seq = seq;
            }
            source.rx_frames += 1;
            source.rx_bytes += len;
            source.last_seen_us = now_us;
            return;
        }
        let fresh = SourceCounters {
            sysid,
            compid,
            rx_frames: 1,
            rx_bytes: len,
            tx_frames: 0,
            lost: 0,
            last_seq: seq,
            last_seen_us: now_us,
        };
        if insert_or_evict(&mut self.sources, fresh, |s| s.last_seen_us) {
            self.counters.sources_evicted += 1;
        }
    }
}

/// Puts `item` into the first free slot, or in place of the one with the smallest `age` key;
/// returns whether something was evicted.
fn insert_or_evict<T: Copy>(slots: &mut [Option<T>], item: T, age: impl Fn(&T) -> u64) -> bool {
    if let Some(slot) = slots.iter_mut().find(|s| s.is_none()) {
        *slot = Some(item);
        return false;
    }
    match slots.iter_mut().min_by_key(|s| s.as_ref().map_or(0, &age)) {
        Some(oldest) => {
            *oldest = Some(item);
            true
        }
        None => false,
    }
}

/// Whether link `from` checks signatures, so that a frame that passed them is proven.
fn link_signs<Rules>(links: &[Link<Rules>], from: usize) -> bool {
    links.get(from).is_some_and(|l| l.signing.is_some())
}

/// The target of an addressed message: `(target_system, target_component)`, the component 0
/// when the message has none. `None` for a message without target or an unknown id.
fn target(frame: &ParsedFrame<'_>) -> Option<(u8, u8)> {
    let meta = frame.meta()?;
    let payload = frame.payload();
    // A truncated payload lost trailing zeros: a target beyond its end is 0.
    let at = |offset: Option<u8>| offset.map(|o| payload.get(usize::from(o)).copied().unwrap_or(0));
    let system = at(meta.target_system)?;
    Some((system, at(meta.target_component).unwrap_or(0)))
}
