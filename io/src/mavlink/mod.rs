//! MAVLink on PCs: connections from URIs, and telemetry logs.
//!
//! ```no_run
//! use ferrolink_io::mavlink::Connection;
//! # use ferrolink_runtime::mavlink::MessageMeta;
//! # static META: &[MessageMeta] = &[];
//! // A simulator or autopilot sending to UDP port 14550 (pymavlink's `udpin:0.0.0.0:14550`
//! // works too). With generated bindings, pass `Message::META` of the dialect.
//! let mut vehicle = Connection::open("udpin://0.0.0.0:14550", META)?;
//! vehicle.set_ids(255, 190);
//! // Blocks for each frame, through quiet spells, until the connection stops.
//! for frame in vehicle.frames() {
//!     let frame = frame?;
//!     println!("{} from {}/{}", frame.msg_id(), frame.header().sysid, frame.header().compid);
//! }
//! # Ok::<(), std::io::Error>(())
//! ```
//!
//! [`Connection::messages`] does the same with decoded messages of a dialect, and
//! [`Connection::recv`] waits at most a given time. A [`SharedConnection`] is the same
//! connection for many threads and tasks at once: see [`shared`].

pub mod config;
pub mod flight;
pub mod ftp;
pub mod missionfile;
pub mod modes;
pub mod paramfile;
pub mod router;
pub mod services;
pub mod shared;
pub mod tlog;
pub mod vehicle;
pub mod wait;

use std::io;
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use ferrolink_runtime::mavlink::parser::ParsedFrame;
use ferrolink_runtime::mavlink::signing::SecretKey;
use ferrolink_runtime::mavlink::{
    v2, AnyFrame, Dialect, Header, Message, MessageMeta, UnknownMessageId, Version,
};

#[cfg(feature = "tokio")]
pub use crate::framed::Async;
pub use crate::framed::{Blocking, Events};
pub use crate::link::PeerId;
use crate::uri::{Form, Grammar, Scheme};
pub use shared::{
    Counts, Filter, OwnHeartbeat, Route, SharedConnection, Subscription, Tap, Unsigned,
};

/// Baud rate of a serial URI without one.
pub const DEFAULT_BAUD: u32 = 57_600;

/// The endpoint URIs MAVLink programs take (`Connection::open`, the router), on the one URI
/// grammar ([`uri`](crate::uri)):
///
/// | URI | endpoint |
/// |-----|----------|
/// | `udpin://HOST:PORT` | listen; every sender is a peer |
/// | `udpout://HOST:PORT[?replies=any]` | send there, read the replies (from anyone, with `?replies=any`) |
/// | `udpbcast://ADDR:PORT` | send to a broadcast address; every host that answers is a peer |
/// | `udpmcast://GROUP:PORT[?iface=NAME]` | join a multicast group and send to it; every host heard there is a peer |
/// | `tcpin://HOST:PORT` | TCP server; every client is a peer |
/// | `tcpout://HOST:PORT` | TCP client that reconnects |
/// | `serial://PATH[:BAUD]` | serial device, 8N1, 57600 baud unless named |
/// | `pty://NAME` | a pseudo-terminal linked at `NAME` |
///
/// The spellings of pymavlink and rust-mavlink are accepted as well, so a user can paste what
/// they know: `udpin:0.0.0.0:14550`, `udpout:HOST:PORT`, `udp:HOST:PORT` (= udpin),
/// `udpbcast:ADDR:PORT`, `mcast:` (= `udpmcast://239.255.145.50:14550`, ArduPilot's group) or
/// `mcast:GROUP:PORT`, `tcp:HOST:PORT` (= tcpout), `tcpin:HOST:PORT`,
/// `serial:/dev/ttyUSB0:57600`, a bare device path (`/dev/ttyACM0[,BAUD]` or `COM3`).
pub const ENDPOINTS: Grammar = Grammar {
    schemes: &[
        Scheme::new("udpin", Form::UdpIn),
        Scheme::new("udpout", Form::UdpOut),
        Scheme::new("udpbcast", Form::UdpBcast),
        Scheme::new("udpmcast", Form::UdpMcast { default: None }),
        Scheme::new("tcpin", Form::TcpIn { host: None }),
        Scheme::new("tcpout", Form::TcpOut { port: None }),
        Scheme::new("serial", Form::Serial { baud: DEFAULT_BAUD }),
        Scheme::new("pty", Form::Pty),
        Scheme::alias("udp", Form::UdpIn),
        Scheme::alias(
            "mcast",
            Form::UdpMcast {
                default: Some(("239.255.145.50", 14550)),
            },
        ),
        Scheme::alias("tcp", Form::TcpOut { port: None }),
    ],
    routes: false,
    loose: true,
    note: "pymavlink spellings (udpin:HOST:PORT, tcp:HOST:PORT, serial:PATH:BAUD) work too",
};

/// Microseconds since the Unix epoch, by the system clock.
pub fn unix_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
}

/// A received frame, owned (cloning it shares the bytes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    bytes: Arc<[u8]>,
    checked: bool,
    peer: PeerId,
}

