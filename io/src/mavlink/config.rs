//! Router configuration files: our TOML form, and mavlink-router's `main.conf` for users
//! migrating from it.
//!
//! TOML:
//!
//! ```toml
//! tlog = "flight.tlog"            # optional, as --tlog: a .tlog appended to, or a directory
//! log_mode = "always"             # as --log-mode: "always", or "while-armed" (a log per flight)
//! log_system_id = 1               # the vehicle whose arming counts (default: the first heard)
//! http = "127.0.0.1:8088"         # as --http: the REST and WebSocket API and inspector page
//! max_log_files = 100             # a tlog directory keeps this many logs, the oldest deleted
//! min_free_space = 100_000_000    # and this many bytes free
//! stats_json = "stats.jsonl"      # optional, as --stats-json
//! peer_expiry = 10.0              # seconds
//! queue_bytes = 65536             # a TCP, serial or pty peer's output queue, in bytes
//! queue_drop = "oldest"           # what a full queue drops: "oldest" or "newest"
//! one_frame_per_datagram = false  # true: each frame to a UDP peer in a datagram of its own
//! dialects = ["ardupilotmega.xml"]
//!
//! [[endpoint]]
//! uri = "serial:///dev/ttyACM0:115200"
//!
//! [[endpoint]]
//! uri = "udpout://127.0.0.1:14550"
//! group = "radios"                # redundant links share routes and never feed each other
//! dedup_ms = 100                  # drop frames seen within 100 ms (on any link)
//! max_delay_ms = 500              # do not send frames received longer ago
//! allow_msg_out = [0, 30]         # and block_msg_out, allow_msg_in, block_msg_in,
//! block_src_sys_in = [66]         # allow/block_src_sys_in/out, allow/block_src_comp_in/out
//! signing_key = "00..1f"          # 64 hex digits: accept only frames signed with this key
//! ```
//!
//! An endpoint's `uri` may also be of a scheme the caller registers ([`from_toml_with`]; the
//! CLI registers `zenoh://`); such endpoints land in [`FileConfig::extra`].
//!
//! `main.conf`, mavlink-router's form. Keys are case-insensitive, as mavlink-router reads them.
//! Every key it documents is honoured, or reported once as a warning that names the key and
//! says what the router does instead; any other key is reported as not supported. Nothing is
//! silently ignored.
//!
//! Honoured:
//! - `[General]` `TcpServerPort` (0: none); `Log` (a directory: a new numbered tlog per run),
//!   `MaxLogFiles` and `MinFreeSpace` (bytes; the oldest logs there are deleted when a run
//!   starts, never the new one);
//!   `DeduplicationPeriod` (ms, for every endpoint); `ReportStats` (`true`: link statistics
//!   on stderr every second, as `--stats 1`); `MavlinkDialect` (`auto`: every standard
//!   dialect, our default; `common` or `ardupilotmega`: that built-in dialect); `LogMode`
//!   (`always`, or `while-armed`: a new log each time the vehicle arms, closed when it
//!   disarms); `LogSystemId` (the vehicle whose arming counts; by default the first autopilot
//!   heard); `Http` (ours, as `--http`: the web API's address).
//! - `[UartEndpoint NAME]` `Device`, `Baud` (the first of a list), `FlowControl = false`.
//! - `[UdpEndpoint NAME]` `Mode` (`Normal`/`Client` sends to `Address:Port`, `Server` or
//!   `Eavesdropping` listens there), `Address`, `Port`, and `Filter` (the old name of
//!   `AllowMsgIdOut`).
//! - `[TcpEndpoint NAME]` `Address`, `Port`.
//! - In every endpoint `Group` and the filters `AllowMsgIdOut`, `BlockMsgIdOut`,
//!   `AllowSrcCompOut`, `BlockSrcCompOut`, `AllowSrcSysOut`, `BlockSrcSysOut` and their `In`
//!   counterparts, as comma-separated lists.
//!
//! Reported, with what the router does instead: `DebugLogLevel` (it has no levels: it prints
//! its errors and warnings), `SnifferSysid` (no sniffer: every system's frames are routed by their
//! targets), `FlowControl = true` (the port is opened without flow control) and `RetryTimeout`
//! (a TCP client reconnects with a backoff from 50 ms doubling to 1 s).

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use ferrolink_runtime::mavlink::router::{ByteSet, Filter, IdSet, LinkConfig};
use ferrolink_runtime::mavlink::signing::SecretKey;
use ferrolink_runtime::mavlink::v2;
use serde::Deserialize;

