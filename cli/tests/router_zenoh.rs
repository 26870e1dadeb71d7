//! Two routers joined by Zenoh: the frames one read from Zenoh brings go to a UDP ground station
//! in shared datagrams, whole and in order, as frames read from a UDP socket do. Before, each
//! frame was a datagram of its own (one `sendto` per frame and peer, the largest cost of a
//! router fed by Zenoh). And a Zenoh endpoint from the configuration file, with its filter.
#![cfg(feature = "zenoh")]

mod common;

use std::net::UdpSocket;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use ferrolink_runtime::mavlink::{v2, Header};
use ferrolink_test_support::free_port;

fn frame(seq: u8, sysid: u8, id: u32, crc_extra: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n =
        v2::encode_raw(Header::new(seq, sysid, 1), id, crc_extra, payload, &mut out).expect("fits");
    out[..n].to_vec()
}

fn heartbeat(sysid: u8) -> Vec<u8> {
    frame(0, sysid, 0, 50, &[0, 0, 0, 0, 6, 8, 0, 0, 3])
}

/// PING number `n`, its number in `seq`.
fn ping(n: u32) -> Vec<u8> {
    let mut payload = [0u8; 14];
    payload[8..12].copy_from_slice(&n.to_le_bytes());
    frame(n as u8, 1, 4, 237, &payload)
}

struct Router(Child);

impl Router {
    fn start(endpoints: &[String]) -> Router {
        let mut child = Command::new(common::ferrolink())
            .args(["mavlink", "router"])
            .args(endpoints)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("the router starts");
        common::wait_ready(&mut child);
        Router(child)
    }
}

impl Drop for Router {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The frames in one datagram: (message id, PING number, source system).
fn frames(datagram: &[u8]) -> Vec<(u32, u32, u8)> {
    let mut out = Vec::new();
    let mut rest = datagram;
    while rest.len() >= 12 {
        assert_eq!(rest[0], 0xFD, "a datagram holds whole frames only");
        let len = 12 + usize::from(rest[1]);
        let id = u32::from_le_bytes([rest[7], rest[8], rest[9], 0]);
        let mut payload = [0u8; 14];
        let body = &rest[10..len - 2];
        payload[..body.len()].copy_from_slice(body);
        out.push((
            id,
            u32::from_le_bytes([payload[8], payload[9], payload[10], payload[11]]),
            rest[5],
        ));
        rest = &rest[len..];
    }
    assert!(rest.is_empty(), "a datagram holds whole frames only");
    out
}

#[test]
fn frames_from_zenoh_share_datagrams_to_a_udp_peer() {
    let (p_source, p_gcs, p_zenoh) = (free_port(), free_port(), free_port());
    let zenoh = |role: &str| {
        format!("zenoh://?mode=peer&{role}=tcp/127.0.0.1:{p_zenoh}&prefix=packing{p_zenoh}")
    };
    let _b = Router::start(&[zenoh("listen"), format!("udpin://127.0.0.1:{p_gcs}")]);
    let _a = Router::start(&[format!("udpin://127.0.0.1:{p_source}"), zenoh("connect")]);

    let gcs = UdpSocket::bind("127.0.0.1:0").expect("bind");
    gcs.connect(("127.0.0.1", p_gcs)).expect("connect");
    gcs.set_read_timeout(Some(Duration::from_millis(200)))
        .expect("timeout");
    let source = UdpSocket::bind("127.0.0.1:0").expect("bind");
    source.connect(("127.0.0.1", p_source)).expect("connect");
    let mut buf = [0u8; 65536];

    // The routers meet over Zenoh: the source's heartbeats reach the ground station.
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        assert!(Instant::now() < deadline, "Zenoh never joined the routers");
        gcs.send(&heartbeat(255)).expect("send");
        source.send(&heartbeat(1)).expect("send");
        if gcs
            .recv(&mut buf)
            .is_ok_and(|n| frames(&buf[..n]).iter().any(|f| f.0 == 0))
        {
            break;
        }
    }
    while gcs.recv(&mut buf).is_ok() {}

