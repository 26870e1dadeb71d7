//! A false start on a quiet stream link: a stray start byte whose header claims 255 bytes, then
//! one heartbeat, then silence (a vehicle that sends one heartbeat a second over a bad radio).
//! The router forwards the heartbeat once the link has paused for `link::QUIET`, instead of
//! holding it until 255 more bytes have come.

mod daemon;

use std::io::Write;
use std::net::{TcpStream, UdpSocket};
use std::thread;
use std::time::{Duration, Instant};

use daemon::heartbeat;
use ferrolink_io::link::{Endpoint, QUIET};
use ferrolink_io::mavlink::config::EndpointConfig;
use ferrolink_test_support::free_port;

#[test]
fn a_heartbeat_behind_a_false_start_is_forwarded_when_the_link_pauses() {
    let (p_tcp, p_gcs) = (free_port(), free_port());
    let mut config = daemon::on(Endpoint::TcpIn("127.0.0.1".into(), p_tcp));
    config.endpoints.push(EndpointConfig::new(Endpoint::UdpIn(
        "127.0.0.1".into(),
        p_gcs,
    )));
    let router = daemon::start(config);
    let gcs = UdpSocket::bind("127.0.0.1:0").expect("bind");
    gcs.send_to(&heartbeat(255), ("127.0.0.1", p_gcs))
        .expect("send");
    gcs.set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    let mut vehicle = TcpStream::connect(("127.0.0.1", p_tcp)).expect("connect");
    thread::sleep(Duration::from_millis(200));

    // A MAVLink 2 header of HEARTBEAT claiming 255 bytes, then a real heartbeat from system 7.
    let mut bytes = vec![0xFD, 0xFF, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00];
    bytes.extend(heartbeat(7));
    let sent = Instant::now();
    vehicle.write_all(&bytes).expect("write");
    let mut buf = [0u8; 2048];
    let n = gcs.recv(&mut buf).expect("the heartbeat arrives");
    assert_eq!(&buf[..n], &heartbeat(7)[..]);
    assert!(sent.elapsed() >= QUIET, "it came before the pause");
    drop(vehicle);
    router.stop();
}
