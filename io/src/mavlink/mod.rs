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
//! [`Connection::recv`] waits at most a given time.

pub mod config;
pub mod ftp;
pub mod missionfile;
pub mod paramfile;
pub mod router;
pub mod services;
pub mod tlog;
pub mod vehicle;

use std::collections::VecDeque;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use ferrolink_runtime::mavlink::parser::{ParsedFrame, Parser};
use ferrolink_runtime::mavlink::signing::{timestamp_from_unix_micros, SecretKey, Signer};
use ferrolink_runtime::mavlink::{
    find_meta, v1, v2, AnyFrame, Dialect, Header, Message, MessageMeta, UnknownMessageId, Version,
};

#[cfg(feature = "tokio")]
pub use crate::framed::Async;
use crate::framed::Framed;
pub use crate::framed::{Blocking, Events};
use crate::uri::{Form, Grammar, Scheme};

/// Baud rate of a serial URI without one.
pub const DEFAULT_BAUD: u32 = 57_600;

/// The endpoint URIs MAVLink programs take (`Connection::open`, the router), on the one URI
/// grammar ([`uri`](crate::uri)):
///
/// | URI | endpoint |
/// |-----|----------|
/// | `udpin://HOST:PORT` | listen; every sender is a peer |
/// | `udpout://HOST:PORT` | send there, read the replies |
/// | `tcpin://HOST:PORT` | TCP server; every client is a peer |
/// | `tcpout://HOST:PORT` | TCP client that reconnects |
/// | `serial://PATH[:BAUD]` | serial device, 8N1, 57600 baud unless named |
/// | `pty://NAME` | a pseudo-terminal linked at `NAME` |
///
/// The spellings of pymavlink and rust-mavlink are accepted as well, so a user can paste what
/// they know: `udpin:0.0.0.0:14550`, `udpout:HOST:PORT`, `udp:HOST:PORT` (= udpin),
/// `udpbcast:HOST:PORT` (= udpout), `tcp:HOST:PORT` (= tcpout), `tcpin:HOST:PORT`,
/// `serial:/dev/ttyUSB0:57600`, a bare device path (`/dev/ttyACM0[,BAUD]` or `COM3`).
pub const ENDPOINTS: Grammar = Grammar {
    schemes: &[
        Scheme::new("udpin", Form::UdpIn),
        Scheme::new("udpout", Form::UdpOut),
        Scheme::new("tcpin", Form::TcpIn { host: None }),
        Scheme::new("tcpout", Form::TcpOut { port: None }),
        Scheme::new("serial", Form::Serial { baud: DEFAULT_BAUD }),
        Scheme::new("pty", Form::Pty),
        Scheme::alias("udp", Form::UdpIn),
        Scheme::alias("udpbcast", Form::UdpOut),
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

/// A received frame, owned.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    bytes: Vec<u8>,
    checked: bool,
}

impl Frame {
    fn view(&self) -> AnyFrame<&[u8]> {
        match AnyFrame::new_checked(self.bytes.as_slice()) {
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

    /// Decodes it as a message of dialect `D`.
    pub fn decode<D: Dialect>(&self) -> Result<D, UnknownMessageId> {
        self.view().decode()
    }
}

impl From<&ParsedFrame<'_>> for Frame {
    fn from(frame: &ParsedFrame<'_>) -> Self {
        Frame {
            bytes: frame.as_bytes().to_vec(),
            checked: frame.is_checked(),
        }
    }
}

/// The async connection: [`Connection`] with `recv` and `recv_message` as `async fn`s.
#[cfg(feature = "tokio")]
pub type AsyncConnection = Connection<Async>;

/// A MAVLink connection on one endpoint URI (see [`crate::link`] for the forms): blocking, or
/// async as `AsyncConnection` (feature `tokio`).
///
/// Frames are received from every peer of the endpoint (each with its own stream parser, so
/// interleaved peers never corrupt each other) and sent to every peer: on `udpin`, that is every
/// address heard from in the last 10 s. Sends use the connection's own system and component ids
/// and sequence numbers counting up, as MAVLink 2 (or 1) frames, signed if a key is set.
pub struct Connection<E = Blocking> {
    framed: Framed<Parser<{ v2::MAX_FRAME_LEN }, Arc<[MessageMeta]>>, E>,
    table: Arc<[MessageMeta]>,
    /// Read by the parsers of peers yet to come.
    pass_unknown: Arc<AtomicBool>,
    queue: VecDeque<Frame>,
    sysid: u8,
    compid: u8,
    seq: u8,
    version: Version,
    signer: Option<Signer>,
}

impl<E> std::fmt::Debug for Connection<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Connection")
            .field("framed", &self.framed)
            .field("sysid", &self.sysid)
            .field("compid", &self.compid)
            .finish_non_exhaustive()
    }
}

