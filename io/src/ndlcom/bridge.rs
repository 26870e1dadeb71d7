//! The NDLCom bridge program: the runtime's [`Bridge`] over real links.
//!
//! The interfaces are opened on the [`link`] layer, whose threads feed a channel; the main loop
//! feeds the bridge, answers pings for its own ids, tracks missed packets, writes the log, drains
//! the output queues into the links and prints what was asked for.
//!
//! Interface `i` is the `i`-th URI given (mirrors after the interfaces). A `tcp-listen://`
//! interface serves any number of clients: its first client is interface `i`, every further one
//! an interface of its own (numbered after the URIs, named `URI <- ADDRESS`, with the URI's mirror
//! setting), as long as [`MAX_INTERFACES`] allows (a client past that is closed at once); a
//! client leaving frees its interface and the routes learned through it. Serial devices that
//! fail or are unplugged are reopened every second, and TCP clients reconnect; a link coming and
//! going is reported (`link_up`, `link_down`). `ferrolink ndlcom bridge` and
//! `ferrolink ndlcom log` are thin wrappers around [`run`].

use std::collections::{BTreeMap, HashMap};
use std::fmt::{self, Write as _};
use std::fs::File;
use std::io::{self, BufRead};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc, Mutex, PoisonError};
use std::thread;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use ferrolink_runtime::mavlink::Message;
use ferrolink_runtime::ndlcom::bridge::{Bridge, IfaceStats, Mode};
use ferrolink_runtime::ndlcom::counters::{MissTracker, Observation};
use ferrolink_runtime::ndlcom::{self, payload, storage_len, Frame, Header, BROADCAST};
use serde_json::json;

pub use super::ping::Ping;
use super::Interface;
use crate::link::{self, PeerId, Sender};
use crate::printer::{self, Printer};

/// The most interfaces (mirrors included) one bridge process serves.
pub const MAX_INTERFACES: usize = 8;
/// Bytes per output queue.
pub const QUEUE_BYTES: usize = 16 * 1024;
/// Bytes one peer may have waiting for the main loop. What a peer sends beyond that (a flood
/// faster than the bridge forwards) is dropped and counted as its `rx_overruns`: memory stays
/// bounded, and the flood costs that peer's data, not another's.
pub const BACKLOG_BYTES: usize = 256 * 1024;

type Node = Bridge<MAX_INTERFACES, { storage_len(ndlcom::MAX_PAYLOAD_LEN) }, QUEUE_BYTES>;

/// Which frames to print as they pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Print {
    /// None.
    #[default]
    None,
    /// Frames for the bridge's own ids (and broadcasts).
    Own,
    /// Every intact frame.
    All,
}

/// What the bridge program does.
#[derive(Debug, Clone, Default)]
pub struct Config {
    /// The interfaces, in order (interface 0 first).
    pub interfaces: Vec<Interface>,
    /// Mirror interfaces: they get every frame and teach nothing.
    pub mirrors: Vec<Interface>,
    /// Own ids: frames to them are answered (pings) and not forwarded.
    pub own_ids: Vec<u8>,
    /// Forward cut-through between all interface pairs instead of store & forward.
    pub cut_through: bool,
    /// Frames to print.
    pub print: Print,
    /// Print statistics, missed packets and routes this often.
    pub stats_every: Option<Duration>,
    /// Stop after this long (statistics are printed at the end).
    pub run_for: Option<Duration>,
    /// Send a ping to this id every `ping_every`, from the first own id.
    pub ping: Option<u8>,
    /// Ping period.
    pub ping_every: Duration,
    /// Append every intact frame to this file (JSON lines: `t_us`, `interface`, `frame`).
    pub log: Option<PathBuf>,
    /// Only record: nothing is forwarded or answered.
    pub log_only: bool,
    /// Print JSON lines instead of text.
    pub json: bool,
    /// The names of the messages printed, by message id (empty: no names).
    pub names: BTreeMap<u32, String>,
    /// Read commands from stdin: `s` statistics, `r` routes, `m` missed packets, `a`/`o`/`n`
    /// print all/own/no frames, `q` quit.
    pub commands: bool,
}

enum Event {
    Up {
        endpoint: usize,
        peer: PeerId,
        name: String,
        sender: Sender,
        backlog: Arc<Backlog>,
    },
    Rx(PeerId, Vec<u8>, Arc<Backlog>),
    Down(PeerId, String),
    Command(String),
}

