//! The web API inside a router run by the test: a posted message goes out signed with the key
//! given, from the ids its header names, and the API stops with the router.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::config::EndpointConfig;
use ferrolink_io::mavlink::router::{self, Config};
use ferrolink_runtime::mavlink::signing::{signature_matches, SecretKey};
use ferrolink_runtime::mavlink::{v2, Header};
use ferrolink_test_support::free_port;
use ferrolink_traffic::Dialects;

/// One HTTP/1.1 request on a fresh connection; the status and the body.
fn http(port: u16, method: &str, path: &str, body: &str) -> (u16, String) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).expect("connect");
    let request = format!(
        "{method} {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    );
    s.write_all(request.as_bytes()).expect("send");
    let mut reply = String::new();
    s.read_to_string(&mut reply).expect("read");
    let status = reply[9..12].parse().expect("a status");
    let body = reply
        .split_once("\r\n\r\n")
        .map_or("", |(_, b)| b)
        .to_owned();
    (status, body)
}

#[test]
fn a_post_goes_out_signed_from_its_header_ids_and_the_api_stops_with_the_router() {
    let dialects = Dialects::load(&["common".into()], "common").expect("common");
    let key = SecretKey::new([7; 32]);
    let (udp, http_port) = (free_port(), free_port());
    let config = Config {
        endpoints: vec![EndpointConfig::new(Endpoint::UdpIn(
            "127.0.0.1".into(),
            udp,
        ))],
        table: dialects.table.clone(),
        ..Config::default()
    };
    let web = ferrolink_web::endpoint(ferrolink_web::Config {
        addr: SocketAddr::from(([127, 0, 0, 1], http_port)),
        decoder: dialects.decoder(),
        signing: Some(key.clone()),
    });
    let stop = Arc::new(AtomicBool::new(false));
    let router = {
        let stop = stop.clone();
        thread::spawn(move || router::run(&config, vec![web], &stop))
    };
    thread::sleep(Duration::from_millis(300));
    // A vehicle on the udpin port, so that the command has somewhere to go.
    let vehicle = UdpSocket::bind("127.0.0.1:0").expect("bind");
    vehicle
        .set_read_timeout(Some(Duration::from_millis(200)))
        .expect("timeout");
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(
        Header::new(0, 1, 1),
        0,
        50,
        &[0, 0, 0, 0, 2, 3, 0, 4, 3],
        &mut out,
    )
    .expect("fits");
    vehicle
        .send_to(&out[..n], ("127.0.0.1", udp))
        .expect("send");
    thread::sleep(Duration::from_millis(200));

    let (status, body) = http(http_port, "GET", "/v1/mavlink/vehicles/1", "");
    assert_eq!(status, 200, "{body}");
    let (status, body) = http(http_port, "GET", "/v1/mavlink/vehicles/9", "");
    assert_eq!(status, 404);
    assert!(body.contains("\"error\""), "{body}");

    let post = r#"{"header": {"system_id": 200, "component_id": 190, "sequence": 9},
        "message": {"type": "COMMAND_LONG", "target_system": 1, "target_component": 1,
                    "command": {"type": "MAV_CMD_COMPONENT_ARM_DISARM"}, "param1": 1.0}}"#;
    let (status, body) = http(http_port, "POST", "/v1/mavlink", post);
    assert_eq!(status, 200, "{body}");
    let deadline = Instant::now() + Duration::from_secs(5);
    let frame = loop {
        let mut buf = [0u8; 600];
        if let Ok((n, _)) = vehicle.recv_from(&mut buf) {
            let frame = v2::Frame::new_checked(buf[..n].to_vec()).expect("a MAVLink 2 frame");
            if frame.msg_id() == 76 {
                break frame;
            }
        }
        assert!(
            Instant::now() < deadline,
            "no COMMAND_LONG reached the vehicle"
        );
    };
    assert_eq!((frame.header().sysid, frame.header().compid), (200, 190));
    assert!(
        frame.is_signed() && signature_matches(&key, &frame),
        "signed with the key"
    );

    let (status, body) = http(http_port, "POST", "/v1/mavlink", "{\"message\": 3}");
    assert_eq!(status, 400);
    assert!(body.contains("a message is a JSON object"), "{body}");

    stop.store(true, Ordering::Relaxed);
    router
        .join()
        .expect("the router thread")
        .expect("the router ran");
    assert!(
        TcpStream::connect(("127.0.0.1", http_port)).is_err(),
        "the API stopped with the router"
    );
}
