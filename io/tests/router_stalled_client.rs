//! No head-of-line blocking in the router daemon: a TCP client that connects and never reads
//! (a phone's ground station sent to the background) loses its own frames, counted as its
//! `tx_dropped`, while two UDP ground stations get everything at 10,000 messages a second with
//! no added latency.
//!
//! Before output queues, each write to such a client blocked for 100 ms under the routing lock:
//! the UDP ground stations lost 70 % and saw seconds of latency.

mod daemon;

use std::io::BufRead;
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::thread;
use std::time::{Duration, Instant};

use daemon::{heartbeat, HEARTBEAT};
use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::config::EndpointConfig;
use ferrolink_io::mavlink::router::Config;
use ferrolink_runtime::mavlink::{v2, Header, MessageMeta};
use ferrolink_test_support::free_port;

/// HEARTBEAT, and a 255-byte broadcast that carries its send time, so that the stalled
/// client's socket buffers fill within a second.
static META: &[MessageMeta] = &[
    HEARTBEAT,
    MessageMeta {
        id: 1000,
        crc_extra: 7,
        min_len: 255,
        max_len: 255,
        target_system: None,
        target_component: None,
    },
];

const RATE: u64 = 10_000;
const SECONDS: u64 = 4;

fn frame(id: u32, crc_extra: u8, payload: &[u8], sysid: u8, seq: u8) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n =
        v2::encode_raw(Header::new(seq, sysid, 1), id, crc_extra, payload, &mut out).expect("fits");
    out[..n].to_vec()
}

/// A client with a small receive window that never reads.
fn stalled_client(port: u16) -> TcpStream {
    use socket2::{Domain, Socket, Type};
    let socket = Socket::new(Domain::IPV4, Type::STREAM, None).expect("socket");
    socket.set_recv_buffer_size(4096).expect("SO_RCVBUF");
    let to: SocketAddr = ([127, 0, 0, 1], port).into();
    socket.connect(&to.into()).expect("connect");
    socket.into()
}

#[test]
fn a_client_that_never_reads_slows_no_one() {
    let epoch = Instant::now();
    let (p_in, p_gcs1, p_gcs2, p_tcp) = (free_port(), free_port(), free_port(), free_port());
    let dir = tempfile::tempdir().expect("scratch");
    let stats = dir.path().join("stats.jsonl");
    let udpin = |port| EndpointConfig::new(Endpoint::UdpIn("127.0.0.1".into(), port));
    let config = Config {
        endpoints: vec![
            udpin(p_in),
            udpin(p_gcs1),
            udpin(p_gcs2),
            EndpointConfig::new(Endpoint::TcpIn("127.0.0.1".into(), p_tcp)),
        ],
        table: META.into(),
        stats_json: Some(stats.clone()),
        ..Config::default()
    };
    let router = daemon::start(config);

    let stalled = stalled_client(p_tcp);
    // Two ground stations make themselves known, then count and time what arrives.
    let receivers: Vec<_> = [(p_gcs1, 201), (p_gcs2, 202)]
        .into_iter()
        .map(|(port, sysid)| {
            let socket = UdpSocket::bind("127.0.0.1:0").expect("bind");
            socket
                .send_to(&heartbeat(sysid), ("127.0.0.1", port))
                .expect("send");
            socket
                .set_read_timeout(Some(Duration::from_millis(500)))
                .expect("timeout");
            thread::spawn(move || {
                let mut latencies_us = Vec::new();
                let mut buf = vec![0u8; 65536];
                while let Ok(n) = socket.recv(&mut buf) {
                    let now = epoch.elapsed().as_micros() as u64;
                    // The router packs the frames of a burst into shared datagrams: each is
                    // a MAVLink 2 frame, unsigned, of 12 bytes beside its payload.
                    let mut rest = &buf[..n];
                    while let Some(&len) = rest.get(1) {
                        let (frame, tail) = rest.split_at((12 + usize::from(len)).min(rest.len()));
                        rest = tail;
                        let Ok(sent) = <[u8; 8]>::try_from(frame.get(10..18).unwrap_or(&[])) else {
                            continue;
                        };
                        if frame.len() > 100 {
                            latencies_us.push(now.saturating_sub(u64::from_le_bytes(sent)));
                        }
                    }
                }
                latencies_us
            })
        })
        .collect();
    thread::sleep(Duration::from_millis(200));

    // The vehicle: 10,000 broadcasts a second, in bursts of ten every millisecond.
    let vehicle = UdpSocket::bind("127.0.0.1:0").expect("bind");
    let total = RATE * SECONDS;
    let start = Instant::now();
    let mut payload = [0x55u8; 255];
    for i in 0..total {
        if i % 10 == 0 {
            let due = start + Duration::from_micros(i * 1_000_000 / RATE);
            thread::sleep(due.saturating_duration_since(Instant::now()));
        }
        let now = epoch.elapsed().as_micros() as u64;
        payload[..8].copy_from_slice(&now.to_le_bytes());
        vehicle
            .send_to(&frame(1000, 7, &payload, 1, i as u8), ("127.0.0.1", p_in))
            .expect("send");
    }
    let heard: Vec<Vec<u64>> = receivers
        .into_iter()
        .map(|r| r.join().expect("receiver"))
        .collect();
    router.stop();
    drop(stalled);

    let last = std::fs::read(&stats)
        .expect("stats")
        .lines()
        .map_while(Result::ok)
        .last()
        .expect("a stats line");
    let last: serde_json::Value = serde_json::from_str(&last).expect("JSON");
    let tcp = last["links"]
        .as_array()
        .expect("links")
        .iter()
        .find(|l| l["link"].as_str().is_some_and(|n| n.starts_with("tcpin")))
        .expect("the stalled client's link")
        .clone();
    let dropped = tcp["tx_dropped"].as_u64().expect("tx_dropped");

    for (i, mut latencies) in heard.into_iter().enumerate() {
        latencies.sort_unstable();
        let got = latencies.len() as u64;
        let p99 = latencies
            .get(latencies.len() * 99 / 100)
            .copied()
            .unwrap_or(0);
        eprintln!(
            "ground station {}: {got} of {total}, p50 {} µs, p99 {p99} µs",
            i + 1,
            latencies.get(latencies.len() / 2).copied().unwrap_or(0)
        );
        assert!(
            got * 100 >= total * 99,
            "ground station {} got {got} of {total}: more than 1 % lost",
            i + 1
        );
        // One write blocked on the client used to add 100 ms; noise on a busy test machine is
        // a few milliseconds.
        assert!(p99 < 50_000, "ground station {}: p99 {p99} µs", i + 1);
    }
    eprintln!("the stalled client's queue dropped {dropped} frames");
    assert!(
        dropped > 0,
        "the stalled client lost nothing: did it stall? {tcp}"
    );
}
