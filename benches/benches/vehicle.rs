//! The vehicle API's telemetry and actions against MAVSDK's, in one run, on the same vehicle.
//!
//! ```sh
//! cargo bench -p ferrolink-bench --bench vehicle           # 10 s of telemetry each
//! cargo bench -p ferrolink-bench --bench vehicle -- 30     # 30 s
//! ```
//!
//! The vehicle is a child process of this program (the same binary, `--vehicle`): a PX4
//! quadrotor's HEARTBEAT at 1 Hz, and 6 messages at 50 Hz each, one every 3.3 ms in turn
//! (GLOBAL_POSITION_INT, ATTITUDE, ATTITUDE_QUATERNION, GPS_RAW_INT, BATTERY_STATUS,
//! SYS_STATUS), each carrying its number in a field the subscriber sees (the latitude, the
//! yaw, the quaternion's w, the battery's voltage); it accepts every command at once. It notes
//! when it sent each frame on the system's monotonic clock, which every process of the
//! machine shares.
//!
//! Each ground station, in turn, as a user would write it:
//!
//! - the bare connection (a `SharedConnection` subscription to the six messages' frames,
//!   decoded in the loop), for what the API's subscriber adds to the latency;
//! - ours, blocking: `Node::connect`, `wait_for_system`, `telemetry().wait_position`, `arm()`,
//!   then a subscription to the six kinds read with `recv` in this thread;
//! - ours, async: the same on a tokio current-thread runtime, `recv_async`;
//! - MAVSDK 4.1 (the `mavsdk` Python package, its C++ core in-process): `first_autopilot`, the
//!   first `subscribe_position` value, `Action.arm()`, then the six subscriptions (position,
//!   attitude_euler, attitude_quaternion, raw_gps, battery, health), each an async loop
//!   (`vehicle/mavsdk_telemetry.py`).
//!
//! Measured: the time from the vehicle's first frame (the ground station connected before it)
//! to the first position in the program's hands, the time `arm` takes, then over
//! the window the updates delivered a second, the CPU time of the ground station's process per
//! 1,000 updates (getrusage, user + system), and the latency from the vehicle's send to the
//! subscriber's hands (p50, p99) for the four kinds that carry their number.

#[allow(dead_code)]
mod harness;

use std::io::{BufRead, Write};
use std::net::UdpSocket;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use ferrolink_dialects::common::{
    Attitude, AttitudeQuaternion, BatteryStatus, CommandAck, GlobalPositionInt, GpsFixType,
    GpsRawInt, Heartbeat, MavAutopilot, MavModeFlag, MavResult, MavState, MavType, Message,
    SysStatus,
};
use ferrolink_runtime::mavlink::parser::{Feed, Parser};
use ferrolink_runtime::mavlink::{v2, Dialect, Header};
use ferrolink_vehicle::telemetry::{Kind, Update, Updates};
use ferrolink_vehicle::Node;

/// Each message's rate.
const HZ: f64 = 50.0;
/// The messages, in the order the vehicle sends them.
const KINDS: [&str; 6] = [
    "position",
    "attitude",
    "quaternion",
    "gps",
    "battery",
    "health",
];

/// Nanoseconds on the system's monotonic clock (CLOCK_MONOTONIC), shared by every process.
fn mono_ns() -> u64 {
    let t = nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC).expect("a clock");
    t.tv_sec() as u64 * 1_000_000_000 + t.tv_nsec() as u64
}

/// CPU time of this process so far, user and system, in seconds.
fn cpu_s() -> f64 {
    let u = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_SELF)
        .expect("getrusage");
    let t = |tv: nix::sys::time::TimeVal| tv.tv_sec() as f64 + tv.tv_usec() as f64 / 1e6;
    t(u.user_time()) + t(u.system_time())
}

