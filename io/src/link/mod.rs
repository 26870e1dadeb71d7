//! The link layer every protocol runs on: endpoints with any number of peers, where every peer
//! (each UDP sender, each TCP client) is a link of its own.
//!
//! The MAVLink router and connections, the NDLCom bridge, TosNet's UDP nodes and ModRob's
//! Ethernet-1 all open their sockets, devices and pseudo-terminals here.
//!
//! An [`Endpoint`] is opened with [`open`], which starts its threads and reports to one [`Sink`],
//! called on those threads: [`Event::Up`] when a peer appears (with a [`Sender`] to write to
//! it), [`Event::Rx`] for every read, [`Event::Quiet`] when a stream peer pauses for
//! [`QUIET`] after sending, [`Event::Down`] when it goes away. Peers are numbered by
//! [`PeerId`], never reused.
//!
//! | endpoint, as [`Display`](fmt::Display) writes it | peers | |
//! |-----|-------|-|
//! | `udpin://HOST:PORT` | each address that sends to the bound socket | a peer quiet for the expiry (10 s by default) is reported down |
//! | `udpout://HOST:PORT` | the one address | sent to from an ephemeral port; replies to that port from that address are read (from any address with `?replies=any`) |
//! | `udpbcast://ADDR:PORT` | the broadcast address, and each host that answers | sent to with `SO_BROADCAST` from an ephemeral port; a host is answered directly, and is [reached through](Sender::reached_through) the broadcast address |
//! | `udpmcast://GROUP:PORT[?iface=NAME]` | the group, and each host heard in it | the group's port is shared (`SO_REUSEADDR`); sent to from an ephemeral port, whose datagrams coming back are dropped; a host is sent to through the group |
//! | [`Endpoint::Udp`] (NDLCom's `udp://HOST:IN_PORT:OUT_PORT`) | `HOST:OUT_PORT` | sent to from local port `IN_PORT`; every datagram arriving there is read |
//! | `tcpin://HOST:PORT` | each client | any number of clients |
//! | `tcpout://HOST:PORT` | the server | reconnects with a backoff from 50 ms doubling to 1 s |
//! | `serial://PATH[:BAUD]` | the device | reopened every second after it fails or is unplugged |
//! | `pty://NAME` | the program attached to the pseudo-terminal linked at `NAME` | created and reported up at open, removed once the endpoint and its senders are dropped |
//!
//! Users name endpoints in their protocol's spelling: [`uri`](crate::uri) holds the one grammar,
//! and each protocol declares its schemes and defaults there
//! ([`mavlink::ENDPOINTS`](crate::mavlink::ENDPOINTS),
//! [`ndlcom::ENDPOINTS`](crate::ndlcom::ENDPOINTS)).
//!
//! A UDP endpoint also sends to any address from its bound socket ([`Handle::sender_to`]), for
//! protocols that fan out to a list of addresses on a shared medium (ModRob's Ethernet-1).
//!
//! A stream peer's [`Sender`] writes on the caller's thread by default ([`Overflow::Wait`]).
//! With [`Options::queue`] set to drop, each stream peer gets a bounded output queue and a
//! writer thread: a peer that stops reading loses its own frames, counted by
//! [`Sender::dropped`], and a sender never waits for it.
//!
//! Threads, not an async runtime (measured against tokio in `cargo bench -p ferrolink-bench --bench
//! router`): one blocking reader per socket or client, parked in the kernel while nothing
//! arrives. A UDP reader waits without a timeout (dropping the [`Handle`] wakes it with an empty
//! datagram) and takes every datagram that has arrived with one `recvmmsg`; a TCP reader waits
//! too (the stop shuts its socket down), and so do serial and pty readers (they wait for their
//! device and the stop's [`Bell`] at once). The sink runs on the reader's thread, so a router can
//! route a datagram the moment it is read, with no hand-over between threads. The UDP datagrams
//! sent on a UDP reader's thread go out together when it next waits: in the same system call as
//! the wait, through an io_uring, on Linux 5.11 and later where the kernel gives one (container
//! sandboxes may not), and otherwise one `sendmmsg` per socket before it; the peers they wake
//! then run while the reader sleeps, not in its way. Other threads send what they write while
//! handling a read when the sink returns. With [`Options::pack_up_to`] set, the datagrams bound
//! for one address share datagrams.

