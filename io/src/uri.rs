//! NDLCom interface URIs: parsing ([`Interface::from_str`]), the canonical form
//! ([`fmt::Display`]) and the [`link`](crate::link) endpoint each one opens ([`Interface::link`]).
//!
//! An NDLCom interface is named by a URI, the same forms the C reference implementation takes.
//!
//! | URI | opens | defaults |
//! |-----|-------|----------|
//! | `serial://PATH[:BAUD]` | serial device, 8N1, no flow control, locked while open; reopened every second after it fails or is unplugged | baud 921600 |
//! | `udp://HOST[:IN_PORT][:OUT_PORT]` | UDP socket bound to `IN_PORT` on the unspecified address of `HOST`'s family, sending to `HOST:OUT_PORT`, reading datagrams from any sender | in 34000, out 34001 |
//! | `tcp://HOST[:PORT]` | TCP client that reconnects (backoff from 50 ms doubling to 1 s) | port 34000 |
//! | `tcp-listen://[HOST]:PORT` | TCP server; every client is an interface of its own | host 0.0.0.0 |
//! | `pty://NAME` | pseudo-terminal in raw mode; a symlink at `NAME` points to its slave device | — |
//!
//! Any URI may end with `&ID,ID,...`: NDLCom device ids (decimal or `0x` hex) that sit behind
//! the interface, for the router to pre-seed ([`Interface::routes`]). Examples:
//! `serial:///dev/ttyUSB0:115200`, `udp://127.0.0.1:34000:34001&3,4`, `udp://[::1]:5000:5001`,
//! `tcp-listen://:34000`, `pty:///tmp/ndlcom0&0x10`.
//!
//! ```
//! use ferrolink_io::{link, Interface, Transport};
//!
//! let interface: Interface = "udp://127.0.0.1&3,0x04".parse()?;
//! assert_eq!(
//!     interface.transport,
//!     Transport::Udp { host: "127.0.0.1".into(), in_port: 34000, out_port: 34001 }
//! );
//! assert_eq!(interface.routes, [3, 4]);
//! assert_eq!(interface.to_string(), "udp://127.0.0.1:34000:34001&3,4");
//! assert_eq!(interface.link(), link::Endpoint::Udp("127.0.0.1".into(), 34000, 34001));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Details per transport:
//! - **serial**: a trailing `:DIGITS` is the baud rate, any other `:` belongs to the path, so
//!   `/dev/serial/by-path/...:1.0-port0` works as is. The device is locked against other
//!   openers (they get "busy") while it is open.
//! - **udp**: each write is one datagram, each read one datagram. An empty port field keeps
//!   the default: `udp://host::5001`.
//! - **tcp** and **tcp-listen**: `TCP_NODELAY` is set; a client that does not read for 100 ms
//!   loses the write.
//! - **pty**: both ends of the pair stay open, so reads never fail because nobody is attached.
//!   Another program attaches through the symlink (`picocom NAME`, or `serial://NAME` in a
//!   second bridge). An existing symlink at `NAME` (left over from an earlier run) is replaced;
//!   any other file there is an error. The symlink is removed when the endpoint closes.

use std::fmt;
use std::str::FromStr;

/// Baud rate of `serial://` links that do not name one.
pub const DEFAULT_BAUD: u32 = 921_600;
/// Local port a `udp://` link binds when the URI does not name one.
pub const DEFAULT_UDP_IN_PORT: u16 = 34000;
/// Remote port a `udp://` link sends to when the URI does not name one.
pub const DEFAULT_UDP_OUT_PORT: u16 = 34001;
/// Port a `tcp://` client connects to when the URI does not name one.
pub const DEFAULT_TCP_PORT: u16 = 34000;
/// Address a `tcp-listen://` link listens on when the URI does not name one.
pub const DEFAULT_LISTEN_HOST: &str = "0.0.0.0";

