//! MAVLink routers on loopback, side by side in one run: `ferrolink mavlink router`,
//! mavlink-routerd and MAVProxy used as a forwarder, each with three UDP endpoints.
//!
//! ```sh
//! cargo build --release -p ferrolink-cli
//! cargo bench -p ferrolink-bench --bench router
//! ```
//!
//! One peer sends PING broadcasts (its send time in `time_usec`) into endpoint A; two peers on
//! endpoints B and C receive them. Per router:
//! - at 10,000 msg/s offered for 5 s: what arrived at B and C, the router's CPU time per 10,000
//!   messages (from /proc, in nanoseconds where the kernel keeps schedstat), and the latency from A to B at p50 and p99;
//! - at 1,000 msg/s for 10 s: the latency from A to B at p99;
//! - at 50,000 msg/s for 3 s: what arrived at B and C;
//! - the most it forwards: 400,000 msg/s offered for 3 s, messages per second arriving at B;
//! - idle: CPU use over 5 s with the three peers connected and nothing sent;
//! - six peers, one per endpoint, each sending broadcasts at a sixth of 10,000 msg/s for 5 s: the
//!   share of the copies owed to the other five that arrived (not for MAVProxy, which forwards
//!   between its master and its outputs only).
//!
//! First, the floor: the latency of one loopback hop with no router at all, at the same rate.
//!
//! Then a fleet of two: two ferrolink routers in a row, joined by UDP or by Zenoh, PINGs into the
//! first and a receiving peer on the second (the `zenoh` feature, on by default); and the floor
//! their Zenoh link is judged against: a bare Zenoh publisher and subscriber (two processes,
//! this bench run as `--bare-zenoh pub|sub`) carrying the same datagrams from the same UDP port
//! to the same peer. The goal: the routers' CPU per frame at most 1.2 times theirs.
//!
//! Last, the I/O model behind the daemon, measured the same way in this process: the runtime's
//! router over three UDP sockets, driven by a blocking reader thread per socket (what `io::link`
//! does), by a single-threaded tokio runtime (one epoll loop), and by tokio's multi-threaded
//! runtime with two workers. CPU is that of the forwarding threads only.
//!
//! Peers that are not installed are skipped with a note: mavlink-routerd is taken from
//! `MAVLINK_ROUTERD` or the `PATH`, MAVProxy from `.venv/bin/mavproxy.py` or the `PATH`.

#[allow(dead_code)]
mod harness;
#[path = "router/peers.rs"]
mod peers;
use std::io::{BufRead, BufReader};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_generated::mavlink::minimal::Message;
use ferrolink_runtime::mavlink::parser::Parser;
use ferrolink_runtime::mavlink::router::{LinkConfig, Router as Core};
use ferrolink_runtime::mavlink::{v2, Dialect, Header, MessageMeta};
use peers::*;

/// HEARTBEAT and PING (and the rest of our minimal dialect).
static META: &[MessageMeta] = <Message as Dialect>::META;

fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

fn now_us() -> u64 {
    epoch().elapsed().as_micros() as u64
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A PING broadcast from `sysid`, its send time in `time_usec`.
fn ping(seq: u32, sysid: u8) -> Vec<u8> {
    let mut payload = [0u8; 14];
    payload[..8].copy_from_slice(&now_us().to_le_bytes());
    payload[8..12].copy_from_slice(&seq.to_le_bytes());
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(seq as u8, sysid, 1), 4, 237, &payload, &mut out)
        .expect("encode");
    out[..n].to_vec()
}

fn heartbeat(sysid: u8) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(
        Header::new(0, sysid, 190),
        0,
        50,
        &[0, 0, 0, 0, 6, 8, 0, 0, 3],
        &mut out,
    )
    .expect("encode");
    out[..n].to_vec()
}

/// A receiving peer: counts PINGs and records their latency.
struct Sink {
    socket: UdpSocket,
    received: Arc<Mutex<Vec<u64>>>,
    stop: Arc<AtomicBool>,
    thread: Option<thread::JoinHandle<()>>,
}