/// The vehicle: sends to 127.0.0.1:`port` for `secs` seconds, answers commands, then writes
/// "kind index ns" per frame sent to `out`.
fn vehicle(port: u16, secs: f64, out: &Path) {
    let socket = UdpSocket::bind("127.0.0.1:0").expect("bind");
    socket.set_nonblocking(true).expect("nonblocking");
    let to = format!("127.0.0.1:{port}");
    let mut parser: Parser<{ v2::MAX_FRAME_LEN }, &[ferrolink_runtime::mavlink::MessageMeta]> =
        Parser::new(Message::META);
    let mut seq = 0u8;
    let mut send = |socket: &UdpSocket, message: &Message| {
        let mut buf = [0u8; v2::MAX_FRAME_LEN];
        let n = v2::encode_dialect(Header::new(seq, 1, 1), message, &mut buf).expect("encode");
        seq = seq.wrapping_add(1);
        let _ = socket.send_to(&buf[..n], &to);
    };
    let start = Instant::now();
    let started_ns = mono_ns();
    let period = Duration::from_secs_f64(1.0 / (HZ * KINDS.len() as f64));
    let mut sent: Vec<(usize, u32, u64)> = Vec::new();
    let mut counts = [0u32; 6];
    let mut next = start;
    let mut beat = start;
    let mut turn = 0;
    let mut buf = [0u8; 2048];
    while start.elapsed().as_secs_f64() < secs {
        let now = Instant::now();
        if now >= beat {
            let hb = Heartbeat {
                r#type: MavType::Quadrotor,
                autopilot: MavAutopilot::Px4,
                base_mode: MavModeFlag::CUSTOM_MODE_ENABLED,
                custom_mode: 3 << 16,
                system_status: MavState::Standby,
                mavlink_version: 3,
            };
            send(&socket, &Message::Heartbeat(hb));
            beat += Duration::from_secs(1);
        }
        while let Ok((n, _)) = socket.recv_from(&mut buf) {
            let mut input = &buf[..n];
            let mut commands = Vec::new();
            while let Feed::Frame { frame, remaining } = parser.feed(input) {
                if let Ok(Message::CommandLong(c)) = frame.frame().decode::<Message>() {
                    let h = frame.header();
                    commands.push((c.command, h.sysid, h.compid));
                }
                input = remaining;
            }
            for (command, sysid, compid) in commands {
                let ack = Message::CommandAck(CommandAck {
                    command,
                    result: MavResult::Accepted,
                    target_system: sysid,
                    target_component: compid,
                    ..Default::default()
                });
                // To the ground station's address, where everything goes.
                send(&socket, &ack);
            }
        }
        if now < next {
            std::thread::sleep((next - now).min(Duration::from_millis(1)));
            continue;
        }
        next += period;
        let i = counts[turn];
        counts[turn] += 1;
        let message = match turn {
            0 => Message::GlobalPositionInt(GlobalPositionInt {
                lat: 470_000_000 + i as i32,
                lon: 85_000_000,
                alt: 500_000,
                relative_alt: 12_000,
                ..Default::default()
            }),
            1 => Message::Attitude(Attitude {
                yaw: i as f32 * 1e-3,
                ..Default::default()
            }),
            2 => Message::AttitudeQuaternion(AttitudeQuaternion {
                q1: i as f32,
                ..Default::default()
            }),
            3 => Message::GpsRawInt(GpsRawInt {
                fix_type: GpsFixType::Type3dFix,
                satellites_visible: 12,
                time_usec: u64::from(i),
                ..Default::default()
            }),
            4 => {
                let mut voltages = [u16::MAX; 10];
                voltages[0] = 10_000 + i as u16;
                Message::BatteryStatus(BatteryStatus {
                    voltages,
                    battery_remaining: 80,
                    ..Default::default()
                })
            }
            _ => Message::SysStatus(SysStatus {
                errors_count1: i as u16,
                voltage_battery: u16::MAX,
                battery_remaining: -1,
                ..Default::default()
            }),
        };
        let t = mono_ns();
        send(&socket, &message);
        sent.push((turn, i, t));
        turn = (turn + 1) % KINDS.len();
    }
    let mut f = std::io::BufWriter::new(std::fs::File::create(out).expect("the send log"));
    writeln!(f, "start {started_ns}").expect("write");
    for (kind, i, t) in sent {
        writeln!(f, "{kind} {i} {t}").expect("write");
    }
}

