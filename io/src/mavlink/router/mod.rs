//! The MAVLink router daemon: the runtime's [`Router`] between endpoints on a PC.
//!
//! Every peer of every endpoint (each UDP sender on a `udpin` port, each client of a `tcpin`
//! server, the one peer of `udpout`, `tcpout` and `serial`, the broadcast address or group of a
//! `udpbcast` or `udpmcast` and each host heard there) is its own link, with its own parser
//! and counters. Each endpoint has reader threads that route what they read, under one lock;
//! what goes to a TCP, serial or pty peer waits in that peer's bounded output queue, written by
//! a thread of its own. `ferrolink mavlink router` is a thin wrapper around [`run`].
//!
//! Admission: a `udpin` sender, and a host heard on a broadcast address or group, gets a link
//! slot with its first datagram that holds a frame whose checksum checks (junk never holds a
//! slot); every other peer (a TCP client, a device, the address of a `udpout`, the broadcast
//! address or group itself) gets one when it appears. A host heard on a broadcast address or
//! group is reached through that address's link (`Router::reached_through`): it never gets a
//! frame twice. A peer refused for want of a slot is
//! offered one again at its next read; a refused TCP client is closed at once.
//!
//! Endpoints that are not opened from a [`link`] URI are [`Attached`]: they report to a
//! [`link::Sink`] like the link layer does (the Zenoh endpoint of `ferrolink-zenoh` is one, the
//! web API of `ferrolink-web`, a sniffer that is sent every frame, another).

use std::collections::HashMap;
use std::fs::File;
use std::io;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use ferrolink_runtime::mavlink::parser::Parser;
use ferrolink_runtime::mavlink::router::{Daemon, LinkConfig, LinkCounters, Routed, MAX_LINKS};
use ferrolink_runtime::mavlink::{v2, MessageMeta};
use serde_json::json;

use super::config::EndpointConfig;
use super::{tlog, unix_us};
use crate::link::{self, Event, OutputQueue, Overflow, PeerId, Sender};
use crate::printer::{self, Printer};

mod endpoints;
mod flightlog;
mod output;
mod stats;
use endpoints::{open_endpoint, reload};
use flightlog::FlightLog;
pub use flightlog::LogMode;
use output::{create, give_up, say};
use stats::{sorted_links, stats_line, table};

/// What the router daemon does.
#[derive(Debug, Clone, Default)]
pub struct Config {
    /// The endpoints, each with the configuration of its links.
    pub endpoints: Vec<EndpointConfig>,
    /// The messages it knows (CRC_EXTRA, target offsets), sorted by id.
    pub table: Arc<[MessageMeta]>,
    /// Log every frame received here: a `.tlog` file appended to, or a directory that gets a
    /// new numbered file per run (see [`tlog::files::open`]).
    pub tlog: Option<PathBuf>,
    /// What a log directory keeps.
    pub retention: tlog::Retention,
    /// When the log is written: always, or one file per flight.
    pub log_mode: LogMode,
    /// The vehicle whose arming opens and closes a flight's log (by default the first
    /// autopilot heard).
    pub log_system_id: Option<u8>,
    /// Append a JSON object of statistics here every second and at exit.
    pub stats_json: Option<PathBuf>,
    /// Print a statistics table this often.
    pub stats_every: Option<Duration>,
    /// Stop after this long.
    pub run_for: Option<Duration>,
    /// How long a quiet `udpin` peer keeps its link (default 10 s).
    pub peer_expiry: Option<Duration>,
    /// The output queue of each TCP, serial and pty peer ([`link::DAEMON_QUEUE`] if not given): a
    /// peer that does not keep up loses its own frames, counted as its `tx_dropped`, and never
    /// slows another.
    pub queue: Option<OutputQueue>,
    /// Send each frame to a UDP peer in a datagram of its own. By default, the frames a UDP
    /// peer is sent while one read is handled share datagrams of up to
    /// [`link::PACKED_DATAGRAM`] bytes, each frame whole: MAVLink's UDP readers (pymavlink,
    /// MAVSDK, QGroundControl, mavlink-router, the autopilots) parse a datagram as a run of
    /// frames.
    pub one_frame_per_datagram: bool,
}