impl Sink {
    fn new(port: u16, sysid: u8) -> Sink {
        let socket = UdpSocket::bind("127.0.0.1:0").expect("bind");
        socket.connect(("127.0.0.1", port)).expect("connect");
        socket
            .set_read_timeout(Some(Duration::from_millis(50)))
            .expect("timeout");
        // Room for bursts, so that what is lost is lost in the router, not in this peer's
        // socket while the scheduler keeps its thread waiting (the kernel caps it at
        // net.core.rmem_max).
        let _ = socket2::SockRef::from(&socket).set_recv_buffer_size(4 << 20);
        let received = Arc::new(Mutex::new(Vec::with_capacity(1 << 20)));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (socket, received, stop) = (
                socket.try_clone().expect("clone"),
                received.clone(),
                stop.clone(),
            );
            thread::spawn(move || {
                let mut parser: Parser = Parser::new(META);
                let mut buf = [0u8; 65536];
                // A ground station says it is alive once a second; routers forget silent peers.
                let mut next_heartbeat = Instant::now();
                while !stop.load(Ordering::Relaxed) {
                    if Instant::now() >= next_heartbeat {
                        let _ = socket.send(&heartbeat(sysid));
                        next_heartbeat += Duration::from_secs(1);
                    }
                    let Ok(n) = socket.recv(&mut buf) else {
                        continue;
                    };
                    let t = now_us();
                    parser.feed_all(&buf[..n], |frame| {
                        if frame.msg_id() == 4 {
                            // A MAVLink 2 payload comes without its trailing zeros.
                            let p = ferrolink_runtime::wire::zero_extend::<14>(frame.payload());
                            let sent: u64 = ferrolink_runtime::wire::get(&p, 0);
                            if let Ok(mut r) = received.lock() {
                                r.push(t.saturating_sub(sent));
                            }
                        }
                    });
                }
            })
        };
        Sink {
            socket,
            received,
            stop,
            thread: Some(thread),
        }
    }

    fn take(&self) -> Vec<u64> {
        std::mem::take(&mut *self.received.lock().expect("lock"))
    }
}

impl Drop for Sink {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let _ = &self.socket;
    }
}

/// Sends `rate` PINGs per second from `sysid` for `duration`; returns how many were sent.
fn send(socket: &UdpSocket, sysid: u8, rate: u64, duration: Duration) -> u64 {
    let start = Instant::now();
    let mut sent = 0u64;
    while start.elapsed() < duration {
        let due = (start.elapsed().as_secs_f64() * rate as f64) as u64;
        while sent < due {
            let _ = socket.send(&ping(sent as u32, sysid));
            sent += 1;
        }
        thread::sleep(Duration::from_micros(200));
    }
    sent
}