/// What a ground station measured.
#[derive(Debug, Default)]
struct Result_ {
    /// When the first position was in hands, on the monotonic clock.
    first_position_ns: u64,
    arm_s: f64,
    updates: u64,
    window_s: f64,
    cpu_s: f64,
    /// (kind, index, received ns).
    received: Vec<(usize, u32, u64)>,
}

/// The kind and number an update carries.
fn numbered(update: &Update) -> Option<(usize, Option<u32>)> {
    Some(match update {
        Update::Position(p) => (0, Some(((p.lat * 1e7).round() as i64 - 470_000_000) as u32)),
        Update::Attitude(a) => (1, Some((a.yaw.to_radians() * 1000.0).round() as u32)),
        Update::Quaternion(q) => (2, Some(q.w as u32)),
        Update::Gps(_) => (3, None),
        Update::Battery(b) => (4, Some((b.voltage * 1000.0).round() as u32 - 10_000)),
        Update::Health(_) => (5, None),
        _ => return None,
    })
}

const SUBSCRIBED: [Kind; 6] = [
    Kind::Position,
    Kind::Attitude,
    Kind::Quaternion,
    Kind::Gps,
    Kind::Battery,
    Kind::Health,
];

/// Takes in one update.
fn take(r: &mut Result_, update: &Update) {
    let t = mono_ns();
    if let Some((kind, index)) = numbered(update) {
        r.updates += 1;
        if let Some(i) = index {
            r.received.push((kind, i, t));
        }
    }
}

fn spawn_vehicle(port: u16, secs: f64, log: &Path) -> Child {
    Command::new(std::env::current_exe().expect("this program"))
        .args(["--vehicle", &port.to_string(), &secs.to_string()])
        .arg(log)
        .spawn()
        .expect("the vehicle")
}

fn ours_blocking(window: f64, log: &Path) -> Result_ {
    let node = Node::connect("udpin://127.0.0.1:0").expect("connect");
    let port = node.connection().local_addr().expect("bound").port();
    let mut vehicle = spawn_vehicle(port, window + 8.0, log);
    let system = node
        .wait_for_system(Duration::from_secs(10))
        .expect("discovery")
        .expect("the vehicle");
    system
        .telemetry()
        .wait_position(Duration::from_secs(5))
        .expect("a position");
    let mut r = Result_ {
        first_position_ns: mono_ns(),
        ..Result_::default()
    };
    let t = Instant::now();
    system.arm().expect("arm");
    r.arm_s = t.elapsed().as_secs_f64();
    let updates = system.telemetry().subscribe(&SUBSCRIBED);
    let (cpu0, t0) = (cpu_s(), Instant::now());
    while t0.elapsed().as_secs_f64() < window {
        if let Some(u) = updates.recv(Duration::from_millis(100)) {
            take(&mut r, &u);
        }
    }
    r.window_s = t0.elapsed().as_secs_f64();
    r.cpu_s = cpu_s() - cpu0;
    let _ = vehicle.wait();
    r
}

