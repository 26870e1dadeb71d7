//! The router's web API against mavlink2rest, side by side in one run, each fed the same
//! telemetry on its own UDP port: a vehicle's set of 60 message types once a second (taken from
//! the test vectors, frames mavlink2rest reads), and ATTITUDE at 1,000 msg/s:
//!
//! ```sh
//! cargo build --release -p ferrolink-cli
//! cargo bench -p ferrolink-bench --bench web
//! ```
//!
//! - requests a second for `GET /v1/mavlink/vehicles/1/components/1/messages/ATTITUDE`, over
//!   keep-alive connections, from 1 client and from 100 at once, for 3 s each;
//! - 20 WebSocket clients (`/v1/ws/mavlink`, no filter) reading everything while the feed runs at
//!   full rate for 5 s: messages delivered, and the server's CPU time per message delivered.
//!
//! mavlink2rest is taken from `MAVLINK2REST` or the `PATH`; without it, only our figures are
//! printed, with a note. The load comes from this process, on the same machine.

#[allow(dead_code)]
mod harness;
#[allow(dead_code)]
#[path = "router/peers.rs"]
mod peers;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpStream, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_runtime::mavlink::{v2, Header};
use peers::{cpu_time, which};

/// A server under test: its process, where it listens for HTTP and for MAVLink.
struct Server {
    name: &'static str,
    child: Child,
    http: u16,
    udp: u16,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn start_ferrolink(udp: u16, http: u16) -> Option<Server> {
    let bin = workspace().join("target/release/ferrolink");
    if !bin.exists() {
        eprintln!(
            "note: {} missing; run cargo build --release -p ferrolink-cli",
            bin.display()
        );
        return None;
    }
    let mut child = Command::new(bin)
        .args(["mavlink", "router", &format!("udpin://127.0.0.1:{udp}")])
        .args(["--http", &format!("127.0.0.1:{http}")])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let mut line = String::new();
    BufReader::new(child.stdout.take()?)
        .read_line(&mut line)
        .ok()?;
    line.contains("ready").then_some(Server {
        name: "ferrolink",
        child,
        http,
        udp,
    })
}

fn start_mavlink2rest(udp: u16, http: u16) -> Option<Server> {
    let bin = std::env::var_os("MAVLINK2REST")
        .map(PathBuf::from)
        .or_else(|| which("mavlink2rest"));
    let Some(bin) = bin else {
        println!("note: mavlink2rest is not installed (set MAVLINK2REST or put it on the PATH); its figures are left out");
        return None;
    };
    let child = Command::new(bin)
        .args(["--connect", &format!("udpin:127.0.0.1:{udp}")])
        .args(["--server", &format!("127.0.0.1:{http}")])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let server = Server {
        name: "mavlink2rest 1.0.2",
        child,
        http,
        udp,
    };
    let deadline = Instant::now() + Duration::from_secs(10);
    while TcpStream::connect(("127.0.0.1", http)).is_err() {
        if Instant::now() > deadline {
            return None;
        }
        thread::sleep(Duration::from_millis(50));
    }
    Some(server)
}

fn frame(seq: u8, id: u32, crc_extra: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(seq, 1, 1), id, crc_extra, payload, &mut out).expect("fits");
    out[..n].to_vec()
}

/// The first frame of each of the first 60 message types of the test vectors: system 1,
/// component 1, as a vehicle sends its telemetry.
fn vehicle_set() -> Vec<Vec<u8>> {
    let text = include_str!("../../web/tests/vectors/mavlink2rest-1.0.2.jsonl");
    let mut seen = std::collections::BTreeSet::new();
    text.lines()
        .filter_map(|line| serde_json::from_str::<serde_json::Value>(line).ok())
        .filter_map(|v| hex_bytes(v["frame"].as_str()?))
        .filter(|f| {
            f.len() > 9 && f[6] == 1 && seen.insert(u32::from_le_bytes([f[7], f[8], f[9], 0]))
        })
        .take(60)
        .collect()
}

fn hex_bytes(text: &str) -> Option<Vec<u8>> {
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(text.get(i..i + 2)?, 16).ok())
        .collect()
}

