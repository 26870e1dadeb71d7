//! Endpoint URIs, telemetry logs and connections on loopback.

use std::time::Duration;

use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::tlog::{self, read_tlog, redact_setup_signing};
use ferrolink_io::mavlink::{self, Connection};
use ferrolink_runtime::mavlink::{v2, Header, MessageMeta};

static META: &[MessageMeta] = &[
    MessageMeta {
        id: 0,
        crc_extra: 50,
        min_len: 9,
        max_len: 9,
        target_system: None,
        target_component: None,
    },
    MessageMeta {
        id: 256,
        crc_extra: 71,
        min_len: 42,
        max_len: 42,
        target_system: Some(8),
        target_component: Some(9),
    },
];

#[test]
fn uris_in_every_spelling() {
    let cases = [
        ("udpin://0.0.0.0:14550", "udpin://0.0.0.0:14550"),
        ("udpin:0.0.0.0:14550", "udpin://0.0.0.0:14550"),
        ("udp:0.0.0.0:14550", "udpin://0.0.0.0:14550"),
        ("udpout://10.0.0.2:14550", "udpout://10.0.0.2:14550"),
        ("udpbcast:10.0.0.255:14550", "udpbcast://10.0.0.255:14550"),
        (
            "udpout://10.0.0.2:14550?replies=any",
            "udpout://10.0.0.2:14550?replies=any",
        ),
        (
            "udpmcast://239.255.145.50:14550",
            "udpmcast://239.255.145.50:14550",
        ),
        (
            "udpmcast://[ff02::1:5]:14550?iface=eth0",
            "udpmcast://[ff02::1:5]:14550?iface=eth0",
        ),
        ("mcast:", "udpmcast://239.255.145.50:14550"),
        ("mcast:239.0.0.9:5000", "udpmcast://239.0.0.9:5000"),
        ("tcpin://[::1]:5760", "tcpin://[::1]:5760"),
        ("tcp:127.0.0.1:5760", "tcpout://127.0.0.1:5760"),
        ("tcpout://localhost:5760", "tcpout://localhost:5760"),
        ("serial:/dev/ttyUSB0:57600", "serial:///dev/ttyUSB0:57600"),
        ("serial:///dev/ttyACM0", "serial:///dev/ttyACM0:57600"),
        ("/dev/ttyACM0,115200", "serial:///dev/ttyACM0:115200"),
        (
            "serial:///dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0:921600",
            "serial:///dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0:921600",
        ),
    ];
    for (uri, canonical) in cases {
        let parsed: Endpoint = mavlink::ENDPOINTS
            .endpoint(uri)
            .unwrap_or_else(|e| panic!("{uri}: {e}"));
        assert_eq!(parsed.to_string(), canonical, "{uri}");
        assert_eq!(mavlink::ENDPOINTS.endpoint(canonical).unwrap(), parsed);
    }
    for bad in [
        "udpin://:14550",
        "udpin://host",
        "tcp:host:99999",
        "ftp://x:1",
        "x",
        "udpout://h:1?replies=some",
        "udpout://h:1?iface=eth0",
        "udpin://h:1?replies=any",
        "udpmcast://239.0.0.1:1?iface=",
        "udpmcast://239.0.0.1:1?iface=a&iface=b",
        "udpmcast://239.0.0.1:1?iface",
        "udpmcast:",
        "udpbcast://10.0.0.255:0",
    ] {
        let e = mavlink::ENDPOINTS.endpoint(bad).unwrap_err().to_string();
        assert!(e.contains(bad) && e.contains("hint"), "{bad}: {e}");
    }
}

fn frame(id: u32, crc_extra: u8, payload: &[u8], seq: u8) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(seq, 1, 1), id, crc_extra, payload, &mut out).unwrap();
    out[..n].to_vec()
}

