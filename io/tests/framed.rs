//! The one read loop: every protocol's stream parser on a serial link (a pseudo-terminal and the
//! serial device opened on it), both directions; a TosNet ring over serial links and over UDP.
#![cfg(unix)]

use std::fmt::Debug;
use std::path::Path;
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_io::framed::Framed;
use ferrolink_io::link::Endpoint;
use ferrolink_io::tosnet::{Framing, LinkNode, UdpNode};
use ferrolink_runtime::framing::{Counters, Deframer};
use ferrolink_runtime::mavlink::{self, v2, Header, MessageMeta};
use ferrolink_runtime::modrob::{self, uart, Message};
use ferrolink_runtime::ndlcom;
use ferrolink_runtime::tosnet::{frame::Repr, stream, Config, Node, Phase};

const WAIT: Duration = Duration::from_secs(10);

/// Line noise no protocol takes for a frame start.
const NOISE: [u8; 4] = [0x11, 0x22, 0x33, 0x44];

static META: &[MessageMeta] = &[MessageMeta {
    id: 0,
    crc_extra: 50,
    min_len: 9,
    max_len: 9,
    target_system: None,
    target_component: None,
}];

/// Whether this machine can make pseudo-terminals; a note and `false` if not.
fn ptys() -> bool {
    match serialport::TTYPort::pair() {
        Ok(_) => true,
        Err(e) => {
            eprintln!("skipping: cannot create a pseudo-terminal here: {e}");
            false
        }
    }
}

/// Both ends of a serial link: the pty and the serial device opened through its symlink, each
/// framed by a parser from `new`, both with their peer up.
fn serial_link<D: Deframer + Send + 'static>(
    path: &Path,
    new: fn() -> D,
) -> (Framed<D>, Framed<D>) {
    let name = path.to_str().unwrap().to_owned();
    let pty = Framed::open(&Endpoint::Pty(name.clone()), new).unwrap();
    let serial = Framed::open(&Endpoint::Serial(name, 115_200), new).unwrap();
    let mut ends = (pty, serial);
    let deadline = Instant::now() + WAIT;
    while ends.0.peers() == 0 || ends.1.peers() == 0 {
        assert!(Instant::now() < deadline, "the serial link did not come up");
        ends.0.poll(|_, _| {}).unwrap();
        ends.1.poll(|_, _| {}).unwrap();
        thread::sleep(Duration::from_millis(10));
    }
    ends
}

/// Sends noise, then every frame of `wire`, from `from` to `to`, and returns what `to` framed.
fn carry<D: Deframer + 'static, T>(
    from: &Framed<D>,
    to: &mut Framed<D>,
    wire: &[Vec<u8>],
    mut owned: impl FnMut(D::Frame<'_>) -> T,
) -> Vec<T> {
    from.send(&NOISE).unwrap();
    for frame in wire {
        from.send(frame).unwrap();
    }
    let mut got = Vec::new();
    let deadline = Instant::now() + WAIT;
    while got.len() < wire.len() && Instant::now() < deadline {
        to.wait(Some(Duration::from_millis(50)), |_, frame| {
            got.push(owned(frame))
        })
        .unwrap();
    }
    got
}

/// Carries `wire` both ways over a serial link and checks the frames and the counters.
fn both_ways<D, T>(
    protocol: &str,
    new: fn() -> D,
    wire: &[Vec<u8>],
    expected: &[T],
    mut owned: impl FnMut(D::Frame<'_>) -> T,
) where
    D: Deframer + Send + 'static,
    T: PartialEq + Debug,
{
    let dir = tempfile::tempdir().unwrap();
    let (mut pty, mut serial) = serial_link(&dir.path().join(protocol), new);
    let got = carry(&serial, &mut pty, wire, &mut owned);
    assert_eq!(got, expected, "{protocol}: serial device to pty");
    let got = carry(&pty, &mut serial, wire, &mut owned);
    assert_eq!(got, expected, "{protocol}: pty to serial device");
    for end in [&pty, &serial] {
        let frames: u64 = end.stats().map(|(_, s)| s.frames()).sum();
        assert_eq!(frames, expected.len() as u64, "{protocol}: {end:?}");
    }
}

#[test]
fn mavlink_on_a_serial_link() {
    if !ptys() {
        return;
    }
    let wire: Vec<Vec<u8>> = (0..5u8)
        .map(|seq| {
            let mut out = [0u8; v2::MAX_FRAME_LEN];
            let n = v2::encode_raw(Header::new(seq, 1, 1), 0, 50, &[seq; 9], &mut out).unwrap();
            out[..n].to_vec()
        })
        .collect();
    let expected: Vec<(u8, u32)> = (0..5).map(|seq| (seq, 0)).collect();
    both_ways(
        "mavlink",
        || mavlink::parser::Parser::<{ v2::MAX_FRAME_LEN }>::new(META),
        &wire,
        &expected,
        |frame| (frame.header().seq, frame.msg_id()),
    );
}

/// A false start (a MAVLink 2 header of a known message claiming 255 bytes, as a bad radio or
/// a link joined midway makes them) and then one frame, and nothing more: the frame comes out
/// once the serial device has been quiet for `link::QUIET`, not after 255 bytes more.
#[test]
fn a_false_start_on_a_quiet_serial_link_holds_nothing_back() {
    if !ptys() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let new = || mavlink::parser::Parser::<{ v2::MAX_FRAME_LEN }>::new(META);
    let (pty, mut serial) = serial_link(&dir.path().join("false-start"), new);
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(7, 1, 1), 0, 50, &[7; 9], &mut out).unwrap();
    let mut wire = std::vec![0xFD, 0xFF, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00];
    wire.extend_from_slice(&out[..n]);
    let sent = Instant::now();
    let got = carry(&pty, &mut serial, &[wire], |frame| frame.header().seq);
    assert_eq!(got, [7], "the frame behind the false start");
    assert!(
        sent.elapsed() >= ferrolink_io::link::QUIET,
        "it came before the pause"
    );
    let (_, stats) = serial.stats().next().expect("a peer");
    assert_eq!(stats.garbage_bytes, NOISE.len() + 10, "{stats:?}");
}