/// Sends ATTITUDE at `rate` a second, and the vehicle's set once a second, to `port` until
/// `stop`.
fn feed(port: u16, rate: u32, stop: Arc<AtomicBool>) -> thread::JoinHandle<u64> {
    let set = vehicle_set();
    thread::spawn(move || {
        let sock = UdpSocket::bind("127.0.0.1:0").expect("bind");
        let start = Instant::now();
        let mut sent = 0u64;
        while !stop.load(Ordering::Relaxed) {
            let due = (start.elapsed().as_secs_f64() * f64::from(rate)) as u64;
            while sent < due {
                let mut payload = [0u8; 28];
                payload[..4].copy_from_slice(&(sent as u32).to_le_bytes());
                payload[4..8].copy_from_slice(&(sent as f32 * 1e-3).to_le_bytes());
                let _ = sock.send_to(&frame(sent as u8, 30, 39, &payload), ("127.0.0.1", port));
                if sent.is_multiple_of(u64::from(rate)) {
                    for f in &set {
                        let _ = sock.send_to(f, ("127.0.0.1", port));
                    }
                }
                sent += 1;
            }
            thread::sleep(Duration::from_millis(1));
        }
        sent
    })
}

/// One keep-alive HTTP/1.1 GET; `false` if the answer was not a 200 with its body.
fn get(stream: &mut BufReader<TcpStream>, path: &str) -> bool {
    let request = format!("GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    if stream.get_mut().write_all(request.as_bytes()).is_err() {
        return false;
    }
    let mut line = String::new();
    if stream.read_line(&mut line).is_err() || !line.contains(" 200 ") {
        return false;
    }
    let mut length = 0usize;
    loop {
        line.clear();
        if stream.read_line(&mut line).is_err() {
            return false;
        }
        let l = line.trim_end();
        if l.is_empty() {
            break;
        }
        if let Some((k, v)) = l.split_once(':') {
            if k.eq_ignore_ascii_case("content-length") {
                length = v.trim().parse().unwrap_or(0);
            }
        }
    }
    let mut body = vec![0u8; length];
    stream.read_exact(&mut body).is_ok() && length > 0
}

/// Requests a second from `clients` keep-alive connections for `seconds`, and the server's CPU
/// time per request in µs.
fn requests(server: &Server, clients: usize, seconds: u64) -> (f64, f64) {
    let path = "/v1/mavlink/vehicles/1/components/1/messages/ATTITUDE";
    let stop = Arc::new(AtomicBool::new(false));
    let done = Arc::new(AtomicU64::new(0));
    let cpu0 = cpu_time(server.child.id());
    let start = Instant::now();
    let workers: Vec<_> = (0..clients)
        .map(|_| {
            let (stop, done, port) = (stop.clone(), done.clone(), server.http);
            thread::spawn(move || {
                let Ok(stream) = TcpStream::connect(("127.0.0.1", port)) else {
                    return;
                };
                let _ = stream.set_nodelay(true);
                let mut stream = BufReader::new(stream);
                while !stop.load(Ordering::Relaxed) {
                    if !get(&mut stream, path) {
                        return;
                    }
                    done.fetch_add(1, Ordering::Relaxed);
                }
            })
        })
        .collect();
    thread::sleep(Duration::from_secs(seconds));
    stop.store(true, Ordering::Relaxed);
    let n = done.load(Ordering::Relaxed);
    let elapsed = start.elapsed().as_secs_f64();
    let cpu = cpu_time(server.child.id())
        .zip(cpu0)
        .map_or(0.0, |(b, a)| (b - a).as_secs_f64());
    for w in workers {
        let _ = w.join();
    }
    (n as f64 / elapsed, cpu * 1e6 / n.max(1) as f64)
}