use std::collections::HashMap;
use std::fmt;
use std::io;
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream, UdpSocket};

use crate::{is_timeout, LinkReader, LinkWriter};

mod batch;
mod bell;
mod queue;
mod stream;
mod udp;
#[cfg(target_os = "linux")]
mod uring;

pub use batch::{batch, PACKED_DATAGRAM};
pub(crate) use bell::{Bell, Rang};
use queue::Queue;
pub use queue::{OutputQueue, Overflow, DAEMON_QUEUE, DEFAULT_QUEUE_BYTES};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread;
use std::time::{Duration, Instant};
use stream::{peer_up, read_until_down, serial, tcp_in, tcp_out, wait_for_clients};
use udp::{udp_in, udp_one_peer};

/// How long a `udpin` peer may be quiet before it is reported down.
pub const DEFAULT_PEER_EXPIRY: Duration = Duration::from_secs(10);
/// The longest wait between `tcpout` connection attempts.
pub const MAX_BACKOFF: Duration = Duration::from_secs(1);
/// How often a reader that nothing wakes at a stop (a device's, where the system gives no pipe
/// for a [`Bell`]) looks up from its read to notice it; how long a reader pauses after a failed
/// read.
const POLL: Duration = Duration::from_millis(200);
/// The most clients one `tcpin` endpoint serves at once, each with a thread of its own. A
/// client past it is closed as soon as it is accepted, with a log line, so a flood of
/// connections costs neither threads nor descriptors (the router's own limit, 64 links in all,
/// is never looser).
pub const MAX_TCP_CLIENTS: usize = 64;
/// How long a thread that is woken at its endpoint's stop (a `tcpin` accept, by a connection; a
/// TCP reader, by its socket's shutdown) waits before it looks whether it was stopped anyway,
/// should the wake-up not arrive.
const WOKEN_PATIENCE: Duration = Duration::from_secs(2);

/// An endpoint's stop: the flag its threads look at; its connected TCP streams, shut down at
/// the stop so that their readers, which wait without polling, see it at once; and a
/// [`Bell`] for the threads that wait on a device or a clock, made when one asks for it.
#[derive(Debug, Default)]
struct Stop {
    flag: AtomicBool,
    streams: Mutex<HashMap<u64, TcpStream>>,
    next: AtomicU64,
    bell: Mutex<Option<Arc<Bell>>>,
}

impl Stop {
    fn is_set(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
    }

    /// Sets the flag and shuts down every stream it watches.
    fn set(&self) {
        self.flag.store(true, Ordering::SeqCst);
        let streams =
            std::mem::take(&mut *self.streams.lock().unwrap_or_else(PoisonError::into_inner));
        for stream in streams.into_values() {
            let _ = stream.shutdown(Shutdown::Both);
        }
        if let Some(bell) = &*self.bell.lock().unwrap_or_else(PoisonError::into_inner) {
            bell.ring();
        }
    }

    /// The bell that rings at the stop (rung already if the stop came first), or `None` where
    /// the system gives no pipe for one.
    fn bell(&self) -> Option<Arc<Bell>> {
        let mut bell = self.bell.lock().unwrap_or_else(PoisonError::into_inner);
        if bell.is_none() {
            *bell = Bell::new().map(Arc::new);
            // `set` stores the flag before it looks for a bell, under the same lock.
            if let Some(b) = bell.as_ref().filter(|_| self.is_set()) {
                b.ring();
            }
        }
        bell.clone()
    }

    /// Sleeps for `time`, or less if the stop comes first.
    fn sleep(&self, time: Duration) {
        match self.bell() {
            Some(bell) => bell.sleep(time),
            None => thread::sleep(time),
        }
    }

    /// Watches `stream` until [`forget`](Self::forget) is called with what this returns.
    fn watch(&self, stream: &TcpStream) -> Option<u64> {
        let clone = stream.try_clone().ok()?;
        let id = self.next.fetch_add(1, Ordering::Relaxed);
        self.streams
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(id, clone);
        Some(id)
    }

    /// Stops watching a stream; the clone it kept, if the stop has not shut it down already.
    fn forget(&self, id: Option<u64>) -> Option<TcpStream> {
        self.streams
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .remove(&id?)
    }
}