/// The accepted URI forms, appended to every parse error.
const FORMS: &str = "accepted forms: serial://PATH[:BAUD], udp://HOST[:IN_PORT][:OUT_PORT], \
                     tcp://HOST[:PORT], tcp-listen://[HOST]:PORT, pty://NAME; \
                     each may end with &ID,ID,... (route ids, decimal or 0x-hex)";

/// A parsed interface URI plus the routes to pre-seed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Interface {
    /// How the link is opened.
    pub transport: Transport,
    /// NDLCom device ids known to sit behind this interface, from the `&id,id,...` suffix.
    pub routes: Vec<u8>,
}

/// The transport part of an interface URI, with every default filled in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Transport {
    /// `serial://PATH[:BAUD]`: a serial device, 8N1, no flow control.
    Serial {
        /// Device path, e.g. `/dev/ttyUSB0`.
        path: String,
        /// Baud rate.
        baud: u32,
    },
    /// `udp://HOST[:IN_PORT][:OUT_PORT]`: datagrams received on local `in_port`, sent to
    /// `host:out_port`.
    Udp {
        /// Peer host name or address (IPv6 without brackets).
        host: String,
        /// Local port to bind.
        in_port: u16,
        /// Peer port to send to.
        out_port: u16,
    },
    /// `tcp://HOST[:PORT]`: a TCP client that reconnects.
    Tcp {
        /// Server host name or address (IPv6 without brackets).
        host: String,
        /// Server port.
        port: u16,
    },
    /// `tcp-listen://[HOST]:PORT`: a TCP server; every client is an interface of its own.
    TcpListen {
        /// Local address to listen on (IPv6 without brackets).
        host: String,
        /// Local port to listen on.
        port: u16,
    },
    /// `pty://NAME`: a pseudo-terminal whose slave device is linked at path `name`.
    Pty {
        /// Where to create the symlink to the slave device.
        name: String,
    },
}

/// Why an interface URI did not parse. The message names the offending part and the URI, and
/// the [`Display`](fmt::Display) form adds a hint listing the accepted forms.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UriError {
    message: String,
}

impl UriError {
    fn new(message: impl Into<String>) -> Self {
        UriError {
            message: message.into(),
        }
    }

    /// The message without the hint.
    pub fn message(&self) -> &str {
        &self.message
    }
}

impl fmt::Display for UriError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}\n  hint: {FORMS}", self.message)
    }
}

impl std::error::Error for UriError {}

impl FromStr for Interface {
    type Err = UriError;

    fn from_str(uri: &str) -> Result<Self, UriError> {
        let (body, routes) = match uri.split_once('&') {
            Some((body, list)) => (body, parse_routes(uri, list)?),
            None => (uri, Vec::new()),
        };
        let Some((scheme, rest)) = body.split_once("://") else {
            return Err(UriError::new(format!(
                "missing scheme in {uri:?}: expected SCHEME://..."
            )));
        };
        let transport = match scheme {
            "serial" => parse_serial(uri, rest)?,
            "udp" => {
                let (host, ports) = split_host(uri, rest)?;
                let host = require_host(uri, host)?;
                if ports.len() > 2 {
                    return Err(too_many(uri, "udp://HOST[:IN_PORT][:OUT_PORT]"));
                }
                Transport::Udp {
                    host,
                    in_port: port_or(uri, ports.first(), DEFAULT_UDP_IN_PORT)?,
                    out_port: port_or(uri, ports.get(1), DEFAULT_UDP_OUT_PORT)?,
                }
            }
            "tcp" => {
                let (host, ports) = split_host(uri, rest)?;
                let host = require_host(uri, host)?;
                if ports.len() > 1 {
                    return Err(too_many(uri, "tcp://HOST[:PORT]"));
                }
                Transport::Tcp {
                    host,
                    port: port_or(uri, ports.first(), DEFAULT_TCP_PORT)?,
                }
            }
            "tcp-listen" => {
                let (host, ports) = split_host(uri, rest)?;
                if ports.len() > 1 {
                    return Err(too_many(uri, "tcp-listen://[HOST]:PORT"));
                }
                let Some(port) = ports.first().filter(|p| !p.is_empty()) else {
                    let example = if !host.is_empty() && host.bytes().all(|b| b.is_ascii_digit()) {
                        format!(" (to listen on all interfaces write tcp-listen://:{host})")
                    } else {
                        String::new()
                    };
                    return Err(UriError::new(format!("missing port in {uri}{example}")));
                };
                Transport::TcpListen {
                    host: if host.is_empty() {
                        DEFAULT_LISTEN_HOST.to_owned()
                    } else {
                        host.to_owned()
                    },
                    port: parse_port(uri, port)?,
                }
            }
            "pty" => {
                if rest.is_empty() {
                    return Err(UriError::new(format!("missing pty name in {uri}")));
                }
                Transport::Pty {
                    name: rest.to_owned(),
                }
            }
            _ => {
                return Err(UriError::new(format!(
                "unknown scheme {scheme:?} in {uri}: expected serial, udp, tcp, tcp-listen or pty"
            )))
            }
        };
        Ok(Interface { transport, routes })
    }
}

