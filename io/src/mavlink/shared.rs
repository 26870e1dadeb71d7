//! One MAVLink connection that many threads and tasks share.
//!
//! A [`SharedConnection`] is a handle: clone it into every thread or task that sends. Frames
//! are received in one place, the endpoint's own threads, each peer through a stream parser of
//! its own, and handed to every [`Subscription`] whose [`Filter`] takes them. Each
//! subscription has a queue of its own, bounded: a subscriber that stops reading loses its own
//! frames, counted ([`Subscription::dropped`]), and never stalls the link or another
//! subscriber, as the router treats a slow link.
//!
//! ```no_run
//! use std::time::Duration;
//! use ferrolink_io::mavlink::{Filter, SharedConnection};
//! # use ferrolink_runtime::mavlink::MessageMeta;
//! # static META: &[MessageMeta] = &[];
//!
//! let link = SharedConnection::open("udpin://0.0.0.0:14550", META)?;
//! link.start_heartbeat(Default::default()); // a ground station's, once a second
//! let attitude = link.subscribe(Filter::all().ids(&[30]));
//! let sender = link.clone();
//! std::thread::spawn(move || {
//!     // ... sender.send(&message) from here, while the main thread reads.
//! #   let _ = sender;
//! });
//! while let Some(frame) = attitude.recv(Duration::from_secs(1))? {
//!     println!("ATTITUDE from {} ({} dropped)", frame.header().sysid, attitude.dropped());
//! }
//! # Ok::<(), std::io::Error>(())
//! ```
//!
//! Sends go to every peer, from the connection's own ids ([`SharedConnection::send`]), to one
//! peer, as a reply ([`SharedConnection::send_to`] with the peer a frame came from), or from
//! other ids ([`SharedConnection::send_as`]: forwarding, or several components in one
//! program). Each source's frames count their own sequence numbers.
//!
//! With a key ([`SharedConnection::set_signing`]), sends are signed and received signed frames
//! are checked, with the router's replay rules ([`Verifier`]): a bad signature, a replayed or a
//! stale timestamp is refused and counted, never handed out. Unsigned frames are then taken as
//! [`Unsigned`] says: by default only RADIO_STATUS, which radios insert unsigned, as the MAVLink
//! signing specification advises.

use std::collections::HashMap;
use std::io;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, Weak};
use std::time::Duration;

use ferrolink_runtime::mavlink::parser::{ParsedFrame, Parser};
use ferrolink_runtime::mavlink::service::messages::{
    Heartbeat as HeartbeatMessage, MavAutopilot, MavModeFlag, MavState, MavType,
};
use ferrolink_runtime::mavlink::signing::{
    timestamp_from_unix_micros, SecretKey, Signer, Verifier,
};
use ferrolink_runtime::mavlink::{
    find_meta, v1, v2, Dialect, Header, Message, MessageMeta, Version,
};

use super::{unix_us, Frame, ENDPOINTS};
use crate::framed::PeerTable;
use crate::link::{self, Event, PeerId};

/// How many frames a subscription holds for its reader by default.
pub const DEFAULT_QUEUE: usize = 4096;

/// RADIO_STATUS, the one message taken unsigned by default on a signed connection.
const RADIO_STATUS: u32 = 109;

/// Which frames a [`Subscription`] takes.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Filter {
    ids: Option<Vec<u32>>,
    system: Option<u8>,
    capacity: Option<usize>,
}

impl Filter {
    /// Every frame.
    pub fn all() -> Self {
        Self::default()
    }

    /// Only messages with these ids.
    pub fn ids(mut self, ids: &[u32]) -> Self {
        let mut ids = ids.to_vec();
        ids.sort_unstable();
        ids.dedup();
        self.ids = Some(ids);
        self
    }

    /// Only frames from system `sysid`.
    pub fn system(mut self, sysid: u8) -> Self {
        self.system = Some(sysid);
        self
    }

