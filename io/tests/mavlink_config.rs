//! Router configuration files: our TOML form and mavlink-router's main.conf.

use std::path::Path;
use std::time::Duration;

use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::config::{from_main_conf, from_toml, from_toml_with};
use ferrolink_io::mavlink::router::LogMode;
use ferrolink_io::uri::{Extension, UriError};

#[test]
fn toml_with_filters_groups_and_signing() {
    let text = r#"
dialects = ["common.xml"]
tlog = "flight.tlog"
peer_expiry = 2.5

[[endpoint]]
uri = "serial:///dev/ttyACM0:115200"

[[endpoint]]
uri = "udpout://127.0.0.1:14550"
group = "radios"
dedup_ms = 100
max_delay_ms = 500
allow_msg_out = [0, 30]
block_src_sys_in = [66]

[[endpoint]]
uri = "udpin:0.0.0.0:14551"
group = "radios"
signing_key = "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f"
"#;
    let c = from_toml(text, Path::new("/etc/ferrolink")).unwrap();
    assert_eq!(c.dialects, [Path::new("/etc/ferrolink/common.xml")]);
    assert_eq!(c.tlog.as_deref(), Some(Path::new("flight.tlog")));
    assert_eq!(c.peer_expiry, Some(Duration::from_millis(2500)));
    assert_eq!(
        c.endpoints[0].endpoint,
        Endpoint::Serial("/dev/ttyACM0".into(), 115_200)
    );
    let radio = &c.endpoints[1].link;
    assert_eq!(
        (radio.group, radio.dedup_window_us, radio.max_delay_us),
        (1, 100_000, 500_000)
    );
    assert_eq!(radio.outbound.allow_msg.as_slice(), [0, 30]);
    assert!(radio.inbound.block_src_sys.contains(66));
    assert!(radio.outbound.passes(30, 1, 1) && !radio.outbound.passes(31, 1, 1));
    let second = &c.endpoints[2].link;
    assert_eq!(second.group, 1, "same group name, same group");
    assert!(second.require_signing.is_some());
}

