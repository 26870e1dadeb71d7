//! `zenoh://?mode=peer&listen=tcp/HOST:PORT[&connect=tcp/HOST:PORT][&encoding=raw|json][&prefix=ferrolink]`

use std::fmt;
use std::str::FromStr;

use ferrolink_io::uri::{Extension, UriError};

/// How a Zenoh endpoint joins the network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// Peer to peer: talks to the peers it connects to, that connect to it, or (Zenoh's
    /// multicast scouting) that it finds on the local network.
    #[default]
    Peer,
    /// A client of a Zenoh router (`zenohd`).
    Client,
}

/// What a sample holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Encoding {
    /// The frame's bytes exactly as received, so another router can forward it unchanged.
    #[default]
    Raw,
    /// One JSON object: `{"sysid":..,"compid":..,"seq":..,"msg":{<pymavlink to_dict() form>}}`.
    Json,
}

/// A parsed `zenoh://` URI.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ZenohUri {
    /// `mode`: `peer` (default) or `client`.
    pub mode: Mode,
    /// `listen`: Zenoh endpoints to listen on (`tcp/127.0.0.1:7447`); repeatable.
    pub listen: Vec<String>,
    /// `connect`: Zenoh endpoints to connect to; repeatable.
    pub connect: Vec<String>,
    /// `encoding`: `raw` (default) or `json`.
    pub encoding: Encoding,
    /// `prefix`: the first segment of every key expression (default `ferrolink`).
    pub prefix: String,
}

/// The default key expression prefix.
pub const DEFAULT_PREFIX: &str = "ferrolink";

/// The form, for hints.
pub const FORM: &str = "zenoh://?mode=peer|client&listen=tcp/HOST:PORT&connect=tcp/HOST:PORT\
                        &encoding=raw|json&prefix=NAME (listen and connect repeat; at least one)";

/// The `zenoh://` scheme, for [`Grammar::parse_with`](ferrolink_io::uri::Grammar::parse_with):
/// with it, a protocol's endpoint list takes Zenoh URIs too.
pub const SCHEME: Extension<ZenohUri> = Extension {
    scheme: "zenoh",
    usage: FORM,
    parse: |uri| uri.parse(),
};

impl FromStr for ZenohUri {
    type Err = UriError;

    fn from_str(uri: &str) -> Result<Self, UriError> {
        let bad = |part: &str, what: String| UriError::at_part(uri, part, what).with_hint(FORM);
        let query = uri
            .strip_prefix("zenoh://")
            .ok_or_else(|| bad(uri, "not a zenoh:// URI".into()))?;
        let query = query.strip_prefix('?').unwrap_or(query);
        let mut parsed = ZenohUri {
            prefix: DEFAULT_PREFIX.into(),
            ..ZenohUri::default()
        };
        for pair in query.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = pair
                .split_once('=')
                .ok_or_else(|| bad(pair, format!("{pair:?} is not KEY=VALUE")))?;
            match key {
                "mode" => {
                    parsed.mode = match value {
                        "peer" => Mode::Peer,
                        "client" => Mode::Client,
                        _ => return Err(bad(value, format!("mode {value:?} (peer or client)"))),
                    }
                }
                "listen" | "connect" => {
                    let ok = value
                        .split_once('/')
                        .is_some_and(|(proto, addr)| !proto.is_empty() && !addr.is_empty())
                        && !value.chars().any(char::is_whitespace);
                    if !ok {
                        return Err(bad(
                            value,
                            format!(
                                "{key} {value:?} is no Zenoh endpoint (PROTOCOL/ADDRESS, e.g. tcp/127.0.0.1:7447)"
                            ),
                        ));
                    }
                    let list = if key == "listen" {
                        &mut parsed.listen
                    } else {
                        &mut parsed.connect
                    };
                    list.push(value.into());
                }
                "encoding" => {
                    parsed.encoding = match value {
                        "raw" => Encoding::Raw,
                        "json" => Encoding::Json,
                        _ => return Err(bad(value, format!("encoding {value:?} (raw or json)"))),
                    }
                }
                "prefix" => {
                    let ok = !value.is_empty()
                        && !value
                            .chars()
                            .any(|c| c.is_whitespace() || c.is_control() || "/*$?#".contains(c));
                    if !ok {
                        return Err(bad(
                            value,
                            format!(
                                "prefix {value:?} (one key expression segment: no '/', '*', '$', '?', '#')"
                            ),
                        ));
                    }
                    parsed.prefix = value.into();
                }
                _ => return Err(bad(key, format!("unknown parameter {key:?}"))),
            }
        }
        if parsed.listen.is_empty() && parsed.connect.is_empty() {
            return Err(bad(query, "neither listen nor connect".into()));
        }
        Ok(parsed)
    }
}