    /// Holds at most `frames` frames for the reader ([`DEFAULT_QUEUE`] unless set); past that
    /// the subscription loses frames, counted.
    pub fn capacity(mut self, frames: usize) -> Self {
        self.capacity = Some(frames.max(1));
        self
    }

    fn takes(&self, id: u32, sysid: u8) -> bool {
        self.ids
            .as_ref()
            .is_none_or(|ids| ids.binary_search(&id).is_ok())
            && self.system.is_none_or(|s| s == sysid)
    }
}

/// What a signed connection does with unsigned frames.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Unsigned {
    /// Refuse them all.
    Refuse,
    /// Take these message ids unsigned, refuse the rest. The default is RADIO_STATUS alone.
    Only(Vec<u32>),
    /// Take them all (only signed frames are checked).
    Accept,
}

impl Default for Unsigned {
    fn default() -> Self {
        Unsigned::Only(vec![RADIO_STATUS])
    }
}

/// Counts of a [`SharedConnection`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Frames received whole (checksum good, or an id the table lacks when those pass).
    pub frames: u64,
    /// Frames refused for being unsigned on a signed connection.
    pub unsigned: u64,
    /// Signed frames refused: a bad signature, a replayed or a stale timestamp.
    pub bad_signature: u64,
    /// Frames subscribers lost because their queues were full, over every subscriber.
    pub dropped: u64,
}

/// Our own HEARTBEAT, as [`SharedConnection::start_heartbeat`] sends it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OwnHeartbeat {
    /// What we are (a ground station by default).
    pub mav_type: MavType,
    /// Our autopilot (`INVALID`: none, as ground stations and companions say).
    pub autopilot: MavAutopilot,
    /// Our state.
    pub system_status: MavState,
    /// How often.
    pub interval: Duration,
}

impl Default for OwnHeartbeat {
    fn default() -> Self {
        Self {
            mav_type: MavType::Gcs,
            autopilot: MavAutopilot::Invalid,
            system_status: MavState::Active,
            interval: Duration::from_secs(1),
        }
    }
}

/// Where a frame goes and whom it is from: [`SharedConnection::send_raw_with`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Route {
    /// The source system and component; `None`: the connection's own.
    pub from: Option<(u8, u8)>,
    /// One peer; `None`: every peer.
    pub to: Option<PeerId>,
}

type MavParser = Parser<{ v2::MAX_FRAME_LEN }, Arc<[MessageMeta]>>;

/// The receiving side, touched by the endpoint's threads.
struct Rx {
    peers: PeerTable<MavParser>,
    verifier: Option<Verifier<32>>,
    unsigned: Unsigned,
}

/// The sending side.
struct Tx {
    own: (u8, u8),
    seqs: HashMap<(u8, u8), u8>,
    version: Version,
    signer: Option<Signer>,
}

/// A subscriber: its filter, and its end of its queue or its tap.
struct Slot {
    filter: Filter,
    to: To,
}

/// Where a subscriber's frames go.
enum To {
    Queue {
        tx: flume::Sender<Frame>,
        dropped: Arc<AtomicU64>,
    },
    Tap {
        id: u64,
        f: Arc<TapFn>,
    },
}

/// What a [`Tap`] runs on each frame it takes.
type TapFn = dyn Fn(&Frame) + Send + Sync;

static NEXT_TAP: AtomicU64 = AtomicU64::new(1);

struct Inner {
    name: Arc<str>,
    local: std::sync::OnceLock<SocketAddr>,
    table: Arc<[MessageMeta]>,
    /// Read by the parsers of peers yet to come.
    pass_unknown: Arc<AtomicBool>,
    rx: Mutex<Rx>,
    tx: Mutex<Tx>,
    subscribers: Mutex<Vec<Slot>>,
    counts: Mutex<Counts>,
    stopped: AtomicBool,
    heartbeat: Arc<Beat>,
    /// Last, so that the endpoint's threads stop after the rest is gone.
    handle: Mutex<Option<link::Handle>>,
}