/// The bare connection, for the latency a subscriber adds: a subscription to the six messages'
/// frames, each decoded here for its number.
fn bare(window: f64, log: &Path) -> Result_ {
    use ferrolink_io::mavlink::{Filter, SharedConnection};
    let link = SharedConnection::open("udpin://127.0.0.1:0", Message::META).expect("open");
    let frames = link.subscribe(Filter::all().ids(&[33, 30, 31, 24, 147, 1]));
    let port = link.local_addr().expect("bound").port();
    let mut vehicle = spawn_vehicle(port, window + 2.0, log);
    let mut r = Result_::default();
    let (cpu0, t0) = (cpu_s(), Instant::now());
    while t0.elapsed().as_secs_f64() < window {
        let Ok(Some(frame)) = frames.recv(Duration::from_millis(100)) else {
            continue;
        };
        let t = mono_ns();
        let numbered = match frame.decode::<Message>() {
            Ok(Message::GlobalPositionInt(m)) => Some((0, (m.lat - 470_000_000) as u32)),
            Ok(Message::Attitude(m)) => Some((1, (m.yaw * 1000.0).round() as u32)),
            Ok(Message::AttitudeQuaternion(m)) => Some((2, m.q1 as u32)),
            Ok(Message::BatteryStatus(m)) => Some((4, u32::from(m.voltages[0]) - 10_000)),
            _ => None,
        };
        r.updates += 1;
        if let Some((kind, i)) = numbered {
            r.received.push((kind, i, t));
        }
    }
    r.window_s = t0.elapsed().as_secs_f64();
    r.cpu_s = cpu_s() - cpu0;
    let _ = vehicle.wait();
    r
}

fn ours_async(window: f64, log: &Path) -> Result_ {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .expect("a runtime");
    rt.block_on(async {
        let node = Node::connect("udpin://127.0.0.1:0").expect("connect");
        let port = node.connection().local_addr().expect("bound").port();
        let mut vehicle = spawn_vehicle(port, window + 8.0, log);
        let system = node
            .wait_for_system_async(Duration::from_secs(10))
            .await
            .expect("discovery")
            .expect("the vehicle");
        system
            .telemetry()
            .wait_position_async(Duration::from_secs(5))
            .await
            .expect("a position");
        let mut r = Result_ {
            first_position_ns: mono_ns(),
            ..Result_::default()
        };
        let t = Instant::now();
        system.arm().await.expect("arm");
        r.arm_s = t.elapsed().as_secs_f64();
        let updates: Updates = system.telemetry().subscribe(&SUBSCRIBED);
        let (cpu0, t0) = (cpu_s(), Instant::now());
        let end = tokio::time::Instant::now() + Duration::from_secs_f64(window);
        while let Ok(Some(u)) = tokio::time::timeout_at(end, updates.recv_async()).await {
            take(&mut r, &u);
        }
        r.window_s = t0.elapsed().as_secs_f64();
        r.cpu_s = cpu_s() - cpu0;
        let _ = vehicle.wait();
        r
    })
}