fn percentile(sorted: &[u64], p: f64) -> u64 {
    if sorted.is_empty() {
        return 0;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

struct Row {
    name: &'static str,
    six_peers: Option<f64>,
    delivered: f64,
    cpu_per_10k_ms: f64,
    p50: u64,
    p99: u64,
    max_rate: f64,
    idle_pct: f64,
    /// Latency p99 at 1,000 msg/s.
    p99_1k: u64,
    /// Share delivered to B and C at 50,000 msg/s.
    delivered_50k: f64,
}

fn measure(router: &Router, ports: &[u16]) -> Row {
    let pid = router.child.id();
    measure_with(router.name, ports, || cpu_time(pid).unwrap_or_default())
}

/// The measurements of one router on `ports` (A, B, C), whose CPU time `cpu` reads.
fn measure_with(name: &'static str, ports: &[u16], cpu: impl Fn() -> Duration) -> Row {
    let source = UdpSocket::bind("127.0.0.1:0").expect("bind");
    source.connect(("127.0.0.1", ports[0])).expect("connect");
    let _ = source.send(&heartbeat(1));
    let (b, c) = (Sink::new(ports[1], 201), Sink::new(ports[2], 202));
    thread::sleep(Duration::from_millis(500));
    let _ = (b.take(), c.take());

    // Idle, with every peer known.
    let idle = Duration::from_secs(5);
    let before = cpu();
    thread::sleep(idle);
    let idle_pct = 100.0 * cpu().saturating_sub(before).as_secs_f64() / idle.as_secs_f64();

    // 10,000 msg/s.
    let before = cpu();
    let sent = send(&source, 1, 10_000, Duration::from_secs(5));
    thread::sleep(Duration::from_millis(500));
    let used = cpu().saturating_sub(before);
    let (mut lb, lc) = (b.take(), c.take());
    lb.sort_unstable();
    let delivered = (lb.len() + lc.len()) as f64 / (2 * sent) as f64;
    let forwarded = (lb.len() + lc.len()).max(1) as f64;
    let row = Row {
        name,
        six_peers: None,
        delivered,
        cpu_per_10k_ms: used.as_secs_f64() * 1e3 * 10_000.0 / forwarded,
        p50: percentile(&lb, 0.5),
        p99: percentile(&lb, 0.99),
        max_rate: 0.0,
        idle_pct,
        p99_1k: 0,
        delivered_50k: 0.0,
    };

    // 1,000 msg/s: the latency of a frame that finds nothing queued. 10,000 frames, so that the
    // p99 is the 100th worst, not a handful of the VM's stalls.
    send(&source, 1, 1_000, Duration::from_secs(10));
    thread::sleep(Duration::from_millis(300));
    let mut l1 = b.take();
    l1.sort_unstable();
    let _ = c.take();
    let p99_1k = percentile(&l1, 0.99);

    // 50,000 msg/s: what arrives.
    let sent = send(&source, 1, 50_000, Duration::from_secs(3));
    thread::sleep(Duration::from_millis(500));
    let delivered_50k = (b.take().len() + c.take().len()) as f64 / (2 * sent) as f64;

    // The most it forwards to one peer: more offered than any router here forwards.
    let window = Duration::from_secs(3);
    send(&source, 1, MAX_OFFERED, window);
    thread::sleep(Duration::from_millis(500));
    let max_rate = b.take().len() as f64 / window.as_secs_f64();
    let _ = c.take();
    Row {
        max_rate,
        p99_1k,
        delivered_50k,
        ..row
    }
}

/// The rate offered to find the most a router forwards.
const MAX_OFFERED: u64 = 400_000;

/// The floor: latency p50 and p99 of one loopback hop with no router, PINGs at `rate` for 5 s
/// straight from the sender to a receiving peer. A router adds a second hop.
fn direct(rate: u64) -> (u64, u64) {
    let source = UdpSocket::bind("127.0.0.1:0").expect("bind");
    let port = source.local_addr().expect("bound").port();
    let sink = Sink::new(port, 201);
    source
        .connect(sink.socket.local_addr().expect("bound"))
        .expect("connect");
    thread::sleep(Duration::from_millis(200));
    send(&source, 1, rate, Duration::from_secs(5));
    thread::sleep(Duration::from_millis(200));
    let mut l = sink.take();
    l.sort_unstable();
    (percentile(&l, 0.5), percentile(&l, 0.99))
}

/// Two ferrolink routers in a row, joined by UDP (`udpout` to `udpin`) or by Zenoh (peer mode
/// over TCP on loopback): PINGs go into the first, a receiving peer sits on the second. Returns
/// the row (CPU of both routers) or `None` if a router did not start.
fn two_routers(zenoh: bool, base: u16) -> Option<Row> {
    let (join_a, join_b) = if zenoh {
        let z = format!("tcp/127.0.0.1:{}&prefix=bench{base}", base + 3);
        (
            format!("zenoh://?mode=peer&listen={z}"),
            format!("zenoh://?mode=peer&connect={z}"),
        )
    } else {
        (
            format!("udpout://127.0.0.1:{}", base + 2),
            format!("udpin://127.0.0.1:{}", base + 2),
        )
    };
    let b = start_ferrolink_with(vec![join_b, format!("udpin://127.0.0.1:{}", base + 1)])?;
    let a = start_ferrolink_with(vec![format!("udpin://127.0.0.1:{base}"), join_a])?;
    let source = UdpSocket::bind("127.0.0.1:0").expect("bind");
    source.connect(("127.0.0.1", base)).expect("connect");
    let sink = Sink::new(base + 1, 201);
    // Zenoh peers meet, the first router's udpout speaks first, every peer says hello.
    for _ in 0..4 {
        let _ = source.send(&heartbeat(1));
        thread::sleep(Duration::from_millis(500));
    }
    let _ = sink.take();
    let cpu =
        || cpu_time(a.child.id()).unwrap_or_default() + cpu_time(b.child.id()).unwrap_or_default();
    let before = cpu();
    let sent = send(&source, 1, 10_000, Duration::from_secs(5));
    thread::sleep(Duration::from_millis(500));
    let used = cpu().saturating_sub(before);
    let mut l = sink.take();
    l.sort_unstable();
    let row = Row {
        name: if zenoh { "Zenoh" } else { "UDP" },
        six_peers: None,
        delivered: l.len() as f64 / sent as f64,
        cpu_per_10k_ms: used.as_secs_f64() * 1e3 * 10_000.0 / l.len().max(1) as f64,
        p50: percentile(&l, 0.5),
        p99: percentile(&l, 0.99),
        max_rate: 0.0,
        idle_pct: 0.0,
        p99_1k: 0,
        delivered_50k: 0.0,
    };
    let window = Duration::from_secs(3);
    send(&source, 1, MAX_OFFERED, window);
    thread::sleep(Duration::from_millis(500));
    let max_rate = sink.take().len() as f64 / window.as_secs_f64();
    Some(Row { max_rate, ..row })
}

/// A bare Zenoh bridge: this bench run as a publisher (UDP in) and a subscriber (UDP out).
struct Bare {
    children: Vec<Child>,
}

impl Drop for Bare {
    fn drop(&mut self) {
        for c in &mut self.children {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// `--bare-zenoh pub|sub ZENOH_PORT UDP_PORT`: the publisher reads datagrams on the UDP port and
/// puts each on one key; the subscriber sends each sample to the peer heard on its UDP port.
/// Runs until killed.
fn bare_zenoh_helper(role: &str, zport: u16, udp: u16) {
    use zenoh::Wait;
    let mut config = zenoh::Config::default();
    let endpoints = format!("[\"tcp/127.0.0.1:{zport}\"]");
    config.insert_json5("mode", "\"peer\"").expect("mode");
    let side = if role == "pub" {
        "listen/endpoints"
    } else {
        "connect/endpoints"
    };
    config.insert_json5(side, &endpoints).expect("endpoints");
    let session = zenoh::open(config).wait().expect("a Zenoh session");
    let key = format!("bench{zport}/bare");
    let socket = UdpSocket::bind(("127.0.0.1", udp)).expect("bind");
    let mut buf = [0u8; 65536];
    if role == "pub" {
        let publisher = session.declare_publisher(key).wait().expect("publisher");
        println!("ready");
        loop {
            if let Ok(n) = socket.recv(&mut buf) {
                let _ = publisher.put(buf[..n].to_vec()).wait();
            }
        }
    }
    let peer: Arc<Mutex<Option<std::net::SocketAddr>>> = Arc::default();
    let out = socket.try_clone().expect("clone");
    let to = peer.clone();
    let _subscriber = session
        .declare_subscriber(key)
        .callback(move |sample| {
            if let Some(addr) = *to.lock().unwrap_or_else(std::sync::PoisonError::into_inner) {
                let _ = out.send_to(&sample.payload().to_bytes(), addr);
            }
        })
        .wait()
        .expect("subscriber");
    println!("ready");
    loop {
        if let Ok((_, from)) = socket.recv_from(&mut buf) {
            *peer
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(from);
        }
    }
}

/// The same load as [`two_routers`] through a bare Zenoh publisher and subscriber.
fn bare_zenoh(base: u16) -> Option<Row> {
    let exe = std::env::current_exe().ok()?;
    let start = |role: &str, udp: u16| -> Option<Child> {
        let mut child = Command::new(&exe)
            .args([
                "--bare-zenoh",
                role,
                &(base + 3).to_string(),
                &udp.to_string(),
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .ok()?;
        let mut line = String::new();
        BufReader::new(child.stdout.take()?)
            .read_line(&mut line)
            .ok()?;
        line.contains("ready").then_some(child)
    };
    let sub = start("sub", base + 1)?;
    let mut bare = Bare {
        children: vec![sub],
    };
    bare.children.push(start("pub", base)?);
    let source = UdpSocket::bind("127.0.0.1:0").expect("bind");
    source.connect(("127.0.0.1", base)).expect("connect");
    let sink = Sink::new(base + 1, 201);
    for _ in 0..4 {
        let _ = source.send(&heartbeat(1));
        thread::sleep(Duration::from_millis(500));
    }
    let _ = sink.take();
    let cpu = || {
        bare.children
            .iter()
            .map(|c| cpu_time(c.id()).unwrap_or_default())
            .sum::<Duration>()
    };
    let before = cpu();
    let sent = send(&source, 1, 10_000, Duration::from_secs(5));
    thread::sleep(Duration::from_millis(500));
    let used = cpu().saturating_sub(before);
    let mut l = sink.take();
    l.sort_unstable();
    let row = Row {
        name: "bare Zenoh (publisher and subscriber, no router)",
        six_peers: None,
        delivered: l.len() as f64 / sent as f64,
        cpu_per_10k_ms: used.as_secs_f64() * 1e3 * 10_000.0 / l.len().max(1) as f64,
        p50: percentile(&l, 0.5),
        p99: percentile(&l, 0.99),
        max_rate: 0.0,
        idle_pct: 0.0,
        p99_1k: 0,
        delivered_50k: 0.0,
    };
    let window = Duration::from_secs(3);
    send(&source, 1, MAX_OFFERED, window);
    thread::sleep(Duration::from_millis(500));
    let max_rate = sink.take().len() as f64 / window.as_secs_f64();
    Some(Row { max_rate, ..row })
}

/// Six peers, one per endpoint and each a system of its own, sending PING broadcasts at a sixth
/// of 10,000 msg/s for 5 s: the share of the copies owed to the other five that arrived.
fn six_peers(ports: &[u16]) -> f64 {
    let sinks: Vec<Sink> = ports
        .iter()
        .enumerate()
        .map(|(i, &p)| Sink::new(p, 10 + i as u8))
        .collect();
    thread::sleep(Duration::from_millis(500));
    for s in &sinks {
        s.take();
    }
    let senders: Vec<_> = sinks
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let socket = s.socket.try_clone().expect("clone");
            let sysid = 10 + i as u8;
            thread::spawn(move || send(&socket, sysid, 10_000 / 6, Duration::from_secs(5)))
        })
        .collect();
    let sent: u64 = senders.into_iter().map(|t| t.join().unwrap_or(0)).sum();
    thread::sleep(Duration::from_millis(500));
    let received: usize = sinks.iter().map(|s| s.take().len()).sum();
    received as f64 / (5 * sent) as f64
}

/// A router core over three UDP sockets, each with one peer (the first address heard from).
struct Forwarder {
    core: Mutex<Box<Core<3, 64, 64, 64>>>,
    peers: Mutex<[Option<std::net::SocketAddr>; 3]>,
}

impl Forwarder {
    fn new() -> Arc<Forwarder> {
        let mut core: Box<Core<3, 64, 64, 64>> = Box::new(Core::new(META));
        for _ in 0..3 {
            core.open_link(LinkConfig::default()).expect("three links");
        }
        Arc::new(Forwarder {
            core: Mutex::new(core),
            peers: Mutex::new([None; 3]),
        })
    }

    /// Routes a datagram `bytes` read on socket `link` from `from`; `send(link, bytes, to)`
    /// writes a copy.
    fn route(
        &self,
        link: usize,
        from: std::net::SocketAddr,
        bytes: &[u8],
        mut send: impl FnMut(usize, &[u8], std::net::SocketAddr),
    ) {
        let peers = {
            let mut peers = self.peers.lock().expect("lock");
            peers[link].get_or_insert(from);
            *peers
        };
        let now = now_us();
        let mut core = self.core.lock().expect("lock");
        core.receive(link, bytes, now, now, |routed| {
            let mut to = routed.to;
            while to != 0 {
                let out = to.trailing_zeros() as usize;
                to &= to - 1;
                if let Some(addr) = peers.get(out).copied().flatten() {
                    send(out, routed.bytes, addr);
                }
            }
        });
    }
}

/// How the forwarder's sockets are driven.
#[derive(Clone, Copy)]
enum Model {
    Threads,
    TokioCurrentThread,
    TokioTwoWorkers,
}

impl Model {
    fn name(self) -> &'static str {
        match self {
            Model::Threads => "a blocking reader thread per socket",
            Model::TokioCurrentThread => "tokio, current-thread runtime",
            Model::TokioTwoWorkers => "tokio, multi-thread runtime, 2 workers",
        }
    }
}

/// Runs the forwarder on `ports` under `model` until `stop` is set. Its threads are named
/// `fwd...` so that their CPU time can be told from the load generator's.
fn forward(model: Model, ports: [u16; 3], stop: Arc<AtomicBool>) -> thread::JoinHandle<()> {
    let sockets: Vec<UdpSocket> = ports
        .iter()
        .map(|p| UdpSocket::bind(("127.0.0.1", *p)).expect("bind"))
        .collect();
    let fwd = Forwarder::new();
    match model {
        Model::Threads => {
            let sockets: Vec<Arc<UdpSocket>> = sockets.into_iter().map(Arc::new).collect();
            let readers: Vec<_> = (0..3)
                .map(|link| {
                    let (sockets, fwd, stop) = (sockets.clone(), fwd.clone(), stop.clone());
                    thread::Builder::new()
                        .name(format!("fwd{link}"))
                        .spawn(move || {
                            let socket = &sockets[link];
                            let _ = socket.set_read_timeout(Some(Duration::from_millis(200)));
                            let mut buf = [0u8; 65536];
                            while !stop.load(Ordering::Relaxed) {
                                let Ok((n, from)) = socket.recv_from(&mut buf) else {
                                    continue;
                                };
                                fwd.route(link, from, &buf[..n], |out, bytes, to| {
                                    let _ = sockets[out].send_to(bytes, to);
                                });
                            }
                        })
                        .expect("spawn")
                })
                .collect();
            thread::spawn(move || {
                for r in readers {
                    let _ = r.join();
                }
            })
        }
        Model::TokioCurrentThread | Model::TokioTwoWorkers => {
            let runtime = match model {
                Model::TokioCurrentThread => tokio::runtime::Builder::new_current_thread(),
                _ => {
                    let mut b = tokio::runtime::Builder::new_multi_thread();
                    b.worker_threads(2);
                    b
                }
            }
            .thread_name("fwd-tokio")
            .enable_io()
            .enable_time()
            .build()
            .expect("runtime");
            thread::Builder::new()
                .name("fwd-tokio".into())
                .spawn(move || {
                    runtime.block_on(async move {
                        let sockets: Vec<Arc<tokio::net::UdpSocket>> = sockets
                            .into_iter()
                            .map(|s| {
                                s.set_nonblocking(true).expect("nonblocking");
                                Arc::new(tokio::net::UdpSocket::from_std(s).expect("tokio"))
                            })
                            .collect();
                        let tasks: Vec<_> = (0..3)
                            .map(|link| {
                                let (sockets, fwd, stop) =
                                    (sockets.clone(), fwd.clone(), stop.clone());
                                tokio::spawn(async move {
                                    let mut buf = vec![0u8; 65536];
                                    while !stop.load(Ordering::Relaxed) {
                                        let wait = Duration::from_millis(200);
                                        let got = tokio::time::timeout(
                                            wait,
                                            sockets[link].recv_from(&mut buf),
                                        )
                                        .await;
                                        let Ok(Ok((n, from))) = got else {
                                            continue;
                                        };
                                        fwd.route(link, from, &buf[..n], |out, bytes, to| {
                                            let _ = sockets[out].try_send_to(bytes, to);
                                        });
                                    }
                                })
                            })
                            .collect();
                        for t in tasks {
                            let _ = t.await;
                        }
                    });
                })
                .expect("spawn")
        }
    }
}

/// CPU time of this process's threads whose name starts with `fwd`.
fn forwarder_cpu() -> Duration {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return Duration::ZERO;
    };
    let mut ns = 0u64;
    for task in tasks.flatten() {
        let comm = std::fs::read_to_string(task.path().join("comm")).unwrap_or_default();
        if !comm.starts_with("fwd") {
            continue;
        }
        let schedstat = std::fs::read_to_string(task.path().join("schedstat")).unwrap_or_default();
        ns += schedstat
            .split_whitespace()
            .next()
            .and_then(|f| f.parse::<u64>().ok())
            .unwrap_or(0);
    }
    Duration::from_nanos(ns)
}

/// One I/O model: delivered share, CPU per 10,000 messages, latency p50/p99 at 10k msg/s, p99
/// at 1k msg/s, and idle CPU, as in [`measure`].
fn measure_model(model: Model, ports: [u16; 3]) -> Row {
    let stop = Arc::new(AtomicBool::new(false));
    let runner = forward(model, ports, stop.clone());
    let row = measure_with(model.name(), &ports, forwarder_cpu);
    stop.store(true, Ordering::Relaxed);
    let _ = runner.join();
    row
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let args: Vec<String> = std::env::args().collect();
    if let [_, flag, role, zport, udp] = &args[..] {
        if flag == "--bare-zenoh" {
            if let (Ok(zport), Ok(udp)) = (zport.parse(), udp.parse()) {
                bare_zenoh_helper(role, zport, udp);
            }
            return;
        }
    }
    println!("machine: {}", harness::machine());
    // `cargo bench -p ferrolink-bench --bench router -- fleet`: the two-router section only.
    let only_fleet = std::env::args().any(|a| a == "fleet");
    println!("three UDP endpoints on loopback; PING broadcasts from A to B and C");
    let mut bare_p99 = [0u64; 2];
    for (i, rate) in [10_000, 1_000].into_iter().enumerate() {
        let (p50, p99) = direct(rate);
        bare_p99[i] = p99;
        println!(
            "one loopback hop without a router, {}k msg/s: latency p50 {p50} µs, p99 {p99} µs",
            rate / 1000
        );
    }
    let mut rows = Vec::new();
    type Start = fn(&[u16]) -> Option<Router>;
    let starters: [(u16, Start); 3] = [
        (34550, start_ferrolink),
        (34560, start_mavlink_routerd),
        (34570, start_mavproxy),
    ];
    for (i, (base, start)) in starters.into_iter().enumerate().filter(|_| !only_fleet) {
        let ports = [base, base + 1, base + 2];
        let Some(router) = start(&ports) else {
            continue;
        };
        let mut row = measure(&router, &ports);
        drop(router);
        // MAVProxy forwards between its master and its outputs only, not among outputs.
        if i < 2 {
            let ports: Vec<u16> = (base + 3..base + 9).collect();
            // The router runs until `_router` is dropped at the end of the block.
            if let Some(_router) = start(&ports) {
                row.six_peers = Some(six_peers(&ports));
            }
        }
        rows.push(row);
    }
    println!(
        "\n| router | delivered at 10k msg/s | six peers, 10k msg/s in all | CPU per 10,000 msgs | latency p50 | p99 | p99 at 1k msg/s | delivered at 50k msg/s | most forwarded to one peer | idle CPU |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        let six = r
            .six_peers
            .map_or_else(|| "n/a".to_owned(), |d| format!("{:.2} %", 100.0 * d));
        println!(
            "| {} | {:.2} % | {six} | {:.1} ms | {} µs | {} µs | {} µs | {:.2} % | {:.0} msg/s | {:.3} % |",
            r.name,
            100.0 * r.delivered,
            r.cpu_per_10k_ms,
            r.p50,
            r.p99,
            r.p99_1k,
            100.0 * r.delivered_50k,
            r.max_rate,
            r.idle_pct
        );
    }
    let mut joined: Vec<Row> = [(false, 34700), (true, 34710)]
        .into_iter()
        .filter_map(|(zenoh, base)| two_routers(zenoh, base))
        .collect();
    joined.extend(bare_zenoh(34720));
    let models = [
        Model::Threads,
        Model::TokioCurrentThread,
        Model::TokioTwoWorkers,
    ];
    let model_rows: Vec<Row> = models
        .iter()
        .filter(|_| !only_fleet)
        .enumerate()
        .map(|(i, &m)| {
            let base = 34600 + 10 * i as u16;
            measure_model(m, [base, base + 1, base + 2])
        })
        .collect();
    if let Some(ours) = rows.iter().find(|r| r.name == "ferrolink") {
        for other in rows.iter().filter(|r| r.name != "ferrolink") {
            println!(
                "ferrolink / {}: CPU per message {:.2}x, most forwarded {:.2}x, p99 {:.2}x, idle CPU {:.2}x",
                other.name,
                ours.cpu_per_10k_ms / other.cpu_per_10k_ms,
                ours.max_rate / other.max_rate.max(1.0),
                ours.p99 as f64 / other.p99.max(1) as f64,
                ours.idle_pct / other.idle_pct.max(1e-6)
            );
            // The goal: the p99 a router adds over one bare hop, measured in this run, no more
            // than mavlink-routerd's.
            let added = |r: &Row| {
                (
                    r.p99 as i64 - bare_p99[0] as i64,
                    r.p99_1k as i64 - bare_p99[1] as i64,
                )
            };
            let (ours_10k, ours_1k) = added(ours);
            let (theirs_10k, theirs_1k) = added(other);
            println!(
                "p99 added over one bare hop: at 10k msg/s ferrolink {ours_10k} µs, {} {theirs_10k} µs; at 1k msg/s {ours_1k} µs against {theirs_1k} µs",
                other.name
            );
        }
    }
    println!("\nthe I/O model, in-process, same load, one datagram a system call (CPU of the forwarding threads only):");
    println!(
        "\n| I/O model | delivered at 10k msg/s | CPU per 10,000 msgs | latency p50 | p99 | p99 at 1k msg/s | most forwarded to one peer | idle CPU |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in &model_rows {
        println!(
            "| {} | {:.2} % | {:.1} ms | {} µs | {} µs | {} µs | {:.0} msg/s | {:.2} % |",
            r.name,
            100.0 * r.delivered,
            r.cpu_per_10k_ms,
            r.p50,
            r.p99,
            r.p99_1k,
            r.max_rate,
            r.idle_pct
        );
    }
    println!(
        "\ntwo ferrolink routers in a row, PINGs into the first, a peer on the second; joined by:"
    );
    println!(
        "\n| joined by | delivered at 10k msg/s | CPU per 10,000 msgs, both routers | latency p50 | p99 | most forwarded to one peer |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    for r in &joined {
        println!(
            "| {} | {:.2} % | {:.1} ms | {} µs | {} µs | {:.0} msg/s |",
            r.name,
            100.0 * r.delivered,
            r.cpu_per_10k_ms,
            r.p50,
            r.p99,
            r.max_rate
        );
    }
    if let [udp, zenoh, ..] = &joined[..] {
        println!(
            "Zenoh over UDP: added latency p50 {} µs, p99 {} µs; most forwarded {:.2}x",
            zenoh.p50 as i64 - udp.p50 as i64,
            zenoh.p99 as i64 - udp.p99 as i64,
            zenoh.max_rate / udp.max_rate.max(1.0)
        );
    }
    if let [_, zenoh, bare] = &joined[..] {
        println!(
            "the routers' Zenoh link over bare Zenoh: CPU per frame {:.2}x (goal: at most 1.20x)",
            zenoh.cpu_per_10k_ms / bare.cpu_per_10k_ms.max(1e-9)
        );
    }
}
