//! The one URI grammar of every link, for every protocol.
//!
//! A protocol declares the endpoints it accepts as a [`Grammar`]: its schemes, each with a
//! [`Form`] and that protocol's defaults (a serial speed, default ports), whether an
//! `&ID,ID,...` route list may follow, and whether the pymavlink spellings without `//` are
//! accepted. [`mavlink::ENDPOINTS`](crate::mavlink::ENDPOINTS) and
//! [`ndlcom::ENDPOINTS`](crate::ndlcom::ENDPOINTS) are the two in this crate. Parsing gives a
//! link-layer [`Endpoint`]; writing an endpoint back gives the protocol's canonical spelling,
//! which parses to the same endpoint.
//!
//! A crate that provides a link of its own registers its scheme as an [`Extension`] (the Zenoh
//! crate's `zenoh://` is one): [`Grammar::parse_with`] hands such URIs to it, and its forms join
//! the hint of every error.
//!
//! Every error is a [`UriError`]: what is wrong, where in the URI (a byte offset, shown with a
//! caret), and a hint listing the accepted forms.
//!
//! ```
//! use ferrolink_io::{link::Endpoint, mavlink, ndlcom};
//!
//! // The same scheme means what each protocol's users expect.
//! assert_eq!(mavlink::ENDPOINTS.endpoint("udp:0.0.0.0:14550")?, Endpoint::UdpIn("0.0.0.0".into(), 14550));
//! let (endpoint, routes) = ndlcom::ENDPOINTS.parse("udp://robot&3")?;
//! assert_eq!(endpoint, Endpoint::Udp("robot".into(), 34000, 34001));
//! assert_eq!(routes, [3]);
//!
//! let err = ndlcom::ENDPOINTS.parse("udp://robot:x").unwrap_err();
//! assert_eq!((err.message(), err.at()), ("bad port \"x\": expected 0..=65535", 12));
//! # Ok::<(), ferrolink_io::uri::UriError>(())
//! ```

use std::fmt;

use crate::link::Endpoint;

/// Why a URI did not parse: a message, the byte offset in the URI it is about, and a hint.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UriError {
    uri: String,
    at: usize,
    message: String,
    hint: String,
}

impl UriError {
    /// An error about the part of `uri` that starts at byte `at`.
    pub fn new(uri: &str, at: usize, message: impl Into<String>) -> Self {
        UriError {
            uri: uri.to_owned(),
            at: at.min(uri.len()),
            message: message.into(),
            hint: String::new(),
        }
    }

    /// An error about `part`, a slice of `uri`.
    pub fn at_part(uri: &str, part: &str, message: impl Into<String>) -> Self {
        UriError::new(uri, offset(uri, part), message)
    }

    /// The same error with a hint (kept if it already has one).
    pub fn with_hint(mut self, hint: impl Into<String>) -> Self {
        if self.hint.is_empty() {
            self.hint = hint.into();
        }
        self
    }

    /// What is wrong, without the URI or the hint.
    pub fn message(&self) -> &str {
        &self.message
    }

    /// The byte offset in the URI of the part the message is about.
    pub fn at(&self) -> usize {
        self.at
    }

    /// The URI.
    pub fn uri(&self) -> &str {
        &self.uri
    }

    /// The accepted forms.
    pub fn hint(&self) -> &str {
        &self.hint
    }
}

impl fmt::Display for UriError {
    /// The message, the URI with a caret under the offending part, and the hint.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let column = self.uri.get(..self.at).map_or(0, |s| s.chars().count());
        write!(
            f,
            "{}\n  {}\n  {:column$}^",
            self.message,
            self.uri.escape_debug(),
            ""
        )?;
        if !self.hint.is_empty() {
            write!(f, "\n  hint: {}", self.hint)?;
        }
        Ok(())
    }
}

impl std::error::Error for UriError {}

/// The byte offset of `part` in `whole`, for a `part` sliced from `whole` (0 otherwise).
pub fn offset(whole: &str, part: &str) -> usize {
    let (start, at) = (whole.as_ptr() as usize, part.as_ptr() as usize);
    if (start..=start + whole.len()).contains(&at) {
        at - start
    } else {
        0
    }
}