/// An endpoint the daemon does not open from a [`link`] URI.
pub struct Attached {
    /// The configuration of its links.
    pub link: LinkConfig,
    /// Starts it; its status is the router's links and the systems behind them,
    /// `{"links": [NAME, ...], "systems": [{"sysid": .., "compid": .., "link": NAME}, ...],
    /// "stats": {..}}` (`stats` as a `--stats-json` line).
    pub open: link::Open,
}

impl std::fmt::Debug for Attached {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Attached")
            .field("link", &self.link)
            .finish_non_exhaustive()
    }
}

/// What the links that closed counted, summed.
#[derive(Default)]
struct Closed {
    links: u64,
    counters: LinkCounters,
    tx_errors: u64,
    tx_dropped: u64,
}

struct Link {
    endpoint: usize,
    slot: usize,
    name: String,
    sender: Sender,
    tx_errors: u64,
    /// When it last sent a checked frame (or was given its slot), in Unix µs.
    heard_us: u64,
}

/// What the endpoint threads share: they route each read on their own thread, under this lock.
struct State {
    router: Box<Daemon<Arc<[MessageMeta]>>>,
    /// Every endpoint ever opened, by number (`None` once a reload removed it).
    endpoints: Vec<Option<EndpointState>>,
    links: HashMap<PeerId, Link>,
    /// Peers without a slot, with their endpoint: `udpin` senders until a datagram proves them,
    /// and peers refused for want of a slot. Offered one at their next (proven) read.
    /// With each, its endpoint, name and sender, and whether it was refused (and said so).
    waiting: HashMap<PeerId, (usize, String, Sender, bool)>,
    /// Parses datagrams of peers on probation.
    probe: Parser<{ v2::MAX_FRAME_LEN }, Arc<[MessageMeta]>>,
    /// Datagrams from peers on probation that held no checked frame.
    junk_datagrams: u64,
    by_slot: Vec<Option<PeerId>>,
    /// The `--tlog`, written by a thread of its own.
    tlog: Option<FlightLog>,
    refused: u64,
    /// The totals of links that closed, so that no count is lost with its link.
    closed: Closed,
    /// How long a TCP client may go without a checked frame before its slot can be given to
    /// a newcomer when none is free, in µs (the peer expiry).
    quiet_us: u64,
}

impl State {
    fn handle(&mut self, event: Event<'_>) {
        match event {
            Event::Up {
                endpoint,
                peer,
                name,
                sender,
            } => {
                if self.on_probation(endpoint, &sender) {
                    self.waiting.insert(peer, (endpoint, name, sender, false));
                } else {
                    self.admit(endpoint, peer, name, sender, false);
                }
            }
            Event::Rx { peer, bytes, at } => {
                if let Some((endpoint, name, sender, refused)) = self.waiting.remove(&peer) {
                    if self.on_probation(endpoint, &sender) && !self.proves(bytes) {
                        self.junk_datagrams += 1;
                        self.waiting.insert(peer, (endpoint, name, sender, refused));
                        return;
                    }
                    // A peer refused before is not reported refused again, however much it sends.
                    self.admit(endpoint, peer, name, sender, refused);
                }
                let now_us = unix_us();
                let rx_us = now_us.saturating_sub(at.elapsed().as_micros() as u64);
                self.route(peer, Some(bytes), rx_us, now_us);
            }
            Event::Quiet { peer } => {
                let now_us = unix_us();
                self.route(peer, None, now_us, now_us);
            }
            Event::Down { peer, why } => {
                self.waiting.remove(&peer);
                if let Some((link, totals)) = self.close(peer) {
                    say(format!("link down: {}: {why} ({totals})", link.name));
                }
            }
        }
    }