use super::router::LogMode;
use super::tlog::Retention;
use crate::link::{Endpoint, OutputQueue, Overflow};
use crate::uri::{is_host, Extension, Target};

/// An endpoint and how its links behave.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EndpointConfig {
    /// The endpoint.
    pub endpoint: Endpoint,
    /// The configuration of each of its links (every peer of it).
    pub link: LinkConfig,
}

impl EndpointConfig {
    /// An endpoint with the default link configuration.
    pub fn new(endpoint: Endpoint) -> Self {
        Self {
            endpoint,
            link: LinkConfig::default(),
        }
    }
}

/// What a configuration file says. `X` is what the URIs of the caller's own schemes parse to
/// (see [`from_toml_with`]); with none, `()`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileConfig<X = ()> {
    /// Endpoints, in file order.
    pub endpoints: Vec<EndpointConfig>,
    /// Endpoints of the caller's schemes (`zenoh://`, say), in file order, each with the
    /// configuration of its links.
    pub extra: Vec<(X, LinkConfig)>,
    /// Dialect files (relative paths resolved against the file's folder).
    pub dialects: Vec<PathBuf>,
    /// Where to write the tlog.
    pub tlog: Option<PathBuf>,
    /// Where to write statistics.
    pub stats_json: Option<PathBuf>,
    /// How often to print link statistics (`main.conf`'s `ReportStats`).
    pub stats_every: Option<Duration>,
    /// What a tlog directory keeps.
    pub retention: Retention,
    /// When the tlog is written (`log_mode`, `LogMode`), when the file says.
    pub log_mode: Option<LogMode>,
    /// The vehicle whose arming starts a flight's log (`log_system_id`, `LogSystemId`).
    pub log_system_id: Option<u8>,
    /// Where the web API listens (`http`, `Http`), as `--http`.
    pub http: Option<std::net::SocketAddr>,
    /// How long a quiet UDP peer keeps its link.
    pub peer_expiry: Option<Duration>,
    /// The output queue of stream peers, when the file sets it.
    pub queue: Option<OutputQueue>,
    /// Whether each frame to a UDP peer goes in a datagram of its own, when the file says.
    pub one_frame_per_datagram: Option<bool>,
    /// Problems that did not stop the file from being read (unknown keys).
    pub warnings: Vec<String>,
}

impl<X> Default for FileConfig<X> {
    fn default() -> Self {
        FileConfig {
            endpoints: Vec::new(),
            extra: Vec::new(),
            dialects: Vec::new(),
            tlog: None,
            stats_json: None,
            stats_every: None,
            retention: Retention::default(),
            log_mode: None,
            log_system_id: None,
            http: None,
            peer_expiry: None,
            queue: None,
            one_frame_per_datagram: None,
            warnings: Vec::new(),
        }
    }
}

impl FileConfig {
    /// The same settings, for a caller with schemes of its own (none of which this file uses:
    /// `main.conf` has no way to name them).
    pub fn with_extra<X>(self) -> FileConfig<X> {
        FileConfig {
            endpoints: self.endpoints,
            extra: Vec::new(),
            dialects: self.dialects,
            tlog: self.tlog,
            stats_json: self.stats_json,
            stats_every: self.stats_every,
            retention: self.retention,
            log_mode: self.log_mode,
            log_system_id: self.log_system_id,
            http: self.http,
            peer_expiry: self.peer_expiry,
            queue: self.queue,
            one_frame_per_datagram: self.one_frame_per_datagram,
            warnings: self.warnings,
        }
    }
}

/// A configuration file that cannot be used: where (line and column, when the syntax is at
/// fault; otherwise the message names the section or endpoint) and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// 1-based line and column.
    pub line_col: Option<(usize, usize)>,
    /// What is wrong.
    pub message: String,
}

/// An error that the message locates by itself.
fn error(message: String) -> ConfigError {
    ConfigError {
        line_col: None,
        message,
    }
}