/// What follows `SCHEME://`, and the protocol's defaults for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// `HOST:PORT`, bound; every sender is a peer ([`Endpoint::UdpIn`]).
    UdpIn,
    /// `HOST:PORT[?replies=any]`, sent to from an ephemeral port ([`Endpoint::UdpOut`], or
    /// with `?replies=any`, [`Endpoint::UdpOutAny`]).
    UdpOut,
    /// `ADDR:PORT`, a broadcast address sent to from an ephemeral port
    /// ([`Endpoint::UdpBcast`]).
    UdpBcast,
    /// `GROUP:PORT[?iface=NAME]`, a multicast group ([`Endpoint::UdpMcast`]); with a default
    /// group and port, the whole `GROUP:PORT` may be left out.
    UdpMcast {
        /// The group and port when none is given.
        default: Option<(&'static str, u16)>,
    },
    /// `HOST[:IN_PORT][:OUT_PORT]`: bind `IN_PORT`, send to `HOST:OUT_PORT`
    /// ([`Endpoint::Udp`]).
    UdpPair {
        /// `IN_PORT` when not given.
        in_port: u16,
        /// `OUT_PORT` when not given.
        out_port: u16,
    },
    /// `HOST:PORT`, or `[HOST]:PORT` with a default host: a TCP server ([`Endpoint::TcpIn`]).
    TcpIn {
        /// The host when not given; `None` makes it required.
        host: Option<&'static str>,
    },
    /// `HOST:PORT`, or `HOST[:PORT]` with a default port: a TCP client ([`Endpoint::TcpOut`]).
    TcpOut {
        /// The port when not given; `None` makes it required.
        port: Option<u16>,
    },
    /// `PATH[:BAUD]`: a serial device ([`Endpoint::Serial`]). A trailing `:DIGITS` is the
    /// speed, any other `:` belongs to the path.
    Serial {
        /// The speed when not given.
        baud: u32,
    },
    /// `NAME`: a pseudo-terminal linked at `NAME` ([`Endpoint::Pty`]).
    Pty,
}

impl Form {
    fn usage(self) -> &'static str {
        match self {
            Form::UdpIn | Form::TcpIn { host: None } | Form::TcpOut { port: None } => "HOST:PORT",
            Form::UdpOut => "HOST:PORT[?replies=any]",
            Form::UdpBcast => "ADDR:PORT",
            Form::UdpMcast { .. } => "GROUP:PORT[?iface=NAME]",
            Form::UdpPair { .. } => "HOST[:IN_PORT][:OUT_PORT]",
            Form::TcpIn { host: Some(_) } => "[HOST]:PORT",
            Form::TcpOut { port: Some(_) } => "HOST[:PORT]",
            Form::Serial { .. } => "PATH[:BAUD]",
            Form::Pty => "NAME",
        }
    }

    /// Whether `endpoint` is of this form.
    fn opens(self, endpoint: &Endpoint) -> bool {
        matches!(
            (self, endpoint),
            (Form::UdpIn, Endpoint::UdpIn(..))
                | (Form::UdpOut, Endpoint::UdpOut(..) | Endpoint::UdpOutAny(..))
                | (Form::UdpBcast, Endpoint::UdpBcast(..))
                | (Form::UdpMcast { .. }, Endpoint::UdpMcast(..))
                | (Form::UdpPair { .. }, Endpoint::Udp(..))
                | (Form::TcpIn { .. }, Endpoint::TcpIn(..))
                | (Form::TcpOut { .. }, Endpoint::TcpOut(..))
                | (Form::Serial { .. }, Endpoint::Serial(..))
                | (Form::Pty, Endpoint::Pty(..))
        )
    }
}

/// One scheme of a [`Grammar`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scheme {
    /// The name before `://`.
    pub name: &'static str,
    /// What follows it.
    pub form: Form,
    /// Another spelling of an earlier scheme: accepted, but neither listed in hints nor written.
    pub alias: bool,
}

impl Scheme {
    /// A scheme that is listed and written.
    pub const fn new(name: &'static str, form: Form) -> Self {
        Scheme {
            name,
            form,
            alias: false,
        }
    }

    /// Another spelling of an earlier scheme.
    pub const fn alias(name: &'static str, form: Form) -> Self {
        Scheme {
            name,
            form,
            alias: true,
        }
    }
}