/// `serial://PATH[:BAUD]`: a trailing `:DIGITS` is the baud rate, anything else is part of
/// the path (so `/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0-port0` needs no escaping).
fn parse_serial(uri: &str, rest: &str) -> Result<Transport, UriError> {
    let (path, baud) = match rest.rsplit_once(':') {
        Some((path, baud)) if !baud.is_empty() && baud.bytes().all(|b| b.is_ascii_digit()) => {
            let baud = baud.parse::<u32>().ok().filter(|&b| b > 0).ok_or_else(|| {
                UriError::new(format!(
                    "bad baud rate {baud:?} in {uri}: expected 1..={}",
                    u32::MAX
                ))
            })?;
            (path, baud)
        }
        _ => (rest, DEFAULT_BAUD),
    };
    if path.is_empty() {
        return Err(UriError::new(format!("missing device path in {uri}")));
    }
    Ok(Transport::Serial {
        path: path.to_owned(),
        baud,
    })
}

/// Splits `HOST[:A][:B]...` into the host and the `:`-separated fields after it. An IPv6
/// host is written in brackets: `[::1]:5000`.
fn split_host<'a>(uri: &str, rest: &'a str) -> Result<(&'a str, Vec<&'a str>), UriError> {
    let (host, tail) = if let Some(bracketed) = rest.strip_prefix('[') {
        let Some((host, tail)) = bracketed.split_once(']') else {
            return Err(UriError::new(format!(
                "missing ']' after IPv6 host in {uri}"
            )));
        };
        if host.is_empty() {
            return Err(UriError::new(format!("empty IPv6 host \"[]\" in {uri}")));
        }
        if !tail.is_empty() && !tail.starts_with(':') {
            return Err(UriError::new(format!(
                "unexpected {tail:?} after ']' in {uri}: expected :PORT"
            )));
        }
        (host, tail)
    } else {
        match rest.find(':') {
            Some(colon) => rest.split_at(colon),
            None => (rest, ""),
        }
    };
    if let Some(bad) = host
        .chars()
        .find(|c| c.is_whitespace() || "/[]".contains(*c))
    {
        return Err(UriError::new(format!(
            "bad host {host:?} in {uri}: {bad:?} is not allowed in a host name"
        )));
    }
    let fields = match tail.strip_prefix(':') {
        Some(fields) => fields.split(':').collect(),
        None => Vec::new(),
    };
    Ok((host, fields))
}

fn require_host(uri: &str, host: &str) -> Result<String, UriError> {
    if host.is_empty() {
        let ipv6 = if uri.contains("::") {
            " (write IPv6 addresses in brackets, e.g. [::1])"
        } else {
            ""
        };
        return Err(UriError::new(format!("missing host in {uri}{ipv6}")));
    }
    Ok(host.to_owned())
}