/// A WebSocket client that counts the messages it reads until `stop`.
fn ws_client(port: u16, stop: Arc<AtomicBool>, got: Arc<AtomicU64>) -> thread::JoinHandle<()> {
    thread::spawn(move || {
        let Ok(mut s) = TcpStream::connect(("127.0.0.1", port)) else {
            return;
        };
        let _ = s.write_all(
            b"GET /v1/ws/mavlink HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n\
              Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\
              Sec-WebSocket-Version: 13\r\n\r\n",
        );
        let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
        let mut r = BufReader::new(s);
        let mut line = String::new();
        while r.read_line(&mut line).is_ok() && line != "\r\n" {
            line.clear();
        }
        // Server frames: unmasked; text frames counted, everything skipped.
        let mut head = [0u8; 2];
        while !stop.load(Ordering::Relaxed) {
            if r.read_exact(&mut head).is_err() {
                continue;
            }
            let mut len = u64::from(head[1] & 0x7f);
            if len == 126 {
                let mut b = [0u8; 2];
                let _ = r.read_exact(&mut b);
                len = u64::from(u16::from_be_bytes(b));
            } else if len == 127 {
                let mut b = [0u8; 8];
                let _ = r.read_exact(&mut b);
                len = u64::from_be_bytes(b);
            }
            let _ = std::io::copy(&mut (&mut r).take(len), &mut std::io::sink());
            if head[0] & 0x0f == 1 {
                got.fetch_add(1, Ordering::Relaxed);
            }
        }
    })
}

/// 20 WebSocket clients for `seconds` at the feed's rate: messages delivered to them all, and
/// the server's CPU time per message delivered, in µs.
fn websockets(server: &Server, seconds: u64) -> (u64, f64) {
    let stop = Arc::new(AtomicBool::new(false));
    let got = Arc::new(AtomicU64::new(0));
    let clients: Vec<_> = (0..20)
        .map(|_| ws_client(server.http, stop.clone(), got.clone()))
        .collect();
    thread::sleep(Duration::from_millis(500));
    let (got0, cpu0) = (got.load(Ordering::Relaxed), cpu_time(server.child.id()));
    thread::sleep(Duration::from_secs(seconds));
    let n = got.load(Ordering::Relaxed) - got0;
    let cpu = cpu_time(server.child.id())
        .zip(cpu0)
        .map_or(0.0, |(b, a)| (b - a).as_secs_f64());
    stop.store(true, Ordering::Relaxed);
    for c in clients {
        let _ = c.join();
    }
    (n, cpu * 1e6 / n.max(1) as f64)
}

struct Row {
    name: &'static str,
    one: f64,
    hundred: f64,
    cpu_per_request: f64,
    ws_messages: u64,
    ws_cpu: f64,
}

fn measure(server: &Server) -> Row {
    let stop = Arc::new(AtomicBool::new(false));
    let feeder = feed(server.udp, 1000, stop.clone());
    thread::sleep(Duration::from_secs(1));
    let (one, _) = requests(server, 1, 3);
    let (hundred, cpu_per_request) = requests(server, 100, 3);
    let (ws_messages, ws_cpu) = websockets(server, 5);
    stop.store(true, Ordering::Relaxed);
    let _ = feeder.join();
    Row {
        name: server.name,
        one,
        hundred,
        cpu_per_request,
        ws_messages,
        ws_cpu,
    }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    println!("machine: {}", harness::machine());
    println!(
        "into each server: a vehicle's {} message types once a second and ATTITUDE at 1,000 msg/s; the load from this process",
        vehicle_set().len()
    );
    let mut rows = Vec::new();
    for (start, udp, http) in [
        (
            start_ferrolink as fn(u16, u16) -> Option<Server>,
            35550,
            35551,
        ),
        (start_mavlink2rest, 35560, 35561),
    ] {
        if let Some(server) = start(udp, http) {
            rows.push(measure(&server));
        }
    }
    println!("\n| server | requests/s, 1 client | 100 clients | CPU per request | 20 WebSockets: messages in 5 s | CPU per WebSocket message |");
    println!("|---|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!(
            "| {} | {:.0} | {:.0} | {:.1} µs | {} | {:.2} µs |",
            r.name, r.one, r.hundred, r.cpu_per_request, r.ws_messages, r.ws_cpu
        );
    }
    if let [ours, theirs] = &rows[..] {
        println!(
            "\nferrolink against mavlink2rest: {:.1}× the requests/s with 1 client (goal 5×), {:.1}× with 100, {:.2}× the CPU per WebSocket message (goal at most 0.3×)",
            ours.one / theirs.one,
            ours.hundred / theirs.hundred,
            ours.ws_cpu / theirs.ws_cpu
        );
    }
}