/// The endpoint URIs a protocol accepts.
#[derive(Debug, Clone, Copy)]
pub struct Grammar {
    /// The schemes, canonical ones first.
    pub schemes: &'static [Scheme],
    /// Whether `&ID,ID,...` (ids, decimal or `0x` hex) may follow.
    pub routes: bool,
    /// Whether `SCHEME:REST` (no `//`) and a bare device path (`/dev/ttyACM0[,BAUD]`, `COM3`)
    /// are accepted, as pymavlink and rust-mavlink users write them.
    pub loose: bool,
    /// Said after the forms in every hint.
    pub note: &'static str,
}

/// A scheme provided by another crate, for [`Grammar::parse_with`].
#[derive(Debug, Clone, Copy)]
pub struct Extension<X> {
    /// The name before `:`.
    pub scheme: &'static str,
    /// The form, for hints (`zenoh://?listen=...`).
    pub usage: &'static str,
    /// Parses the whole URI.
    pub parse: fn(&str) -> Result<X, UriError>,
}

/// What [`Grammar::parse_with`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target<X> {
    /// A link-layer endpoint and its routes.
    Link(Endpoint, Vec<u8>),
    /// A URI of an extension's scheme.
    Other(X),
}

impl Grammar {
    /// Parses a URI into an endpoint and its routes (empty unless the grammar takes routes).
    pub fn parse(&self, uri: &str) -> Result<(Endpoint, Vec<u8>), UriError> {
        match self.parse_with::<()>(uri, &[])? {
            Target::Link(endpoint, routes) => Ok((endpoint, routes)),
            Target::Other(()) => unreachable!("no extensions were given"),
        }
    }

    /// Parses a URI into an endpoint, for grammars without routes.
    pub fn endpoint(&self, uri: &str) -> Result<Endpoint, UriError> {
        self.parse(uri).map(|(endpoint, _)| endpoint)
    }

    /// Parses a URI of this grammar or of one of the `extensions`.
    pub fn parse_with<X>(
        &self,
        uri: &str,
        extensions: &[Extension<X>],
    ) -> Result<Target<X>, UriError> {
        let hint = || self.hint(extensions);
        if let Some(extension) = extensions.iter().find(|e| {
            uri.strip_prefix(e.scheme)
                .is_some_and(|rest| rest.starts_with(':'))
        }) {
            return (extension.parse)(uri)
                .map(Target::Other)
                .map_err(|e| e.with_hint(extension.usage));
        }
        self.parse_link(uri, extensions)
            .map(|(endpoint, routes)| Target::Link(endpoint, routes))
            .map_err(|e| e.with_hint(hint()))
    }