/// How long a stream peer (TCP, serial, pty) may pause after sending before it is reported
/// [`Event::Quiet`]: far longer than a link pauses inside a frame (a 280-byte MAVLink frame
/// takes 49 ms at 57,600 baud; USB serial adapters and radios hold bytes back for tens of
/// milliseconds), short enough that a false start does not hold frames back for long.
pub const QUIET: Duration = Duration::from_millis(500);

/// Where a link goes: what a URI names, parsed by a protocol's [`Grammar`](crate::uri::Grammar).
/// `Display` writes the link layer's own spelling (MAVLink's, with NDLCom's `udp://` pair).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// `udpin://HOST:PORT`: listen; every sender is a peer.
    UdpIn(String, u16),
    /// `udpout://HOST:PORT`: send there, read the replies.
    UdpOut(String, u16),
    /// `udpout://HOST:PORT?replies=any`: send there, read every datagram that reaches the
    /// port sent from, whoever sends it (a vehicle that answers from another address).
    UdpOutAny(String, u16),
    /// `udpbcast://ADDR:PORT`: send to a broadcast address (`SO_BROADCAST`) from an ephemeral
    /// port; every host that answers is a peer of its own, as on `udpin`, answered directly.
    UdpBcast(String, u16),
    /// `udpmcast://GROUP:PORT[?iface=NAME]`: join a multicast group (IPv4 or IPv6), on the
    /// interface named or the one the system picks, and send to it; every host heard in the
    /// group is a peer of its own, sent to through the group. Our own frames, looped back, are
    /// dropped.
    UdpMcast(String, u16, Option<String>),
    /// `(HOST, IN_PORT, OUT_PORT)`: bind `IN_PORT` on the unspecified address of `HOST`'s
    /// family, send to `HOST:OUT_PORT`, and read every datagram that arrives (NDLCom's
    /// `udp://HOST:IN_PORT:OUT_PORT`, written that way by [`fmt::Display`]).
    Udp(String, u16, u16),
    /// `tcpin://HOST:PORT`: TCP server; every client is a peer.
    TcpIn(String, u16),
    /// `tcpout://HOST:PORT`: TCP client that reconnects.
    TcpOut(String, u16),
    /// `serial://PATH[:BAUD]`: a serial device, 8N1, that is reopened when it fails.
    Serial(String, u32),
    /// `pty://NAME`: a pseudo-terminal whose other end is linked at `NAME`, for programs that
    /// expect a serial device.
    Pty(String),
}

impl Endpoint {
    /// Whether each read is one datagram (UDP), rather than a piece of a byte stream.
    pub fn is_datagrams(&self) -> bool {
        matches!(
            self,
            Endpoint::UdpIn(..)
                | Endpoint::UdpOut(..)
                | Endpoint::UdpOutAny(..)
                | Endpoint::UdpBcast(..)
                | Endpoint::UdpMcast(..)
                | Endpoint::Udp(..)
        )
    }
}

impl fmt::Display for Endpoint {
    /// The canonical URI.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let host = |h: &str| {
            if h.contains(':') {
                format!("[{h}]")
            } else {
                h.to_owned()
            }
        };
        match self {
            Endpoint::UdpIn(h, p) => write!(f, "udpin://{}:{p}", host(h)),
            Endpoint::UdpOut(h, p) => write!(f, "udpout://{}:{p}", host(h)),
            Endpoint::UdpOutAny(h, p) => write!(f, "udpout://{}:{p}?replies=any", host(h)),
            Endpoint::UdpBcast(h, p) => write!(f, "udpbcast://{}:{p}", host(h)),
            Endpoint::UdpMcast(h, p, iface) => {
                write!(f, "udpmcast://{}:{p}", host(h))?;
                match iface {
                    Some(name) => write!(f, "?iface={name}"),
                    None => Ok(()),
                }
            }
            Endpoint::Udp(h, i, o) => write!(f, "udp://{}:{i}:{o}", host(h)),
            Endpoint::TcpIn(h, p) => write!(f, "tcpin://{}:{p}", host(h)),
            Endpoint::TcpOut(h, p) => write!(f, "tcpout://{}:{p}", host(h)),
            Endpoint::Serial(path, baud) => write!(f, "serial://{path}:{baud}"),
            Endpoint::Pty(name) => write!(f, "pty://{name}"),
        }
    }
}

