//! Interface URI parsing, defaults, routes and the canonical `Display` form.

use ferrolink_io::link::Endpoint;
use ferrolink_io::ndlcom::Interface;
use ferrolink_io::uri::UriError;

fn parse(uri: &str) -> Interface {
    uri.parse()
        .unwrap_or_else(|e| panic!("{uri:?} should parse: {e}"))
}

fn transport(uri: &str) -> Endpoint {
    let interface = parse(uri);
    assert!(interface.routes.is_empty(), "{uri}: unexpected routes");
    interface.endpoint
}

/// The URI, the offending part's offset and the message (without the hint) for a URI that must
/// not parse.
fn error(uri: &str) -> String {
    match uri.parse::<Interface>() {
        Ok(e) => panic!("{uri:?} should not parse, got {e:?}"),
        Err(e) => format!("{uri} @{}: {}", e.at(), e.message()),
    }
}

fn serial(path: &str, baud: u32) -> Endpoint {
    Endpoint::Serial(path.into(), baud)
}

fn udp(host: &str, in_port: u16, out_port: u16) -> Endpoint {
    Endpoint::Udp(host.into(), in_port, out_port)
}

#[test]
fn serial_forms() {
    assert_eq!(
        transport("serial:///dev/ttyUSB0"),
        serial("/dev/ttyUSB0", 921_600)
    );
    assert_eq!(
        transport("serial:///dev/ttyUSB0:115200"),
        serial("/dev/ttyUSB0", 115_200)
    );
    assert_eq!(transport("serial://ttyS1:9600"), serial("ttyS1", 9600));
    // Colons that are not followed by digits only belong to the path.
    assert_eq!(
        transport("serial:///dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0-port0"),
        serial(
            "/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0-port0",
            921_600
        )
    );
    assert_eq!(
        transport("serial:///dev/odd:12:57600"),
        serial("/dev/odd:12", 57_600)
    );
}

#[test]
fn udp_forms() {
    assert_eq!(transport("udp://localhost"), udp("localhost", 34000, 34001));
    assert_eq!(
        transport("udp://10.0.0.2:5000"),
        udp("10.0.0.2", 5000, 34001)
    );
    assert_eq!(
        transport("udp://10.0.0.2:5000:5001"),
        udp("10.0.0.2", 5000, 5001)
    );
    assert_eq!(transport("udp://robot::5001"), udp("robot", 34000, 5001));
    assert_eq!(transport("udp://robot:0:1"), udp("robot", 0, 1));
    assert_eq!(transport("udp://h:65535:65535"), udp("h", 65535, 65535));
}

#[test]
fn tcp_forms() {
    assert_eq!(
        transport("tcp://192.168.1.5"),
        Endpoint::TcpOut("192.168.1.5".into(), 34000)
    );
    assert_eq!(
        transport("tcp://robot.local:4000"),
        Endpoint::TcpOut("robot.local".into(), 4000)
    );
    assert_eq!(
        transport("tcp-listen://:4000"),
        Endpoint::TcpIn("0.0.0.0".into(), 4000)
    );
    assert_eq!(
        transport("tcp-listen://127.0.0.1:4000"),
        Endpoint::TcpIn("127.0.0.1".into(), 4000)
    );
}

#[test]
fn pty_forms() {
    assert_eq!(
        transport("pty:///tmp/ndlcom0"),
        Endpoint::Pty("/tmp/ndlcom0".into())
    );
    assert_eq!(
        transport("pty://ttyBridge"),
        Endpoint::Pty("ttyBridge".into())
    );
}

#[test]
fn ipv6_hosts() {
    assert_eq!(transport("udp://[::1]:5000:5001"), udp("::1", 5000, 5001));
    assert_eq!(transport("udp://[fe80::1]"), udp("fe80::1", 34000, 34001));
    assert_eq!(
        transport("tcp://[2001:db8::7]:80"),
        Endpoint::TcpOut("2001:db8::7".into(), 80)
    );
    assert_eq!(
        transport("tcp-listen://[::]:4000"),
        Endpoint::TcpIn("::".into(), 4000)
    );
}

