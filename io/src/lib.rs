//! Ferrolink on PCs: links, and the programs that run protocols over them.
//!
//! - [`mavlink`]: connections from URIs (blocking, or async with the `tokio` feature),
//!   telemetry logs, router configuration files and the router daemon.
//! - [`ndlcom`]: the NDLCom bridge program; every TCP client of an interface is an interface of
//!   its own.
//! - [`tosnet`] and [`modrob`]: TosNet rings and ModRob-1 networks, simulated and over UDP.
//!
//! All of them open their sockets, devices and pseudo-terminals through one link layer,
//! [`link`], named by URIs of one grammar, [`uri`], in which each protocol declares its
//! schemes and defaults (NDLCom keeps the forms of its C reference implementation), and read
//! frames through one loop, [`framed`], over any protocol's stream parser.

#![warn(missing_docs)]

use std::io;
use std::time::Duration;

pub mod framed;
pub mod link;
pub mod mavlink;
pub mod modrob;
pub mod ndlcom;
pub mod printer;
pub mod seconds;
mod serial;
mod tcp;
pub mod tosnet;
pub mod uri;

/// How long a write to a TCP peer, a serial device or a pty may block before it is given up, so
/// that one stalled peer cannot hold up a router or bridge.
const WRITE_TIMEOUT: Duration = Duration::from_millis(100);

/// The receiving half of a stream (serial device, pty, TCP connection).
trait LinkReader: Send {
    /// Blocks up to `timeout` for bytes; Ok(0) means "nothing arrived in time" (not EOF).
    /// A closed stream is an Err(ErrorKind::UnexpectedEof).
    ///
    /// A zero `timeout` only takes what is already there; an empty `buf` returns Ok(0) at once.
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;

    /// Whether a blocked read returns at its endpoint's stop (a socket's, which the stop shuts
    /// down; a device's that waits on the stop's bell too), so that it need not look up now and
    /// then to notice it.
    fn woken_at_stop(&self) -> bool {
        false
    }
}

/// The sending half of a stream.
trait LinkWriter: Send {
    /// Writes some of `bytes`, waiting up to [`WRITE_TIMEOUT`] for the other side to take them;
    /// Ok(0) means it took nothing in that time.
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize>;

    /// Writes all of `bytes`, or fails once the other side took nothing for [`WRITE_TIMEOUT`].
    fn write_all(&mut self, mut bytes: &[u8]) -> io::Result<()> {
        while !bytes.is_empty() {
            let n = match self.write(bytes) {
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                other => other?,
            };
            match n {
                0 => {
                    return Err(io::Error::new(
                        io::ErrorKind::TimedOut,
                        "write timed out, the other side is not reading",
                    ))
                }
                n => bytes = &bytes[n..],
            }
        }
        Ok(())
    }

    /// Ends a connection that can be ended (a TCP client; its reader then sees the end and the
    /// peer goes down); `false` for a device, which stays.
    fn close(&mut self) -> bool {
        false
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

/// A write that ran into its timeout wrote nothing (sockets say `WouldBlock`, devices
/// `TimedOut`).
fn written(result: io::Result<usize>) -> io::Result<usize> {
    match result {
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
            ) =>
        {
            Ok(0)
        }
        other => other,
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