    fn parse_link<X>(
        &self,
        uri: &str,
        extensions: &[Extension<X>],
    ) -> Result<(Endpoint, Vec<u8>), UriError> {
        let (body, routes) = match uri.split_once('&').filter(|_| self.routes) {
            Some((body, list)) => (body, parse_routes(uri, list)?),
            None => (uri, Vec::new()),
        };
        let (scheme, rest) = match body.split_once("://") {
            Some(split) => split,
            None if self.loose => match body.split_once(':') {
                // A one-letter "scheme" is a Windows drive: `C:...`.
                Some((scheme, rest))
                    if scheme.len() > 1 && scheme.bytes().all(|b| b.is_ascii_alphabetic()) =>
                {
                    (scheme, rest)
                }
                _ if body.starts_with('/') || body.starts_with("COM") || body.contains(":\\") => {
                    ("serial", body)
                }
                _ => {
                    return Err(UriError::new(
                        uri,
                        0,
                        "missing scheme: expected SCHEME://...",
                    ))
                }
            },
            None => {
                return Err(UriError::new(
                    uri,
                    0,
                    "missing scheme: expected SCHEME://...",
                ))
            }
        };
        let Some(found) = self.schemes.iter().find(|s| s.name == scheme) else {
            let names: Vec<&str> = self
                .schemes
                .iter()
                .filter(|s| !s.alias)
                .map(|s| s.name)
                .chain(extensions.iter().map(|e| e.scheme))
                .collect();
            let list = match names.split_last() {
                Some((last, [])) => (*last).to_owned(),
                Some((last, init)) => format!("{} or {last}", init.join(", ")),
                None => String::new(),
            };
            return Err(UriError::at_part(
                uri,
                scheme,
                format!("unknown scheme {scheme:?}: expected {list}"),
            ));
        };
        let p = Parts {
            uri,
            scheme,
            form: found.form,
            loose: self.loose,
        };
        let endpoint = match found.form {
            Form::UdpIn | Form::UdpOut | Form::UdpBcast | Form::UdpMcast { .. } => {
                let (rest, options) = p.options(rest)?;
                let (host, port) = match found.form {
                    Form::UdpMcast {
                        default: Some((group, port)),
                    } if rest.is_empty() => (group.to_owned(), port),
                    _ => {
                        let (host, port) = p.host_port(rest, None)?;
                        let host = p.require_host(rest, host)?;
                        let port = port.ok_or_else(|| p.missing_port(rest, host.as_str()))?;
                        (host, port)
                    }
                };
                match found.form {
                    Form::UdpIn => {
                        p.no_options(&options, "")?;
                        Endpoint::UdpIn(host, port)
                    }
                    Form::UdpOut => {
                        p.no_options(&options, "replies")?;
                        let port = p.sent_to(rest, port)?;
                        match options.first() {
                            Some((_, "any")) => Endpoint::UdpOutAny(host, port),
                            Some((_, other)) => {
                                return Err(p.err(
                                    other,
                                    format!("bad replies={other:?}: expected replies=any"),
                                ))
                            }
                            None => Endpoint::UdpOut(host, port),
                        }
                    }
                    Form::UdpBcast => {
                        p.no_options(&options, "")?;
                        Endpoint::UdpBcast(host, p.sent_to(rest, port)?)
                    }
                    _ => {
                        p.no_options(&options, "iface")?;
                        let iface = options.first().map(|(_, name)| *name);
                        if let Some(name) = iface.filter(|n| n.is_empty()) {
                            return Err(p.err(name, "empty iface=: expected an interface name"));
                        }
                        let port = p.sent_to(rest, port)?;
                        Endpoint::UdpMcast(host, port, iface.map(str::to_owned))
                    }
                }
            }
            Form::UdpPair { in_port, out_port } => {
                let (host, fields) = p.split_host(rest)?;
                let host = p.require_host(rest, host)?;
                if let Some(extra) = fields.get(2) {
                    return Err(p.too_many(extra));
                }
                let out = p.port_or(fields.get(1), out_port)?;
                Endpoint::Udp(
                    host,
                    p.port_or(fields.first(), in_port)?,
                    p.sent_to(fields.get(1).copied().unwrap_or(rest), out)?,
                )
            }
            Form::TcpIn { host: default } => {
                let (host, port) = p.host_port(rest, None)?;
                let host = match default {
                    Some(default) if host.is_empty() => default.to_owned(),
                    _ => p.require_host(rest, host)?,
                };
                let port = port.ok_or_else(|| p.missing_port(rest, host.as_str()))?;
                Endpoint::TcpIn(host, port)
            }
            Form::TcpOut { port: default } => {
                let (host, port) = p.host_port(rest, default)?;
                let host = p.require_host(rest, host)?;
                let port = port.ok_or_else(|| p.missing_port(rest, host.as_str()))?;
                Endpoint::TcpOut(host, p.sent_to(rest, port)?)
            }
            Form::Serial { baud } => p.serial(rest, baud)?,
            Form::Pty => {
                if rest.is_empty() {
                    return Err(UriError::at_part(uri, rest, "missing pty name"));
                }
                Endpoint::Pty(rest.to_owned())
            }
        };
        Ok((endpoint, routes))
    }

    /// The accepted forms, for hints and `--help`.
    pub fn hint<X>(&self, extensions: &[Extension<X>]) -> String {
        let forms: Vec<String> = self
            .schemes
            .iter()
            .filter(|s| !s.alias)
            .map(|s| format!("{}://{}", s.name, s.form.usage()))
            .chain(extensions.iter().map(|e| e.usage.to_owned()))
            .collect();
        let mut hint = format!("accepted forms: {}", forms.join(", "));
        if self.routes {
            hint.push_str("; each may end with &ID,ID,... (route ids, decimal or 0x-hex)");
        }
        if !self.note.is_empty() {
            hint.push_str("; ");
            hint.push_str(self.note);
        }
        hint
    }

    /// Writes `endpoint` (and `routes`) in this grammar's canonical spelling, every default
    /// spelled out; it parses back to the same endpoint.
    pub fn write(
        &self,
        f: &mut fmt::Formatter<'_>,
        endpoint: &Endpoint,
        routes: &[u8],
    ) -> fmt::Result {
        match self
            .schemes
            .iter()
            .find(|s| !s.alias && s.form.opens(endpoint))
        {
            Some(scheme) => {
                let canonical = endpoint.to_string();
                let (_, rest) = canonical.split_once("://").unwrap_or(("", &canonical));
                write!(f, "{}://{rest}", scheme.name)?;
            }
            None => write!(f, "{endpoint}")?,
        }
        for (i, id) in routes.iter().enumerate() {
            write!(f, "{}{id}", if i == 0 { '&' } else { ',' })?;
        }
        Ok(())
    }
}