/// What one peer has waiting for the main loop.
#[derive(Debug, Default)]
struct Backlog {
    bytes: AtomicUsize,
    /// Reads dropped because [`BACKLOG_BYTES`] were waiting.
    overruns: AtomicU64,
}

/// One interface of the bridge.
struct Slot {
    /// The URI, or `URI <- ADDRESS` for a further client of a server.
    name: String,
    /// The link to write to while it is up.
    sender: Option<Sender>,
    /// Whether a link was ever up here: until then output waits in the queue (a serial device
    /// or TCP server still being opened), afterwards it is dropped while no link is up.
    was_up: bool,
    /// Output that could not be written (no link, or the write failed).
    tx_errors: u64,
    /// The backlog of the peer on it, for its overruns.
    backlog: Option<Arc<Backlog>>,
    /// The overruns of the peers on it before.
    overruns_before: u64,
}

struct Program {
    config: Config,
    /// The interface URIs (mirrors last); slot `i < uris.len()` belongs to URI `i`.
    uris: Vec<String>,
    slots: Vec<Slot>,
    /// The slot of every peer that is up.
    peers: HashMap<PeerId, usize>,
    node: Box<Node>,
    missed: Box<MissTracker<256>>,
    missed_pairs: BTreeMap<(u8, u8), u64>,
    /// The `--log`, through a printer too: a FIFO nobody reads or a disk that stalls loses
    /// lines (and the log says how many), never forwarding.
    log: Option<Printer>,
    start: Instant,
    /// Standard output, through a printer: a terminal paused with Ctrl-S or a pipe nobody
    /// reads loses lines (and says how many), never forwarding.
    out: Printer,
    ping_seq: u32,
    ping_sent: BTreeMap<u32, Instant>,
    replies: u64,
}

fn unix_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

/// An interface not opened from an [`Interface`] URI (Zenoh, in `ferrolink-zenoh`): its name,
/// and how to start it. It comes after the interfaces and mirrors.
pub struct Attached {
    /// The interface's name in statistics and routes.
    pub name: String,
    /// Starts it.
    pub open: link::Open,
}

impl fmt::Debug for Attached {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Attached")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

/// Runs the bridge on the configured interfaces and the `attached` ones until `run_for` elapses
/// or `q` is read.
pub fn run(config: Config, attached: Vec<Attached>) -> io::Result<()> {
    let endpoints: Vec<&Interface> = config.interfaces.iter().chain(&config.mirrors).collect();
    let count = endpoints.len() + attached.len();
    if count == 0 || count > MAX_INTERFACES {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("give 1 to {MAX_INTERFACES} interfaces (mirrors included)"),
        ));
    }
    let mut node: Box<Node> = Box::default();
    node.set_deliver_all(true);
    let router = node.router_mut();
    if config.log_only {
        for id in 0..=u8::MAX {
            router.add_own_id(id);
        }
    }
    for &id in &config.own_ids {
        router.add_own_id(id);
    }
    let (tx, rx) = mpsc::channel();
    let mut handles = Vec::new();
    // A client that stops reading loses its own frames; it never holds up the bridge.
    let options = link::Options {
        queue: link::DAEMON_QUEUE,
        ..link::Options::default()
    };
    for (i, endpoint) in endpoints.iter().enumerate() {
        for &id in &endpoint.routes {
            node.router_mut().seed(id, i);
        }
        if i >= config.interfaces.len() {
            node.router_mut().set_mirror(i, true);
        }
        let uri = endpoint.to_string();
        let handle = link::open(i, &endpoint.endpoint, options, sink(&tx))
            .map_err(|e| io::Error::new(e.kind(), format!("{uri}: {e}")))?;
        handles.push(handle);
    }
    let mut uris: Vec<String> = endpoints.iter().map(ToString::to_string).collect();
    let names = uris.clone();
    let mut guards = Vec::new();
    for (i, endpoint) in (endpoints.len()..).zip(attached) {
        uris.push(endpoint.name);
        let sink = sink(&tx);
        let names = names.clone();
        let status: link::Status = Arc::new(move || json!({ "interfaces": names }));
        guards.push((endpoint.open)(i, sink, status)?);
    }
    if config.cut_through {
        for from in 0..MAX_INTERFACES {
            for to in 0..MAX_INTERFACES {
                if from != to {
                    node.set_mode(from, to, Mode::CutThrough);
                }
            }
        }
    }
    if config.commands {
        let tx = tx.clone();
        thread::spawn(move || {
            for line in io::stdin().lock().lines() {
                let Ok(line) = line else { return };
                if tx.send(Event::Command(line)).is_err() {
                    return;
                }
            }
        });
    }
    drop(tx);
    let log = match &config.log {
        Some(path) => Some(Printer::new(
            File::options()
                .create(true)
                .append(true)
                .open(path)
                .map_err(|e| in_file("log", Some(path), e))?,
            printer::LINES,
            printer::json_note,
        )),
        None => None,
    };
    let mut program = Program {
        slots: uris
            .iter()
            .map(|name| Slot {
                name: name.clone(),
                sender: None,
                was_up: false,
                tx_errors: 0,
                backlog: None,
                overruns_before: 0,
            })
            .collect(),
        uris,
        peers: HashMap::new(),
        node,
        missed: Box::default(),
        missed_pairs: BTreeMap::new(),
        log,
        start: Instant::now(),
        out: Printer::new(
            io::stdout(),
            printer::LINES,
            if config.json {
                printer::json_note
            } else {
                printer::text_note
            },
        ),
        ping_seq: 0,
        ping_sent: BTreeMap::new(),
        replies: 0,
        config,
    };
    // Links that are up at once (UDP, pty) are taken in before anything is sent.
    while let Ok(event) = rx.try_recv() {
        program.event(event)?;
    }
    let result = program.main_loop(rx);
    drop(handles);
    drop(guards);
    result
}