impl<E: Events> Connection<E> {
    fn start(uri: &str, table: Arc<[MessageMeta]>) -> io::Result<Self> {
        let endpoint = ENDPOINTS
            .endpoint(uri)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        let pass_unknown = Arc::new(AtomicBool::new(false));
        let (pass, shared) = (pass_unknown.clone(), table.clone());
        let framed = Framed::open(&endpoint, move || {
            Parser::new(shared.clone()).pass_unknown_ids(pass.load(Ordering::Relaxed))
        })?;
        Ok(Self {
            framed,
            table,
            pass_unknown,
            queue: VecDeque::new(),
            sysid: 255,
            compid: 190,
            seq: 0,
            version: Version::V2,
            signer: None,
        })
    }

    /// The bound local address, for `udpin`, `udpout` and `tcpin` URIs.
    pub fn local_addr(&self) -> Option<std::net::SocketAddr> {
        self.framed.local_addr()
    }

    /// The system and component ids frames are sent from (255/190, a ground station, by
    /// default).
    pub fn set_ids(&mut self, sysid: u8, compid: u8) {
        (self.sysid, self.compid) = (sysid, compid);
    }

    /// Send MAVLink 1 or 2 (the default) frames.
    pub fn set_version(&mut self, version: Version) {
        self.version = version;
    }

    /// Signs every frame sent with `key` on `link_id`, with timestamps from the system clock.
    pub fn set_signing(&mut self, key: SecretKey, link_id: u8) {
        self.signer = Some(Signer::new(key, link_id));
    }

    /// Hands out frames with ids the table lacks too, unchecked (off by default).
    pub fn set_pass_unknown_ids(&mut self, pass: bool) {
        self.pass_unknown.store(pass, Ordering::Relaxed);
        for parser in self.framed.deframers_mut() {
            parser.set_pass_unknown_ids(pass);
        }
    }

    /// How many peers are connected now.
    pub fn peers(&self) -> usize {
        self.framed.peers()
    }

    /// Takes in what arrived without waiting (peers appearing and going too).
    pub fn poll(&mut self) {
        let queue = &mut self.queue;
        // A stopped endpoint shows at the next `recv`.
        let _ = self
            .framed
            .poll(|_, frame| queue.push_back(Frame::from(&frame)));
    }

    /// Sends `message` to every peer, from this connection's ids, with the next sequence
    /// number. Fails if no peer is connected or every write failed.
    pub fn send<M: Message>(&mut self, message: &M) -> io::Result<()> {
        let mut payload = [0u8; ferrolink_runtime::mavlink::MAX_PAYLOAD_LEN];
        let len = message.encode(&mut payload);
        self.send_raw(M::ID, M::CRC_EXTRA, &payload[..len])
    }

    /// Sends any message of dialect `D`, as [`Connection::send`] does.
    pub fn send_dialect<D: Dialect>(&mut self, message: &D) -> io::Result<()> {
        let mut payload = [0u8; ferrolink_runtime::mavlink::MAX_PAYLOAD_LEN];
        let len = message.encode(&mut payload);
        let meta = message.meta();
        self.send_raw(meta.id, meta.crc_extra, &payload[..len])
    }

    /// Sends a payload (whole, not truncated) of message `id` with `crc_extra`.
    pub fn send_raw(&mut self, id: u32, crc_extra: u8, payload: &[u8]) -> io::Result<()> {
        self.poll();
        let header = Header::new(self.seq, self.sysid, self.compid);
        let mut out = [0u8; v2::MAX_FRAME_LEN];
        let encoded = match (self.version, &mut self.signer) {
            (Version::V1, _) => {
                let min =
                    find_meta(&self.table, id).map_or(payload.len(), |m| usize::from(m.min_len));
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
        self.seq = self.seq.wrapping_add(1);
        self.framed.send(&out[..n])
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
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(frame) = self.queue.pop_front() {
                return Ok(Some(frame));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            let queue = &mut self.queue;
            if !self
                .framed
                .wait(Some(left), |_, frame| queue.push_back(Frame::from(&frame)))?
            {
                return Ok(None);
            }
        }
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
        loop {
            if let Some(frame) = self.queue.pop_front() {
                return Ok(frame);
            }
            let queue = &mut self.queue;
            self.framed
                .wait(None, |_, frame| queue.push_back(Frame::from(&frame)))?;
        }
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
        loop {
            if let Some(frame) = self.queue.pop_front() {
                return Ok(frame);
            }
            let queue = &mut self.queue;
            self.framed
                .next(|_, frame| queue.push_back(Frame::from(&frame)))
                .await?;
        }
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