    /// Routes every frame that `bytes` from `peer` complete, or with `None` (the peer went
    /// quiet), every frame its parser holds behind a false start.
    fn route(&mut self, peer: PeerId, bytes: Option<&[u8]>, rx_us: u64, now_us: u64) {
        let Some(from) = self.links.get(&peer).map(|l| l.slot) else {
            return;
        };
        let State {
            router,
            links,
            by_slot,
            tlog,
            ..
        } = self;
        let mut checked = false;
        let on_frame = |routed: Routed<'_>| {
            checked |= routed.frame.is_checked();
            if let Some(log) = tlog.as_mut() {
                log.write(rx_us, &routed.frame, routed.bytes);
            }
            let mut to = routed.to;
            while to != 0 {
                let slot = to.trailing_zeros() as usize;
                to &= to - 1;
                let link = by_slot
                    .get(slot)
                    .copied()
                    .flatten()
                    .and_then(|p| links.get_mut(&p));
                if let Some(link) = link {
                    if link.sender.send(routed.bytes).is_err() {
                        link.tx_errors += 1;
                    }
                }
            }
        };
        match bytes {
            Some(bytes) => router.receive(from, bytes, rx_us, now_us, on_frame),
            None => router.receive_stalled(from, rx_us, now_us, on_frame),
        }
        if let Some(link) = links.get_mut(&peer).filter(|_| checked) {
            link.heard_us = now_us;
        }
    }
}

impl State {
    /// Adds an endpoint and returns its number. Every link with its signing key (its peers,
    /// and those of other endpoints with the same key) shares one replay state.
    fn add_endpoint(&mut self, link: LinkConfig, peers: Peers) -> usize {
        let index = self.endpoints.len();
        self.endpoints.push(Some(EndpointState { link, peers }));
        index
    }

    /// Removes endpoint `index` (a reload dropped it): its links close, its waiting peers are
    /// forgotten, and peers its threads report from now on are turned away.
    fn remove_endpoint(&mut self, index: usize) {
        if let Some(e) = self.endpoints.get_mut(index) {
            *e = None;
        }
        self.waiting.retain(|_, (endpoint, ..)| *endpoint != index);
        let gone: Vec<PeerId> = self
            .links
            .iter()
            .filter(|(_, l)| l.endpoint == index)
            .map(|(p, _)| *p)
            .collect();
        for peer in gone {
            self.handle(Event::Down {
                peer,
                why: "the endpoint was removed from the configuration".into(),
            });
        }
    }

    /// Whether a peer of `endpoint` must prove itself with a checked frame before it gets a
    /// link slot.
    fn on_probation(&self, endpoint: usize, sender: &Sender) -> bool {
        match self.endpoints.get(endpoint) {
            Some(Some(e)) => match e.peers {
                Peers::OnProbation => true,
                Peers::Group => sender.reached_through().is_some(),
                Peers::Kept | Peers::Clients => false,
            },
            _ => false,
        }
    }

    /// Closes the TCP client that has gone longest without a checked frame, if that is longer
    /// than `quiet_us`, so that a newcomer can have its slot when none is free: idle
    /// connections (a listen-only client, or a flood of them) cannot hold every slot. Returns
    /// whether it closed one.
    fn make_room(&mut self) -> bool {
        let now_us = unix_us();
        let endpoints = &self.endpoints;
        let Some((&peer, _)) = self
            .links
            .iter()
            .filter(|(_, l)| {
                matches!(endpoints.get(l.endpoint), Some(Some(e)) if e.peers == Peers::Clients)
            })
            .filter(|(_, l)| now_us.saturating_sub(l.heard_us) >= self.quiet_us)
            .min_by_key(|(_, l)| l.heard_us)
        else {
            return false;
        };
        let Some((link, totals)) = self.close(peer) else {
            return false;
        };
        link.sender.close();
        say(format!(
            "link closed to make room: {}: no checked frame from it for {} s, and all \
             {MAX_LINKS} links in use ({totals})",
            link.name,
            now_us.saturating_sub(link.heard_us) / 1_000_000
        ));
        true
    }

