//! The router daemon's outputs. What a link counted outlives the link: the statistics keep the
//! totals of closed links. An output that fails (a tlog or statistics file on a full disk) is
//! reported and given up, and routing goes on (it used to end the router, cutting the vehicle
//! off from its ground station when a log's disk filled). The exit says so.

mod daemon;

use std::io::Write;
use std::net::{TcpStream, UdpSocket};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::Duration;

use daemon::heartbeat;
use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::config::EndpointConfig;
use ferrolink_io::mavlink::router::{self, Config};
use ferrolink_test_support::free_port;

/// Routes 500 heartbeats from a vehicle to a ground station, then 50 more, 50 ms apart, through
/// a router configured by `outputs`; returns how many of the 50 arrived and how it ended.
fn route_with(outputs: impl FnOnce(&mut Config)) -> (usize, std::io::Result<()>) {
    let (p_vehicle, p_gcs) = (free_port(), free_port());
    let mut config = daemon::on(Endpoint::UdpIn("127.0.0.1".into(), p_vehicle));
    config.endpoints.push(EndpointConfig::new(Endpoint::UdpIn(
        "127.0.0.1".into(),
        p_gcs,
    )));
    outputs(&mut config);
    let stop = Arc::new(AtomicBool::new(false));
    let router = {
        let stop = stop.clone();
        thread::spawn(move || router::run(&config, Vec::new(), &stop))
    };
    thread::sleep(Duration::from_millis(300));
    let (vehicle, gcs) = (
        UdpSocket::bind("127.0.0.1:0").expect("bind"),
        UdpSocket::bind("127.0.0.1:0").expect("bind"),
    );
    gcs.set_read_timeout(Some(Duration::from_millis(300)))
        .expect("timeout");
    gcs.send_to(&heartbeat(255), ("127.0.0.1", p_gcs))
        .expect("send");
    thread::sleep(Duration::from_millis(100));
    // More than the tlog's buffer holds, so that its writes fail while the router runs.
    for _ in 0..500 {
        vehicle
            .send_to(&heartbeat(2), ("127.0.0.1", p_vehicle))
            .expect("send");
        thread::sleep(Duration::from_micros(200));
    }
    thread::sleep(Duration::from_millis(1_200));
    while gcs.recv(&mut [0u8; 2048]).is_ok() {}
    for _ in 0..50 {
        vehicle
            .send_to(&heartbeat(1), ("127.0.0.1", p_vehicle))
            .expect("send");
        thread::sleep(Duration::from_millis(50));
    }
    let (mut got, mut buf) = (0, [0u8; 2048]);
    while let Ok(n) = gcs.recv(&mut buf) {
        got += buf[..n]
            .windows(heartbeat(1).len())
            .filter(|w| *w == heartbeat(1))
            .count();
    }
    stop.store(true, Ordering::Relaxed);
    (got, router.join().expect("router thread"))
}

fn full_disk() -> Option<PathBuf> {
    let full = PathBuf::from("/dev/full");
    if full.exists() {
        Some(full)
    } else {
        eprintln!("note: no /dev/full here; skipped");
        None
    }
}

#[test]
fn a_tlog_on_a_full_disk_is_given_up_and_routing_goes_on() {
    let Some(full) = full_disk() else { return };
    let (got, ended) = route_with(|c| c.tlog = Some(full));
    assert_eq!(got, 50, "heartbeats lost while the tlog failed");
    let e = ended.expect_err("the exit says the tlog was given up");
    assert!(
        e.to_string().starts_with("tlog /dev/full: ") && e.to_string().contains("given up"),
        "{e}"
    );
}

#[test]
fn statistics_on_a_full_disk_are_given_up_and_routing_goes_on() {
    let Some(full) = full_disk() else { return };
    let (got, ended) = route_with(|c| c.stats_json = Some(full));
    assert_eq!(got, 50, "heartbeats lost while the statistics failed");
    let e = ended.expect_err("the exit says the statistics were given up");
    assert!(
        e.to_string().starts_with("statistics file /dev/full: "),
        "{e}"
    );
}

#[test]
fn closed_links_keep_their_counts_in_the_statistics() {
    let (p_vehicle, p_tcp) = (free_port(), free_port());
    let dir = tempfile::tempdir().expect("scratch");
    let stats = dir.path().join("stats.jsonl");
    let mut config = daemon::on(Endpoint::UdpIn("127.0.0.1".into(), p_vehicle));
    config.endpoints.push(EndpointConfig::new(Endpoint::TcpIn(
        "127.0.0.1".into(),
        p_tcp,
    )));
    config.stats_json = Some(stats.clone());
    let router = daemon::start(config);
    let vehicle = UdpSocket::bind("127.0.0.1:0").expect("bind");
    // Two ground stations over TCP, one after the other: 20 and 5 heartbeats each, and each
    // gets the vehicle's 10.
    for (sysid, n) in [(201, 20), (202, 5)] {
        let mut gcs = TcpStream::connect(("127.0.0.1", p_tcp)).expect("connect");
        for _ in 0..n {
            gcs.write_all(&heartbeat(sysid)).expect("write");
        }
        thread::sleep(Duration::from_millis(200));
        for _ in 0..10 {
            vehicle
                .send_to(&heartbeat(1), ("127.0.0.1", p_vehicle))
                .expect("send");
        }
        thread::sleep(Duration::from_millis(200));
        drop(gcs);
        thread::sleep(Duration::from_millis(200));
    }
    router.stop();
    let text = std::fs::read_to_string(&stats).expect("statistics");
    let last: serde_json::Value =
        serde_json::from_str(text.lines().last().expect("a line")).expect("JSON");
    let closed = &last["closed"];
    assert_eq!(closed["links"], 2, "{last}");
    assert_eq!(closed["rx_frames"], 25, "{last}");
    assert_eq!(closed["tx_frames"], 20, "{last}");
    assert_eq!(closed["tx_dropped"], 0, "{last}");
    // The vehicle's link is still open: its 20 heartbeats are its own.
    let links = last["links"].as_array().expect("links");
    assert_eq!(links.len(), 1, "{last}");
    assert_eq!(links[0]["rx_frames"], 20, "{last}");
}