/// A URI's `?KEY=VALUE&...` options, each a slice of the URI.
type Options<'u> = Vec<(&'u str, &'u str)>;

/// The URI being parsed, for error positions.
struct Parts<'u> {
    uri: &'u str,
    scheme: &'u str,
    form: Form,
    loose: bool,
}

impl<'u> Parts<'u> {
    fn err(&self, part: &str, message: impl Into<String>) -> UriError {
        UriError::at_part(self.uri, part, message)
    }

    /// `HOST[:A][:B]...` split into the host and the `:`-separated fields after it. An IPv6 host
    /// is written in brackets: `[::1]:5000`.
    fn split_host(&self, rest: &'u str) -> Result<(&'u str, Vec<&'u str>), UriError> {
        let (host, tail) = if let Some(bracketed) = rest.strip_prefix('[') {
            let Some((host, tail)) = bracketed.split_once(']') else {
                return Err(self.err(rest, "missing ']' after IPv6 host"));
            };
            if host.is_empty() {
                return Err(self.err(rest, "empty IPv6 host \"[]\""));
            }
            if !tail.is_empty() && !tail.starts_with(':') {
                return Err(self.err(
                    tail,
                    format!("unexpected {tail:?} after ']': expected :PORT"),
                ));
            }
            (host, tail)
        } else {
            rest.split_at(rest.find(':').unwrap_or(rest.len()))
        };
        if let Some(bad) = host.chars().find(|&c| !is_host_char(c)) {
            return Err(self.err(
                host,
                format!("bad host {host:?}: {bad:?} is not allowed in a host name"),
            ));
        }
        let fields = match tail.strip_prefix(':') {
            Some(fields) => fields.split(':').collect(),
            None => Vec::new(),
        };
        Ok((host, fields))
    }

    /// `HOST:PORT` with the port optional: `default` when absent, or `None`.
    fn host_port(
        &self,
        rest: &'u str,
        default: Option<u16>,
    ) -> Result<(&'u str, Option<u16>), UriError> {
        let (host, fields) = self.split_host(rest)?;
        if let Some(extra) = fields.get(1) {
            return Err(self.too_many(extra));
        }
        let port = match fields.first() {
            Some(field) if !field.is_empty() => Some(self.port(field)?),
            _ => default,
        };
        Ok((host, port))
    }

    fn require_host(&self, rest: &str, host: &str) -> Result<String, UriError> {
        if host.is_empty() {
            let ipv6 = if rest.starts_with("::") {
                " (write IPv6 addresses in brackets, e.g. [::1])"
            } else {
                ""
            };
            return Err(self.err(rest, format!("missing host{ipv6}")));
        }
        Ok(host.to_owned())
    }

    fn missing_port(&self, rest: &str, host: &str) -> UriError {
        let example = match self.form {
            Form::TcpIn { host: Some(_) } if host.bytes().all(|b| b.is_ascii_digit()) => {
                format!(
                    " (to listen on all interfaces write {}://:{host})",
                    self.scheme
                )
            }
            _ => String::new(),
        };
        UriError::new(
            self.uri,
            offset(self.uri, rest) + rest.len(),
            format!("missing port{example}"),
        )
    }

    fn too_many(&self, field: &str) -> UriError {
        self.err(
            field,
            format!(
                "too many ':' fields: expected {}://{}",
                self.scheme,
                self.form.usage()
            ),
        )
    }

    /// `port`, the port a client sends or connects to, at the end of `part`: 0 is refused (the
    /// kernel delivers nothing there; binding to 0 means "any port", sending to it is an error
    /// that would only show as silence).
    fn sent_to(&self, part: &str, port: u16) -> Result<u16, UriError> {
        if port != 0 {
            return Ok(port);
        }
        let field = part.rsplit(':').next().unwrap_or(part);
        Err(self.err(
            field,
            "port 0: nothing can be sent to port 0; give the port the peer listens on",
        ))
    }