/// MAVSDK's ground station, or `None` when it cannot run (no mavsdk package).
fn mavsdk(window: f64, log: &Path) -> Option<Result_> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/vehicle/mavsdk_telemetry.py");
    let port = ferrolink_test_support::free_port();
    let mut gcs = Command::new(harness::python())
        .arg(script)
        .args([port.to_string(), window.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    // MAVSDK's own log goes to stdout too: skip to our first line.
    let mut lines = std::io::BufReader::new(gcs.stdout.take()?).lines();
    if !lines
        .by_ref()
        .map_while(Result::ok)
        .any(|l| l == "listening")
    {
        let _ = gcs.kill();
        let _ = gcs.wait();
        return None;
    }
    let mut vehicle = spawn_vehicle(port, window + 8.0, log);
    let r = read_mavsdk(lines.map_while(Result::ok));
    let ok = gcs.wait().is_ok_and(|s| s.success());
    let _ = vehicle.wait();
    r.filter(|r| ok && r.updates > 0)
}

/// What MAVSDK's ground station printed.
fn read_mavsdk(lines: impl Iterator<Item = String>) -> Option<Result_> {
    let mut r = Result_::default();
    for line in lines {
        let mut f = line.split_whitespace();
        match f.next() {
            Some("first_position_ns") => r.first_position_ns = f.next()?.parse().ok()?,
            Some("arm_s") => r.arm_s = f.next()?.parse().ok()?,
            Some("updates") => r.updates = f.next()?.parse().ok()?,
            Some("window_s") => r.window_s = f.next()?.parse().ok()?,
            Some("cpu_s") => r.cpu_s = f.next()?.parse().ok()?,
            Some("rx") => {
                let kind = f.next()?.parse().ok()?;
                let index = f.next()?.parse().ok()?;
                let t = f.next()?.parse().ok()?;
                r.received.push((kind, index, t));
            }
            _ => {}
        }
    }
    Some(r)
}

/// When the vehicle started sending, from its log.
fn started_ns(log: &Path) -> u64 {
    let text = std::fs::read_to_string(log).expect("the send log");
    text.lines()
        .find_map(|l| l.strip_prefix("start "))
        .and_then(|t| t.parse().ok())
        .unwrap_or(0)
}

/// p50 and p99 of the latencies, in µs, from the vehicle's log.
fn latency(r: &Result_, log: &Path) -> (f64, f64) {
    let text = std::fs::read_to_string(log).expect("the send log");
    let sent: std::collections::HashMap<(usize, u32), u64> = text
        .lines()
        .filter_map(|l| {
            let mut f = l.split_whitespace().map(|x| x.parse::<u64>().ok());
            Some(((f.next()?? as usize, f.next()?? as u32), f.next()??))
        })
        .collect();
    let mut lat: Vec<f64> = r
        .received
        .iter()
        .filter_map(|(k, i, t)| {
            sent.get(&(*k, *i))
                .map(|s| t.saturating_sub(*s) as f64 / 1e3)
        })
        .collect();
    if lat.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    lat.sort_by(f64::total_cmp);
    let at = |q: f64| lat[((lat.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99))
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.first().is_some_and(|a| a == "--vehicle") {
        vehicle(
            args[1].parse().expect("port"),
            args[2].parse().expect("seconds"),
            Path::new(&args[3]),
        );
        return;
    }
    let window: f64 = args.first().and_then(|a| a.parse().ok()).unwrap_or(10.0);
    let dir = std::env::temp_dir().join(format!("ferrolink-vehicle-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    println!("machine: {}", harness::machine());
    println!(
        "work: 6 messages at {HZ} Hz each ({} a second) for {window} s, after connect and arm",
        HZ as usize * KINDS.len()
    );
    println!();
    println!("| ground station | first position | arm | updates/s | CPU per 1,000 updates | latency p50 | p99 |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    type Run = Box<dyn Fn(&Path) -> Option<Result_>>;
    let runs: [(&str, Run); 4] = [
        (
            "ferrolink, bare connection",
            Box::new(move |l| Some(bare(window, l))),
        ),
        (
            "ferrolink, blocking",
            Box::new(move |l| Some(ours_blocking(window, l))),
        ),
        (
            "ferrolink, async",
            Box::new(move |l| Some(ours_async(window, l))),
        ),
        ("MAVSDK 4.1 (Python)", Box::new(move |l| mavsdk(window, l))),
    ];
    for (name, run) in runs {
        let log = dir.join(format!("{}.log", name.len()));
        match run(&log) {
            Some(r) => {
                let (p50, p99) = latency(&r, &log);
                let (first, arm) = if r.first_position_ns == 0 {
                    ("–".to_owned(), "–".to_owned())
                } else {
                    let first = r.first_position_ns.saturating_sub(started_ns(&log)) as f64 / 1e6;
                    (format!("{first:.1} ms"), format!("{:.1} ms", r.arm_s * 1e3))
                };
                println!(
                    "| {name} | {first} | {arm} | {:.0} | {:.1} ms | {p50:.0} µs | {p99:.0} µs |",
                    r.updates as f64 / r.window_s,
                    r.cpu_s * 1e6 / r.updates.max(1) as f64,
                );
            }
            None => println!("| {name} | not run (no mavsdk package) | | | | | |"),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
