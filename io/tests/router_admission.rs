//! The router daemon's admission: a peer refused because every link slot was taken is offered a
//! slot again once one frees, even while it keeps sending (it never goes quiet, so the link
//! layer never reports it anew).

mod daemon;

use std::net::UdpSocket;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use daemon::heartbeat;
use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::router::Config;
use ferrolink_runtime::mavlink::router::MAX_LINKS;
use ferrolink_test_support::free_port;

fn peer() -> UdpSocket {
    let s = UdpSocket::bind("127.0.0.1:0").expect("bind");
    s.set_read_timeout(Some(Duration::from_millis(50)))
        .expect("timeout");
    s
}

#[test]
fn a_refused_peer_gets_a_slot_once_one_frees() {
    let port = free_port();
    let config = Config {
        peer_expiry: Some(Duration::from_millis(800)),
        ..daemon::on(Endpoint::UdpIn("127.0.0.1".into(), port))
    };
    let router = daemon::start(config);
    let to = ("127.0.0.1", port);

    // Every slot taken by peers that then go quiet.
    let fillers: Vec<UdpSocket> = (0..MAX_LINKS).map(|_| peer()).collect();
    for (i, f) in fillers.iter().enumerate() {
        f.send_to(&heartbeat(i as u8 + 1), to).expect("send");
    }
    thread::sleep(Duration::from_millis(100));
    // The late peer is refused, and keeps sending.
    let late = peer();
    let keep_sending = Arc::new(AtomicBool::new(true));
    let sender = {
        let (late, keep) = (late.try_clone().expect("clone"), keep_sending.clone());
        thread::spawn(move || {
            while keep.load(Ordering::Relaxed) {
                let _ = late.send_to(&heartbeat(200), to);
                thread::sleep(Duration::from_millis(50));
            }
        })
    };
    // Once the fillers expired, a watcher joins and must hear the late peer.
    thread::sleep(Duration::from_millis(1_500));
    let watcher = peer();
    watcher.send_to(&heartbeat(250), to).expect("send");
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut heard = false;
    let mut buf = [0u8; 512];
    while !heard && Instant::now() < deadline {
        if let Ok(n) = watcher.recv(&mut buf) {
            heard = buf[..n] == heartbeat(200)[..];
        }
    }
    keep_sending.store(false, Ordering::Relaxed);
    sender.join().expect("sender");
    router.stop();
    assert!(heard, "the refused peer never got a slot");
}

/// A TCP client past the last link slot is closed at once: it keeps no thread or descriptor in
/// the router, and sees its connection end.
#[test]
fn a_refused_tcp_client_is_closed() {
    use std::io::Read;
    use std::net::TcpStream;

    let port = free_port();
    let router = daemon::start(daemon::on(Endpoint::TcpIn("127.0.0.1".into(), port)));
    let clients: Vec<TcpStream> = (0..MAX_LINKS)
        .map(|_| TcpStream::connect(("127.0.0.1", port)).expect("connect"))
        .collect();
    thread::sleep(Duration::from_millis(300));
    let mut refused = TcpStream::connect(("127.0.0.1", port)).expect("connect");
    refused
        .set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    let mut buf = [0u8; 16];
    let got = refused.read(&mut buf);
    router.stop();
    drop(clients);
    assert!(
        matches!(got, Ok(0)) || got.is_err_and(|e| e.kind() != std::io::ErrorKind::WouldBlock),
        "the refused client was not closed"
    );
}