impl Frame {
    /// `frame` as received from `peer`.
    pub(crate) fn new(frame: &ParsedFrame<'_>, peer: PeerId) -> Self {
        Frame {
            bytes: frame.as_bytes().into(),
            checked: frame.is_checked(),
            peer,
        }
    }

    fn view(&self) -> AnyFrame<&[u8]> {
        match AnyFrame::new_checked(&self.bytes[..]) {
            Ok(frame) => frame,
            // Only frames the parser accepted are stored, so their length is right.
            Err(_) => AnyFrame::V2(v2::Frame::new_unchecked(&[0; v2::MIN_FRAME_LEN][..])),
        }
    }

    /// The frame exactly as received, signature included.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// Sequence number and sender.
    pub fn header(&self) -> Header {
        self.view().header()
    }

    /// The message id.
    pub fn msg_id(&self) -> u32 {
        self.view().msg_id()
    }

    /// MAVLink 1 or 2.
    pub fn version(&self) -> Version {
        self.view().version()
    }

    /// Whether the checksum was verified (false for ids the table lacks).
    pub fn is_checked(&self) -> bool {
        self.checked
    }

    /// Whether it carries a MAVLink 2 signature.
    pub fn is_signed(&self) -> bool {
        self.view().is_signed()
    }

    /// The peer it came from, to answer it alone ([`SharedConnection::send_to`]).
    pub fn peer(&self) -> PeerId {
        self.peer
    }

    /// Decodes it as a message of dialect `D`.
    pub fn decode<D: Dialect>(&self) -> Result<D, UnknownMessageId> {
        self.view().decode()
    }
}

/// The async connection: [`Connection`] with `recv` and `recv_message` as `async fn`s.
#[cfg(feature = "tokio")]
pub type AsyncConnection = Connection<Async>;

/// A MAVLink connection on one endpoint URI (see [`crate::link`] for the forms), read by one
/// owner: blocking, or async as `AsyncConnection` (feature `tokio`). It is a
/// [`SharedConnection`] with one subscription to every frame; [`Connection::shared`] hands out
/// the shared connection, for senders on other threads and for more subscribers.
///
/// Frames are received from every peer of the endpoint (each with its own stream parser, so
/// interleaved peers never corrupt each other) and sent to every peer: on `udpin`, that is every
/// address heard from in the last 10 s. Sends use the connection's own system and component ids
/// and sequence numbers counting up, as MAVLink 2 (or 1) frames, signed if a key is set (and
/// then signed frames received are checked).
pub struct Connection<E = Blocking> {
    shared: SharedConnection,
    frames: Subscription,
    face: std::marker::PhantomData<fn() -> E>,
}

impl<E> std::fmt::Debug for Connection<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Connection")
            .field("shared", &self.shared)
            .finish_non_exhaustive()
    }
}

/// How many frames a [`Connection`] holds for its owner; past that it loses the newest,
/// counted in [`Connection::dropped`].
const CONNECTION_QUEUE: usize = 65_536;

impl<E> Connection<E> {
    fn start(uri: &str, table: Arc<[MessageMeta]>) -> io::Result<Self> {
        let shared = SharedConnection::open(uri, table)?;
        let frames = shared.subscribe(Filter::all().capacity(CONNECTION_QUEUE));
        Ok(Self {
            shared,
            frames,
            face: std::marker::PhantomData,
        })
    }

    /// The shared connection underneath: clone it into other threads to send, or subscribe
    /// to it.
    pub fn shared(&self) -> &SharedConnection {
        &self.shared
    }

    /// The bound local address, for `udpin`, `udpout` and `tcpin` URIs.
    pub fn local_addr(&self) -> Option<std::net::SocketAddr> {
        self.shared.local_addr()
    }

    /// The system and component ids frames are sent from (255/190, a ground station, by
    /// default).
    pub fn set_ids(&mut self, sysid: u8, compid: u8) {
        self.shared.set_ids(sysid, compid);
    }

    /// The system and component ids frames are sent from.
    pub fn ids(&self) -> (u8, u8) {
        self.shared.ids()
    }

    /// Send MAVLink 1 or 2 (the default) frames.
    pub fn set_version(&mut self, version: Version) {
        self.shared.set_version(version);
    }

    /// Signs every frame sent with `key` on `link_id`, with timestamps from the system clock,
    /// and checks signed frames received ([`SharedConnection::set_signing`]).
    pub fn set_signing(&mut self, key: SecretKey, link_id: u8) {
        self.shared.set_signing(key, link_id);
    }

    /// Hands out frames with ids the table lacks too, unchecked (off by default).
    pub fn set_pass_unknown_ids(&mut self, pass: bool) {
        self.shared.set_pass_unknown_ids(pass);
    }

    /// How many peers are connected now.
    pub fn peers(&self) -> usize {
        self.shared.peers()
    }

    /// How many frames were lost because the owner did not read them in time.
    pub fn dropped(&self) -> u64 {
        self.frames.dropped()
    }

