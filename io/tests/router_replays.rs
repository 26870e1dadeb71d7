//! Replay protection in the router daemon is kept per signing key, keyed as the spec keys it,
//! (link id, system, component): a captured signed frame replayed from a new UDP port, over a
//! new TCP connection, through a reopened serial device or into another endpoint with the same
//! key is dropped, while fresh frames pass.
//!
//! Before, each peer had its own replay state, so every one of these replays reached the
//! vehicle; then each endpoint had one, and a frame replayed into another endpoint with the
//! same key (a radio's and a Wi-Fi link's) did.

mod daemon;

use std::io::Write;
use std::net::{TcpStream, UdpSocket};
use std::path::Path;
use std::sync::{mpsc, Arc};
use std::thread;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use daemon::{heartbeat, HEARTBEAT_ONLY as META};
use ferrolink_io::link::{self, Endpoint, Sender};
use ferrolink_io::mavlink::config::EndpointConfig;
use ferrolink_io::mavlink::router::Config;
use ferrolink_runtime::mavlink::signing::{timestamp_from_unix_micros, SecretKey, Signer};
use ferrolink_runtime::mavlink::{v2, Header};
use ferrolink_test_support::free_port;

const KEY: [u8; 32] = [7; 32];

/// A HEARTBEAT from `sysid` signed on stream `link_id`, stamped now.
fn signed(link_id: u8, sysid: u8) -> Vec<u8> {
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .expect("after 1970")
        .as_micros() as u64;
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = Signer::new(SecretKey::new(KEY), link_id)
        .encode_raw(
            timestamp_from_unix_micros(now),
            Header::new(0, sysid, 1),
            0,
            50,
            &[1; 9],
            &mut out,
        )
        .expect("fits");
    out[..n].to_vec()
}

/// The vehicle, on an endpoint without signing: says which frames reach it.
struct Vehicle(UdpSocket);

impl Vehicle {
    /// Whether `frame` arrives within a second (other frames are skipped).
    fn gets(&self, frame: &[u8]) -> bool {
        let deadline = Instant::now() + Duration::from_secs(1);
        let mut buf = [0u8; 512];
        while Instant::now() < deadline {
            if let Ok(n) = self.0.recv(&mut buf) {
                if &buf[..n] == frame {
                    return true;
                }
            }
        }
        false
    }
}

/// A pseudo-terminal linked at `path`, standing in for a serial device: the router's
/// `serial://` endpoint opens it, and loses it when it is dropped.
fn device(path: &Path) -> (link::Handle, Sender) {
    let (tx, rx) = mpsc::channel();
    let sink: link::Sink = Arc::new(move |event| {
        if let link::Event::Up { sender, .. } = event {
            let _ = tx.send(sender);
        }
        true
    });
    let handle = link::open(
        0,
        &Endpoint::Pty(path.display().to_string()),
        link::Options::default(),
        sink,
    )
    .expect("a pty");
    let sender = rx.recv_timeout(Duration::from_secs(5)).expect("pty up");
    (handle, sender)
}

#[test]
fn replays_through_new_peers_of_a_signing_endpoint_are_dropped() {
    let dir = tempfile::tempdir().expect("scratch");
    let tty = dir.path().join("ttyRADIO");
    let (first_device, first_writer) = device(&tty);
    let (p_vehicle, p_gcs, p_tcp) = (free_port(), free_port(), free_port());
    let signing = |endpoint| {
        let mut e = EndpointConfig::new(endpoint);
        e.link.require_signing = Some(SecretKey::new(KEY));
        e
    };
    let config = Config {
        endpoints: vec![
            EndpointConfig::new(Endpoint::UdpIn("127.0.0.1".into(), p_vehicle)),
            signing(Endpoint::UdpIn("127.0.0.1".into(), p_gcs)),
            signing(Endpoint::TcpIn("127.0.0.1".into(), p_tcp)),
            signing(Endpoint::Serial(tty.display().to_string(), 57_600)),
        ],
        table: META.into(),
        ..Config::default()
    };
    let router = daemon::start(config);
    let vehicle = UdpSocket::bind("127.0.0.1:0").expect("bind");
    vehicle
        .set_read_timeout(Some(Duration::from_millis(50)))
        .expect("timeout");
    vehicle
        .send_to(&heartbeat(1), ("127.0.0.1", p_vehicle))
        .expect("send");
    let vehicle = Vehicle(vehicle);
    thread::sleep(Duration::from_millis(100));
    let mut failures = Vec::new();

    // UDP: a ground station's signed frame, then the same bytes from a new port.
    let gcs = UdpSocket::bind("127.0.0.1:0").expect("bind");
    let captured = signed(3, 255);
    let captured_on_udp = captured.clone();
    gcs.send_to(&captured, ("127.0.0.1", p_gcs)).expect("send");
    assert!(vehicle.gets(&captured), "the ground station's frame");
    let attacker = UdpSocket::bind("127.0.0.1:0").expect("bind");
    attacker
        .send_to(&captured, ("127.0.0.1", p_gcs))
        .expect("send");
    if vehicle.gets(&captured) {
        failures.push("replayed from a new UDP port");
    }
    let probe = signed(30, 250);
    attacker
        .send_to(&probe, ("127.0.0.1", p_gcs))
        .expect("send");
    assert!(vehicle.gets(&probe), "a fresh frame from the new port");

    // TCP: a client's signed frame, then the same bytes over a new connection.
    let captured = signed(4, 254);
    let mut client = TcpStream::connect(("127.0.0.1", p_tcp)).expect("connect");
    thread::sleep(Duration::from_millis(100));
    client.write_all(&captured).expect("write");
    assert!(vehicle.gets(&captured), "the TCP client's frame");
    drop(client);
    let mut again = TcpStream::connect(("127.0.0.1", p_tcp)).expect("connect");
    thread::sleep(Duration::from_millis(100));
    again.write_all(&captured).expect("write");
    if vehicle.gets(&captured) {
        failures.push("replayed over a new TCP connection");
    }
    // The frame taken on the UDP endpoint, replayed into the TCP one, which has the same key.
    again.write_all(&captured_on_udp).expect("write");
    if vehicle.gets(&captured_on_udp) {
        failures.push("replayed into another endpoint with the same key");
    }
    let probe = signed(40, 249);
    again.write_all(&probe).expect("write");
    assert!(
        vehicle.gets(&probe),
        "a fresh frame over the new connection"
    );

    // Serial: a radio's signed frame; the radio is unplugged and plugged in again, and the
    // same bytes arrive through the reopened device.
    thread::sleep(Duration::from_millis(1_500)); // the router opens the device within a second
    let captured = signed(6, 253);
    first_writer.send(&captured).expect("write");
    assert!(vehicle.gets(&captured), "the radio's frame");
    drop((first_device, first_writer));
    thread::sleep(Duration::from_millis(500));
    let (_second_device, second_writer) = device(&tty);
    thread::sleep(Duration::from_millis(2_500)); // reopened within a second of each try
    second_writer.send(&captured).expect("write");
    if vehicle.gets(&captured) {
        failures.push("replayed through the reopened serial device");
    }
    let probe = signed(60, 248);
    second_writer.send(&probe).expect("write");
    assert!(
        vehicle.gets(&probe),
        "a fresh frame through the reopened device"
    );

    router.stop();
    assert!(
        failures.is_empty(),
        "replays reached the vehicle: {failures:?}"
    );
}
