//! Ferrolink on PCs: links, and the programs that run protocols over them.
//!
//! - [`mavlink`]: connections from URIs (blocking, or async with the `tokio` feature),
//!   telemetry logs, router configuration files and the router daemon, on top of [`peers`]:
//!   endpoints with any number of peers (each UDP sender, each TCP client), reconnecting TCP
//!   clients and serial devices that survive being unplugged.
//! - [`bridge`]: the NDLCom bridge program, on the links below.
//! - [`tosnet`] and [`modrob`]: TosNet rings and ModRob-1 networks, simulated and over UDP.
//!
//! The serial, pty and TCP primitives underneath are shared by both link kinds.
//!
//! # NDLCom links
//!
//! An NDLCom interface is named by a URI, the same forms the C reference implementation takes.
//! [`Endpoint`] parses one; [`Link::open`] opens it; [`Link::split`] hands out a reader and a
//! writer that can live on different threads. This crate only moves bytes: the NDLCom framing
//! (0x7E flags, escaping, CRC) and the routing are done by the caller.
//!
//! | URI | opens | defaults |
//! |-----|-------|----------|
//! | `serial://PATH[:BAUD]` | serial device, 8N1, no flow control, locked while open | baud 921600 |
//! | `udp://HOST[:IN_PORT][:OUT_PORT]` | UDP socket bound to `IN_PORT` on the unspecified address of `HOST`'s family, sending to `HOST:OUT_PORT` | in 34000, out 34001 |
//! | `tcp://HOST[:PORT]` | TCP client | port 34000 |
//! | `tcp-listen://[HOST]:PORT` | TCP server; the most recent client is the peer | host 0.0.0.0 |
//! | `pty://NAME` | pseudo-terminal in raw mode; a symlink at `NAME` points to its slave device | — |
//!
//! Any URI may end with `&ID,ID,...`: NDLCom device ids (decimal or `0x` hex) that sit behind
//! the interface, for the router to pre-seed ([`Endpoint::routes`]). Examples:
//! `serial:///dev/ttyUSB0:115200`, `udp://127.0.0.1:34000:34001&3,4`, `udp://[::1]:5000:5001`,
//! `tcp-listen://:34000`, `pty:///tmp/ndlcom0&0x10`.
//!
//! ```
//! use ferrolink_io::{Endpoint, Transport};
//!
//! let endpoint: Endpoint = "udp://127.0.0.1&3,0x04".parse()?;
//! assert_eq!(
//!     endpoint.transport,
//!     Transport::Udp { host: "127.0.0.1".into(), in_port: 34000, out_port: 34001 }
//! );
//! assert_eq!(endpoint.routes, [3, 4]);
//! assert_eq!(endpoint.to_string(), "udp://127.0.0.1:34000:34001&3,4");
//! // Then: let (reader, writer) = ferrolink_io::Link::open(&endpoint)?.split();
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Details per transport:
//! - **serial**: a trailing `:DIGITS` is the baud rate, any other `:` belongs to the path, so
//!   `/dev/serial/by-path/...:1.0-port0` works as is. The device is locked against other
//!   openers (they get "busy") while the link is open.
//! - **udp**: each [`LinkWriter::write_all`] is one datagram; each [`LinkReader::read`] returns
//!   one datagram (cut to the buffer: use a 64 KiB buffer to never lose bytes). Datagrams from
//!   any sender are accepted. An empty port field keeps the default: `udp://host::5001`.
//! - **tcp**: `TCP_NODELAY` is set. When the server closes the connection the reader returns
//!   [`io::ErrorKind::UnexpectedEof`]; the link is not reconnected.
//! - **tcp-listen**: connections are accepted in the background; a new client replaces (and
//!   disconnects) the previous one. Writes without a client fail with
//!   [`io::ErrorKind::NotConnected`]; reads wait for a client. A client leaving is not an error.
//! - **pty**: both ends of the pair stay open, so reads never fail because nobody is attached.
//!   Another program attaches through the symlink (`picocom NAME`, or `serial://NAME` in a
//!   second bridge). An existing symlink at `NAME` (left over from an earlier run) is replaced;
//!   any other file there is an error. The symlink is removed when both halves are dropped.
//!   Bytes written while nobody is attached queue up in the kernel (some KiB); once that is
//!   full, writes fail with [`io::ErrorKind::TimedOut`] after 100 ms.
//!
//! Writes on serial and TCP links give up with [`io::ErrorKind::TimedOut`] when the other side
//! does not drain the link for 1 s; a write that times out may have sent part of the bytes.