    /// Takes `peer`'s link out: its slot is freed and its counters go into the closed links'
    /// totals. Returns the link and what it counted, as the log line says it.
    fn close(&mut self, peer: PeerId) -> Option<(Link, String)> {
        let link = self.links.remove(&peer)?;
        let c = self
            .router
            .link_counters(link.slot)
            .copied()
            .unwrap_or_default();
        let tx_dropped = link.sender.dropped();
        let closed = &mut self.closed;
        closed.links += 1;
        closed.counters += &c;
        closed.tx_errors += link.tx_errors;
        closed.tx_dropped += tx_dropped;
        self.router.close_link(link.slot);
        self.by_slot[link.slot] = None;
        let totals = format!(
            "received {} frames, sent {}, dropped {} coming in and {} in its queue",
            c.rx_frames,
            c.tx_frames.saturating_sub(tx_dropped),
            c.drops.inbound(),
            tx_dropped
        );
        Some((link, totals))
    }

    /// Whether a datagram holds a frame whose checksum checks.
    fn proves(&mut self, datagram: &[u8]) -> bool {
        self.probe.reset();
        let mut checked = false;
        self.probe
            .feed_all(datagram, |frame| checked |= frame.is_checked());
        self.probe.reset();
        checked
    }

    /// Gives a peer a link slot; without a free one, it waits for one (see `waiting`), and the
    /// refusal is counted and reported unless the peer was `refused` before. Returns whether it
    /// got one.
    fn admit(
        &mut self,
        endpoint: usize,
        peer: PeerId,
        name: String,
        sender: Sender,
        refused: bool,
    ) -> bool {
        let Some(Some(config)) = self.endpoints.get(endpoint) else {
            // A peer of an endpoint a reload just removed.
            sender.close();
            return false;
        };
        let link = config.link.clone();
        let opened = self.router.open_link(link.clone());
        let Some(slot) =
            opened.or_else(|| self.make_room().then(|| self.router.open_link(link))?)
        else {
            if sender.close() {
                // A TCP client: closed at once, so it holds no thread or descriptor here; it
                // may connect again.
                self.refused += 1;
                say(format!(
                    "link refused and closed: {name}: all {MAX_LINKS} links in use"
                ));
                return false;
            }
            if !refused {
                self.refused += 1;
                say(format!(
                    "link refused for now: {name}: all {MAX_LINKS} links in use"
                ));
            }
            self.waiting.insert(peer, (endpoint, name, sender, true));
            return false;
        };
        self.by_slot[slot] = Some(peer);
        if let Some(group) = sender.reached_through().and_then(|g| self.links.get(&g)) {
            self.router.reached_through(slot, group.slot);
        }
        say(format!("link up: {name}"));
        self.links.insert(
            peer,
            Link {
                endpoint,
                slot,
                name,
                sender,
                tx_errors: 0,
                heard_us: unix_us(),
            },
        );
        true
    }

    fn status(&self) -> serde_json::Value {
        let name = |slot: usize| {
            self.by_slot
                .get(slot)
                .copied()
                .flatten()
                .and_then(|p| self.links.get(&p))
                .map(|l| l.name.clone())
        };
        let links: Vec<String> = sorted_links(&self.links)
            .into_iter()
            .map(|l| l.name.clone())
            .collect();
        let mut systems: Vec<_> = self
            .router
            .routes()
            .filter_map(|r| Some((r.sysid, r.compid, name(r.link)?)))
            .collect();
        systems.sort();
        json!({
            "links": links,
            "systems": systems.into_iter().map(|(sysid, compid, link)|
                json!({"sysid": sysid, "compid": compid, "link": link})).collect::<Vec<_>>(),
            "stats": stats::stats_json(self),
        })
    }
}