#[test]
fn toml_output_queues() {
    use ferrolink_io::link::{OutputQueue, Overflow, DAEMON_QUEUE};
    let queue = |text: &str| from_toml(text, Path::new(".")).map(|c| c.queue);
    assert_eq!(queue(""), Ok(None), "the router's default applies");
    assert_eq!(
        queue("queue_bytes = 1000\nqueue_drop = \"newest\"\n"),
        Ok(Some(OutputQueue {
            overflow: Overflow::DropNewest,
            bytes: 1000
        }))
    );
    assert_eq!(
        queue("queue_drop = \"oldest\"\n"),
        Ok(Some(DAEMON_QUEUE)),
        "one key alone keeps the other's default"
    );
    let err = |text: &str| queue(text).unwrap_err().to_string();
    insta::assert_snapshot!(err("queue_bytes = 0\n"), @r"
    queue_bytes = 0: less than the largest MAVLink frame (280 bytes), which could never be queued
      hint: give the bytes a slow peer may have waiting, e.g. queue_bytes = 65536 (the default)
    ");
    insta::assert_snapshot!(err("queue_drop = \"middle\"\n"), @"1:14: unknown variant `middle`, expected `oldest` or `newest`");
}

#[test]
fn toml_one_frame_per_datagram() {
    let packing = |text: &str| from_toml(text, Path::new(".")).map(|c| c.one_frame_per_datagram);
    assert_eq!(
        packing(""),
        Ok(None),
        "the router's default (packed) applies"
    );
    assert_eq!(packing("one_frame_per_datagram = true\n"), Ok(Some(true)));
    assert_eq!(packing("one_frame_per_datagram = false\n"), Ok(Some(false)));
    insta::assert_snapshot!(
        packing("one_frame_per_datagram = 1\n").unwrap_err().to_string(),
        @"1:26: invalid type: integer `1`, expected a boolean"
    );
}

#[test]
fn toml_errors_say_where() {
    let err = |text: &str| from_toml(text, Path::new(".")).unwrap_err().to_string();
    insta::assert_snapshot!(err("[[endpoint]]\nuri = \"udpin://x:1\"\nbogus = 1\n"), @"3:1: unknown field `bogus`, expected one of `uri`, `group`, `dedup_ms`, `max_delay_ms`, `signing_key`, `drop_unknown_ids`, `allow_msg_in`, `block_msg_in`, `allow_msg_out`, `block_msg_out`, `allow_src_sys_in`, `block_src_sys_in`, `allow_src_sys_out`, `block_src_sys_out`, `allow_src_comp_in`, `block_src_comp_in`, `allow_src_comp_out`, `block_src_comp_out`");
    insta::assert_snapshot!(err("[[endpoint]]\nuri = \"ftp://x:1\"\n"), @r#"
    endpoint #1 (ftp://x:1): unknown scheme "ftp": expected udpin, udpout, udpbcast, udpmcast, tcpin, tcpout, serial or pty
      ftp://x:1
      ^
      hint: accepted forms: udpin://HOST:PORT, udpout://HOST:PORT[?replies=any], udpbcast://ADDR:PORT, udpmcast://GROUP:PORT[?iface=NAME], tcpin://HOST:PORT, tcpout://HOST:PORT, serial://PATH[:BAUD], pty://NAME; pymavlink spellings (udpin:HOST:PORT, tcp:HOST:PORT, serial:PATH:BAUD) work too
    "#);
    insta::assert_snapshot!(err("[[endpoint]]\nuri = \"udpin://x:1\"\nsigning_key = \"abc\"\n"), @"endpoint #1 (udpin://x:1): signing_key must be 64 hex digits");
    insta::assert_snapshot!(err("[endpoint]\nuri = \"udpin://x:1\"\n"), @r"
    1:1: invalid type: map, expected a sequence
      hint: write [[endpoint]], with double brackets, once per endpoint
    ");
    insta::assert_snapshot!(err("peer_expiry = 1e300\n[[endpoint]]\nuri = \"udpin://x:1\"\n"), @"peer_expiry = 1e300: use a number of seconds from 0 to 1e9 (about 31 years), e.g. 10 or 0.5");
}

#[test]
fn mavlink_router_main_conf() {
    let text = "
[General]
TcpServerPort = 5760
ReportStats = false
Log = /var/log/flight
DeduplicationPeriod = 50

[UartEndpoint alpha]
Device = /dev/ttyS1
Baud = 57600,115200

[UdpEndpoint gcs]
Mode = Normal
Address = 127.0.0.1
Port = 14550
AllowMsgIdOut = 0, 30
BlockSrcSysIn = 66
Group = radios

[UdpEndpoint listen]
mode = server
address = 0.0.0.0
port = 14551
group = radios

[TcpEndpoint companion]
Address = 10.0.0.2
Port = 5790
Colour = blue
";
    let c = from_main_conf(text).unwrap();
    let endpoints: Vec<String> = c.endpoints.iter().map(|e| e.endpoint.to_string()).collect();
    assert_eq!(
        endpoints,
        [
            "tcpin://0.0.0.0:5760",
            "serial:///dev/ttyS1:57600",
            "udpout://127.0.0.1:14550",
            "udpin://0.0.0.0:14551",
            "tcpout://10.0.0.2:5790"
        ]
    );
    assert_eq!(c.tlog.as_deref(), Some(Path::new("/var/log/flight")));
    let gcs = &c.endpoints[2].link;
    assert_eq!(gcs.outbound.allow_msg.as_slice(), [0, 30]);
    assert!(gcs.inbound.block_src_sys.contains(66));
    assert!(c.endpoints.iter().all(|e| e.link.dedup_window_us == 50_000));
    assert_eq!((gcs.group, c.endpoints[3].link.group), (1, 1));
    assert_eq!(
        c.warnings,
        ["[TcpEndpoint companion]: key \"colour\" is not supported, ignored"]
    );
}

/// The deduplication period is the whole router's, as in mavlink-router: it holds for the
/// endpoints of sections before `[General]` and for the TCP server's clients too.
#[test]
fn main_conf_deduplication_holds_for_every_endpoint() {
    let text = "
[UdpEndpoint radio]
Mode = Server
Port = 14550

[General]
DeduplicationPeriod = 20
TcpServerPort = 5760

[UdpEndpoint gcs]
Address = 127.0.0.1
Port = 14551
";
    let c = from_main_conf(text).unwrap();
    let windows: Vec<(String, u64)> = c
        .endpoints
        .iter()
        .map(|e| (e.endpoint.to_string(), e.link.dedup_window_us))
        .collect();
    assert_eq!(
        windows,
        [
            ("udpin://0.0.0.0:14550".to_owned(), 20_000),
            ("tcpin://0.0.0.0:5760".to_owned(), 20_000),
            ("udpout://127.0.0.1:14551".to_owned(), 20_000),
        ]
    );
}

/// Every `[General]` key mavlink-router documents is honoured, or reported once with what the
/// router does instead.
#[test]
fn main_conf_general_keys_are_honoured_or_reported() {
    let text = "
[General]
ReportStats = true
MavlinkDialect = ardupilotmega
LogMode = while-armed
MinFreeSpace = 1000000
MaxLogFiles = 10
LogSystemId = 1
SnifferSysid = 254
DebugLogLevel = debug

[UartEndpoint a]
Device = /dev/ttyUSB0
FlowControl = false

[UdpEndpoint b]
Address = 127.0.0.1
Port = 14550
Filter = 0,30
";
    let c = from_main_conf(text).unwrap();
    assert_eq!(c.stats_every, Some(std::time::Duration::from_secs(1)));
    assert_eq!(
        (c.retention.max_files, c.retention.min_free_bytes),
        (Some(10), Some(1_000_000))
    );
    assert_eq!(c.dialects, [Path::new("ardupilotmega")]);
    assert_eq!(c.endpoints[1].link.outbound.allow_msg.as_slice(), [0, 30]);
    assert_eq!(
        (c.log_mode, c.log_system_id),
        (Some(LogMode::WhileArmed), Some(1))
    );
    insta::assert_debug_snapshot!(c.warnings, @r#"
    [
        "[General] DebugLogLevel = debug: not supported; the router has no log levels; it prints its errors and warnings",
        "[General] SnifferSysid = 254: not supported; there is no sniffer; every system's frames are routed by their targets",
    ]
    "#);
    let quiet =
        from_main_conf("[General]\nReportStats = false\nMavlinkDialect = auto\nLogMode = always\n")
            .unwrap();
    assert_eq!(
        (
            quiet.stats_every,
            quiet.dialects.len(),
            quiet.warnings.len()
        ),
        (None, 0, 0)
    );
}

#[test]
fn main_conf_errors_say_where() {
    let err = |text: &str| from_main_conf(text).unwrap_err().to_string();
    insta::assert_snapshot!(err("[UdpEndpoint a]\nPort = 99999\n"), @r#"[UdpEndpoint a] Port = "99999": not a port"#);
    insta::assert_snapshot!(err("[TcpEndpoint a]\nAddress = 10.0.0.2\nPort = 0\n"), @"[TcpEndpoint a] Port = 0: nothing can be sent to port 0; give the port the peer listens on");
    insta::assert_snapshot!(err("[UdpEndpoint a]\nMode = Normal\nAddress = 10.0.0.2\nPort = 0\n"), @"[UdpEndpoint a] Port = 0: nothing can be sent to port 0; give the port the peer listens on");
    insta::assert_snapshot!(err("[UdpEndpoint a]\nMode = Sideways\nPort = 1\n"), @r#"[UdpEndpoint a] Mode = "sideways": expected Normal, Client, Server or Eavesdropping"#);
    insta::assert_snapshot!(err("[UartEndpoint a]\nBaud = 1\n"), @"[UartEndpoint a]: Device is missing");
    // Found by fuzzing: an empty value is no device or address either.
    insta::assert_snapshot!(err("[UartEndpoint a]\nDevice = \n"), @"[UartEndpoint a]: Device is missing");
    insta::assert_snapshot!(err("[UdpEndpoint a]\nAddress =\nPort = 1\n"), @"[UdpEndpoint a]: Address is empty");
    insta::assert_snapshot!(err("[General]\nReportStats = maybe\n"), @r#"[General] ReportStats = "maybe": expected true or false"#);
    insta::assert_snapshot!(err("[General]\nMavlinkDialect = px4\n"), @r#"[General] MavlinkDialect = "px4": expected auto, common or ardupilotmega"#);
    insta::assert_snapshot!(err("[UartEndpoint a]\nDevice = /dev/x\nFlowControl = sometimes\n"), @r#"[UartEndpoint a] FlowControl = "sometimes": expected true or false"#);
    insta::assert_snapshot!(err("[UartEndpoint a]\nDevice = /dev/ttyS1\nBaud = 0\n"), @r#"[UartEndpoint a] Baud = "0": not a baud rate"#);
    insta::assert_snapshot!(err("[UdpEndpoint a]\nAddress = 10.0.0.1]\nPort = 1\n"), @r#"[UdpEndpoint a] Address = "10.0.0.1]": not a host"#);
    insta::assert_snapshot!(err("[TcpEndpoint a]\nAddress = \nPort = 1\n"), @"[TcpEndpoint a]: Address is missing");
    insta::assert_snapshot!(err("[General]\n[UdpEndpoint a\nPort = 1\n"), @r#"
    2:1: "[UdpEndpoint a": a section header without its closing ]
      hint: write it as [UdpEndpoint a]
    "#);
    insta::assert_snapshot!(err("[UdpEndpoint a]\nPort = 1\nAllowMsgIdOut = 1,x\n"), @r#"[UdpEndpoint a] allowmsgidout: "x" is not a valid number"#);
}

/// A scheme the caller registers (as the CLI registers `zenoh://`): its endpoints land in
/// `extra`, in file order, with their filters and group; one that does not parse is refused
/// with the scheme's own error; without the extension, the scheme is unknown.
#[test]
fn toml_endpoints_of_a_scheme_the_caller_registers() {
    const SCHEMES: &[Extension<String>] = &[Extension {
        scheme: "bus",
        usage: "bus://NAME",
        parse: |uri| match uri.strip_prefix("bus://") {
            Some(name) if !name.is_empty() => Ok(name.to_owned()),
            _ => Err(UriError::new(uri, 6, "a bus needs a name")),
        },
    }];
    let text = r#"
[[endpoint]]
uri = "bus://left"
group = "buses"
block_msg_in = [4]

[[endpoint]]
uri = "udpin://127.0.0.1:14550"

[[endpoint]]
uri = "bus://right"
group = "buses"
"#;
    let c = from_toml_with(text, Path::new("."), SCHEMES).unwrap();
    assert_eq!(c.endpoints.len(), 1);
    let names: Vec<&str> = c.extra.iter().map(|(name, _)| name.as_str()).collect();
    assert_eq!(names, ["left", "right"]);
    let (left, right) = (&c.extra[0].1, &c.extra[1].1);
    assert!(left.group != 0 && left.group == right.group, "one group");
    assert_eq!(left.inbound.block_msg.as_slice(), [4]);
    assert!(right.inbound.block_msg.is_empty());

    let bad = "[[endpoint]]\nuri = \"bus://\"\n";
    insta::assert_snapshot!(from_toml_with(bad, Path::new("."), SCHEMES).unwrap_err(), @r"
    endpoint #1 (bus://): a bus needs a name
      bus://
            ^
      hint: bus://NAME
    ");
    let err = from_toml("[[endpoint]]\nuri = \"bus://left\"\n", Path::new(".")).unwrap_err();
    assert!(err.to_string().contains("unknown scheme \"bus\""), "{err}");
}

/// Every filter of `rules` lists something.
fn every_filter_set(rules: &ferrolink_runtime::mavlink::router::Filter) -> bool {
    !rules.allow_msg.is_empty()
        && !rules.block_msg.is_empty()
        && !rules.allow_src_sys.is_empty()
        && !rules.block_src_sys.is_empty()
        && !rules.allow_src_comp.is_empty()
        && !rules.block_src_comp.is_empty()
}

/// The fuzzer's `every-key` seeds are files the router takes whole, each key with a value that
/// is not its default, so fuzzing starts from every key-dependent path.
#[test]
fn the_every_key_fuzz_seeds_set_every_key() {
    let seeds = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/router_config");
    let read = |name: &str| std::fs::read_to_string(seeds.join(name)).unwrap();

    let c = from_toml(&read("every-key.toml"), Path::new(".")).unwrap();
    assert_eq!(c.warnings, Vec::<String>::new());
    assert_eq!(c.dialects.len(), 2);
    assert!(c.tlog.is_some() && c.stats_json.is_some() && c.peer_expiry.is_some());
    assert!(c.queue.is_some() && c.one_frame_per_datagram == Some(true));
    let first = &c.endpoints[0].link;
    assert!(every_filter_set(&first.inbound) && every_filter_set(&first.outbound));
    assert!(first.require_signing.is_some() && first.drop_unknown_ids);
    assert!(first.group != 0 && first.dedup_window_us != 0 && first.max_delay_us != 0);

    let c = from_main_conf(&read("every-key.conf")).unwrap();
    // Every key was read: the warnings are for keys the router does not honour, each saying
    // what it does instead, and for the section the seed adds to be ignored.
    insta::assert_debug_snapshot!(c.warnings, @r#"
    [
        "[General] DebugLogLevel = info: not supported; the router has no log levels; it prints its errors and warnings",
        "[UartEndpoint autopilot] FlowControl = true: not supported; the port is opened without flow control",
        "[TcpEndpoint companion] RetryTimeout = 5: not supported; the connection is retried with a backoff from 50 ms doubling to 1 s",
        "[Unknown]: unknown section, ignored",
    ]
    "#);
    assert!(c.tlog.is_some());
    let kinds: Vec<_> = c
        .endpoints
        .iter()
        .map(|e| match &e.endpoint {
            Endpoint::TcpIn(..) => "tcpin",
            Endpoint::Serial(..) => "serial",
            Endpoint::UdpIn(..) => "udpin",
            Endpoint::UdpOut(..) => "udpout",
            Endpoint::TcpOut(..) => "tcpout",
            _ => "other",
        })
        .collect();
    assert_eq!(
        kinds,
        ["tcpin", "serial", "udpin", "udpin", "udpout", "tcpout"]
    );
    let links: Vec<_> = c.endpoints.iter().map(|e| &e.link).collect();
    assert!(links.iter().all(|l| l.dedup_window_us == 100_000));
    let (uart, listen, gcs) = (links[1], links[2], links[4]);
    assert!(!uart.inbound.allow_src_sys.is_empty() && !uart.inbound.block_src_comp.is_empty());
    assert!(!listen.inbound.allow_msg.is_empty() && !listen.inbound.block_msg.is_empty());
    assert!(listen.group != 0 && listen.group == links[3].group);
    assert!(every_filter_set(&gcs.outbound));
}
