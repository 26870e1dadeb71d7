//! Interface URI parsing, defaults, routes and the canonical `Display` form.

use ferrolink_io::{Interface, Transport, UriError};

fn parse(uri: &str) -> Interface {
    uri.parse()
        .unwrap_or_else(|e| panic!("{uri:?} should parse: {e}"))
}

fn transport(uri: &str) -> Transport {
    let endpoint = parse(uri);
    assert!(endpoint.routes.is_empty(), "{uri}: unexpected routes");
    endpoint.transport
}

/// The error message (without the hint) for a URI that must not parse.
fn error(uri: &str) -> String {
    match uri.parse::<Interface>() {
        Ok(e) => panic!("{uri:?} should not parse, got {e:?}"),
        Err(e) => e.message().to_owned(),
    }
}

fn serial(path: &str, baud: u32) -> Transport {
    Transport::Serial {
        path: path.into(),
        baud,
    }
}

fn udp(host: &str, in_port: u16, out_port: u16) -> Transport {
    Transport::Udp {
        host: host.into(),
        in_port,
        out_port,
    }
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
        Transport::Tcp {
            host: "192.168.1.5".into(),
            port: 34000
        }
    );
    assert_eq!(
        transport("tcp://robot.local:4000"),
        Transport::Tcp {
            host: "robot.local".into(),
            port: 4000
        }
    );
    assert_eq!(
        transport("tcp-listen://:4000"),
        Transport::TcpListen {
            host: "0.0.0.0".into(),
            port: 4000
        }
    );
    assert_eq!(
        transport("tcp-listen://127.0.0.1:4000"),
        Transport::TcpListen {
            host: "127.0.0.1".into(),
            port: 4000
        }
    );
}

#[test]
fn pty_forms() {
    assert_eq!(
        transport("pty:///tmp/ndlcom0"),
        Transport::Pty {
            name: "/tmp/ndlcom0".into()
        }
    );
    assert_eq!(
        transport("pty://ttyBridge"),
        Transport::Pty {
            name: "ttyBridge".into()
        }
    );
}

#[test]
fn ipv6_hosts() {
    assert_eq!(transport("udp://[::1]:5000:5001"), udp("::1", 5000, 5001));
    assert_eq!(transport("udp://[fe80::1]"), udp("fe80::1", 34000, 34001));
    assert_eq!(
        transport("tcp://[2001:db8::7]:80"),
        Transport::Tcp {
            host: "2001:db8::7".into(),
            port: 80
        }
    );
    assert_eq!(
        transport("tcp-listen://[::]:4000"),
        Transport::TcpListen {
            host: "::".into(),
            port: 4000
        }
    );
}