/// A peer's number: unique over the life of the process.
pub type PeerId = u64;

static NEXT_PEER: AtomicU64 = AtomicU64::new(1);

/// A fresh peer number, for endpoints opened outside this module (Zenoh, say) that report to a
/// [`Sink`] the same way.
pub fn next_peer() -> PeerId {
    NEXT_PEER.fetch_add(1, Ordering::Relaxed)
}

/// What an endpoint reports.
#[derive(Debug)]
pub enum Event<'a> {
    /// A peer appeared. `name` says who it is (`udpin://0.0.0.0:14550 <- 127.0.0.1:40000`).
    Up {
        /// The endpoint's index, as given to [`open`].
        endpoint: usize,
        /// The peer.
        peer: PeerId,
        /// Who it is.
        name: String,
        /// Writes to it.
        sender: Sender,
    },
    /// Bytes from a peer, read at `at`.
    Rx {
        /// The peer.
        peer: PeerId,
        /// The bytes (one datagram, or what one read returned).
        bytes: &'a [u8],
        /// When they were read.
        at: Instant,
    },
    /// A stream peer sent nothing for [`QUIET`] after its last bytes: a frame it left
    /// unfinished will not be finished, and the parser should judge what it holds
    /// ([`Deframer::drain_stalled`](ferrolink_runtime::framing::Deframer::drain_stalled)).
    /// Datagram peers have no such event: a datagram is whole.
    Quiet {
        /// The peer.
        peer: PeerId,
    },
    /// A peer went away (closed, failed, unplugged or quiet), with the reason.
    Down {
        /// The peer.
        peer: PeerId,
        /// Why.
        why: String,
    },
}

/// Where an endpoint reports its events, called on the endpoint's threads. Returning `false`
/// stops the thread that called (nobody listens any more).
pub type Sink = Arc<dyn Fn(Event<'_>) -> bool + Send + Sync>;

/// What an endpoint opened outside this module may ask of the program it reports to (a router's
/// links and the systems behind them, say), as JSON.
pub type Status = Arc<dyn Fn() -> serde_json::Value + Send + Sync>;

/// Starts an endpoint opened outside this module (Zenoh, in `ferrolink-zenoh`) as endpoint
/// number `index`, reporting to the sink the way [`open`] does; what it returns keeps it running
/// until dropped.
pub type Open = Box<dyn FnOnce(usize, Sink, Status) -> io::Result<Box<dyn Send>> + Send>;

/// Writes to one peer. Cloning shares the socket.
#[derive(Debug, Clone)]
pub struct Sender(SenderKind, Option<PeerId>);

/// Writes one frame or datagram somewhere outside this module.
type WriteFn = dyn Fn(&[u8]) -> io::Result<()> + Send + Sync;

#[derive(Clone)]
enum SenderKind {
    Udp(batch::Route),
    /// A stream, written by the caller or, with a queue, by the queue's writer thread.
    Stream(Arc<Mutex<Box<dyn LinkWriter>>>, Option<Arc<Queue>>),
    Fn(Arc<WriteFn>),
}

impl fmt::Debug for SenderKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SenderKind::Udp(route) => f
                .debug_tuple("Udp")
                .field(&route.socket)
                .field(&route.to)
                .finish(),
            SenderKind::Stream(..) => f.write_str("Stream"),
            SenderKind::Fn(_) => f.write_str("Fn"),
        }
    }
}

impl Sender {
    /// A sender from a UDP socket to `to`, whose writes in one batch may share datagrams of up
    /// to `pack_up_to` bytes (see [`Options::pack_up_to`]).
    fn udp(socket: Arc<UdpSocket>, to: SocketAddr, pack_up_to: usize) -> Sender {
        Sender(
            SenderKind::Udp(batch::Route {
                socket,
                to,
                pack_up_to,
            }),
            None,
        )
    }

    /// A sender that hands every write to `write`: for endpoints opened outside this module.
    pub fn from_fn(write: impl Fn(&[u8]) -> io::Result<()> + Send + Sync + 'static) -> Sender {
        Sender(SenderKind::Fn(Arc::new(write)), None)
    }

