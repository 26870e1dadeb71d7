//! The router on a broadcast address and a multicast group, over loopback: `udpbcast` sends
//! with `SO_BROADCAST` and takes replies from any host; `udpmcast` joins its group, drops its
//! own frames coming back, and reaches every host once, a frame for one system included; and
//! `udpout ?replies=any` takes a reply from another address than its target.

mod daemon;

use std::net::{Ipv4Addr, SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use daemon::heartbeat;
use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::config::EndpointConfig;
use ferrolink_io::mavlink::router::Config;
use ferrolink_runtime::mavlink::{v2, Header, MessageMeta};
use ferrolink_test_support::free_port;

/// HEARTBEAT and COMMAND_LONG (common.xml), so that a command is routed by its target.
static TABLE: &[MessageMeta] = &[
    daemon::HEARTBEAT,
    MessageMeta {
        id: 76,
        crc_extra: 152,
        min_len: 33,
        max_len: 33,
        target_system: Some(30),
        target_component: Some(31),
    },
];

fn command_long(from: u8, to: u8) -> Vec<u8> {
    let mut payload = [0u8; 33];
    payload[30] = to;
    payload[31] = 1;
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(0, from, 190), 76, 152, &payload, &mut out).expect("fits");
    out[..n].to_vec()
}

fn router(endpoints: Vec<Endpoint>) -> daemon::Running {
    daemon::start(Config {
        endpoints: endpoints.into_iter().map(EndpointConfig::new).collect(),
        table: TABLE.into(),
        ..Config::default()
    })
}

fn socket(at: impl std::net::ToSocketAddrs) -> UdpSocket {
    let s = UdpSocket::bind(at).expect("bind");
    s.set_read_timeout(Some(Duration::from_millis(50)))
        .expect("timeout");
    s
}

/// Every datagram `s` receives within `window`, with its sender.
fn drain(s: &UdpSocket, window: Duration) -> Vec<(Vec<u8>, SocketAddr)> {
    let mut got = Vec::new();
    let until = Instant::now() + window;
    let mut buf = [0u8; 2048];
    while Instant::now() < until {
        if let Ok((n, from)) = s.recv_from(&mut buf) {
            got.push((buf[..n].to_vec(), from));
        }
    }
    got
}

/// The frames received, in order (the router packs the frames a read gives a peer into
/// one datagram, as MAVLink's UDP readers take them).
fn frames(got: &[(Vec<u8>, SocketAddr)]) -> Vec<Vec<u8>> {
    let mut frames = Vec::new();
    for (mut bytes, _) in got.iter().map(|(b, from)| (&b[..], from)) {
        while bytes.len() >= v2::HEADER_LEN {
            let len = v2::HEADER_LEN + usize::from(bytes[1]) + 2;
            frames.push(bytes[..len].to_vec());
            bytes = &bytes[len..];
        }
    }
    frames
}

/// The system id of each frame received.
fn senders(got: &[(Vec<u8>, SocketAddr)]) -> Vec<u8> {
    frames(got).iter().map(|f| f[5]).collect()
}

const WINDOW: Duration = Duration::from_millis(400);

#[test]
fn udpbcast_broadcasts_and_takes_replies_from_any_host() {
    let (gcs_port, vehicle_port) = (free_port(), free_port());
    let running = router(vec![
        Endpoint::UdpIn("127.0.0.1".into(), gcs_port),
        Endpoint::UdpBcast("127.255.255.255".into(), vehicle_port),
    ]);
    let gcs = socket("127.0.0.1:0");
    let vehicle = socket((Ipv4Addr::UNSPECIFIED, vehicle_port));
    gcs.send_to(&heartbeat(255), ("127.0.0.1", gcs_port))
        .expect("send");
    // Sent to the broadcast address: a socket without SO_BROADCAST could not.
    let got = drain(&vehicle, WINDOW);
    assert_eq!(senders(&got), [255]);
    let router_at = got[0].1;
    // The vehicle answers from its own address, not the broadcast one it was sent to.
    vehicle.send_to(&heartbeat(1), router_at).expect("send");
    assert_eq!(senders(&drain(&gcs, WINDOW)), [1]);
    // A broadcast reaches the vehicle once, through the broadcast address; a command for its
    // system goes to it directly; its own frames never come back.
    gcs.send_to(&heartbeat(255), ("127.0.0.1", gcs_port))
        .expect("send");
    gcs.send_to(&command_long(255, 1), ("127.0.0.1", gcs_port))
        .expect("send");
    let got = drain(&vehicle, WINDOW);
    assert_eq!(senders(&got), [255, 255], "{got:?}");
    assert_eq!(frames(&got)[1], command_long(255, 1));
    running.stop();
}