/// A sink that hands the link layer's events to the main loop, each peer's reads up to
/// [`BACKLOG_BYTES`] waiting.
fn sink(tx: &mpsc::Sender<Event>) -> link::Sink {
    let tx = tx.clone();
    let backlogs: Mutex<HashMap<PeerId, Arc<Backlog>>> = Mutex::default();
    Arc::new(move |event| {
        let mut backlogs = backlogs.lock().unwrap_or_else(PoisonError::into_inner);
        let mut backlog = |peer: PeerId| Arc::clone(backlogs.entry(peer).or_default());
        let event = match event {
            link::Event::Up {
                endpoint,
                peer,
                name,
                sender,
            } => Event::Up {
                endpoint,
                peer,
                name,
                sender,
                backlog: backlog(peer),
            },
            link::Event::Rx { peer, bytes, .. } => {
                let backlog = backlog(peer);
                let waiting = backlog.bytes.fetch_add(bytes.len(), Ordering::Relaxed);
                if waiting + bytes.len() > BACKLOG_BYTES {
                    backlog.bytes.fetch_sub(bytes.len(), Ordering::Relaxed);
                    backlog.overruns.fetch_add(1, Ordering::Relaxed);
                    return true;
                }
                Event::Rx(peer, bytes.to_vec(), backlog)
            }
            link::Event::Down { peer, why } => {
                backlogs.remove(&peer);
                Event::Down(peer, why)
            }
            // NDLCom resynchronises on its frame flag: a pause changes nothing.
            link::Event::Quiet { .. } => return true,
        };
        tx.send(event).is_ok()
    })
}

impl Program {
    fn now_us(&self) -> u64 {
        self.start.elapsed().as_micros() as u64
    }