    /// The peer of the same endpoint whose every send reaches this one too: the broadcast
    /// address or multicast group of a `udpbcast` or `udpmcast` endpoint, for each host heard
    /// there. A router sends a frame bound for both only through that peer
    /// ([`Router::reached_through`](ferrolink_runtime::mavlink::router::Router::reached_through)).
    pub fn reached_through(&self) -> Option<PeerId> {
        self.1
    }

    fn through(mut self, peer: Option<PeerId>) -> Sender {
        self.1 = peer;
        self
    }

    /// Sends `bytes` as one datagram, or writes them to the stream: on this thread (failing
    /// when the peer took nothing for 100 ms), or through the peer's output queue, which never
    /// waits (see [`Overflow`]).
    pub fn send(&self, bytes: &[u8]) -> io::Result<()> {
        match &self.0 {
            SenderKind::Udp(route) => {
                if !batch::defer(route, bytes) {
                    route.socket.send_to(bytes, route.to)?;
                }
                Ok(())
            }
            SenderKind::Stream(_, Some(queue)) => queue.push(bytes),
            SenderKind::Stream(stream, None) => stream
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .write_all(bytes),
            SenderKind::Fn(write) => write(bytes),
        }
    }

    /// Frames the peer's output queue dropped because the peer did not keep up (0 without a
    /// queue).
    pub fn dropped(&self) -> u64 {
        match &self.0 {
            SenderKind::Stream(_, Some(queue)) => queue.dropped(),
            _ => 0,
        }
    }

    /// Ends the peer's connection if it has one to end (a TCP client or server): its reader
    /// sees the end, reports the peer down and closes the socket. `false` for a UDP peer, a
    /// device or a pty, which stay.
    pub fn close(&self) -> bool {
        match &self.0 {
            SenderKind::Stream(stream, queue) => {
                if let Some(queue) = queue {
                    queue.close();
                }
                stream
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .close()
            }
            SenderKind::Udp(..) | SenderKind::Fn(_) => false,
        }
    }
}

/// Options of [`open`].
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// How long a `udpin` peer may be quiet before it is reported down.
    pub peer_expiry: Duration,
    /// How writes to a stream peer (TCP, serial, pty) wait or queue.
    pub queue: OutputQueue,
    /// The largest datagram that writes to one UDP peer may share: what is written to a peer
    /// while one read is handled goes out in as few datagrams of at most this many bytes as
    /// hold it, each write whole and in order (a write longer than this goes alone). 0, the
    /// default, sends each write in a datagram of its own, for protocols whose peers read one
    /// frame a datagram. See [`PACKED_DATAGRAM`].
    pub pack_up_to: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            peer_expiry: DEFAULT_PEER_EXPIRY,
            queue: OutputQueue::default(),
            pack_up_to: 0,
        }
    }
}

/// An open endpoint. Dropping it stops its threads at once and closes its peers.
#[derive(Debug)]
pub struct Handle {
    stop: Arc<Stop>,
    local: Option<SocketAddr>,
    udp: Option<Arc<UdpSocket>>,
    /// A multicast endpoint's sending socket and group: its reader, bound to the group, is
    /// woken by a datagram to the group that never leaves this host.
    wake_group: Option<(Arc<UdpSocket>, SocketAddr)>,
    /// Whether this is a `tcpin` endpoint, whose accept waits without a timeout.
    listens: bool,
    pack_up_to: usize,
}

/// Where a datagram wakes a UDP reader blocked on a socket bound to `local`.
fn wake_address(local: SocketAddr) -> SocketAddr {
    let mut to = local;
    if to.ip().is_unspecified() {
        to.set_ip(match to {
            SocketAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
            SocketAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
        });
    }
    to
}

impl Handle {
    /// The bound address of a UDP or `tcpin` endpoint (useful with port 0).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.local
    }

    /// Sends from a UDP endpoint's socket to `to`, whether or not it was heard from; `None`
    /// for other endpoints.
    pub fn sender_to(&self, to: SocketAddr) -> Option<Sender> {
        let socket = self.udp.clone()?;
        Some(Sender::udp(socket, to, self.pack_up_to))
    }
}