/// What the router keeps of an endpoint.
struct EndpointState {
    /// The configuration of each of its links.
    link: LinkConfig,
    /// How its peers are admitted.
    peers: Peers,
}

/// How the peers of an endpoint are given link slots.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Peers {
    /// At once, and kept: the endpoint's one peer (a device, a pty, a `tcpout` server, Zenoh).
    Kept,
    /// At once, but a client that sends no checked frame for the peer expiry loses its slot
    /// to a newcomer when none is free (`tcpin`).
    Clients,
    /// Only once they send a datagram with a checked frame (`udpin`); they expire when quiet.
    OnProbation,
    /// The broadcast address or group at once, and kept; each host heard there as on
    /// `udpin`, reached through the group (`udpbcast`, `udpmcast`).
    Group,
}

fn lock(state: &Mutex<State>) -> MutexGuard<'_, State> {
    state.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A reload of the endpoints while the router runs (on SIGHUP, say).
pub struct Reload {
    /// Set to ask for a reload; the router clears it.
    pub requested: Arc<AtomicBool>,
    /// Reads the endpoints anew (from the configuration file). On an error the router keeps
    /// what it runs, and says why.
    pub endpoints: Box<dyn Fn() -> Result<Vec<EndpointConfig>, String> + Send>,
    /// Wakes the router to look at `requested` and at its `stop` flag at once (a signal
    /// thread sends on it); otherwise it looks once a second.
    pub wake: Option<std::sync::mpsc::Receiver<()>>,
}

impl std::fmt::Debug for Reload {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reload").finish_non_exhaustive()
    }
}

/// Runs the router on the configured endpoints and the `attached` ones (numbered after them)
/// until `run_for` elapses or `stop` is set. Prints `ready` on stdout once every endpoint is
/// bound and listening.
pub fn run(config: &Config, attached: Vec<Attached>, stop: &Arc<AtomicBool>) -> io::Result<()> {
    run_reloading(config, attached, stop, None)
}

/// The shortest time between two statistics tables.
const MIN_STATS_EVERY: Duration = Duration::from_millis(100);