    fn main_loop(&mut self, rx: mpsc::Receiver<Event>) -> io::Result<()> {
        let mut next_stats = self.config.stats_every.map(|d| self.start + d);
        let mut next_ping = self.config.ping.map(|_| self.start);
        let deadline = self.config.run_for.map(|d| self.start + d);
        loop {
            let now = Instant::now();
            if deadline.is_some_and(|d| now >= d) {
                break;
            }
            // It wakes for input, and for a timer only when one is due: the statistics, a
            // ping, the end, or a cut-through frame that may have stalled.
            let stalls = self
                .node
                .next_poll_us()
                .map(|us| self.start + Duration::from_micros(us));
            let wake = [next_stats, next_ping, deadline, stalls]
                .into_iter()
                .flatten()
                .min();
            let received = match wake {
                Some(wake) => rx.recv_timeout(wake.saturating_duration_since(now)),
                None => rx.recv().map_err(|_| mpsc::RecvTimeoutError::Disconnected),
            };
            match received {
                Ok(event) => {
                    if !self.event(event)? {
                        break;
                    }
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => break,
            }
            let now_us = self.now_us();
            self.node.poll(now_us);
            let now = Instant::now();
            if let (Some(target), Some(at)) = (self.config.ping, next_ping) {
                if now >= at && deadline.is_none_or(|d| now < d) {
                    self.send_ping(target)?;
                    next_ping = Some(at + self.config.ping_every);
                }
            }
            self.flush_outputs();
            if let (Some(every), Some(at)) = (self.config.stats_every, next_stats) {
                if now >= at {
                    self.print_everything()?;
                    next_stats = Some(at + every);
                }
            }
        }
        // Let the last replies go out, then the final report.
        self.flush_outputs();
        self.print_everything()?;
        // The log and what is printed get what is queued for them, within one patience.
        let deadline = Instant::now() + printer::FLUSH_PATIENCE;
        if let Some(log) = &self.log {
            log.flush_until(deadline)
                .map_err(|e| in_file("log", self.config.log.as_deref(), e))?;
        }
        // What is printed goes out, unless nobody reads it.
        let _ = printer::flush_stderr(deadline.saturating_duration_since(Instant::now()));
        match self.out.flush_until(deadline) {
            Err(e) if e.kind() == io::ErrorKind::TimedOut => Ok(()),
            flushed => flushed,
        }
    }

    /// Handles one event; `false` ends the program.
    fn event(&mut self, event: Event) -> io::Result<bool> {
        match event {
            Event::Up {
                endpoint,
                peer,
                name,
                sender,
                backlog,
            } => self.link_up(endpoint, peer, &name, sender, backlog)?,
            Event::Rx(peer, bytes, backlog) => {
                let handled = match self.peers.get(&peer) {
                    Some(&slot) => self.receive(slot, &bytes),
                    None => Ok(()),
                };
                backlog.bytes.fetch_sub(bytes.len(), Ordering::Relaxed);
                handled?;
            }
            Event::Down(peer, why) => {
                if let Some(slot) = self.peers.remove(&peer) {
                    self.slots[slot].sender = None;
                    self.node.link_down(slot);
                    let name = self.slots[slot].name.clone();
                    self.report(
                        json!({"event": "link_down", "interface": name, "error": why}),
                        format!("link down: {name}: {why}"),
                    )?;
                }
            }
            Event::Command(line) => return self.command(line.trim()),
        }
        Ok(true)
    }

    /// Gives a peer that came up its interface: the URI's own if it is free, else a further
    /// one (a server's second client).
    fn link_up(
        &mut self,
        endpoint: usize,
        peer: PeerId,
        name: &str,
        sender: Sender,
        backlog: Arc<Backlog>,
    ) -> io::Result<()> {
        let uri = self.uris[endpoint].clone();
        let slot = if self.slots[endpoint].sender.is_none() {
            self.slots[endpoint].name = uri;
            endpoint
        } else {
            let address = name.rsplit_once(" <- ").map_or(name, |(_, a)| a);
            let name = format!("{uri} <- {address}");
            let free =
                (self.uris.len()..self.slots.len()).find(|&i| self.slots[i].sender.is_none());
            match free {
                Some(i) => {
                    self.slots[i].name = name;
                    i
                }
                None if self.slots.len() < MAX_INTERFACES => {
                    self.slots.push(Slot {
                        name,
                        sender: None,
                        was_up: false,
                        tx_errors: 0,
                        backlog: None,
                        overruns_before: 0,
                    });
                    self.slots.len() - 1
                }
                None => {
                    // Closed at once (a TCP client), so that it keeps no thread or socket here.
                    sender.close();
                    self.report(
                        json!({"event": "link_refused", "interface": name,
                               "error": format!("all {MAX_INTERFACES} interfaces are in use")}),
                        format!(
                            "link refused and closed: {name}: all {MAX_INTERFACES} interfaces \
                             are in use"
                        ),
                    )?;
                    return Ok(());
                }
            }
        };
        let mirror = (self.config.interfaces.len()
            ..self.config.interfaces.len() + self.config.mirrors.len())
            .contains(&endpoint);
        self.node.router_mut().set_mirror(slot, mirror);
        self.slots[slot].sender = Some(sender);
        let replaced = self.slots[slot].backlog.replace(backlog);
        self.slots[slot].overruns_before +=
            replaced.map_or(0, |b| b.overruns.load(Ordering::Relaxed));
        self.slots[slot].was_up = true;
        self.peers.insert(peer, slot);
        let name = self.slots[slot].name.clone();
        self.report(
            json!({"event": "link_up", "interface": name, "index": slot}),
            format!("link up: {name} (interface {slot})"),
        )
    }

    fn receive(&mut self, i: usize, bytes: &[u8]) -> io::Result<()> {
        let now_us = self.now_us();
        let mut frames: Vec<(Header, Vec<u8>)> = Vec::new();
        self.node.receive(i, bytes, now_us, |frame: Frame<'_>| {
            frames.push((frame.header(), frame.payload().to_vec()));
        });
        for (header, payload) in frames {
            self.frame(i, &header, &payload)?;
        }
        self.flush_outputs();
        Ok(())
    }