impl Drop for Handle {
    /// Stops the endpoint's threads. A UDP reader waits for datagrams without a timeout (an
    /// idle router wakes for nothing): an empty datagram to its socket wakes it. A `tcpin`
    /// endpoint's accept is woken the same way, by a connection.
    fn drop(&mut self) {
        self.stop.set();
        if let Some(local) = self.local.filter(|_| self.listens) {
            let _ = TcpStream::connect_timeout(&wake_address(local), Duration::from_millis(100));
        }
        if let Some((socket, group)) = &self.wake_group {
            // Hop limit 0: delivered on this host only.
            let limited = match group {
                SocketAddr::V4(_) => socket.set_multicast_ttl_v4(0),
                SocketAddr::V6(_) => socket2::SockRef::from(&**socket).set_multicast_hops_v6(0),
            };
            if limited.is_ok() {
                let _ = socket.send_to(&[], group);
            }
        } else if let Some(local) = self.udp.as_ref().and_then(|s| s.local_addr().ok()) {
            let to = wake_address(local);
            let any: SocketAddr = match to {
                SocketAddr::V4(_) => (std::net::Ipv4Addr::UNSPECIFIED, 0).into(),
                SocketAddr::V6(_) => (std::net::Ipv6Addr::UNSPECIFIED, 0).into(),
            };
            if let Ok(waker) = UdpSocket::bind(any) {
                let _ = waker.send_to(&[], to);
            }
        }
    }
}

/// The first address of `host` (IPv4 preferred, see [`crate::resolve`]).
fn resolve(host: &str, port: u16) -> io::Result<SocketAddr> {
    crate::resolve(host, port)?
        .into_iter()
        .next()
        .ok_or_else(|| io::Error::from(io::ErrorKind::NotFound))
}