impl fmt::Display for ZenohUri {
    /// The canonical URI, every parameter spelled out.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mode = match self.mode {
            Mode::Peer => "peer",
            Mode::Client => "client",
        };
        write!(f, "zenoh://?mode={mode}")?;
        for l in &self.listen {
            write!(f, "&listen={l}")?;
        }
        for c in &self.connect {
            write!(f, "&connect={c}")?;
        }
        let encoding = match self.encoding {
            Encoding::Raw => "raw",
            Encoding::Json => "json",
        };
        write!(f, "&encoding={encoding}&prefix={}", self.prefix)
    }
}

impl ZenohUri {
    /// The Zenoh configuration: the mode and the endpoints given; everything else (a peer's
    /// listening on an ephemeral port when no `listen` is given, scouting, gossip) as Zenoh
    /// defaults it.
    pub fn config(&self) -> Result<zenoh::Config, String> {
        self.config_as(self.mode)
    }

    /// [`ZenohUri::config`] in another mode.
    pub fn config_as(&self, mode: Mode) -> Result<zenoh::Config, String> {
        let mut config = zenoh::Config::default();
        let list = |l: &[String]| serde_json::to_string(l).unwrap_or_default();
        let mode = match mode {
            Mode::Peer => "\"peer\"",
            Mode::Client => "\"client\"",
        };
        let mut set = |key: &str, value: &str| {
            config
                .insert_json5(key, value)
                .map_err(|e| format!("{self}: {key}: {e}"))
        };
        set("mode", mode)?;
        if !self.listen.is_empty() {
            set("listen/endpoints", &list(&self.listen))?;
        }
        if !self.connect.is_empty() {
            set("connect/endpoints", &list(&self.connect))?;
        }
        Ok(config)
    }

    /// `<prefix>/mavlink`, under which every MAVLink key lies.
    pub fn mavlink_root(&self) -> String {
        format!("{}/mavlink", self.prefix)
    }

    /// `<prefix>/fleet`, under which every router answers who it is.
    pub fn fleet_root(&self) -> String {
        format!("{}/fleet", self.prefix)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_contract_forms() {
        let uri: ZenohUri = "zenoh://?mode=peer&listen=tcp/127.0.0.1:7447"
            .parse()
            .unwrap();
        assert_eq!(uri.mode, Mode::Peer);
        assert_eq!(uri.listen, ["tcp/127.0.0.1:7447"]);
        assert_eq!(uri.encoding, Encoding::Raw);
        assert_eq!(uri.prefix, "ferrolink");
        let uri: ZenohUri = "zenoh://?mode=client&connect=tcp/10.0.0.1:7447&connect=udp/[::1]:7000&listen=tcp/0.0.0.0:0&encoding=json&prefix=fleet2"
            .parse()
            .unwrap();
        assert_eq!(uri.mode, Mode::Client);
        assert_eq!(uri.connect, ["tcp/10.0.0.1:7447", "udp/[::1]:7000"]);
        assert_eq!(uri.encoding, Encoding::Json);
        assert_eq!(uri.prefix, "fleet2");
        assert_eq!(
            uri.to_string(),
            "zenoh://?mode=client&listen=tcp/0.0.0.0:0&connect=tcp/10.0.0.1:7447&connect=udp/[::1]:7000&encoding=json&prefix=fleet2"
        );
        assert_eq!(uri.to_string().parse::<ZenohUri>().unwrap(), uri);
        assert_eq!(uri.mavlink_root(), "fleet2/mavlink");
        uri.config().expect("a valid Zenoh config");
    }

    #[test]
    fn errors_name_the_part_and_show_the_form() {
        let err = |uri: &str| uri.parse::<ZenohUri>().unwrap_err().to_string();
        assert!(err("zenoh://?mode=peer").starts_with("neither listen nor connect\n"));
        let e = "zenoh://?listen=tcp/h:1&mode=router"
            .parse::<ZenohUri>()
            .unwrap_err();
        assert_eq!(e.at(), "zenoh://?listen=tcp/h:1&mode=".len());
        assert!(err("zenoh://?listen=7447").contains("is no Zenoh endpoint"));
        assert!(err("zenoh://?listen=tcp/h:1&mode=router").contains("mode \"router\""));
        assert!(err("zenoh://?listen=tcp/h:1&encoding=cbor").contains("encoding \"cbor\""));
        assert!(err("zenoh://?listen=tcp/h:1&prefix=a/b").contains("prefix \"a/b\""));
        assert!(err("zenoh://?listen=tcp/h:1&qos=1").contains("unknown parameter \"qos\""));
        assert!(err("zenoh://?listen").contains("is not KEY=VALUE"));
        assert!(err("udp://x").contains("not a zenoh:// URI"));
        assert!(err("zenoh://?mode=peer").contains("hint: zenoh://?mode="));
    }
}