    /// An optional port field: absent or empty means `default`.
    fn port_or(&self, field: Option<&&str>, default: u16) -> Result<u16, UriError> {
        match field {
            Some(field) if !field.is_empty() => self.port(field),
            _ => Ok(default),
        }
    }

    fn port(&self, field: &str) -> Result<u16, UriError> {
        // `u16::from_str` takes a leading '+'; a port is plain digits.
        field
            .bytes()
            .all(|b| b.is_ascii_digit())
            .then(|| field.parse::<u16>().ok())
            .flatten()
            .ok_or_else(|| {
                self.err(
                    field,
                    format!("bad port {field:?}: expected 0..={}", u16::MAX),
                )
            })
    }

    /// `REST[?KEY=VALUE&...]` split into `REST` and its options, each a `(key, value)` slice of
    /// the URI.
    fn options(&self, rest: &'u str) -> Result<(&'u str, Options<'u>), UriError> {
        let Some((rest, query)) = rest.split_once('?') else {
            return Ok((rest, Vec::new()));
        };
        let options = query
            .split('&')
            .map(|option| {
                option.split_once('=').ok_or_else(|| {
                    self.err(option, format!("bad option {option:?}: expected KEY=VALUE"))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok((rest, options))
    }

    /// Fails on any option but one `allowed` (none when empty).
    fn no_options(&self, options: &[(&str, &str)], allowed: &str) -> Result<(), UriError> {
        let expected = if allowed.is_empty() {
            format!("{}:// takes no options", self.scheme)
        } else {
            format!("{}:// takes only ?{allowed}=...", self.scheme)
        };
        for (i, (key, _)) in options.iter().enumerate() {
            if *key != allowed {
                return Err(self.err(key, format!("unknown option {key:?}: {expected}")));
            }
            if i > 0 {
                return Err(self.err(key, format!("{key}= given twice")));
            }
        }
        Ok(())
    }

    /// `PATH[:BAUD]` (or `PATH,BAUD` in loose grammars).
    fn serial(&self, rest: &str, default: u32) -> Result<Endpoint, UriError> {
        let split = rest
            .rsplit_once(':')
            .or_else(|| rest.rsplit_once(',').filter(|_| self.loose));
        // Any other `:` belongs to the path (`/dev/serial/by-path/...-usb-0:2:1.0-port0`), but a
        // word after the last one is a mistyped speed, not a device: a path retried forever.
        if let Some((_, tail)) = split {
            let word = tail.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_');
            if !tail.is_empty() && word && !tail.bytes().all(|c| c.is_ascii_digit()) {
                return Err(self.err(
                    tail,
                    format!("bad baud rate {tail:?}: expected digits, e.g. :57600"),
                ));
            }
        }
        let split = split.filter(|(_, b)| !b.is_empty() && b.bytes().all(|c| c.is_ascii_digit()));
        let (path, baud) = match split {
            Some((path, baud)) => (
                path,
                baud.parse::<u32>().ok().filter(|&b| b > 0).ok_or_else(|| {
                    self.err(
                        baud,
                        format!("bad baud rate {baud:?}: expected 1..={}", u32::MAX),
                    )
                })?,
            ),
            None => (rest, default),
        };
        if path.is_empty() {
            return Err(self.err(rest, "missing device path"));
        }
        Ok(Endpoint::Serial(path.to_owned(), baud))
    }
}

/// Whether `host` can stand in a URI: a name or an address (IPv6 colons allowed), without
/// spaces, control characters or URI punctuation.
pub fn is_host(host: &str) -> bool {
    !host.is_empty() && host.chars().all(is_host_char)
}

/// Whether `c` may stand in a host name or address (an IPv6 address's colons come only from
/// inside brackets: outside, the first `:` ends the host).
fn is_host_char(c: char) -> bool {
    !(c.is_whitespace() || c.is_control() || "/[]@?#&,".contains(c))
}

/// `ID,ID,...` after the `&`: decimal or `0x`-prefixed hex device ids.
fn parse_routes(uri: &str, list: &str) -> Result<Vec<u8>, UriError> {
    if list.trim().is_empty() {
        return Err(UriError::at_part(
            uri,
            list,
            "empty route list after '&': expected &ID,ID,...",
        ));
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
                UriError::at_part(
                    uri,
                    id,
                    format!("bad route id {id:?}: expected 0..=255 (decimal) or 0x00..=0xff"),
                )
            })
        })
        .collect()
}