#[test]
fn routes() {
    let e = parse("udp://127.0.0.1:34000:34001&3,4");
    assert_eq!(e.transport, udp("127.0.0.1", 34000, 34001));
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
            transport: serial("/dev/ttyACM0", 921_600),
            routes: vec![],
        },
        Interface {
            transport: serial("/dev/odd:12", 57_600),
            routes: vec![1, 2, 3],
        },
        Interface {
            transport: serial("/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0-port0", 1),
            routes: vec![],
        },
        Interface {
            transport: udp("127.0.0.1", 34000, 34001),
            routes: vec![3, 4],
        },
        Interface {
            transport: udp("fe80::1", 0, 65535),
            routes: vec![255, 0, 255],
        },
        Interface {
            transport: Transport::Tcp {
                host: "robot.local".into(),
                port: 34000,
            },
            routes: vec![],
        },
        Interface {
            transport: Transport::Tcp {
                host: "::1".into(),
                port: 1,
            },
            routes: vec![7],
        },
        Interface {
            transport: Transport::TcpListen {
                host: "0.0.0.0".into(),
                port: 4000,
            },
            routes: vec![],
        },
        Interface {
            transport: Transport::TcpListen {
                host: "::".into(),
                port: 0,
            },
            routes: vec![42],
        },
        Interface {
            transport: Transport::Pty {
                name: "/tmp/some dir/ttyX".into(),
            },
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
    bad port "x" in udp://localhost:x: expected 0..=65535
    bad port "70000" in udp://localhost:5000:70000: expected 0..=65535
    bad port "+5" in udp://localhost:+5: expected 0..=65535
    too many ':' fields in udp://localhost:1:2:3: expected udp://HOST[:IN_PORT][:OUT_PORT]
    missing host in udp://:5000
    missing host in udp://::1:5000 (write IPv6 addresses in brackets, e.g. [::1])
    missing ']' after IPv6 host in udp://[::1:5000
    unexpected "5000" after ']' in udp://[::1]5000: expected :PORT
    empty IPv6 host "[]" in udp://[]:5000
    bad host "my host" in udp://my host: ' ' is not allowed in a host name
    missing host in tcp://
    too many ':' fields in tcp://host:1:2: expected tcp://HOST[:PORT]
    bad port "-1" in tcp://host:-1: expected 0..=65535
    missing port in tcp-listen://
    missing port in tcp-listen://5000 (to listen on all interfaces write tcp-listen://:5000)
    missing port in tcp-listen://host
    too many ':' fields in tcp-listen://:1:2: expected tcp-listen://[HOST]:PORT
    missing device path in serial://
    missing device path in serial://:115200
    bad baud rate "0" in serial:///dev/ttyUSB0:0: expected 1..=4294967295
    bad baud rate "99999999999" in serial:///dev/ttyUSB0:99999999999: expected 1..=4294967295
    missing pty name in pty://
    missing pty name in pty://&3
    empty route list after '&' in udp://h&: expected &ID,ID,...
    bad route id "" in udp://h&3,: expected 0..=255 (decimal) or 0x00..=0xff
    bad route id "256" in udp://h&256: expected 0..=255 (decimal) or 0x00..=0xff
    bad route id "0x100" in udp://h&0x100: expected 0..=255 (decimal) or 0x00..=0xff
    bad route id "0xg" in udp://h&0xg: expected 0..=255 (decimal) or 0x00..=0xff
    bad route id "-1" in udp://h&-1: expected 0..=255 (decimal) or 0x00..=0xff
    bad route id "3;4" in udp://h&3;4: expected 0..=255 (decimal) or 0x00..=0xff
    missing scheme in "/dev/ttyUSB0": expected SCHEME://...
    unknown scheme "http" in http://example.com: expected serial, udp, tcp, tcp-listen or pty
    unknown scheme "UDP" in UDP://host: expected serial, udp, tcp, tcp-listen or pty
    "#);
}

#[test]
fn error_display_has_hint() {
    let err: UriError = "udp://localhost:x".parse::<Interface>().unwrap_err();
    insta::assert_snapshot!(err.to_string(), @r#"
    bad port "x" in udp://localhost:x: expected 0..=65535
      hint: accepted forms: serial://PATH[:BAUD], udp://HOST[:IN_PORT][:OUT_PORT], tcp://HOST[:PORT], tcp-listen://[HOST]:PORT, pty://NAME; each may end with &ID,ID,... (route ids, decimal or 0x-hex)
    "#);
    // It is a proper error type.
    let boxed: Box<dyn std::error::Error> = Box::new(err);
    assert!(boxed.to_string().starts_with("bad port"));
}

#[test]
fn every_interface_opens_on_the_link_layer() {
    use ferrolink_io::link::Endpoint as L;
    let cases = [
        (
            "serial:///dev/ttyUSB0",
            L::Serial("/dev/ttyUSB0".into(), 921_600),
        ),
        ("udp://[::1]:5000:5001&3", L::Udp("::1".into(), 5000, 5001)),
        ("tcp://example.org", L::TcpOut("example.org".into(), 34000)),
        ("tcp-listen://:34000", L::TcpIn("0.0.0.0".into(), 34000)),
        ("pty:///tmp/ndlcom0", L::Pty("/tmp/ndlcom0".into())),
    ];
    for (uri, link) in cases {
        assert_eq!(parse(uri).link(), link, "{uri}");
    }
    // The link layer names a UDP pair the way the interface URI does.
    assert_eq!(
        parse("udp://[::1]:5000:5001&3").link().to_string(),
        "udp://[::1]:5000:5001"
    );
}
