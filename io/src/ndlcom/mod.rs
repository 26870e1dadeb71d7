//! NDLCom on PCs: the interface URIs of the C reference implementation, and the bridge program
//! ([`bridge`]).
//!
//! An NDLCom interface is named by a URI, in the forms the C reference takes, declared here as
//! [`ENDPOINTS`] on the one URI grammar ([`uri`](crate::uri)):
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
//! use ferrolink_io::{link::Endpoint, ndlcom::Interface};
//!
//! let interface: Interface = "udp://127.0.0.1&3,0x04".parse()?;
//! assert_eq!(interface.endpoint, Endpoint::Udp("127.0.0.1".into(), 34000, 34001));
//! assert_eq!(interface.routes, [3, 4]);
//! assert_eq!(interface.to_string(), "udp://127.0.0.1:34000:34001&3,4");
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

pub mod bridge;
mod ping;

use std::fmt;
use std::str::FromStr;

use crate::link::Endpoint;
use crate::uri::{Form, Grammar, Scheme, UriError};

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

/// The interface URIs NDLCom takes: the C reference's forms, each with a route list.
pub const ENDPOINTS: Grammar = Grammar {
    schemes: &[
        Scheme::new("serial", Form::Serial { baud: DEFAULT_BAUD }),
        Scheme::new(
            "udp",
            Form::UdpPair {
                in_port: DEFAULT_UDP_IN_PORT,
                out_port: DEFAULT_UDP_OUT_PORT,
            },
        ),
        Scheme::new(
            "tcp",
            Form::TcpOut {
                port: Some(DEFAULT_TCP_PORT),
            },
        ),
        Scheme::new(
            "tcp-listen",
            Form::TcpIn {
                host: Some(DEFAULT_LISTEN_HOST),
            },
        ),
        Scheme::new("pty", Form::Pty),
    ],
    routes: true,
    loose: false,
    note: "",
};

/// A parsed interface URI: the link it opens and the routes to pre-seed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Interface {
    /// The link-layer endpoint that opens this interface, every default filled in.
    pub endpoint: Endpoint,
    /// NDLCom device ids known to sit behind this interface, from the `&id,id,...` suffix.
    pub routes: Vec<u8>,
}

impl FromStr for Interface {
    type Err = UriError;

    fn from_str(uri: &str) -> Result<Self, UriError> {
        let (endpoint, routes) = ENDPOINTS.parse(uri)?;
        Ok(Interface { endpoint, routes })
    }
}

impl fmt::Display for Interface {
    /// The canonical URI with every default spelled out, routes in decimal; it parses back to
    /// the same value.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        ENDPOINTS.write(f, &self.endpoint, &self.routes)
    }
}