    // 500 PINGs as fast as the source can send them.
    const PINGS: u32 = 500;
    for n in 0..PINGS {
        source.send(&ping(n)).expect("send");
    }
    let (mut pings, mut datagrams) = (Vec::new(), 0);
    let deadline = Instant::now() + Duration::from_secs(10);
    while pings.len() < PINGS as usize && Instant::now() < deadline {
        let Ok(n) = gcs.recv(&mut buf) else { continue };
        let got: Vec<u32> = frames(&buf[..n])
            .into_iter()
            .filter(|f| f.0 == 4)
            .map(|f| f.1)
            .collect();
        if !got.is_empty() {
            datagrams += 1;
            pings.extend(got);
        }
    }
    assert_eq!(
        pings,
        (0..PINGS).collect::<Vec<_>>(),
        "every PING, in order"
    );
    assert!(
        datagrams < PINGS / 2,
        "{PINGS} PINGs came in {datagrams} datagrams"
    );
}

/// A `zenoh://` endpoint from the TOML configuration file, with a filter: the routers meet over
/// it, and the filter holds (PINGs from Zenoh are blocked, heartbeats pass).
#[test]
fn a_zenoh_endpoint_from_the_configuration_file_keeps_its_filter() {
    let (p_source, p_gcs, p_zenoh) = (free_port(), free_port(), free_port());
    let dir = tempfile::tempdir().expect("temp dir");
    let config = dir.path().join("router.toml");
    std::fs::write(
        &config,
        format!(
            "[[endpoint]]\n\
             uri = \"zenoh://?mode=peer&listen=tcp/127.0.0.1:{p_zenoh}&prefix=file{p_zenoh}\"\n\
             block_msg_in = [4]\n\n\
             [[endpoint]]\n\
             uri = \"udpin://127.0.0.1:{p_gcs}\"\n"
        ),
    )
    .expect("write");
    let _b = Router::start(&["--config".into(), config.to_str().expect("utf-8").into()]);
    let _a = Router::start(&[
        format!("udpin://127.0.0.1:{p_source}"),
        format!("zenoh://?mode=peer&connect=tcp/127.0.0.1:{p_zenoh}&prefix=file{p_zenoh}"),
    ]);

    let gcs = UdpSocket::bind("127.0.0.1:0").expect("bind");
    gcs.connect(("127.0.0.1", p_gcs)).expect("connect");
    gcs.set_read_timeout(Some(Duration::from_millis(200)))
        .expect("timeout");
    let source = UdpSocket::bind("127.0.0.1:0").expect("bind");
    source.connect(("127.0.0.1", p_source)).expect("connect");
    let mut buf = [0u8; 65536];
    let mut heard = |gcs: &UdpSocket| {
        gcs.recv(&mut buf)
            .map(|n| frames(&buf[..n]))
            .unwrap_or_default()
    };

    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        assert!(Instant::now() < deadline, "Zenoh never joined the routers");
        gcs.send(&heartbeat(255)).expect("send");
        source.send(&heartbeat(1)).expect("send");
        if heard(&gcs).iter().any(|f| f.0 == 0) {
            break;
        }
    }
    // PINGs, then a heartbeat of system 2 behind them on the same path: once it is in, so
    // would they be.
    for n in 0..20 {
        source.send(&ping(n)).expect("send");
    }
    source.send(&heartbeat(2)).expect("send");
    let marker = |f: &(u32, u32, u8)| f.0 == 0 && f.2 == 2;
    let mut got = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(10);
    while !got.iter().any(marker) && Instant::now() < deadline {
        got.extend(heard(&gcs));
    }
    assert!(got.iter().any(marker), "the heartbeat behind the PINGs");
    assert!(
        got.iter().all(|f| f.0 != 4),
        "a PING passed the filter: {got:?}"
    );
}