    fn frame(&mut self, i: usize, header: &Header, payload: &[u8]) -> io::Result<()> {
        if let Observation::Missed(n) = self.missed.observe(header) {
            *self
                .missed_pairs
                .entry((header.sender, header.receiver))
                .or_default() += u64::from(n);
        }
        let own = header.receiver == BROADCAST || self.node.router().is_own(header.receiver);
        let name = self
            .slots
            .get(i)
            .map(|s| s.name.clone())
            .unwrap_or_default();
        if let Some(log) = &self.log {
            let mut buf = [0u8; ndlcom::MAX_FRAME_LEN];
            if let Ok(n) = ndlcom::encode(header, payload, &mut buf) {
                let line =
                    json!({"t_us": unix_us(), "interface": name, "frame": hex::encode(&buf[..n])});
                log.line(line.to_string())
                    .map_err(|e| in_file("log", self.config.log.as_deref(), e))?;
            }
        }
        if self.config.print == Print::All || (self.config.print == Print::Own && own) {
            let message = payload::message_id(payload)
                .and_then(|id| self.config.names.get(&id.into()))
                .map_or("", String::as_str);
            self.report(
                json!({"event": "frame", "interface": name, "receiver": header.receiver,
                       "sender": header.sender, "counter": header.counter,
                       "message": message, "payload": hex::encode(payload)}),
                format!(
                    "{name}: {:>3} -> {:>3} #{:<3} {:<12} {}",
                    header.sender,
                    header.receiver,
                    header.counter,
                    message,
                    hex::encode(payload)
                ),
            )?;
        }
        if own && !self.config.log_only && header.receiver != BROADCAST {
            if let Ok(ping) = payload::decode_message::<Ping>(payload) {
                self.answer_ping(header, ping)?;
            }
        }
        Ok(())
    }

    fn answer_ping(&mut self, header: &Header, ping: Ping) -> io::Result<()> {
        if ping.target_system == 0 {
            let reply = Ping {
                target_system: header.sender,
                ..ping
            };
            self.send(header.sender, header.receiver, &reply);
            return Ok(());
        }
        // A reply to one of ours.
        if let Some(sent) = self.ping_sent.remove(&ping.seq) {
            self.replies += 1;
            let rtt = sent.elapsed().as_micros() as u64;
            self.report(
                json!({"event": "ping_reply", "from": header.sender, "seq": ping.seq, "rtt_us": rtt}),
                format!("reply from {} seq {} in {rtt} us", header.sender, ping.seq),
            )?;
        }
        Ok(())
    }

    fn send_ping(&mut self, target: u8) -> io::Result<()> {
        let Some(&own) = self.config.own_ids.first() else {
            return Ok(());
        };
        self.ping_seq += 1;
        let ping = Ping {
            time_usec: unix_us(),
            seq: self.ping_seq,
            target_system: 0,
            target_component: 0,
        };
        self.ping_sent.insert(ping.seq, Instant::now());
        // Forget requests that were never answered.
        while self.ping_sent.len() > 64 {
            self.ping_sent.pop_first();
        }
        self.send(target, own, &ping);
        Ok(())
    }

    fn send(&mut self, receiver: u8, sender: u8, msg: &impl Message) {
        let mut buf = [0u8; ndlcom::MAX_PAYLOAD_LEN];
        if let Ok(n) = payload::encode_message(msg, &mut buf) {
            let _ = self.node.send(receiver, sender, &[&buf[..n]]);
        }
        self.flush_outputs();
    }

    fn flush_outputs(&mut self) {
        let mut buf = [0u8; QUEUE_BYTES];
        for (i, slot) in self.slots.iter_mut().enumerate() {
            if !slot.was_up {
                continue;
            }
            loop {
                let n = self.node.transmit(i, &mut buf);
                if n == 0 {
                    break;
                }
                let sent = slot.sender.as_ref().map(|s| s.send(&buf[..n]));
                if !matches!(sent, Some(Ok(()))) {
                    slot.tx_errors += 1;
                }
            }
        }
    }