fn too_many(uri: &str, form: &str) -> UriError {
    UriError::new(format!("too many ':' fields in {uri}: expected {form}"))
}

/// An optional port field: absent or empty means `default`.
fn port_or(uri: &str, field: Option<&&str>, default: u16) -> Result<u16, UriError> {
    match field {
        Some(field) if !field.is_empty() => parse_port(uri, field),
        _ => Ok(default),
    }
}

fn parse_port(uri: &str, field: &str) -> Result<u16, UriError> {
    // `u16::from_str` accepts a leading '+'; a port is plain digits.
    field
        .bytes()
        .all(|b| b.is_ascii_digit())
        .then(|| field.parse::<u16>().ok())
        .flatten()
        .ok_or_else(|| {
            UriError::new(format!(
                "bad port {field:?} in {uri}: expected 0..={}",
                u16::MAX
            ))
        })
}

/// `ID,ID,...` after the `&`: decimal or `0x`-prefixed hex device ids.
fn parse_routes(uri: &str, list: &str) -> Result<Vec<u8>, UriError> {
    if list.trim().is_empty() {
        return Err(UriError::new(format!(
            "empty route list after '&' in {uri}: expected &ID,ID,..."
        )));
    }
    list.split(',')
        .map(|field| {
            let id = field.trim();
            let parsed = match id.strip_prefix("0x").or_else(|| id.strip_prefix("0X")) {
                Some(hex) if hex.bytes().all(|b| b.is_ascii_hexdigit()) => {
                    u8::from_str_radix(hex, 16).ok()
                }
                Some(_) => None,
                None if id.bytes().all(|b| b.is_ascii_digit()) => id.parse().ok(),
                None => None,
            };
            parsed.ok_or_else(|| {
                UriError::new(format!(
                    "bad route id {id:?} in {uri}: expected 0..=255 (decimal) or 0x00..=0xff"
                ))
            })
        })
        .collect()
}

/// Writes `host` so that it parses back: IPv6 addresses go in brackets.
fn write_host(f: &mut fmt::Formatter<'_>, host: &str) -> fmt::Result {
    if host.contains(':') {
        write!(f, "[{host}]")
    } else {
        f.write_str(host)
    }
}

impl fmt::Display for Transport {
    /// The canonical URI with every default spelled out.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Transport::Serial { path, baud } => write!(f, "serial://{path}:{baud}"),
            Transport::Udp {
                host,
                in_port,
                out_port,
            } => {
                f.write_str("udp://")?;
                write_host(f, host)?;
                write!(f, ":{in_port}:{out_port}")
            }
            Transport::Tcp { host, port } => {
                f.write_str("tcp://")?;
                write_host(f, host)?;
                write!(f, ":{port}")
            }
            Transport::TcpListen { host, port } => {
                f.write_str("tcp-listen://")?;
                write_host(f, host)?;
                write!(f, ":{port}")
            }
            Transport::Pty { name } => write!(f, "pty://{name}"),
        }
    }
}

impl Interface {
    /// The link-layer endpoint that opens this interface.
    pub fn link(&self) -> crate::link::Endpoint {
        use crate::link::Endpoint;
        match &self.transport {
            Transport::Serial { path, baud } => Endpoint::Serial(path.clone(), *baud),
            Transport::Udp {
                host,
                in_port,
                out_port,
            } => Endpoint::Udp(host.clone(), *in_port, *out_port),
            Transport::Tcp { host, port } => Endpoint::TcpOut(host.clone(), *port),
            Transport::TcpListen { host, port } => Endpoint::TcpIn(host.clone(), *port),
            Transport::Pty { name } => Endpoint::Pty(name.clone()),
        }
    }
}

impl fmt::Display for Interface {
    /// The canonical URI with every default spelled out, routes in decimal; it parses back to
    /// the same value.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.transport)?;
        for (i, id) in self.routes.iter().enumerate() {
            write!(f, "{}{id}", if i == 0 { '&' } else { ',' })?;
        }
        Ok(())
    }
}