/// Our heartbeat's settings, shared with its thread, which holds the connection only while it
/// sends.
#[derive(Default)]
struct Beat {
    settings: Mutex<Option<OwnHeartbeat>>,
    bell: Condvar,
    running: AtomicBool,
}

impl Drop for Inner {
    fn drop(&mut self) {
        // The heartbeat thread wakes, finds the connection gone and ends. Under the lock it
        // checks and waits with, so that the wake-up is not lost between the two.
        let _settings = lock(&self.heartbeat.settings);
        self.heartbeat.bell.notify_all();
    }
}

/// Locks `m`, whatever a panicking holder left (the state stays consistent between calls).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A MAVLink connection on one endpoint URI that any number of threads and tasks share: see
/// the [module documentation](self). Cloning it is cheap; the endpoint closes when the last
/// clone is dropped, and its subscriptions then end.
#[derive(Clone)]
pub struct SharedConnection {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for SharedConnection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SharedConnection")
            .field("endpoint", &self.inner.name)
            .field("peers", &self.peers())
            .finish_non_exhaustive()
    }
}

/// Marks the connection stopped when the endpoint's last thread lets go of its sink.
struct StopGuard(Weak<Inner>);

impl Drop for StopGuard {
    fn drop(&mut self) {
        if let Some(inner) = self.0.upgrade() {
            inner.stop();
        }
    }
}

impl SharedConnection {
    /// Opens `uri` (see [`ENDPOINTS`]), checking received frames against `table` (a dialect's
    /// `META`, or a table built at run time). Sockets are bound before this returns; `tcpout`
    /// and `serial` connect in the background and keep reconnecting. Sends are MAVLink 2 from
    /// 255/190, a ground station, until set otherwise.
    pub fn open(uri: &str, table: impl Into<Arc<[MessageMeta]>>) -> io::Result<Self> {
        let endpoint = ENDPOINTS
            .endpoint(uri)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        let table: Arc<[MessageMeta]> = table.into();
        let pass_unknown = Arc::new(AtomicBool::new(false));
        let (shared, pass) = (table.clone(), pass_unknown.clone());
        let new_parser =
            move || Parser::new(shared.clone()).pass_unknown_ids(pass.load(Ordering::Relaxed));
        let inner = Arc::new(Inner {
            name: endpoint.to_string().into(),
            local: std::sync::OnceLock::new(),
            table,
            pass_unknown,
            rx: Mutex::new(Rx {
                peers: PeerTable::new(new_parser),
                verifier: None,
                unsigned: Unsigned::default(),
            }),
            tx: Mutex::new(Tx {
                own: (255, 190),
                seqs: HashMap::new(),
                version: Version::V2,
                signer: None,
            }),
            subscribers: Mutex::new(Vec::new()),
            counts: Mutex::new(Counts::default()),
            stopped: AtomicBool::new(false),
            heartbeat: Arc::new(Beat::default()),
            handle: Mutex::new(None),
        });
        let weak = Arc::downgrade(&inner);
        let guard = StopGuard(weak.clone());
        let sink: link::Sink = Arc::new(move |event| {
            let _ = &guard;
            match weak.upgrade() {
                Some(inner) => {
                    inner.take(event);
                    true
                }
                None => false,
            }
        });
        let handle = link::open(0, &endpoint, link::Options::default(), sink)?;
        if let Some(local) = handle.local_addr() {
            let _ = inner.local.set(local);
        }
        *lock(&inner.handle) = Some(handle);
        Ok(Self { inner })
    }

