//! The shared connection under load and under attack: four threads send at once while two
//! subscribers read, and one that stops reading costs the others nothing; replies go to one
//! peer; each source keeps its own sequence; forged, replayed and unsigned frames are refused
//! on a signed connection; our heartbeat goes out in the background, and can be stopped.

use std::net::UdpSocket;
use std::time::{Duration, Instant};

use ferrolink_io::mavlink::{Filter, OwnHeartbeat, SharedConnection, Unsigned};
use ferrolink_runtime::mavlink::service::messages::{Heartbeat, MavType, Message};
use ferrolink_runtime::mavlink::signing::{timestamp_from_unix_micros, SecretKey, Signer};
use ferrolink_runtime::mavlink::{v2, Dialect, Header};

const WAIT: Duration = Duration::from_secs(5);

fn heartbeat(n: u32) -> Heartbeat {
    Heartbeat {
        custom_mode: n,
        mavlink_version: 3,
        ..Default::default()
    }
}

/// Waits until `cond` holds, for at most [`WAIT`].
fn until(what: &str, mut cond: impl FnMut() -> bool) {
    let end = Instant::now() + WAIT;
    while !cond() {
        assert!(Instant::now() < end, "{what}: not within {WAIT:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// A `tcpin` connection and a `tcpout` one connected to it.
fn tcp_pair() -> (SharedConnection, SharedConnection) {
    let server = SharedConnection::open("tcpin://127.0.0.1:0", Message::META).unwrap();
    let port = server.local_addr().unwrap().port();
    let client =
        SharedConnection::open(&format!("tcpout://127.0.0.1:{port}"), Message::META).unwrap();
    until("connected", || server.peers() == 1 && client.peers() == 1);
    (server, client)
}

#[test]
fn four_senders_two_readers_and_one_that_stops_reading() {
    let (server, client) = tcp_pair();
    let reader = server.subscribe(Filter::all());
    let heartbeats = server.subscribe(Filter::all().ids(&[Heartbeat::ID]).system(12));
    let stalled = server.subscribe(Filter::all().capacity(10));
    const EACH: u32 = 500;
    let senders: Vec<_> = (0..4u8)
        .map(|i| {
            let client = client.clone();
            std::thread::spawn(move || {
                for n in 0..EACH {
                    client.send_as(10 + i, 1, &heartbeat(n)).unwrap();
                }
            })
        })
        .collect();
    for s in senders {
        s.join().unwrap();
    }
    let mut got = Vec::new();
    while got.len() < 4 * EACH as usize {
        got.push(reader.recv(WAIT).unwrap().expect("every frame"));
    }
    // Every source's frames arrive in order, numbered 0, 1, 2... on their own.
    for i in 0..4u8 {
        let mine: Vec<_> = got.iter().filter(|f| f.header().sysid == 10 + i).collect();
        assert_eq!(mine.len(), EACH as usize);
        for (n, f) in mine.iter().enumerate() {
            assert_eq!(f.header().seq, n as u8, "source {}", 10 + i);
            let Ok(Message::Heartbeat(hb)) = f.decode::<Message>() else {
                panic!("a heartbeat")
            };
            assert_eq!(hb.custom_mode, n as u32);
        }
    }
    // The filtered subscriber got system 12's and nothing else.
    let mut twelve = 0;
    while let Some(f) = heartbeats.try_recv().unwrap() {
        assert_eq!(f.header().sysid, 12);
        twelve += 1;
    }
    assert_eq!((twelve, heartbeats.dropped()), (EACH, 0));
    assert_eq!(reader.dropped(), 0);
    // The one that never read holds 10 and lost the rest, counted.
    assert_eq!(stalled.len(), 10);
    assert_eq!(stalled.dropped(), u64::from(4 * EACH) - 10);
    let counts = server.counts();
    assert_eq!(counts.frames, u64::from(4 * EACH));
    assert_eq!(counts.dropped, stalled.dropped());
}

#[test]
fn a_reply_goes_to_one_peer() {
    let server = SharedConnection::open("udpin://127.0.0.1:0", Message::META).unwrap();
    let port = server.local_addr().unwrap().port();
    let uri = format!("udpout://127.0.0.1:{port}");
    let (a, b) = (
        SharedConnection::open(&uri, Message::META).unwrap(),
        SharedConnection::open(&uri, Message::META).unwrap(),
    );
    let requests = server.subscribe(Filter::all());
    let (from_a, from_b) = (a.subscribe(Filter::all()), b.subscribe(Filter::all()));
    a.set_ids(1, 1);
    b.set_ids(2, 1);
    a.send(&heartbeat(1)).unwrap();
    b.send(&heartbeat(2)).unwrap();
    let mut asked = Vec::new();
    while asked.len() < 2 {
        asked.push(requests.recv(WAIT).unwrap().expect("both"));
    }
    let from_2 = asked.iter().find(|f| f.header().sysid == 2).unwrap();
    server.send_to(from_2.peer(), &heartbeat(99)).unwrap();
    let reply = from_b.recv(WAIT).unwrap().expect("b's reply");
    assert_eq!(reply.header().sysid, 255);
    assert_eq!(from_a.recv(Duration::from_millis(300)).unwrap(), None);
    // To everyone, it reaches both.
    server.send(&heartbeat(100)).unwrap();
    assert!(from_a.recv(WAIT).unwrap().is_some());
    assert!(from_b.recv(WAIT).unwrap().is_some());
}

/// A signed frame of `message` from 1/1, as a peer with `key` signs it on link 0 at
/// `timestamp`.
fn signed(key: &SecretKey, timestamp: u64, seq: u8, message: &Heartbeat) -> Vec<u8> {
    signed_on(0, key, timestamp, seq, message)
}

fn signed_on(link: u8, key: &SecretKey, timestamp: u64, seq: u8, message: &Heartbeat) -> Vec<u8> {
    let mut signer = Signer::new(key.clone(), link);
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = signer
        .encode(timestamp, Header::new(seq, 1, 1), message, &mut out)
        .unwrap();
    out[..n].to_vec()
}

/// An unsigned frame of message `id`.
fn unsigned(id: u32, crc_extra: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(0, 1, 1), id, crc_extra, payload, &mut out).unwrap();
    out[..n].to_vec()
}

#[test]
fn forged_replayed_and_unsigned_frames_are_refused() {
    let key = SecretKey::from([7u8; 32]);
    // RADIO_STATUS, in the table so that its checksum is checked.
    let mut table = Message::META.to_vec();
    table.push(ferrolink_runtime::mavlink::MessageMeta {
        id: 109,
        crc_extra: 185,
        min_len: 9,
        max_len: 9,
        target_system: None,
        target_component: None,
    });
    table.sort_by_key(|m| m.id);
    let server = SharedConnection::open("udpin://127.0.0.1:0", table).unwrap();
    server.set_signing(key.clone(), 3);
    let to = server.local_addr().unwrap();
    let frames = server.subscribe(Filter::all());
    let peer = UdpSocket::bind("127.0.0.1:0").unwrap();
    let now = timestamp_from_unix_micros(ferrolink_io::mavlink::unix_us());
    let good = signed(&key, now, 0, &heartbeat(1));
    let forged = signed(&SecretKey::from([8u8; 32]), now + 10, 1, &heartbeat(2));
    let mut tampered = signed(&key, now + 20, 2, &heartbeat(3));
    tampered[10] ^= 1; // a payload byte, checksum fixed below, so only the signature tells
    let crc_at = tampered.len() - 13 - 2;
    let crc =
        ferrolink_runtime::crc::mcrf4xx_with(&tampered[1..crc_at], Some(Heartbeat::CRC_EXTRA));
    tampered[crc_at..crc_at + 2].copy_from_slice(&crc.to_le_bytes());
    // A new stream (link 5) whose timestamp is more than 60 s behind.
    let stale = signed_on(5, &key, now - 61 * 100_000, 3, &heartbeat(4));
    let radio_status = unsigned(109, 185, &[0; 9]);
    let plain = unsigned(Heartbeat::ID, Heartbeat::CRC_EXTRA, &[0; 9]);
    let later = signed(&key, now + 30, 4, &heartbeat(5));
    for bytes in [
        &good,
        &good, // replayed
        &forged,
        &tampered,
        &stale,
        &plain,
        &radio_status,
        &later,
    ] {
        peer.send_to(bytes, to).unwrap();
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut got = Vec::new();
    while let Some(f) = frames.recv(Duration::from_millis(500)).unwrap() {
        got.push(f);
    }
    let ids: Vec<(u32, bool)> = got.iter().map(|f| (f.msg_id(), f.is_signed())).collect();
    assert_eq!(ids, [(0, true), (109, false), (0, true)], "{got:?}");
    assert_eq!(got[0].as_bytes(), &good[..]);
    assert_eq!(got[2].as_bytes(), &later[..]);
    let counts = server.counts();
    assert_eq!(
        (counts.bad_signature, counts.unsigned),
        (4, 1),
        "{counts:?}"
    );
    // Accepting unsigned frames takes the plain one.
    server.set_unsigned(Unsigned::Accept);
    peer.send_to(&plain, to).unwrap();
    let f = frames.recv(WAIT).unwrap().expect("the unsigned frame");
    assert!(!f.is_signed());
    // What we send is signed, and the other side checks it.
    let client = SharedConnection::open(&format!("udpout://{to}"), Message::META).unwrap();
    client.set_signing(key.clone(), 1);
    let replies = client.subscribe(Filter::all());
    client.send(&heartbeat(6)).unwrap();
    let f = frames
        .recv(WAIT)
        .unwrap()
        .expect("the client's signed frame");
    assert!(f.is_signed());
    server.send(&heartbeat(7)).unwrap();
    let back = replies
        .recv(WAIT)
        .unwrap()
        .expect("the server's signed reply");
    assert!(back.is_signed() && back.header().sysid == 255);
}

#[test]
fn heartbeat_goes_out_in_the_background_and_stops() {
    let server = SharedConnection::open("udpin://127.0.0.1:0", Message::META).unwrap();
    let port = server.local_addr().unwrap().port();
    let vehicle =
        SharedConnection::open(&format!("udpout://127.0.0.1:{port}"), Message::META).unwrap();
    vehicle.set_ids(1, 1);
    vehicle.send(&heartbeat(0)).unwrap();
    let beats = vehicle.subscribe(Filter::all().ids(&[Heartbeat::ID]));
    until("the vehicle is a peer", || server.peers() == 1);
    server.start_heartbeat(OwnHeartbeat {
        mav_type: MavType::OnboardController,
        interval: Duration::from_millis(100),
        ..OwnHeartbeat::default()
    });
    let start = Instant::now();
    let mut n = 0;
    while n < 5 {
        let f = beats.recv(WAIT).unwrap().expect("our heartbeat");
        let Ok(Message::Heartbeat(hb)) = f.decode::<Message>() else {
            panic!()
        };
        assert_eq!(hb.r#type, MavType::OnboardController);
        n += 1;
    }
    assert!(start.elapsed() >= Duration::from_millis(350));
    server.stop_heartbeat();
    std::thread::sleep(Duration::from_millis(150));
    while beats.try_recv().unwrap().is_some() {}
    assert_eq!(beats.recv(Duration::from_millis(400)).unwrap(), None);
}

#[test]
fn subscriptions_end_when_the_connection_is_dropped() {
    let server = SharedConnection::open("udpin://127.0.0.1:0", Message::META).unwrap();
    let frames = server.subscribe(Filter::all());
    drop(server);
    let err = frames.recv(WAIT).unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::BrokenPipe);
}

#[cfg(feature = "tokio")]
#[tokio::test(flavor = "current_thread")]
async fn an_async_subscriber_beside_a_blocking_one() {
    let server = SharedConnection::open("udpin://127.0.0.1:0", Message::META).unwrap();
    let port = server.local_addr().unwrap().port();
    let client =
        SharedConnection::open(&format!("udpout://127.0.0.1:{port}"), Message::META).unwrap();
    let (a, b) = (
        server.subscribe(Filter::all()),
        server.subscribe(Filter::all()),
    );
    client.send(&heartbeat(42)).unwrap();
    let f = tokio::time::timeout(WAIT, a.recv_async())
        .await
        .expect("in time")
        .unwrap();
    assert_eq!(f.header().sysid, 255);
    assert!(b.recv(WAIT).unwrap().is_some());
}

/// The heartbeat thread holds the connection only while it sends: dropping the last handle
/// closes the endpoint at once, even between two slow heartbeats.
#[test]
fn dropping_the_connection_closes_it_while_the_heartbeat_waits() {
    let server = SharedConnection::open("udpin://127.0.0.1:0", Message::META).unwrap();
    let addr = server.local_addr().unwrap();
    server.start_heartbeat(OwnHeartbeat {
        interval: Duration::from_secs(30),
        ..OwnHeartbeat::default()
    });
    std::thread::sleep(Duration::from_millis(50));
    drop(server);
    until("the port is free again", || UdpSocket::bind(addr).is_ok());
}