    fn command(&mut self, line: &str) -> io::Result<bool> {
        match line {
            "s" => self.print_stats()?,
            "r" => self.print_routes()?,
            "m" => self.print_missed()?,
            "a" => self.config.print = Print::All,
            "o" => self.config.print = Print::Own,
            "n" => self.config.print = Print::None,
            "q" => return Ok(false),
            "" => {}
            other => {
                let _ = printer::stderr().line(format!(
                    "unknown command `{other}`: s stats, r routes, m missed, a/o/n print \
                     all/own/none, q quit"
                ));
            }
        }
        Ok(true)
    }

    fn report(&mut self, json: serde_json::Value, text: String) -> io::Result<()> {
        self.out.line(if self.config.json {
            json.to_string()
        } else {
            text
        })
    }

    fn print_everything(&mut self) -> io::Result<()> {
        self.print_stats()?;
        self.print_routes()?;
        self.print_missed()
    }

    fn print_stats(&mut self) -> io::Result<()> {
        let rows: Vec<(String, IfaceStats, u64, u64)> = self
            .slots
            .iter()
            .enumerate()
            .map(|(i, slot)| {
                let overruns = slot.overruns_before
                    + slot
                        .backlog
                        .as_ref()
                        .map_or(0, |b| b.overruns.load(Ordering::Relaxed));
                (
                    slot.name.clone(),
                    self.node.stats(i),
                    slot.tx_errors,
                    overruns,
                )
            })
            .collect();
        let json = json!({"event": "stats", "t_us": self.now_us(), "pings_sent": self.ping_seq, "pings_answered": self.replies,
            "interfaces": rows.iter().map(|(name, s, e, overruns)| json!({
                "interface": name, "rx_frames": s.rx_frames, "rx_bytes": s.rx_bytes,
                "tx_frames": s.tx_frames, "tx_bytes": s.tx_bytes, "crc_failures": s.crc_failures,
                "dropped": s.dropped, "queue_overflows": s.queue_overflows,
                "cut_through": s.cut_through, "timeouts": s.timeouts, "tx_errors": e,
                "rx_overruns": overruns,
            })).collect::<Vec<_>>()});
        let mut text = format!(
            "{:<36} {:>9} {:>11} {:>9} {:>11} {:>6} {:>7} {:>8} {:>7}\n",
            "interface",
            "rx frames",
            "rx bytes",
            "tx frames",
            "tx bytes",
            "crc",
            "dropped",
            "overflow",
            "overrun"
        );
        for (name, s, _, overruns) in &rows {
            let _ = writeln!(
                text,
                "{name:<36} {:>9} {:>11} {:>9} {:>11} {:>6} {:>7} {:>8} {overruns:>7}",
                s.rx_frames,
                s.rx_bytes,
                s.tx_frames,
                s.tx_bytes,
                s.crc_failures,
                s.dropped,
                s.queue_overflows
            );
        }
        self.report(json, text.trim_end().to_owned())
    }

    fn print_routes(&mut self) -> io::Result<()> {
        let routes: Vec<(u8, usize)> = self.node.router().routes().collect();
        let json = json!({"event": "routes", "routes": routes.iter().map(|(id, i)| json!({
            "id": id, "interface": self.slots.get(*i).map(|s| &s.name)})).collect::<Vec<_>>()});
        let mut text = String::from("routes:");
        for (id, i) in &routes {
            let _ = write!(
                text,
                "\n  {id:>3} -> {}",
                self.slots.get(*i).map_or("?", |s| &s.name)
            );
        }
        if routes.is_empty() {
            text.push_str(" none learned");
        }
        self.report(json, text)
    }

    fn print_missed(&mut self) -> io::Result<()> {
        let pairs: Vec<((u8, u8), u64)> = self.missed_pairs.iter().map(|(k, v)| (*k, *v)).collect();
        let json = json!({"event": "missed", "total": self.missed.missed(),
            "pairs": pairs.iter().map(|((s, r), n)| json!({"sender": s, "receiver": r, "missed": n})).collect::<Vec<_>>()});
        let mut text = format!("missed packets: {}", self.missed.missed());
        for ((s, r), n) in &pairs {
            let _ = write!(text, "\n  {s:>3} -> {r:>3}: {n}");
        }
        self.report(json, text)
    }
}

/// `e`, which befell the file `what` at `path`, saying so.
fn in_file(what: &str, path: Option<&std::path::Path>, e: io::Error) -> io::Error {
    let path = path.map_or_else(String::new, |p| p.display().to_string());
    io::Error::new(e.kind(), format!("{what} {path}: {e}"))
}