    /// The bound local address, for `udpin`, `udpout` and `tcpin` URIs.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.inner.local.get().copied()
    }

    /// The message table received frames are checked against.
    pub fn table(&self) -> &Arc<[MessageMeta]> {
        &self.inner.table
    }

    /// How many peers are connected now.
    pub fn peers(&self) -> usize {
        lock(&self.inner.rx).peers.len()
    }

    /// Whether the endpoint stopped (its threads ended); subscriptions then end too.
    pub fn is_stopped(&self) -> bool {
        self.inner.stopped.load(Ordering::Relaxed)
    }

    /// The counts so far.
    pub fn counts(&self) -> Counts {
        *lock(&self.inner.counts)
    }

    /// A new subscription to the frames `filter` takes, from now on.
    pub fn subscribe(&self, filter: Filter) -> Subscription {
        let (tx, rx) = flume::bounded(filter.capacity.unwrap_or(DEFAULT_QUEUE));
        let dropped = Arc::new(AtomicU64::new(0));
        let slot = Slot {
            filter,
            to: To::Queue {
                tx,
                dropped: dropped.clone(),
            },
        };
        if !self.is_stopped() {
            lock(&self.inner.subscribers).push(slot);
        }
        Subscription {
            rx,
            dropped,
            name: self.inner.name.clone(),
        }
    }

    /// Runs `f` on every frame `filter` takes, on the endpoint's thread as the frame arrives,
    /// until the [`Tap`] is dropped: for state that must follow every frame (the latest
    /// telemetry, the systems seen) with no queue and no thread of its own. `f` must be quick
    /// and must not wait; it must not send or subscribe on this connection (the frame's
    /// handling holds the connection's receiving side).
    pub fn tap(&self, filter: Filter, f: impl Fn(&Frame) + Send + Sync + 'static) -> Tap {
        let id = NEXT_TAP.fetch_add(1, Ordering::Relaxed);
        lock(&self.inner.subscribers).push(Slot {
            filter,
            to: To::Tap { id, f: Arc::new(f) },
        });
        Tap {
            id,
            inner: Arc::downgrade(&self.inner),
        }
    }

    /// The system and component ids frames are sent from (255/190, a ground station, by
    /// default).
    pub fn set_ids(&self, sysid: u8, compid: u8) {
        lock(&self.inner.tx).own = (sysid, compid);
    }

    /// The system and component ids frames are sent from.
    pub fn ids(&self) -> (u8, u8) {
        lock(&self.inner.tx).own
    }

    /// Send MAVLink 1 or 2 (the default) frames.
    pub fn set_version(&self, version: Version) {
        lock(&self.inner.tx).version = version;
    }

    /// Signs every frame sent with `key` on `link_id`, with timestamps from the system clock,
    /// and checks every signed frame received against `key` with the router's replay rules;
    /// unsigned frames are taken as [`SharedConnection::set_unsigned`] says (RADIO_STATUS only,
    /// by default).
    pub fn set_signing(&self, key: SecretKey, link_id: u8) {
        lock(&self.inner.tx).signer = Some(Signer::new(key.clone(), link_id));
        lock(&self.inner.rx).verifier = Some(Verifier::new(key));
    }

    /// What a signed connection does with unsigned frames.
    pub fn set_unsigned(&self, unsigned: Unsigned) {
        lock(&self.inner.rx).unsigned = unsigned;
    }

    /// Hands out frames with ids the table lacks too, unchecked (off by default).
    pub fn set_pass_unknown_ids(&self, pass: bool) {
        let mut rx = lock(&self.inner.rx);
        self.inner.pass_unknown.store(pass, Ordering::Relaxed);
        for parser in rx.peers.deframers_mut() {
            parser.set_pass_unknown_ids(pass);
        }
    }

    /// Sends our HEARTBEAT as `heartbeat` says, from the connection's ids, until
    /// [`SharedConnection::stop_heartbeat`] or the last clone is dropped. Calling it again
    /// changes what is sent.
    pub fn start_heartbeat(&self, heartbeat: OwnHeartbeat) {
        let beat = &self.inner.heartbeat;
        *lock(&beat.settings) = Some(heartbeat);
        beat.bell.notify_all();
        if beat.running.swap(true, Ordering::AcqRel) {
            return;
        }
        let (weak, beat) = (Arc::downgrade(&self.inner), beat.clone());
        let spawned = std::thread::Builder::new()
            .name("ferrolink-heartbeat".into())
            .spawn({
                let beat = beat.clone();
                move || heartbeats(&weak, &beat)
            });
        if spawned.is_err() {
            beat.running.store(false, Ordering::Release);
        }
    }

    /// Whether our HEARTBEAT goes out in the background.
    pub fn is_beating(&self) -> bool {
        lock(&self.inner.heartbeat.settings).is_some()
    }

    /// Stops our HEARTBEAT.
    pub fn stop_heartbeat(&self) {
        *lock(&self.inner.heartbeat.settings) = None;
        self.inner.heartbeat.bell.notify_all();
    }

    /// Sends `message` to every peer, from the connection's ids, with that source's next
    /// sequence number. Fails if no peer is connected or every write failed.
    pub fn send<M: Message>(&self, message: &M) -> io::Result<()> {
        self.send_with(Route::default(), message)
    }

    /// Sends `message` to peer `to` alone (the peer a frame came from: [`Frame::peer`]).
    pub fn send_to<M: Message>(&self, to: PeerId, message: &M) -> io::Result<()> {
        self.send_with(
            Route {
                to: Some(to),
                ..Route::default()
            },
            message,
        )
    }

    /// Sends `message` from system `sysid`, component `compid`, with that source's own
    /// sequence numbers.
    pub fn send_as<M: Message>(&self, sysid: u8, compid: u8, message: &M) -> io::Result<()> {
        self.send_with(
            Route {
                from: Some((sysid, compid)),
                ..Route::default()
            },
            message,
        )
    }

    /// Sends `message` along `route`.
    pub fn send_with<M: Message>(&self, route: Route, message: &M) -> io::Result<()> {
        let mut payload = [0u8; ferrolink_runtime::mavlink::MAX_PAYLOAD_LEN];
        let len = message.encode(&mut payload);
        self.send_raw_with(route, M::ID, M::CRC_EXTRA, &payload[..len])
    }

    /// Sends any message of dialect `D`, as [`SharedConnection::send`] does.
    pub fn send_dialect<D: Dialect>(&self, message: &D) -> io::Result<()> {
        let mut payload = [0u8; ferrolink_runtime::mavlink::MAX_PAYLOAD_LEN];
        let len = message.encode(&mut payload);
        let meta = message.meta();
        self.send_raw_with(Route::default(), meta.id, meta.crc_extra, &payload[..len])
    }

    /// Sends a payload (whole, not truncated) of message `id` with `crc_extra` to every peer.
    pub fn send_raw(&self, id: u32, crc_extra: u8, payload: &[u8]) -> io::Result<()> {
        self.send_raw_with(Route::default(), id, crc_extra, payload)
    }

    /// Sends a payload of message `id` with `crc_extra` along `route`.
    pub fn send_raw_with(
        &self,
        route: Route,
        id: u32,
        crc_extra: u8,
        payload: &[u8],
    ) -> io::Result<()> {
        // Encoding and writing under one lock keeps each source's sequence in order on the wire.
        let mut tx = lock(&self.inner.tx);
        let (sysid, compid) = route.from.unwrap_or(tx.own);
        let seq = tx.seqs.entry((sysid, compid)).or_insert(0);
        let header = Header::new(*seq, sysid, compid);
        let mut out = [0u8; v2::MAX_FRAME_LEN];
        let encoded = match (tx.version, &mut tx.signer) {
            (Version::V1, _) => {
                let min = find_meta(&self.inner.table, id)
                    .map_or(payload.len(), |m| usize::from(m.min_len));
                v1::encode_raw(
                    header,
                    id,
                    crc_extra,
                    &payload[..min.min(payload.len())],
                    &mut out,
                )
            }
            (Version::V2, Some(signer)) => signer.encode_raw(
                timestamp_from_unix_micros(unix_us()),
                header,
                id,
                crc_extra,
                payload,
                &mut out,
            ),
            (Version::V2, None) => v2::encode_raw(header, id, crc_extra, payload, &mut out),
        };
        let n = encoded.map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
        let rx = lock(&self.inner.rx);
        let sent = match route.to {
            None => rx.peers.send_all(&out[..n], &self.inner.name),
            Some(peer) => match rx.peers.sender(peer) {
                Some(sender) => sender.send(&out[..n]),
                None => Err(io::Error::new(
                    io::ErrorKind::NotConnected,
                    format!("{}: peer {peer} is gone", self.inner.name),
                )),
            },
        };
        if sent.is_ok() {
            if let Some(seq) = tx.seqs.get_mut(&(sysid, compid)) {
                *seq = seq.wrapping_add(1);
            }
        }
        sent
    }
}