#![warn(missing_docs)]

use std::fmt;
use std::io;
use std::time::Duration;

pub mod bridge;
pub mod mavlink;
pub mod modrob;
pub mod peers;
mod serial;
mod tcp;
pub mod tosnet;
mod udp;
mod uri;

pub use uri::{
    Endpoint, Transport, UriError, DEFAULT_BAUD, DEFAULT_LISTEN_HOST, DEFAULT_TCP_PORT,
    DEFAULT_UDP_IN_PORT, DEFAULT_UDP_OUT_PORT,
};

/// How long a serial or TCP write may wait for the other side to drain the link.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(1);

/// How long a pty write may wait for an attached program to read.
pub const PTY_WRITE_TIMEOUT: Duration = Duration::from_millis(100);

/// The receiving half of a [`Link`].
pub trait LinkReader: Send {
    /// Blocks up to `timeout` for bytes; Ok(0) means "nothing arrived in time" (not EOF).
    /// A closed stream (TCP peer gone for a client link) is an Err(ErrorKind::UnexpectedEof).
    ///
    /// A zero `timeout` only takes what is already there; an empty `buf` returns Ok(0) at once.
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;
}

/// The sending half of a [`Link`].
pub trait LinkWriter: Send {
    /// Writes all of `bytes` (one datagram for UDP) or fails.
    ///
    /// Writing nothing succeeds without touching the link (no empty datagram is sent).
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()>;
}

/// An open link, split into halves that can move to different threads.
pub struct Link {
    name: String,
    reader: Box<dyn LinkReader>,
    writer: Box<dyn LinkWriter>,
}

impl Link {
    /// Opens the interface `endpoint` names. Errors name the URI.
    pub fn open(endpoint: &Endpoint) -> io::Result<Link> {
        let name = endpoint.to_string();
        let halves = match &endpoint.transport {
            Transport::Serial { path, baud } => serial::open_serial(path, *baud),
            Transport::Udp {
                host,
                in_port,
                out_port,
            } => udp::open(host, *in_port, *out_port),
            Transport::Tcp { host, port } => tcp::connect(host, *port),
            Transport::TcpListen { host, port } => tcp::listen(host, *port),
            Transport::Pty { name } => serial::open_pty(name),
        };
        let (reader, writer) =
            halves.map_err(|e| io::Error::new(e.kind(), format!("{name}: {e}")))?;
        Ok(Link {
            name,
            reader,
            writer,
        })
    }

    /// The canonical URI of the link (see [`Endpoint`]'s `Display`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Splits the link into its reader and writer. The underlying resources (device, socket,
    /// listener thread, pty symlink) are released when both halves are dropped.
    pub fn split(self) -> (Box<dyn LinkReader>, Box<dyn LinkWriter>) {
        (self.reader, self.writer)
    }
}

impl fmt::Debug for Link {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Link")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

/// The halves every transport module hands back.
type Halves = (Box<dyn LinkReader>, Box<dyn LinkWriter>);

/// Errors a reader reports as "nothing arrived in time".
fn is_timeout(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
    )
}

/// A socket read timeout: the sockets take no zero timeout, so "don't wait" becomes 1 µs.
fn socket_timeout(timeout: Duration) -> Duration {
    timeout.max(Duration::from_micros(1))
}

/// A write that ran into its timeout reports `TimedOut` (sockets say `WouldBlock`, which would
/// read as "try again").
fn write_error(e: io::Error) -> io::Error {
    if matches!(
        e.kind(),
        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
    ) {
        io::Error::new(
            io::ErrorKind::TimedOut,
            format!("write timed out, the other side is not reading: {e}"),
        )
    } else {
        e
    }
}

/// Resolves `host:port`, IPv4 addresses first: a peer listening on 0.0.0.0 is reachable on
/// 127.0.0.1 but not on ::1, so "localhost" should mean 127.0.0.1 when it can.
fn resolve(host: &str, port: u16) -> io::Result<Vec<std::net::SocketAddr>> {
    use std::net::ToSocketAddrs;
    let mut addrs: Vec<_> = (host, port).to_socket_addrs()?.collect();
    addrs.sort_by_key(|a| a.is_ipv6());
    if addrs.is_empty() {
        return Err(io::Error::new(
            io::ErrorKind::NotFound,
            format!("host {host:?} has no address"),
        ));
    }
    Ok(addrs)
}