#[test]
fn routes() {
    let e = parse("udp://127.0.0.1:34000:34001&3,4");
    assert_eq!(e.endpoint, udp("127.0.0.1", 34000, 34001));
    assert_eq!(e.routes, [3, 4]);

    assert_eq!(parse("serial:///dev/ttyUSB0&0x10").routes, [0x10]);
    assert_eq!(
        parse("serial:///dev/ttyUSB0:115200&0,255,0xFF,0x0a, 7").routes,
        [0, 255, 255, 10, 7]
    );
    assert_eq!(parse("tcp-listen://:4000&1").routes, [1]);
    assert_eq!(parse("pty:///tmp/x&2,3").routes, [2, 3]);
    assert_eq!(parse("udp://[::1]:1:2&9").routes, [9]);
}

#[test]
fn display_spells_out_defaults() {
    let shown: Vec<String> = [
        "serial:///dev/ttyUSB0",
        "udp://localhost",
        "udp://robot::5001",
        "udp://[::1]",
        "tcp://robot",
        "tcp-listen://:4000",
        "tcp-listen://[::]:4000",
        "pty://ttyX&0x10,3",
    ]
    .iter()
    .map(|uri| parse(uri).to_string())
    .collect();
    insta::assert_snapshot!(shown.join("\n"), @r"
    serial:///dev/ttyUSB0:921600
    udp://localhost:34000:34001
    udp://robot:34000:5001
    udp://[::1]:34000:34001
    tcp://robot:34000
    tcp-listen://0.0.0.0:4000
    tcp-listen://[::]:4000
    pty://ttyX&16,3
    ");
}

#[test]
fn display_round_trips() {
    let endpoints = [
        Interface {
            endpoint: serial("/dev/ttyACM0", 921_600),
            routes: vec![],
        },
        Interface {
            endpoint: serial("/dev/odd:12", 57_600),
            routes: vec![1, 2, 3],
        },
        Interface {
            endpoint: serial("/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0-port0", 1),
            routes: vec![],
        },
        Interface {
            endpoint: udp("127.0.0.1", 34000, 34001),
            routes: vec![3, 4],
        },
        Interface {
            endpoint: udp("fe80::1", 0, 65535),
            routes: vec![255, 0, 255],
        },
        Interface {
            endpoint: Endpoint::TcpOut("robot.local".into(), 34000),
            routes: vec![],
        },
        Interface {
            endpoint: Endpoint::TcpOut("::1".into(), 1),
            routes: vec![7],
        },
        Interface {
            endpoint: Endpoint::TcpIn("0.0.0.0".into(), 4000),
            routes: vec![],
        },
        Interface {
            endpoint: Endpoint::TcpIn("::".into(), 0),
            routes: vec![42],
        },
        Interface {
            endpoint: Endpoint::Pty("/tmp/some dir/ttyX".into()),
            routes: vec![0x10],
        },
    ];
    for endpoint in endpoints {
        let text = endpoint.to_string();
        let back: Interface = text
            .parse()
            .unwrap_or_else(|e| panic!("{text:?} (from {endpoint:?}) does not parse: {e}"));
        assert_eq!(back, endpoint, "{text}");
        // And the canonical form is a fixed point.
        assert_eq!(back.to_string(), text);
    }
}

#[test]
fn error_messages() {
    let errors: Vec<String> = [
        "udp://localhost:x",
        "udp://localhost:5000:70000",
        "udp://localhost:+5",
        "udp://localhost:1:2:3",
        "udp://:5000",
        "udp://::1:5000",
        "udp://[::1:5000",
        "udp://[::1]5000",
        "udp://[]:5000",
        "udp://my host",
        "tcp://",
        "tcp://host:1:2",
        "tcp://host:-1",
        "tcp://host:0",
        "udp://host:5000:0",
        "tcp-listen://",
        "tcp-listen://5000",
        "tcp-listen://host",
        "tcp-listen://:1:2",
        "serial://",
        "serial://:115200",
        "serial:///dev/ttyUSB0:0",
        "serial:///dev/ttyUSB0:99999999999",
        "pty://",
        "pty://&3",
        "udp://h&",
        "udp://h&3,",
        "udp://h&256",
        "udp://h&0x100",
        "udp://h&0xg",
        "udp://h&-1",
        "udp://h&3;4",
        "/dev/ttyUSB0",
        "http://example.com",
        "UDP://host",
    ]
    .iter()
    .map(|uri| error(uri))
    .collect();
    insta::assert_snapshot!(errors.join("\n"), @r#"
    udp://localhost:x @16: bad port "x": expected 0..=65535
    udp://localhost:5000:70000 @21: bad port "70000": expected 0..=65535
    udp://localhost:+5 @16: bad port "+5": expected 0..=65535
    udp://localhost:1:2:3 @20: too many ':' fields: expected udp://HOST[:IN_PORT][:OUT_PORT]
    udp://:5000 @6: missing host
    udp://::1:5000 @6: missing host (write IPv6 addresses in brackets, e.g. [::1])
    udp://[::1:5000 @6: missing ']' after IPv6 host
    udp://[::1]5000 @11: unexpected "5000" after ']': expected :PORT
    udp://[]:5000 @6: empty IPv6 host "[]"
    udp://my host @6: bad host "my host": ' ' is not allowed in a host name
    tcp:// @6: missing host
    tcp://host:1:2 @13: too many ':' fields: expected tcp://HOST[:PORT]
    tcp://host:-1 @11: bad port "-1": expected 0..=65535
    tcp://host:0 @11: port 0: nothing can be sent to port 0; give the port the peer listens on
    udp://host:5000:0 @16: port 0: nothing can be sent to port 0; give the port the peer listens on
    tcp-listen:// @13: missing port
    tcp-listen://5000 @17: missing port (to listen on all interfaces write tcp-listen://:5000)
    tcp-listen://host @17: missing port
    tcp-listen://:1:2 @16: too many ':' fields: expected tcp-listen://[HOST]:PORT
    serial:// @9: missing device path
    serial://:115200 @9: missing device path
    serial:///dev/ttyUSB0:0 @22: bad baud rate "0": expected 1..=4294967295
    serial:///dev/ttyUSB0:99999999999 @22: bad baud rate "99999999999": expected 1..=4294967295
    pty:// @6: missing pty name
    pty://&3 @6: missing pty name
    udp://h& @8: empty route list after '&': expected &ID,ID,...
    udp://h&3, @10: bad route id "": expected 0..=255 (decimal) or 0x00..=0xff
    udp://h&256 @8: bad route id "256": expected 0..=255 (decimal) or 0x00..=0xff
    udp://h&0x100 @8: bad route id "0x100": expected 0..=255 (decimal) or 0x00..=0xff
    udp://h&0xg @8: bad route id "0xg": expected 0..=255 (decimal) or 0x00..=0xff
    udp://h&-1 @8: bad route id "-1": expected 0..=255 (decimal) or 0x00..=0xff
    udp://h&3;4 @8: bad route id "3;4": expected 0..=255 (decimal) or 0x00..=0xff
    /dev/ttyUSB0 @0: missing scheme: expected SCHEME://...
    http://example.com @0: unknown scheme "http": expected serial, udp, tcp, tcp-listen or pty
    UDP://host @0: unknown scheme "UDP": expected serial, udp, tcp, tcp-listen or pty
    "#);
}

#[test]
fn error_display_has_hint() {
    let err: UriError = "udp://localhost:x".parse::<Interface>().unwrap_err();
    insta::assert_snapshot!(err.to_string(), @r#"
    bad port "x": expected 0..=65535
      udp://localhost:x
                      ^
      hint: accepted forms: serial://PATH[:BAUD], udp://HOST[:IN_PORT][:OUT_PORT], tcp://HOST[:PORT], tcp-listen://[HOST]:PORT, pty://NAME; each may end with &ID,ID,... (route ids, decimal or 0x-hex)
    "#);
    // It is a proper error type.
    let boxed: Box<dyn std::error::Error> = Box::new(err);
    assert!(boxed.to_string().starts_with("bad port"));
}

#[test]
fn the_link_layer_names_a_udp_pair_the_way_the_interface_uri_does() {
    assert_eq!(
        parse("udp://[::1]:5000:5001&3").endpoint.to_string(),
        "udp://[::1]:5000:5001"
    );
}

#[test]
fn errors_point_at_the_offending_part() {
    for (uri, part) in [
        ("udp://localhost:x", "x"),
        ("udp://localhost:1:2:3", "3"),
        ("udp://my host", "my host"),
        ("udp://h&1,0x100", "0x100"),
        ("serial:///dev/ttyUSB0:0", "0"),
        ("serial:///dev/ttyUSB0:fast", "fast"),
        ("http://example.com", "http"),
        ("tcp-listen://host", ""),
        ("udp://h:0:0", "0"),
    ] {
        let err = uri.parse::<Interface>().unwrap_err();
        assert_eq!(
            err.at(),
            uri.rfind(part)
                .map_or(uri.len(), |at| if part.is_empty() { uri.len() } else { at }),
            "{uri}: {err}"
        );
        assert_eq!(err.uri(), uri);
        assert!(err.hint().starts_with("accepted forms:"), "{uri}: {err}");
    }
}

#[test]
fn one_grammar_many_protocols() {
    use ferrolink_io::mavlink;
    // The same scheme means what each protocol's users expect...
    assert_eq!(
        mavlink::ENDPOINTS.endpoint("udp://0.0.0.0:14550").unwrap(),
        Endpoint::UdpIn("0.0.0.0".into(), 14550)
    );
    assert_eq!(
        transport("udp://0.0.0.0:14550"),
        udp("0.0.0.0", 14550, 34001)
    );
    // ...with each protocol's own defaults...
    assert_eq!(
        mavlink::ENDPOINTS
            .endpoint("serial:///dev/ttyUSB0")
            .unwrap(),
        serial("/dev/ttyUSB0", 57_600)
    );
    assert_eq!(
        transport("serial:///dev/ttyUSB0"),
        serial("/dev/ttyUSB0", 921_600)
    );
    // ...and its own loose spellings: NDLCom has none, MAVLink takes pymavlink's.
    assert!(mavlink::ENDPOINTS.endpoint("/dev/ttyACM0,115200").is_ok());
    assert!("/dev/ttyACM0,115200".parse::<Interface>().is_err());
    // Routes belong to NDLCom: in a MAVLink URI an '&' is no host character.
    let err = mavlink::ENDPOINTS.endpoint("udpin://h&3:1").unwrap_err();
    assert_eq!(
        (err.message(), err.at()),
        ("bad host \"h&3\": '&' is not allowed in a host name", 8)
    );
}

#[test]
fn clients_need_a_port_to_send_to() {
    use ferrolink_io::mavlink;
    for (uri, at) in [
        ("udpout://[::1]:0", 15),
        ("tcpout://127.0.0.1:0", 19),
        ("tcp://127.0.0.1:0", 16),
    ] {
        let err = mavlink::ENDPOINTS.endpoint(uri).unwrap_err();
        assert_eq!(err.at(), at, "{uri}: {err}");
        assert!(
            err.message().starts_with("port 0: nothing can be sent"),
            "{err}"
        );
    }
    // Listening on port 0 (any free port) stays allowed.
    for uri in [
        "udpin://127.0.0.1:0",
        "tcpin://127.0.0.1:0",
        "udp://127.0.0.1:0",
    ] {
        assert!(mavlink::ENDPOINTS.endpoint(uri).is_ok(), "{uri}");
    }
}