impl Inner {
    /// Takes in one event of the endpoint, on the endpoint's thread.
    fn take(&self, event: Event<'_>) {
        let mut rx = lock(&self.rx);
        let Rx {
            peers,
            verifier,
            unsigned,
        } = &mut *rx;
        let mut counts = Counts::default();
        let mut deliver = |peer: PeerId, frame: ParsedFrame<'_>| {
            counts.frames += 1;
            if let Some(verifier) = verifier.as_mut() {
                let signed = frame.as_v2().filter(|f| f.is_signed());
                match signed {
                    Some(v2) => {
                        if verifier
                            .verify(v2, timestamp_from_unix_micros(unix_us()))
                            .is_err()
                        {
                            counts.bad_signature += 1;
                            return;
                        }
                    }
                    None => {
                        let taken = match unsigned {
                            Unsigned::Accept => true,
                            Unsigned::Refuse => false,
                            Unsigned::Only(ids) => ids.contains(&frame.msg_id()),
                        };
                        if !taken {
                            counts.unsigned += 1;
                            return;
                        }
                    }
                }
            }
            counts.dropped += self.fan_out(Frame::new(&frame, peer));
        };
        peers.handle(event, &mut deliver);
        drop(rx);
        if counts != Counts::default() {
            let mut total = lock(&self.counts);
            total.frames += counts.frames;
            total.unsigned += counts.unsigned;
            total.bad_signature += counts.bad_signature;
            total.dropped += counts.dropped;
        }
    }

    /// Hands `frame` to every subscriber that takes it; returns how many lost it to a full
    /// queue. Subscribers that went away are forgotten.
    fn fan_out(&self, frame: Frame) -> u64 {
        let (id, sysid) = (frame.msg_id(), frame.header().sysid);
        let mut dropped = 0;
        lock(&self.subscribers).retain(|slot| match &slot.to {
            To::Tap { f, .. } => {
                if slot.filter.takes(id, sysid) {
                    f(&frame);
                }
                true
            }
            To::Queue { tx, .. } if !slot.filter.takes(id, sysid) => !tx.is_disconnected(),
            To::Queue { tx, dropped: lost } => match tx.try_send(frame.clone()) {
                Ok(()) => true,
                Err(flume::TrySendError::Full(_)) => {
                    lost.fetch_add(1, Ordering::Relaxed);
                    dropped += 1;
                    true
                }
                Err(flume::TrySendError::Disconnected(_)) => false,
            },
        });
        dropped
    }

    /// The endpoint stopped: subscriptions end once they have read what they hold.
    fn stop(&self) {
        self.stopped.store(true, Ordering::Relaxed);
        lock(&self.subscribers).clear();
        let _settings = lock(&self.heartbeat.settings);
        self.heartbeat.bell.notify_all();
    }
}