#[test]
fn ndlcom_on_a_serial_link() {
    if !ptys() {
        return;
    }
    type Parser = ndlcom::Parser<[u8; ndlcom::storage_len(ndlcom::MAX_PAYLOAD_LEN)]>;
    // Payloads with flag and escape bytes in them.
    let payloads: Vec<Vec<u8>> = (0..5u8).map(|i| vec![i, 0x7E, 0x7D, i]).collect();
    let wire: Vec<Vec<u8>> = payloads
        .iter()
        .enumerate()
        .map(|(i, payload)| {
            let header = ndlcom::Header::new(2, 1, i as u8, payload.len() as u8);
            let mut out = [0u8; 64];
            let n = ndlcom::encode(&header, payload, &mut out).unwrap();
            out[..n].to_vec()
        })
        .collect();
    both_ways(
        "ndlcom",
        || Parser::new([0; ndlcom::storage_len(ndlcom::MAX_PAYLOAD_LEN)]),
        &wire,
        &payloads,
        |frame| frame.payload().to_vec(),
    );
}

#[test]
fn modrob_uart_on_a_serial_link() {
    if !ptys() {
        return;
    }
    let messages: Vec<Message> = (0..5u8)
        .map(|i| Message::Publication {
            module: 1,
            variable: i,
            value: f32::from(i) / 2.0,
        })
        .collect();
    let wire: Vec<Vec<u8>> = messages
        .iter()
        .map(|m| {
            let mut out = [0u8; uart::MAX_FRAME_LEN];
            let n = uart::encode(m, &mut out).unwrap();
            out[..n].to_vec()
        })
        .collect();
    both_ways(
        "modrob",
        modrob::parser::Parser::new,
        &wire,
        &messages,
        |m| m,
    );
}

#[test]
fn tosnet_frames_on_a_serial_link() {
    if !ptys() {
        return;
    }
    let frames: Vec<Vec<u8>> = (1..6u8)
        .map(|sender| {
            let mut out = [0u8; 8];
            let n = Repr::Idle { sender }.emit(&mut out).unwrap();
            out[..n].to_vec()
        })
        .collect();
    let wire: Vec<Vec<u8>> = frames
        .iter()
        .map(|f| {
            let mut out = [0u8; 32];
            let n = stream::encode(f, &mut out).unwrap();
            out[..n].to_vec()
        })
        .collect();
    both_ways("tosnet", stream::Parser::<64>::new, &wire, &frames, |f| {
        f.to_vec()
    });
}

fn node(id: u8) -> Node {
    let mut cfg = Config::new(id).registers(0b1, 0b1);
    cfg.watchdog_ns = 200_000_000;
    Node::new(cfg)
}

/// Steps every node on a thread of its own for `duration`; returns them.
fn run_ring<F>(nodes: Vec<LinkNode<F>>, duration: Duration) -> Vec<LinkNode<F>>
where
    F: Framing,
    for<'p> F: Deframer<Frame<'p> = &'p [u8]>,
{
    let threads: Vec<_> = nodes
        .into_iter()
        .map(|mut node| {
            thread::spawn(move || {
                node.run_for(duration).unwrap();
                node
            })
        })
        .collect();
    threads.into_iter().map(|t| t.join().unwrap()).collect()
}

fn check_ring<F>(nodes: &[LinkNode<F>], how: &str)
where
    F: Framing,
    for<'p> F: Deframer<Frame<'p> = &'p [u8]>,
{
    for (i, n) in nodes.iter().enumerate() {
        let status = n.node().status();
        assert_eq!(status.phase, Phase::Running, "{how}: node {i}: {status:?}");
        assert_eq!(status.nodes, 3, "{how}: node {i}");
        assert!(
            n.node().counters().cycles > 50,
            "{how}: node {i}: {:?}",
            n.node().counters()
        );
        assert_eq!(n.send_errors, 0, "{how}: node {i}");
    }
}

#[test]
fn a_tosnet_ring_over_serial_links() {
    if !ptys() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let link = |i: usize| {
        dir.path()
            .join(format!("ring{i}"))
            .to_str()
            .unwrap()
            .to_owned()
    };
    // Node i sends on the pty of link i; node i+1 reads that link through its serial device
    // (opened in the background, retried until the pty exists).
    let nodes: Vec<LinkNode<stream::Parser>> = (0..3)
        .map(|i| {
            let prev = Endpoint::Serial(link((i + 2) % 3), 921_600);
            let next = Endpoint::Pty(link(i));
            LinkNode::stream(node(i as u8 + 1), &prev, &next).unwrap()
        })
        .collect();
    let nodes = run_ring(nodes, Duration::from_secs(3));
    check_ring(&nodes, "serial");
}

#[test]
fn a_tosnet_ring_over_udp() {
    let addrs: Vec<std::net::SocketAddr> = (0..3)
        .map(|_| ([127, 0, 0, 1], ferrolink_test_support::free_port()).into())
        .collect();
    let nodes: Vec<UdpNode> = (0..3)
        .map(|i| UdpNode::bind(node(i as u8 + 1), addrs[i], addrs[(i + 1) % 3]).unwrap())
        .collect();
    let nodes = run_ring(nodes, Duration::from_secs(2));
    check_ring(&nodes, "udp");
}