/// Opens endpoint number `index` and reports its peers to `events`. Sockets are bound (and a
/// server listens) before this returns; `tcpout` and `serial` connect in the background.
pub fn open(
    index: usize,
    endpoint: &Endpoint,
    options: Options,
    events: Sink,
) -> io::Result<Handle> {
    let stop = Arc::new(Stop::default());
    let name = endpoint.to_string();
    let uri = name.clone();
    let context = |e: io::Error| {
        let hint = match e.kind() {
            io::ErrorKind::AddrInUse => {
                "\n  hint: another program (or another endpoint given here) listens on this \
                 port; `ss -lunp` and `ss -ltnp` name it"
            }
            _ => "",
        };
        io::Error::new(e.kind(), format!("{uri}: {e}{hint}"))
    };
    let mut udp = None;
    let mut wake_group = None;
    let local = match endpoint {
        Endpoint::UdpIn(host, port) => {
            let socket =
                Arc::new(UdpSocket::bind(resolve(host, *port).map_err(context)?).map_err(context)?);
            batch::widen_receive_buffer(&socket);
            udp = Some(socket.clone());
            let local = socket.local_addr().ok();
            let sources = udp::Sources::direct(&socket);
            spawn(&uri, {
                let stop = stop.clone();
                move || udp_in(index, &name, &socket, &sources, options, &stop, &events)
            })?;
            local
        }
        Endpoint::UdpBcast(host, port) | Endpoint::UdpMcast(host, port, _) => {
            let (socket, receive, to, sources) = match endpoint {
                Endpoint::UdpMcast(_, _, iface) => {
                    let m = udp::multicast(host, *port, iface.as_deref()).map_err(context)?;
                    let send = Arc::new(m.send);
                    let own = send.local_addr().map_err(context)?.port();
                    wake_group = Some((send.clone(), m.group));
                    let sources = udp::Sources {
                        socket: send.clone(),
                        to: Some(m.group),
                        through: None,
                        own: Some((own, m.local)),
                    };
                    (send, Arc::new(m.receive), m.group, sources)
                }
                _ => {
                    let to = resolve(host, *port).map_err(context)?;
                    let socket = UdpSocket::bind(SocketAddr::new(udp::unspecified(to), 0))
                        .map_err(context)?;
                    socket.set_broadcast(true).map_err(context)?;
                    let socket = Arc::new(socket);
                    let sources = udp::Sources::direct(&socket);
                    (socket.clone(), socket, to, sources)
                }
            };
            batch::widen_receive_buffer(&receive);
            udp = Some(receive.clone());
            let local = receive.local_addr().ok();
            // The broadcast address or group is a peer from the start; each host heard there
            // is one of its own, answered directly (broadcast) or through the group.
            let group = next_peer();
            let up = Event::Up {
                endpoint: index,
                peer: group,
                name: name.clone(),
                sender: Sender::udp(socket, to, options.pack_up_to),
            };
            if !events(up) {
                return Err(io::Error::other(format!(
                    "{uri}: nobody listens for events"
                )));
            }
            let sources = udp::Sources {
                through: Some(group),
                ..sources
            };
            spawn(&uri, {
                let stop = stop.clone();
                move || udp_in(index, &name, &receive, &sources, options, &stop, &events)
            })?;
            local
        }
        Endpoint::UdpOut(host, port)
        | Endpoint::UdpOutAny(host, port)
        | Endpoint::Udp(host, _, port) => {
            let to = resolve(host, *port).map_err(context)?;
            let (bind_port, only_from) = match endpoint {
                Endpoint::Udp(_, in_port, _) => (*in_port, None),
                Endpoint::UdpOutAny(..) => (0, None),
                _ => (0, Some(to)),
            };
            let any: SocketAddr = if to.is_ipv4() {
                (std::net::Ipv4Addr::UNSPECIFIED, bind_port).into()
            } else {
                (std::net::Ipv6Addr::UNSPECIFIED, bind_port).into()
            };
            let socket = Arc::new(UdpSocket::bind(any).map_err(context)?);
            batch::widen_receive_buffer(&socket);
            udp = Some(socket.clone());
            let local = socket.local_addr().ok();
            // The one peer is known now: report it before returning, so a send right after
            // `open` has somewhere to go.
            let peer = next_peer();
            let up = Event::Up {
                endpoint: index,
                peer,
                name,
                sender: Sender::udp(socket.clone(), to, options.pack_up_to),
            };
            if !events(up) {
                return Err(io::Error::other(format!(
                    "{uri}: nobody listens for events"
                )));
            }
            spawn(&uri, {
                let stop = stop.clone();
                move || udp_one_peer(peer, &socket, only_from, &stop, &events)
            })?;
            local
        }
        Endpoint::TcpIn(host, port) => {
            let listener =
                TcpListener::bind(resolve(host, *port).map_err(context)?).map_err(context)?;
            if !wait_for_clients(&listener) {
                listener.set_nonblocking(true).map_err(context)?;
            }
            let local = listener.local_addr().ok();
            spawn(&uri, {
                let stop = stop.clone();
                move || tcp_in(index, &name, &listener, options.queue, &stop, &events)
            })?;
            local
        }
        Endpoint::TcpOut(host, port) => {
            let (host, port) = (host.clone(), *port);
            spawn(&uri, {
                let stop = stop.clone();
                move || tcp_out(index, &name, &host, port, options.queue, &stop, &events)
            })?;
            None
        }
        Endpoint::Serial(path, baud) => {
            let (path, baud) = (path.clone(), *baud);
            spawn(&uri, {
                let stop = stop.clone();
                move || serial(index, &name, &path, baud, options.queue, &stop, &events)
            })?;
            None
        }
        Endpoint::Pty(link) => {
            // Created and reported now, so that the link exists and can be written to when
            // `open` returns.
            let (reader, writer) = crate::serial::open_pty(link, stop.bell()).map_err(context)?;
            let peer = peer_up(index, &name, writer, options.queue, &events)?
                .ok_or_else(|| io::Error::other(format!("{uri}: nobody listens for events")))?;
            spawn(&uri, {
                let stop = stop.clone();
                move || {
                    read_until_down(peer, reader, &stop, &events);
                }
            })?;
            None
        }
    };
    Ok(Handle {
        stop,
        local,
        udp,
        wake_group,
        listens: matches!(endpoint, Endpoint::TcpIn(..)),
        pack_up_to: options.pack_up_to,
    })
}

fn spawn(name: &str, f: impl FnOnce() + Send + 'static) -> io::Result<()> {
    thread::Builder::new()
        .name(name.chars().take(15).collect())
        .spawn(f)
        .map(|_| ())
}