/// The heartbeat thread: sends while the connection lives and a heartbeat is set, holding the
/// connection only while it sends.
fn heartbeats(weak: &Weak<Inner>, beat: &Beat) {
    loop {
        let Some(inner) = weak
            .upgrade()
            .filter(|i| !i.stopped.load(Ordering::Relaxed))
        else {
            beat.running.store(false, Ordering::Release);
            return;
        };
        let now = *lock(&beat.settings);
        if let Some(own) = now {
            let message = HeartbeatMessage {
                r#type: own.mav_type,
                autopilot: own.autopilot,
                base_mode: MavModeFlag::default(),
                custom_mode: 0,
                system_status: own.system_status,
                mavlink_version: 3,
            };
            // No peer yet is no error.
            let _ = SharedConnection {
                inner: inner.clone(),
            }
            .send(&message);
        }
        // Not holding the settings' lock: the last reference's drop takes it to ring the bell.
        drop(inner);
        // Until the interval passes, the settings change or the connection goes.
        let interval = now.map_or(Duration::from_secs(3600), |own| own.interval);
        let settings = lock(&beat.settings);
        drop(
            beat.bell
                .wait_timeout_while(settings, interval, |s| *s == now && weak.strong_count() > 0)
                .unwrap_or_else(std::sync::PoisonError::into_inner),
        );
    }
}