/// Idle TCP connections hold no slot for good: with every slot taken by TCP clients that never
/// send a frame, the one that has gone longest without a checked frame, past the peer expiry,
/// is closed to make room for a newcomer (a ground station over UDP, then a TCP client); a
/// client that talks keeps its slot. Before, the idle connections locked everyone else out.
#[test]
fn idle_tcp_clients_give_their_slots_to_newcomers() {
    use std::io::{Read, Write};
    use std::net::TcpStream;

    let (tcp, udp) = (free_port(), free_port());
    let mut config = daemon::on(Endpoint::TcpIn("127.0.0.1".into(), tcp));
    config
        .endpoints
        .push(ferrolink_io::mavlink::config::EndpointConfig::new(
            Endpoint::UdpIn("127.0.0.1".into(), udp),
        ));
    config.peer_expiry = Some(Duration::from_secs(1));
    let router = daemon::start(config);

    // One client that talks, then idle ones in every other slot.
    let mut talker = TcpStream::connect(("127.0.0.1", tcp)).expect("connect");
    thread::sleep(Duration::from_millis(100));
    let idle: Vec<TcpStream> = (1..MAX_LINKS)
        .map(|_| TcpStream::connect(("127.0.0.1", tcp)).expect("connect"))
        .collect();
    let keep_talking = Arc::new(AtomicBool::new(true));
    let talking = {
        let (mut talker, keep) = (talker.try_clone().expect("clone"), keep_talking.clone());
        thread::spawn(move || {
            while keep.load(Ordering::Relaxed) {
                let _ = talker.write_all(&heartbeat(100));
                thread::sleep(Duration::from_millis(100));
            }
        })
    };
    thread::sleep(Duration::from_millis(1_500));

    // A ground station over UDP gets a slot and hears the talker.
    let gcs = peer();
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut heard = false;
    let mut buf = [0u8; 512];
    while !heard && Instant::now() < deadline {
        gcs.send_to(&heartbeat(250), ("127.0.0.1", udp))
            .expect("send");
        if let Ok(n) = gcs.recv(&mut buf) {
            heard = buf[..n]
                .windows(heartbeat(100).len())
                .any(|w| w == heartbeat(100));
        }
    }
    // So does a new TCP client.
    let mut late = TcpStream::connect(("127.0.0.1", tcp)).expect("connect");
    late.set_read_timeout(Some(Duration::from_secs(3)))
        .expect("timeout");
    let late_heard = matches!(late.read(&mut buf), Ok(n) if n > 0);
    // The talker kept its slot: it hears the ground station.
    talker
        .set_read_timeout(Some(Duration::from_secs(3)))
        .expect("timeout");
    let talker_heard = matches!(talker.read(&mut buf), Ok(n) if n > 0);

    keep_talking.store(false, Ordering::Relaxed);
    talking.join().expect("talker");
    router.stop();
    drop(idle);
    assert!(heard, "the ground station never got a slot");
    assert!(late_heard, "the new TCP client never got a slot");
    assert!(talker_heard, "the talking client lost its slot");
}

/// Junk holds no slot: a hundred senders of random datagrams on a `udpin` port, more than there
/// are slots, and a vehicle and a ground station arriving after them still talk at once.
#[test]
fn junk_senders_hold_no_slot() {
    let port = free_port();
    let router = daemon::start(daemon::on(Endpoint::UdpIn("127.0.0.1".into(), port)));
    let to = ("127.0.0.1", port);
    let junk: Vec<UdpSocket> = (0..100).map(|_| peer()).collect();
    let mut noise = 0x2545_f491_u32;
    for round in 0..3 {
        for j in &junk {
            let datagram: Vec<u8> = (0..40 + round * 7)
                .map(|_| {
                    noise ^= noise << 13;
                    noise ^= noise >> 17;
                    noise ^= noise << 5;
                    // Start markers among the noise, so some of it looks like frames.
                    if noise.is_multiple_of(16) {
                        0xfd
                    } else {
                        noise as u8
                    }
                })
                .collect();
            j.send_to(&datagram, to).expect("send");
        }
    }
    thread::sleep(Duration::from_millis(100));
    let (vehicle, gcs) = (peer(), peer());
    gcs.send_to(&heartbeat(255), to).expect("send");
    thread::sleep(Duration::from_millis(50));
    vehicle.send_to(&heartbeat(1), to).expect("send");
    let deadline = Instant::now() + Duration::from_secs(2);
    let mut heard = false;
    let mut buf = [0u8; 512];
    while !heard && Instant::now() < deadline {
        if let Ok(n) = gcs.recv(&mut buf) {
            heard = buf[..n] == heartbeat(1)[..];
        }
    }
    router.stop();
    assert!(
        heard,
        "the ground station never heard the vehicle past the junk"
    );
    for j in &junk {
        j.set_nonblocking(true).expect("non-blocking");
        assert!(j.recv(&mut buf).is_err(), "a junk sender was sent frames");
    }
}