/// [`run`], reloading the endpoints whenever `reload` is requested. Nothing else of the
/// configuration changes on a reload: the dialects, the logs, the peer expiry and the queues
/// stay as they were at the start.
pub fn run_reloading(
    config: &Config,
    attached: Vec<Attached>,
    stop: &Arc<AtomicBool>,
    reload_with: Option<Reload>,
) -> io::Result<()> {
    if config.endpoints.is_empty() && attached.is_empty() {
        return Err(no_endpoints());
    }
    if config.peer_expiry == Some(Duration::ZERO) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "peer expiry 0 s: every UDP peer would be forgotten at once\n  hint: give the \
             seconds a UDP peer may be quiet before it is forgotten, e.g. --peer-expiry 10 (the \
             default)",
        ));
    }
    if config.stats_every.is_some_and(|d| d < MIN_STATS_EVERY) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "--stats {}: the table would be printed without pause\n  hint: give the seconds \
                 between tables, e.g. --stats 1 (0.1 at the least)",
                config.stats_every.unwrap_or_default().as_secs_f64()
            ),
        ));
    }
    let queue = config.queue.unwrap_or(link::DAEMON_QUEUE);
    if queue.overflow == Overflow::Wait {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "a router never waits for a peer: its output queues drop the oldest or the newest \
             frames",
        ));
    }
    let options = link::Options {
        peer_expiry: config.peer_expiry.unwrap_or(link::DEFAULT_PEER_EXPIRY),
        queue,
        pack_up_to: if config.one_frame_per_datagram {
            0
        } else {
            link::PACKED_DATAGRAM
        },
    };
    // The tlog and the statistics file are written by threads of their own: a FIFO nobody
    // reads, or a disk that stalls, loses their records (counted), never routing.
    let tlog = match &config.tlog {
        Some(path) => Some(FlightLog::open(
            path,
            config.retention,
            config.log_mode,
            config.log_system_id,
        )?),
        None => None,
    };
    let tlog_path = tlog.as_ref().map(|log| log.shown().to_path_buf());
    let mut stats_json = match &config.stats_json {
        Some(path) => Some(Printer::new(
            create("statistics file", path)?,
            printer::LINES,
            printer::json_note,
        )),
        None => None,
    };
    let state = Arc::new(Mutex::new(State {
        router: Box::new(Daemon::new(config.table.clone())),
        endpoints: Vec::new(),
        links: HashMap::new(),
        waiting: HashMap::new(),
        probe: Parser::new(config.table.clone()),
        junk_datagrams: 0,
        by_slot: vec![None; MAX_LINKS],
        tlog,
        refused: 0,
        closed: Closed::default(),
        quiet_us: options.peer_expiry.as_micros() as u64,
    }));
    let mut opened = Vec::new();
    for endpoint in &config.endpoints {
        opened.push(open_endpoint(&state, endpoint, options)?);
    }
    let mut guards = Vec::new();
    let count = config.endpoints.len() + attached.len();
    for endpoint in attached {
        let i = lock(&state).add_endpoint(endpoint.link.clone(), Peers::Kept);
        let shared = state.clone();
        let sink: link::Sink = Arc::new(move |event| {
            lock(&shared).handle(event);
            true
        });
        let shared = state.clone();
        let status: link::Status = Arc::new(move || lock(&shared).status());
        guards.push((endpoint.open)(i, sink, status)?);
    }
    // Standard output (the `ready` line and the tables) through a printer of its own: a
    // terminal paused with Ctrl-S or a pipe nobody reads loses tables, never routing.
    let out = Printer::stdout();
    out.line(format!(
        "ready: routing {} endpoint(s), {} message(s) known",
        count,
        config.table.len()
    ))?;
    let has_tlog = lock(&state).tlog.is_some();
    let start = Instant::now();
    let deadline = config.run_for.map(|d| start + d);
    let mut next_json = start + Duration::from_secs(1);
    let mut next_table = config.stats_every.map(|d| start + d);
    // The first output given up (see `give_up`).
    let mut failed = None;
    // tlog records dropped so far, and up to when the last note on them is the latest.
    let mut tlog_dropped = 0;
    let mut tlog_noted_until = start;
    loop {
        let now = Instant::now();
        if stop.load(Ordering::Relaxed) || deadline.is_some_and(|d| now >= d) {
            break;
        }
        if let Some(r) = &reload_with {
            if r.requested.swap(false, Ordering::Relaxed) {
                match (r.endpoints)() {
                    Ok(endpoints) if endpoints.is_empty() && guards.is_empty() => {
                        say(format!(
                            "reload: kept the running endpoints: {}",
                            no_endpoints()
                        ));
                    }
                    Ok(endpoints) => reload(&state, &mut opened, &endpoints, options),
                    Err(e) => say(format!("reload: kept the running endpoints: {e}")),
                }
            }
        }
        // Wakes for the statistics and the deadline, when asked for, and otherwise only when
        // woken (a signal). Without a wake channel it looks at `stop` once a second, and with
        // a tlog once a second to hand its records over and look for a write error.
        let woken = reload_with.as_ref().and_then(|r| r.wake.as_ref());
        let tick = (woken.is_none() || has_tlog).then(|| now + Duration::from_secs(1));
        let json_at = stats_json.is_some().then_some(next_json);
        let wake = [tick, json_at, next_table, deadline]
            .into_iter()
            .flatten()
            .min();
        let wait = wake.map(|w| w.saturating_duration_since(now));
        let gone = match (woken, wait) {
            (Some(woken), Some(wait)) => matches!(
                woken.recv_timeout(wait),
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected)
            ),
            (Some(woken), None) => woken.recv().is_err(),
            (None, _) => true,
        };
        if gone {
            // Nothing to wake it: sleep, and look at `stop` at least once a second.
            std::thread::sleep(
                wait.map_or(Duration::from_secs(1), |w| w.min(Duration::from_secs(1))),
            );
        }
        let now = Instant::now();
        let mut s = lock(&state);
        // A log or statistics output that fails (a full disk, a closed pipe) is reported and
        // given up; routing goes on.
        if let Some(log) = s.tlog.as_mut() {
            log.hand_over();
            if let Some(e) = log.failure() {
                s.tlog = None;
                failed.get_or_insert(give_up("tlog", tlog_path.as_deref(), &e));
            } else if log.dropped() > tlog_dropped && now >= tlog_noted_until {
                // At most one note every 10 s while the file stalls.
                say(format!(
                    "tlog {}: {} record(s) not written: the file does not keep up; routing goes on",
                    tlog_path
                        .as_deref()
                        .map_or("".into(), |p| p.display().to_string()),
                    log.dropped() - tlog_dropped
                ));
                tlog_dropped = log.dropped();
                tlog_noted_until = now + Duration::from_secs(10);
            }
        }
        if now >= next_json {
            if let Some(out) = &stats_json {
                if let Err(e) = out.line(stats_line(&s)) {
                    stats_json = None;
                    failed.get_or_insert(give_up(
                        "statistics file",
                        config.stats_json.as_deref(),
                        &e,
                    ));
                }
            }
            next_json += Duration::from_secs(1);
        }
        if let (Some(every), Some(at)) = (config.stats_every, next_table) {
            if now >= at {
                next_table = Some(at + every);
                if let Err(e) = out.line(table(&s)) {
                    next_table = None;
                    failed.get_or_insert(give_up("--stats", None, &e));
                }
            }
        }
    }
    // Stop the readers first (they are woken at once, and finish what they were routing well
    // within this), so nothing is routed after the last record is flushed.
    drop(opened);
    drop(guards);
    std::thread::sleep(Duration::from_millis(250));
    let mut s = lock(&state);
    // The last records are handed over first, so that the last line counts them.
    if let Some(log) = s.tlog.as_mut() {
        log.hand_over();
    }
    let last_json = stats_json.as_ref().map(|out| out.line(stats_line(&s)));
    let mut log = s.tlog.take();
    drop(s);
    // The files get what is queued for them, within one patience for all of them.
    let deadline = Instant::now() + printer::FLUSH_PATIENCE;
    if let Some(out) = &stats_json {
        if let Err(e) = last_json
            .unwrap_or(Ok(()))
            .and_then(|()| out.flush_until(deadline))
        {
            failed.get_or_insert(give_up("statistics file", config.stats_json.as_deref(), &e));
        }
    }
    if let Some(log) = &mut log {
        if let Err(e) = log.flush_until(deadline) {
            failed.get_or_insert(give_up("tlog", tlog_path.as_deref(), &e));
        } else if log.dropped() > 0 {
            let e = io::Error::other(format!(
                "{} of {} record(s) not written: the file did not keep up",
                log.dropped(),
                log.records()
            ));
            failed.get_or_insert(give_up("tlog", tlog_path.as_deref(), &e));
        }
    }
    // What is printed goes out, unless nobody reads it.
    let _ = out.flush_until(deadline);
    let _ = printer::flush_stderr(deadline.saturating_duration_since(Instant::now()));
    // An output given up makes the exit status say so, once everything else is done.
    failed.map_or(Ok(()), Err)
}

fn no_endpoints() -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidInput,
        "no endpoints to route between\n  hint: give them as arguments \
         (udpin://0.0.0.0:14550 serial:///dev/ttyACM0:57600 ...) or as [[endpoint]] tables \
         in the --config file",
    )
}