impl ConfigError {
    /// The error as `FILE:LINE:COL: message`, or `FILE: message`.
    pub fn in_file(&self, file: &Path) -> String {
        match self.line_col {
            Some((line, col)) => format!("{}:{line}:{col}: {}", file.display(), self.message),
            None => format!("{}: {}", file.display(), self.message),
        }
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line_col {
            Some((line, col)) => write!(f, "{line}:{col}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for ConfigError {}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlFile {
    #[serde(default)]
    dialects: Vec<PathBuf>,
    tlog: Option<PathBuf>,
    max_log_files: Option<usize>,
    min_free_space: Option<u64>,
    log_mode: Option<String>,
    log_system_id: Option<u8>,
    http: Option<std::net::SocketAddr>,
    stats_json: Option<PathBuf>,
    peer_expiry: Option<f64>,
    queue_bytes: Option<usize>,
    queue_drop: Option<QueueDrop>,
    one_frame_per_datagram: Option<bool>,
    #[serde(default)]
    endpoint: Vec<TomlEndpoint>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlEndpoint {
    uri: String,
    group: Option<String>,
    #[serde(default)]
    dedup_ms: u64,
    #[serde(default)]
    max_delay_ms: u64,
    signing_key: Option<String>,
    #[serde(default)]
    drop_unknown_ids: bool,
    #[serde(default)]
    allow_msg_in: Vec<u32>,
    #[serde(default)]
    block_msg_in: Vec<u32>,
    #[serde(default)]
    allow_msg_out: Vec<u32>,
    #[serde(default)]
    block_msg_out: Vec<u32>,
    #[serde(default)]
    allow_src_sys_in: Vec<u8>,
    #[serde(default)]
    block_src_sys_in: Vec<u8>,
    #[serde(default)]
    allow_src_sys_out: Vec<u8>,
    #[serde(default)]
    block_src_sys_out: Vec<u8>,
    #[serde(default)]
    allow_src_comp_in: Vec<u8>,
    #[serde(default)]
    block_src_comp_in: Vec<u8>,
    #[serde(default)]
    allow_src_comp_out: Vec<u8>,
    #[serde(default)]
    block_src_comp_out: Vec<u8>,
}

/// What a full output queue drops.
#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum QueueDrop {
    Oldest,
    Newest,
}

/// The router's output queue as the file sets it (either key alone keeps the other's default).
fn queue(
    bytes: Option<usize>,
    drop: Option<QueueDrop>,
) -> Result<Option<OutputQueue>, ConfigError> {
    if bytes.is_none() && drop.is_none() {
        return Ok(None);
    }
    let default = crate::link::DAEMON_QUEUE;
    let bytes = bytes.unwrap_or(default.bytes);
    queue_fits(bytes, "queue_bytes = ").map_err(error)?;
    let overflow = match drop {
        Some(QueueDrop::Oldest) => Overflow::DropOldest,
        Some(QueueDrop::Newest) => Overflow::DropNewest,
        None => default.overflow,
    };
    Ok(Some(OutputQueue { overflow, bytes }))
}

/// Group names to the router's group numbers (1, 2, ... in order of appearance).
#[derive(Default)]
struct Groups(BTreeMap<String, u8>);

impl Groups {
    fn number(&mut self, name: &str, at: &str) -> Result<u8, ConfigError> {
        let next = self.0.len() + 1;
        if let Some(&n) = self.0.get(name) {
            return Ok(n);
        }
        let n = u8::try_from(next).map_err(|_| error(format!("{at}: more than 255 groups")))?;
        self.0.insert(name.to_owned(), n);
        Ok(n)
    }
}

/// Whether an output queue of `bytes` holds the largest MAVLink frame; if not, the error, for
/// the option written `option` (`--queue-bytes ` or `queue_bytes = `).
pub fn queue_fits(bytes: usize, option: &str) -> Result<(), String> {
    if bytes >= v2::MAX_FRAME_LEN {
        return Ok(());
    }
    Err(format!(
        "{option}{bytes}: less than the largest MAVLink frame ({} bytes), which could never be \
         queued\n  hint: give the bytes a slow peer may have waiting, e.g. {option}65536 (the \
         default)",
        v2::MAX_FRAME_LEN
    ))
}

fn ids(list: &[u32], at: &str, key: &str) -> Result<IdSet, ConfigError> {
    let mut set = IdSet::EMPTY;
    for &id in list {
        if id > v2::MAX_MSG_ID {
            return Err(error(format!(
                "{at}: {key} lists message id {id}, past the largest a frame carries ({})\n  \
                 hint: message ids are 24 bits",
                v2::MAX_MSG_ID
            )));
        }
        set.insert(id).map_err(|_| {
            error(format!(
                "{at}: {key} lists more than {} message ids",
                ferrolink_runtime::mavlink::router::ID_SET_CAPACITY
            ))
        })?;
    }
    Ok(set)
}

fn bytes(list: &[u8]) -> ByteSet {
    list.iter().copied().collect()
}

/// Parses 64 hex digits into a signing key.
fn key(text: &str, at: &str) -> Result<SecretKey, ConfigError> {
    let raw = hex::decode(text.trim())
        .ok()
        .and_then(|v| <[u8; 32]>::try_from(v).ok())
        .ok_or_else(|| error(format!("{at}: signing_key must be 64 hex digits")))?;
    Ok(SecretKey::new(raw))
}

/// Reads our TOML form. `base` is the file's folder, for relative dialect paths.
pub fn from_toml(text: &str, base: &Path) -> Result<FileConfig, ConfigError> {
    from_toml_with(text, base, &[])
}

/// Reads our TOML form, where an endpoint's `uri` may also be of one of `extensions` (the CLI
/// registers `zenoh://`): such endpoints land in [`FileConfig::extra`], with their filters,
/// group and key like any other.
pub fn from_toml_with<X>(
    text: &str,
    base: &Path,
    extensions: &[Extension<X>],
) -> Result<FileConfig<X>, ConfigError> {
    let file: TomlFile = toml::from_str(text).map_err(|e| {
        let at = e.span().and_then(|s| text.get(s.start..)).unwrap_or("");
        // `[endpoint]` where `[[endpoint]]` was meant: one table, not a list of them.
        let hint = match at.strip_prefix('[') {
            Some(rest) if !rest.starts_with('[') && e.message().contains("expected a sequence") => {
                let name = rest.split(']').next().unwrap_or_default();
                format!("\n  hint: write [[{name}]], with double brackets, once per {name}")
            }
            _ => String::new(),
        };
        ConfigError {
            line_col: e.span().map(|s| {
                let before = text.get(..s.start).unwrap_or(text);
                let line_start = before.rfind('\n').map_or(0, |i| i + 1);
                (
                    before.matches('\n').count() + 1,
                    before[line_start..].chars().count() + 1,
                )
            }),
            message: format!("{}{hint}", e.message()),
        }
    })?;
    let mut groups = Groups::default();
    let mut endpoints = Vec::new();
    let mut extra = Vec::new();
    for (i, e) in file.endpoint.iter().enumerate() {
        let at = format!("endpoint #{} ({})", i + 1, e.uri);
        let target = super::ENDPOINTS
            .parse_with(&e.uri, extensions)
            .map_err(|err| error(format!("{at}: {err}")))?;
        let link = LinkConfig {
            inbound: Filter {
                allow_msg: ids(&e.allow_msg_in, &at, "allow_msg_in")?,
                block_msg: ids(&e.block_msg_in, &at, "block_msg_in")?,
                allow_src_sys: bytes(&e.allow_src_sys_in),
                block_src_sys: bytes(&e.block_src_sys_in),
                allow_src_comp: bytes(&e.allow_src_comp_in),
                block_src_comp: bytes(&e.block_src_comp_in),
            },
            outbound: Filter {
                allow_msg: ids(&e.allow_msg_out, &at, "allow_msg_out")?,
                block_msg: ids(&e.block_msg_out, &at, "block_msg_out")?,
                allow_src_sys: bytes(&e.allow_src_sys_out),
                block_src_sys: bytes(&e.block_src_sys_out),
                allow_src_comp: bytes(&e.allow_src_comp_out),
                block_src_comp: bytes(&e.block_src_comp_out),
            },
            group: match &e.group {
                Some(name) => groups.number(name, &at)?,
                None => 0,
            },
            dedup_window_us: e.dedup_ms.saturating_mul(1000),
            max_delay_us: e.max_delay_ms.saturating_mul(1000),
            require_signing: e.signing_key.as_deref().map(|k| key(k, &at)).transpose()?,
            drop_unknown_ids: e.drop_unknown_ids,
            // Set from the endpoint's kind and place when the router opens its links.
            datagrams: false,
            sniffer: false,
        };
        match target {
            Target::Link(endpoint, _) => endpoints.push(EndpointConfig { endpoint, link }),
            Target::Other(x) => extra.push((x, link)),
        }
    }
    let peer_expiry = file
        .peer_expiry
        .map(|s| {
            crate::seconds::from_f64(s).map_err(|e| error(format!("peer_expiry = {s:?}: {e}")))
        })
        .transpose()?;
    Ok(FileConfig {
        endpoints,
        extra,
        dialects: file.dialects.iter().map(|d| base.join(d)).collect(),
        tlog: file.tlog,
        stats_json: file.stats_json,
        stats_every: None,
        retention: Retention {
            max_files: file.max_log_files,
            min_free_bytes: file.min_free_space,
        },
        log_mode: file
            .log_mode
            .as_deref()
            .map(|m| m.parse().map_err(|e| error(format!("log_mode = {e}"))))
            .transpose()?,
        log_system_id: file.log_system_id,
        http: file.http,
        peer_expiry,
        queue: queue(file.queue_bytes, file.queue_drop)?,
        one_frame_per_datagram: file.one_frame_per_datagram,
        warnings: Vec::new(),
    })
}

/// Reads mavlink-router's `main.conf`.
pub fn from_main_conf(text: &str) -> Result<FileConfig, ConfigError> {
    // A section header left open is told where it is, not where the parser ran out of text.
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.starts_with('[') && !line.contains(']') {
            return Err(ConfigError {
                line_col: Some((i + 1, 1)),
                message: format!(
                    "{line:?}: a section header without its closing ]\n  hint: write it as {line}]"
                ),
            });
        }
    }
    let ini = ini::Ini::load_from_str_opt(
        text,
        ini::ParseOption {
            enabled_quote: true,
            enabled_escape: false,
            ..ini::ParseOption::default()
        },
    )
    .map_err(|e| ConfigError {
        line_col: Some((e.line, e.col)),
        message: e.msg.to_string(),
    })?;
    let mut config = FileConfig::default();
    let mut groups = Groups::default();
    let mut dedup_us = 0;
    let mut sections: Vec<(String, BTreeMap<String, String>)> = Vec::new();
    for (name, props) in &ini {
        let keys = props
            .iter()
            .map(|(k, v)| (k.to_ascii_lowercase(), v.trim().to_owned()))
            .collect();
        sections.push((name.unwrap_or("").trim().to_owned(), keys));
    }
    for (name, keys) in &sections {
        let kind = name.split_whitespace().next().unwrap_or("");
        let at = format!("[{name}]");
        let mut used: Vec<&str> = Vec::new();
        // Keys read but not honoured, each with what the router does instead.
        let mut notes: Vec<String> = Vec::new();
        let mut get = |key: &'static str| {
            used.push(key);
            keys.get(key).map(String::as_str)
        };
        let number = |key: &str, value: Option<&str>| -> Result<Option<u64>, ConfigError> {
            value
                .map(|v| {
                    v.parse::<u64>()
                        .map_err(|_| error(format!("{at} {key} = {v:?}: not a number")))
                })
                .transpose()
        };
        let port = |value: Option<&str>| -> Result<u16, ConfigError> {
            let v = value.ok_or_else(|| error(format!("{at}: Port is missing")))?;
            v.parse::<u16>()
                .map_err(|_| error(format!("{at} Port = {v:?}: not a port")))
        };
        // The port a client sends or connects to: 0 is refused, as in an endpoint URI.
        let sent_to = |port: u16| -> Result<u16, ConfigError> {
            if port == 0 {
                return Err(error(format!(
                    "{at} Port = 0: nothing can be sent to port 0; give the port the peer listens on"
                )));
            }
            Ok(port)
        };
        let endpoint = match kind.to_ascii_lowercase().as_str() {
            "" => None,
            "general" => {
                if let Some(p) = number("TcpServerPort", get("tcpserverport"))? {
                    if p != 0 {
                        let p = u16::try_from(p)
                            .map_err(|_| error(format!("{at} TcpServerPort = {p}: not a port")))?;
                        config
                            .endpoints
                            .push(EndpointConfig::new(Endpoint::TcpIn("0.0.0.0".into(), p)));
                    }
                }
                if let Some(dir) = get("log") {
                    // A directory: a new numbered log per run, as mavlink-router writes them.
                    config.tlog = Some(PathBuf::from(dir));
                }
                config.retention = Retention {
                    max_files: number("MaxLogFiles", get("maxlogfiles"))?
                        .map(|n| usize::try_from(n).unwrap_or(usize::MAX)),
                    min_free_bytes: number("MinFreeSpace", get("minfreespace"))?,
                };
                dedup_us = number("DeduplicationPeriod", get("deduplicationperiod"))?
                    .unwrap_or(0)
                    .saturating_mul(1000);
                if let Some(v) = get("reportstats") {
                    if boolean(v).ok_or_else(|| {
                        error(format!("{at} ReportStats = {v:?}: expected true or false"))
                    })? {
                        config.stats_every = Some(Duration::from_secs(1));
                    }
                }
                match get("mavlinkdialect")
                    .map(str::to_ascii_lowercase)
                    .as_deref()
                {
                    None | Some("auto") => {}
                    Some(name @ ("common" | "ardupilotmega")) => config.dialects.push(name.into()),
                    Some(other) => {
                        return Err(error(format!(
                        "{at} MavlinkDialect = {other:?}: expected auto, common or ardupilotmega"
                    )))
                    }
                }
                if let Some(mode) = get("logmode") {
                    config.log_mode = Some(
                        mode.parse()
                            .map_err(|e| error(format!("{at} LogMode = {e}")))?,
                    );
                }
                if let Some(addr) = get("http") {
                    config.http = Some(addr.trim().parse().map_err(|_| {
                        error(format!(
                            "{at} Http = {addr:?}: expected ADDR:PORT, e.g. 127.0.0.1:8088"
                        ))
                    })?);
                }
                if let Some(id) = get("logsystemid") {
                    config.log_system_id = Some(id.trim().parse().map_err(|_| {
                        error(format!(
                            "{at} LogSystemId = {id:?}: expected a system id, 1 to 255"
                        ))
                    })?);
                }
                let instead = [
                    (
                        "debugloglevel",
                        "DebugLogLevel",
                        "the router has no log levels; it prints its errors and warnings",
                    ),
                    (
                        "sniffersysid",
                        "SnifferSysid",
                        "there is no sniffer; every system's frames are routed by their targets",
                    ),
                ];
                for (key, name, what) in instead {
                    if let Some(v) = get(key) {
                        notes.push(format!("{at} {name} = {v}: not supported; {what}"));
                    }
                }
                None
            }
            "uartendpoint" => {
                let device = get("device")
                    .filter(|d| !d.is_empty())
                    .ok_or_else(|| error(format!("{at}: Device is missing")))?;
                let baud = get("baud")
                    .and_then(|b| b.split(',').next())
                    .map(|b| {
                        b.trim()
                            .parse::<u32>()
                            .ok()
                            .filter(|&b| b > 0)
                            .ok_or_else(|| error(format!("{at} Baud = {b:?}: not a baud rate")))
                    })
                    .transpose()?
                    .unwrap_or(115_200);
                if let Some(v) = get("flowcontrol") {
                    let on = boolean(v).ok_or_else(|| {
                        error(format!("{at} FlowControl = {v:?}: expected true or false"))
                    })?;
                    if on {
                        notes.push(format!(
                            "{at} FlowControl = {v}: not supported; the port is opened without flow control"
                        ));
                    }
                }
                Some(Endpoint::Serial(device.to_owned(), baud))
            }
            "udpendpoint" => {
                let address = match get("address") {
                    Some("") => return Err(error(format!("{at}: Address is empty"))),
                    Some(a) if !is_host(a) => {
                        return Err(error(format!("{at} Address = {a:?}: not a host")))
                    }
                    Some(a) => a.to_owned(),
                    None => "0.0.0.0".to_owned(),
                };
                let port = port(get("port"))?;
                match get("mode").map(str::to_ascii_lowercase).as_deref() {
                    Some("server" | "eavesdropping") => Some(Endpoint::UdpIn(address, port)),
                    Some("normal" | "client") | None => {
                        Some(Endpoint::UdpOut(address, sent_to(port)?))
                    }
                    Some(other) => {
                        return Err(error(format!(
                        "{at} Mode = {other:?}: expected Normal, Client, Server or Eavesdropping"
                    )))
                    }
                }
            }
            "tcpendpoint" => {
                let address = get("address")
                    .filter(|a| !a.is_empty())
                    .ok_or_else(|| error(format!("{at}: Address is missing")))?
                    .to_owned();
                if !is_host(&address) {
                    return Err(error(format!("{at} Address = {address:?}: not a host")));
                }
                if let Some(v) = get("retrytimeout") {
                    notes.push(format!(
                        "{at} RetryTimeout = {v}: not supported; the connection is retried with a backoff from 50 ms doubling to 1 s"
                    ));
                }
                Some(Endpoint::TcpOut(address, sent_to(port(get("port"))?)?))
            }
            _ => {
                config
                    .warnings
                    .push(format!("{at}: unknown section, ignored"));
                continue;
            }
        };
        if let Some(endpoint) = endpoint {
            let mut filter_ids = |key: &'static str| -> Result<IdSet, ConfigError> {
                let list = list::<u32>(get(key), &at, key)?;
                ids(&list, &at, key)
            };
            let mut link: LinkConfig = LinkConfig::default();
            link.outbound.allow_msg = filter_ids("allowmsgidout")?;
            // `Filter`, the old name of `AllowMsgIdOut` (of UDP endpoints).
            let old_filter = filter_ids("filter")?;
            if !old_filter.is_empty() {
                link.outbound.allow_msg = old_filter;
            }
            link.outbound.block_msg = filter_ids("blockmsgidout")?;
            link.inbound.allow_msg = filter_ids("allowmsgidin")?;
            link.inbound.block_msg = filter_ids("blockmsgidin")?;
            let mut filter_bytes = |key: &'static str| -> Result<ByteSet, ConfigError> {
                Ok(bytes(&list::<u8>(get(key), &at, key)?))
            };
            link.outbound.allow_src_comp = filter_bytes("allowsrccompout")?;
            link.outbound.block_src_comp = filter_bytes("blocksrccompout")?;
            link.outbound.allow_src_sys = filter_bytes("allowsrcsysout")?;
            link.outbound.block_src_sys = filter_bytes("blocksrcsysout")?;
            link.inbound.allow_src_comp = filter_bytes("allowsrccompin")?;
            link.inbound.block_src_comp = filter_bytes("blocksrccompin")?;
            link.inbound.allow_src_sys = filter_bytes("allowsrcsysin")?;
            link.inbound.block_src_sys = filter_bytes("blocksrcsysin")?;
            if let Some(group) = get("group") {
                link.group = groups.number(group, &at)?;
            }
            config.endpoints.push(EndpointConfig { endpoint, link });
        }
        config.warnings.append(&mut notes);
        for key in keys.keys() {
            if !used.contains(&key.as_str()) {
                config
                    .warnings
                    .push(format!("{at}: key {key:?} is not supported, ignored"));
            }
        }
    }
    // mavlink-router drops duplicates whichever endpoint they come in on: the period holds for
    // every endpoint, the TCP server's included, wherever [General] stands in the file.
    for e in &mut config.endpoints {
        e.link.dedup_window_us = dedup_us;
    }
    Ok(config)
}

/// A `main.conf` boolean, as mavlink-router reads one.
fn boolean(value: &str) -> Option<bool> {
    match value.to_ascii_lowercase().as_str() {
        "true" | "1" | "yes" | "on" => Some(true),
        "false" | "0" | "no" | "off" => Some(false),
        _ => None,
    }
}

/// A comma-separated list of numbers (absent: empty).
fn list<T: std::str::FromStr>(
    value: Option<&str>,
    at: &str,
    key: &str,
) -> Result<Vec<T>, ConfigError> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    value
        .split(',')
        .map(str::trim)
        .filter(|v| !v.is_empty())
        .map(|v| {
            v.parse::<T>()
                .map_err(|_| error(format!("{at} {key}: {v:?} is not a valid number")))
        })
        .collect()
}