/// A member of a multicast group on loopback: a receiving socket bound to the group's port
/// (shared with every other member) and a sending one.
struct Member {
    receive: UdpSocket,
    send: UdpSocket,
    group: SocketAddr,
}

impl Member {
    fn join(group: Ipv4Addr, port: u16) -> Member {
        let receive = socket2::Socket::new(
            socket2::Domain::IPV4,
            socket2::Type::DGRAM,
            Some(socket2::Protocol::UDP),
        )
        .expect("socket");
        receive.set_reuse_address(true).expect("reuse");
        receive
            .bind(&SocketAddr::from((group, port)).into())
            .expect("bind");
        receive
            .join_multicast_v4(&group, &Ipv4Addr::LOCALHOST)
            .expect("join");
        let receive: UdpSocket = receive.into();
        receive
            .set_read_timeout(Some(Duration::from_millis(50)))
            .expect("timeout");
        let send = socket("127.0.0.1:0");
        socket2::SockRef::from(&send)
            .set_multicast_if_v4(&Ipv4Addr::LOCALHOST)
            .expect("interface");
        Member {
            receive,
            send,
            group: (group, port).into(),
        }
    }

    fn say(&self, frame: &[u8]) {
        self.send.send_to(frame, self.group).expect("send");
    }

    /// What reached it from others than itself within the window.
    fn heard(&self) -> Vec<(Vec<u8>, SocketAddr)> {
        let own = self.send.local_addr().expect("address").port();
        let mut got = drain(&self.receive, WINDOW);
        got.retain(|(_, from)| from.port() != own);
        got
    }
}

#[test]
fn udpmcast_reaches_each_member_once_and_never_hears_itself() {
    let group = Ipv4Addr::new(239, 255, 145, 50);
    let (gcs_port, group_port) = (free_port(), free_port());
    let running = router(vec![
        Endpoint::UdpIn("127.0.0.1".into(), gcs_port),
        Endpoint::UdpMcast(group.to_string(), group_port, Some("lo".into())),
    ]);
    let (one, two) = (
        Member::join(group, group_port),
        Member::join(group, group_port),
    );
    let gcs = socket("127.0.0.1:0");
    gcs.send_to(&heartbeat(255), ("127.0.0.1", gcs_port))
        .expect("send");
    assert_eq!(senders(&one.heard()), [255]);
    assert_eq!(senders(&two.heard()), [255]);
    // Two vehicles speak in the group: the ground station hears each once, and neither is sent
    // back into the group (each member heard the other there already).
    one.say(&heartbeat(1));
    two.say(&heartbeat(2));
    let mut heard = senders(&drain(&gcs, WINDOW));
    heard.sort();
    assert_eq!(heard, [1, 2], "the router's own frames never come back in");
    assert_eq!(senders(&one.heard()), [2]);
    assert_eq!(senders(&two.heard()), [1]);
    // A command for vehicle 2 goes into the group once; a broadcast too.
    gcs.send_to(&command_long(255, 2), ("127.0.0.1", gcs_port))
        .expect("send");
    gcs.send_to(&heartbeat(255), ("127.0.0.1", gcs_port))
        .expect("send");
    let got = two.heard();
    assert_eq!(senders(&got), [255, 255], "{got:?}");
    assert_eq!(frames(&got)[0], command_long(255, 2));
    assert!(drain(&gcs, WINDOW).is_empty(), "nothing echoed");
    running.stop();
}

#[test]
fn udpout_takes_replies_from_any_address_when_asked() {
    let gcs_port = free_port();
    let vehicle = socket("127.0.0.1:0");
    let to = vehicle.local_addr().expect("address").port();
    // The vehicle listens on one socket and answers from another.
    let answers = socket("127.0.0.1:0");
    let run = |endpoint: Endpoint| {
        let running = router(vec![
            Endpoint::UdpIn("127.0.0.1".into(), gcs_port),
            endpoint,
        ]);
        let gcs = socket("127.0.0.1:0");
        gcs.send_to(&heartbeat(255), ("127.0.0.1", gcs_port))
            .expect("send");
        let got = drain(&vehicle, WINDOW);
        assert_eq!(senders(&got), [255]);
        answers.send_to(&heartbeat(1), got[0].1).expect("send");
        let heard = senders(&drain(&gcs, WINDOW));
        running.stop();
        heard
    };
    assert_eq!(
        run(Endpoint::UdpOut("127.0.0.1".into(), to)),
        Vec::<u8>::new(),
        "a plain udpout reads only its target"
    );
    assert_eq!(run(Endpoint::UdpOutAny("127.0.0.1".into(), to)), [1]);
}