#[test]
fn tlog_round_trip_with_monotonic_time_and_a_redacted_key() {
    let heartbeat = frame(0, 50, &[1; 9], 0);
    let mut setup = vec![0u8; 42];
    setup[8] = 1;
    setup[10..42].copy_from_slice(&[0xab; 32]);
    let setup_signing = frame(256, 71, &setup, 1);
    let mut out = Vec::new();
    let mut writer = tlog::Writer::new(&mut out);
    writer.write(2_000, &heartbeat).unwrap();
    writer.write(1_000, &setup_signing).unwrap(); // the clock stepped back
    writer.write(3_000, &heartbeat).unwrap();
    drop(writer);
    let mut records = Vec::new();
    let stats = read_tlog(&out, META, |r| {
        assert!(
            r.frame.is_checked(),
            "the redacted frame has a good checksum"
        );
        records.push((r.t_us, r.frame.msg_id(), r.frame.payload().to_vec()));
    });
    assert_eq!(stats.frames, 3);
    assert_eq!(
        records.iter().map(|r| r.0).collect::<Vec<_>>(),
        [Some(2_000), Some(2_000), Some(3_000)]
    );
    assert_eq!(records[1].1, 256);
    assert!(records[1].2.iter().skip(10).all(|&b| b == 0), "key zeroed");
    assert_eq!(records[1].2[8], 1, "the rest is kept");

    // Damage between records and a record cut off at the end.
    let mut damaged = out[..8 + heartbeat.len()].to_vec();
    damaged.extend_from_slice(&[0xfd, 0x55, 0x00, 0x13]);
    damaged.extend_from_slice(&out[8 + heartbeat.len()..]);
    damaged.extend_from_slice(&out[..12]);
    let stats = read_tlog(&damaged, META, |_| {});
    assert_eq!((stats.frames, stats.resynced), (3, 1));
    assert!(stats.truncated_bytes > 0);

    // Other frames are never touched.
    let mut hb = heartbeat.clone();
    redact_setup_signing(&mut hb);
    assert_eq!(hb, heartbeat);
}

#[test]
fn connections_talk_both_ways_over_udp() {
    let mut server = Connection::open("udpin://127.0.0.1:0", META).unwrap();
    let port = server.local_addr().unwrap().port();
    let mut client = Connection::open(&format!("udpout:127.0.0.1:{port}"), META).unwrap();
    client.set_ids(1, 1);
    client
        .send_raw(0, 50, &[2, 0, 0, 0, 2, 3, 0x51, 4, 3])
        .unwrap();
    let got = server
        .recv(Duration::from_secs(2))
        .unwrap()
        .expect("a frame");
    assert_eq!(
        (got.msg_id(), got.header().sysid, got.header().seq),
        (0, 1, 0)
    );
    assert!(got.is_checked());
    // The server answers every peer heard from.
    server.set_ids(255, 190);
    server.send_raw(0, 50, &[0; 9]).unwrap();
    let back = client
        .recv(Duration::from_secs(2))
        .unwrap()
        .expect("a reply");
    assert_eq!(back.header().sysid, 255);
}

#[cfg(feature = "tokio")]
#[tokio::test(flavor = "current_thread")]
async fn async_connections_talk_both_ways() {
    use ferrolink_io::mavlink::AsyncConnection;
    let mut server = AsyncConnection::connect("udpin://127.0.0.1:0", META).unwrap();
    let port = server.local_addr().unwrap().port();
    let mut client = AsyncConnection::connect(&format!("udpout://127.0.0.1:{port}"), META).unwrap();
    client.set_ids(7, 1);
    client
        .send_raw(0, 50, &[2, 0, 0, 0, 2, 3, 0x51, 4, 3])
        .unwrap();
    let limit = Duration::from_secs(2);
    let got = tokio::time::timeout(limit, server.recv())
        .await
        .expect("in time")
        .unwrap();
    assert_eq!((got.msg_id(), got.header().sysid), (0, 7));
    server.send_raw(0, 50, &[0; 9]).unwrap();
    let back = tokio::time::timeout(limit, client.recv())
        .await
        .expect("in time")
        .unwrap();
    assert_eq!(back.header().sysid, 255);
}