/// A tap on a connection ([`SharedConnection::tap`]); dropping it removes it.
#[derive(Debug)]
pub struct Tap {
    id: u64,
    inner: Weak<Inner>,
}

impl Drop for Tap {
    fn drop(&mut self) {
        if let Some(inner) = self.inner.upgrade() {
            lock(&inner.subscribers)
                .retain(|slot| !matches!(slot.to, To::Tap { id, .. } if id == self.id));
        }
    }
}

/// One subscriber's frames: see [`SharedConnection::subscribe`]. Blocking
/// ([`Subscription::recv`]) or async ([`Subscription::recv_async`], on any executor).
#[derive(Debug)]
pub struct Subscription {
    rx: flume::Receiver<Frame>,
    dropped: Arc<AtomicU64>,
    name: Arc<str>,
}

impl Subscription {
    fn stopped(&self) -> io::Error {
        io::Error::new(
            io::ErrorKind::BrokenPipe,
            format!("{}: the endpoint stopped", self.name),
        )
    }

    /// Waits up to `timeout` for a frame. `Ok(None)` when none came in time; an error once the
    /// connection stopped and everything it held was read.
    pub fn recv(&self, timeout: Duration) -> io::Result<Option<Frame>> {
        match self.rx.recv_timeout(timeout) {
            Ok(frame) => Ok(Some(frame)),
            Err(flume::RecvTimeoutError::Timeout) => Ok(None),
            Err(flume::RecvTimeoutError::Disconnected) => Err(self.stopped()),
        }
    }

    /// Waits for the next frame, however long it takes.
    pub fn recv_blocking(&self) -> io::Result<Frame> {
        self.rx.recv().map_err(|_| self.stopped())
    }

    /// A frame that is already there, without waiting.
    pub fn try_recv(&self) -> io::Result<Option<Frame>> {
        match self.rx.try_recv() {
            Ok(frame) => Ok(Some(frame)),
            Err(flume::TryRecvError::Empty) => Ok(None),
            Err(flume::TryRecvError::Disconnected) => Err(self.stopped()),
        }
    }

    /// Waits for the next frame, from async code (any executor).
    pub async fn recv_async(&self) -> io::Result<Frame> {
        self.rx.recv_async().await.map_err(|_| self.stopped())
    }

    /// How many frames this subscription lost because its queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// How many frames wait to be read.
    pub fn len(&self) -> usize {
        self.rx.len()
    }

    /// Whether no frame waits to be read.
    pub fn is_empty(&self) -> bool {
        self.rx.is_empty()
    }
}