    /// Nothing to do: frames are taken in as they arrive, on the endpoint's threads. Kept for
    /// programs that poll.
    pub fn poll(&mut self) {}

    /// Sends `message` to every peer, from this connection's ids, with the next sequence
    /// number. Fails if no peer is connected or every write failed.
    pub fn send<M: Message>(&mut self, message: &M) -> io::Result<()> {
        self.shared.send(message)
    }

    /// Sends any message of dialect `D`, as [`Connection::send`] does.
    pub fn send_dialect<D: Dialect>(&mut self, message: &D) -> io::Result<()> {
        self.shared.send_dialect(message)
    }

    /// Sends a payload (whole, not truncated) of message `id` with `crc_extra`.
    pub fn send_raw(&mut self, id: u32, crc_extra: u8, payload: &[u8]) -> io::Result<()> {
        self.shared.send_raw(id, crc_extra, payload)
    }
}

impl Connection<Blocking> {
    /// Opens `uri`, checking received frames against `table` (a dialect's `META`, or a table
    /// built at run time, shared with the connection's parsers). Sockets are bound before this
    /// returns; `tcpout` and `serial` connect in the background and keep reconnecting.
    pub fn open(uri: &str, table: impl Into<Arc<[MessageMeta]>>) -> io::Result<Self> {
        Self::start(uri, table.into())
    }

    /// Waits up to `timeout` for a frame. `Ok(None)` when none came in time.
    pub fn recv(&mut self, timeout: Duration) -> io::Result<Option<Frame>> {
        self.frames.recv(timeout)
    }

    /// Waits up to `timeout` for a message of dialect `D`, skipping frames `D` lacks.
    pub fn recv_message<D: Dialect>(
        &mut self,
        timeout: Duration,
    ) -> io::Result<Option<(Header, D)>> {
        let deadline = Instant::now() + timeout;
        while let Some(frame) = self.recv(deadline.saturating_duration_since(Instant::now()))? {
            if let Ok(message) = frame.decode::<D>() {
                return Ok(Some((frame.header(), message)));
            }
        }
        Ok(None)
    }

    /// Waits for the next frame, however long it takes. An error only when the connection
    /// stopped.
    pub fn recv_blocking(&mut self) -> io::Result<Frame> {
        self.frames.recv_blocking()
    }

    /// Every frame as it arrives: the iterator blocks for the next one, through quiet spells,
    /// and ends after the error that says the connection stopped.
    ///
    /// ```no_run
    /// # use ferrolink_io::mavlink::Connection;
    /// # let mut vehicle = Connection::open("udpin://0.0.0.0:14550", &[][..])?;
    /// for frame in vehicle.frames().take(10) {
    ///     println!("message {}", frame?.msg_id());
    /// }
    /// # Ok::<(), std::io::Error>(())
    /// ```
    pub fn frames(&mut self) -> Frames<'_> {
        Frames {
            connection: self,
            stopped: false,
        }
    }

    /// Every message of dialect `D` as it arrives, with its header; frames `D` lacks are
    /// skipped. Blocks as [`Connection::frames`] does.
    pub fn messages<D: Dialect>(&mut self) -> Messages<'_, D> {
        Messages {
            frames: self.frames(),
            dialect: std::marker::PhantomData,
        }
    }
}

/// The blocking iterator of [`Connection::frames`].
#[derive(Debug)]
pub struct Frames<'c> {
    connection: &'c mut Connection<Blocking>,
    stopped: bool,
}

impl Iterator for Frames<'_> {
    type Item = io::Result<Frame>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.stopped {
            return None;
        }
        let next = self.connection.recv_blocking();
        self.stopped = next.is_err();
        Some(next)
    }
}

/// The blocking iterator of [`Connection::messages`].
#[derive(Debug)]
pub struct Messages<'c, D> {
    frames: Frames<'c>,
    dialect: std::marker::PhantomData<fn() -> D>,
}

impl<D: Dialect> Iterator for Messages<'_, D> {
    type Item = io::Result<(Header, D)>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            match self.frames.next()? {
                Ok(frame) => {
                    if let Ok(message) = frame.decode::<D>() {
                        return Some(Ok((frame.header(), message)));
                    }
                }
                Err(e) => return Some(Err(e)),
            }
        }
    }
}

#[cfg(feature = "tokio")]
impl Connection<Async> {
    /// Opens `uri` for async use, as [`Connection::open`] does. Needs no particular runtime.
    pub fn connect(uri: &str, table: impl Into<Arc<[MessageMeta]>>) -> io::Result<Self> {
        Self::start(uri, table.into())
    }

    /// Waits for a frame (wrap it in a timeout as you need).
    pub async fn recv(&mut self) -> io::Result<Frame> {
        self.frames.recv_async().await
    }

    /// Waits for a message of dialect `D`, skipping frames `D` lacks.
    pub async fn recv_message<D: Dialect>(&mut self) -> io::Result<(Header, D)> {
        loop {
            let frame = self.recv().await?;
            if let Ok(message) = frame.decode::<D>() {
                return Ok((frame.header(), message));
            }
        }
    }
}