/// A serial link on a pseudo-terminal: frames both ways; then the device goes away (the pty is
/// closed, as when a USB adapter is unplugged) and comes back, and the serial side resumes.
#[cfg(unix)]
#[test]
fn serial_survives_unplugging() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttyFAKE");
    let pty_uri = format!("pty://{}", link.display());
    let mut device = Connection::open(&pty_uri, META).unwrap();
    let mut serial =
        Connection::open(&format!("serial://{}:115200", link.display()), META).unwrap();
    serial.set_ids(1, 1);
    let heartbeat = [0, 0, 0, 0, 2, 3, 0x51, 4, 3];
    let wait_for_peer = |c: &mut Connection| {
        for _ in 0..50 {
            c.poll();
            if c.peers() > 0 {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        panic!("no peer");
    };
    wait_for_peer(&mut serial);
    serial.send_raw(0, 50, &heartbeat).unwrap();
    let got = device
        .recv(Duration::from_secs(2))
        .unwrap()
        .expect("a frame");
    assert_eq!(got.header().sysid, 1);
    wait_for_peer(&mut device);
    device.send_raw(0, 50, &heartbeat).unwrap();
    assert!(serial.recv(Duration::from_secs(2)).unwrap().is_some());

    // Unplug: the serial side sees the device go and has no peer.
    drop(device);
    for _ in 0..50 {
        serial.poll();
        if serial.peers() == 0 {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(serial.peers(), 0, "the unplugged device is reported down");
    // Plug it back in: within about a second the serial side has reopened it.
    let mut device = Connection::open(&pty_uri, META).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    for _ in 0..60 {
        serial.poll();
        if serial.peers() > 0 {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    serial.send_raw(0, 50, &heartbeat).unwrap();
    let got = device
        .recv(Duration::from_secs(2))
        .unwrap()
        .expect("a frame after replugging");
    assert_eq!(got.header().seq, 1);
}

#[path = "scripts/mavlink.rs"]
mod scripts;

/// The reader invariants on every real capture (when `../shared/captures` is there), on damaged
/// copies of them, and on the tlog this file writes.
#[test]
fn tlog_reader_invariants_on_real_and_damaged_logs() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/captures");
    let mut logs: Vec<Vec<u8>> = std::fs::read_dir(&dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| std::fs::read(e.path()).ok())
        .collect();
    logs.push({
        let mut out = Vec::new();
        let mut writer = tlog::Writer::new(&mut out);
        for i in 0..50u8 {
            writer
                .write(u64::from(i) * 1000, &frame(0, 50, &[i; 9], i))
                .unwrap();
        }
        drop(writer);
        out
    });
    for log in &logs {
        let log = &log[..log.len().min(200_000)];
        scripts::check_tlog(log, META);
        // Damage: a flipped byte every 997, and a cut in the middle.
        let mut damaged = log.to_vec();
        for b in damaged.iter_mut().step_by(997) {
            *b ^= 0x5a;
        }
        scripts::check_tlog(&damaged, META);
        scripts::check_tlog(&log[..log.len() / 2 + 3], META);
    }
}

#[test]
fn config_readers_survive_odd_text() {
    for text in [
        "",
        "[[endpoint]]\nuri = \"udpin://[::1]:1\"\n",
        "[UdpEndpoint x]\nPort=5\nAddress=::1\n",
        "udpin://a:b:1",
        "serial:///dev/x:0",
        "pty://",
        "tcp:[::1]:80",
        "[General]\nTcpServerPort=70000\n",
        "[UartEndpoint]\nDevice=/dev/x,9600\n",
        "\u{0}\u{ff}[",
        // Found by fuzzing: an empty device, and a bracket in an address.
        "[UartEndpoint alpha]\nDevice = ",
        "[UdpEndpoint gcs]\nMode = Normal\nAddress =2127.0.0.\u{0}]\nPort = 145\n",
        "udpout://[::1]]:5",
        // Found by fuzzing: a main.conf client sending to port 0, which a URI refuses.
        "[TcpEndpoint c]\nAddress = 10.0.0.2\nPort =0\n",
        "[UdpEndpoint c]\nAddress = 10.0.0.2\nPort = 0\n",
    ] {
        scripts::check_config(text.as_bytes());
    }
}

/// The blocking iterator waits through a quiet spell longer than any `recv` timeout a loop
/// would use, and goes on with the next frame.
#[test]
fn frames_block_through_quiet_spells() {
    let mut server = Connection::open("udpin://127.0.0.1:0", META).unwrap();
    let port = server.local_addr().unwrap().port();
    let sender = std::thread::spawn(move || {
        let mut client = Connection::open(&format!("udpout:127.0.0.1:{port}"), META).unwrap();
        client.set_ids(7, 1);
        for pause in [0, 1500] {
            std::thread::sleep(Duration::from_millis(pause));
            client.send_raw(0, 50, &[0; 9]).unwrap();
        }
    });
    let got: Vec<u8> = server
        .frames()
        .take(2)
        .map(|f| f.expect("a frame").header().seq)
        .collect();
    assert_eq!(got, [0, 1]);
    sender.join().unwrap();
}
