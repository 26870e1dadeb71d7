//! The microservices on loopback, ours against MAVSDK's, in one run, through the same seeded
//! lossy link.
//!
//! ```sh
//! cargo bench -p ferrolink-bench --bench services            # 0 % and 20 % loss
//! cargo bench -p ferrolink-bench --bench services -- 20     # only 20 %
//! ```
//!
//! Each stack is a vehicle and a ground station of the same software: ours is the software
//! vehicle (`io::mavlink::vehicle`) and `Remote`, in this process; MAVSDK 4.1's is a vehicle of
//! its server plugins (ParamServer, MissionRawServer, FtpServer) and a ground station of its
//! Param, MissionRaw and Ftp plugins, two Python processes (`services/mavsdk_stack.py`, with the
//! `mavsdk` package of the project's `.venv` or `FERROLINK_PYTHON`). Between ground station and
//! vehicle sits the relay of this file: at "20 %" it loses 20 % of datagrams each way, repeats
//! 5 % and holds 5 % back by up to 10 ms so later ones overtake them; every datagram takes 1 ms.
//! The relay's random numbers come from a fixed seed, the same for both stacks.
//!
//! The work, after each ground station has found its vehicle: fetch 1,000 parameters (INT32
//! and REAL32, the types MAVSDK lists), upload a 500-item mission, download it, read a 1 MiB
//! file over FTP (MAVSDK with burst reads). Each result is checked (the count, the bytes) and
//! each operation is given 180 s. A mission transfer that gives up is started again: ours up
//! to three times (what `Remote` does), MAVSDK's up to five (by the driver), and the time is
//! that of all attempts. Times are wall clock, one run each.

#[allow(dead_code)]
mod harness;

use std::collections::BinaryHeap;
use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_io::mavlink::services::{self, Remote};
use ferrolink_io::mavlink::{vehicle, Connection};
use ferrolink_runtime::mavlink::service::messages::{
    MavAutopilot, MavCmd, MavFrame, MavMissionResult, MavMissionType, MavType,
};
use ferrolink_runtime::mavlink::service::mission::Item;
use ferrolink_runtime::mavlink::service::param::{Name, Param, Value};
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_test_support::free_port;

const PARAMS: usize = 1000;
const ITEMS: usize = 500;
const FILE: usize = 1 << 20;
const TIMEOUT: Duration = Duration::from_secs(180);
const SEED: u64 = 20_261_126;
const OPS: [&str; 4] = ["params", "mission_upload", "mission_download", "ftp_read"];

/// A datagram held back until `due`.
struct Held {
    due: Instant,
    order: u64,
    to_vehicle: bool,
    data: Vec<u8>,
}

impl PartialEq for Held {
    fn eq(&self, other: &Self) -> bool {
        (self.due, self.order) == (other.due, other.order)
    }
}
impl Eq for Held {}
impl PartialOrd for Held {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Held {
    // The earliest first, out of a max-heap.
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        (other.due, other.order).cmp(&(self.due, self.order))
    }
}

/// The seeded lossy link: ground stations send to `front`, it forwards to the vehicle's port.
struct Relay {
    front: u16,
    stop: Arc<AtomicBool>,
    thread: Option<thread::JoinHandle<()>>,
}

impl Relay {
    fn new(vehicle_port: u16, loss_percent: u32) -> Self {
        let front = UdpSocket::bind("127.0.0.1:0").expect("relay socket");
        let back = UdpSocket::bind("127.0.0.1:0").expect("relay socket");
        for s in [&front, &back] {
            s.set_nonblocking(true).expect("non-blocking");
        }
        let port = front.local_addr().expect("address").port();
        let stop = Arc::new(AtomicBool::new(false));
        let stopping = stop.clone();
        let vehicle: SocketAddr = ([127, 0, 0, 1], vehicle_port).into();
        let thread = thread::spawn(move || {
            let mut rng = SEED | 1;
            let mut next = move || {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                rng % 1000
            };
            let mut gcs: Option<SocketAddr> = None;
            let mut held = BinaryHeap::new();
            let mut order = 0u64;
            let mut buf = [0u8; 2048];
            while !stopping.load(Ordering::Relaxed) {
                let mut idle = true;
                for (sock, to_vehicle) in [(&front, true), (&back, false)] {
                    while let Ok((n, from)) = sock.recv_from(&mut buf) {
                        idle = false;
                        if to_vehicle {
                            gcs = Some(from);
                        }
                        if next() < u64::from(loss_percent) * 10 {
                            continue;
                        }
                        let copies = if loss_percent > 0 && next() < 50 {
                            2
                        } else {
                            1
                        };
                        for _ in 0..copies {
                            let mut delay = Duration::from_millis(1);
                            if loss_percent > 0 && next() < 50 {
                                delay += Duration::from_micros(next() * 10);
                            }
                            order += 1;
                            held.push(Held {
                                due: Instant::now() + delay,
                                order,
                                to_vehicle,
                                data: buf[..n].to_vec(),
                            });
                        }
                    }
                }
                let now = Instant::now();
                while held.peek().is_some_and(|h: &Held| h.due <= now) {
                    let Some(h) = held.pop() else { break };
                    let _ = if h.to_vehicle {
                        back.send_to(&h.data, vehicle)
                    } else if let Some(g) = gcs {
                        front.send_to(&h.data, g)
                    } else {
                        Ok(0)
                    };
                }
                if idle {
                    thread::sleep(Duration::from_micros(100));
                }
            }
        });
        Self {
            front: port,
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn params() -> Vec<Param> {
    (0..PARAMS)
        .map(|i| Param {
            name: Name::from(format!("P{i:04}").as_str()),
            value: if i % 2 == 0 {
                Value::I32(i as i32 * 7 - 3000)
            } else {
                Value::F32(i as f32 / 8.0)
            },
        })
        .collect()
}

fn items() -> Vec<Item> {
    (0..ITEMS)
        .map(|i| Item {
            frame: MavFrame::GlobalRelativeAlt,
            command: MavCmd::NavWaypoint,
            current: u8::from(i == 0),
            autocontinue: 1,
            params: [0.0, 2.0, 0.0, 0.0],
            x: 473_977_420 + 97 * i as i32,
            y: 85_455_940 - 31 * i as i32,
            z: 10.0 + i as f32 / 8.0,
        })
        .collect()
}

fn file_bytes() -> Vec<u8> {
    (0..FILE as u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
        .collect()
}

/// One operation's outcome: seconds, or why it failed after how long.
type Outcome = Result<f64, (f64, String)>;

fn time(op: impl FnOnce() -> Result<(), String>) -> Outcome {
    let t0 = Instant::now();
    let r = op();
    let s = t0.elapsed().as_secs_f64();
    r.map(|()| s).map_err(|e| (s, e))
}

fn ours(loss: u32, root: &Path) -> Vec<Outcome> {
    let port = free_port();
    let config = vehicle::Config {
        address: Address::new(1, 1),
        autopilot: MavAutopilot::Px4,
        kind: MavType::Quadrotor,
        params: params(),
        table: services::TABLE.into(),
        ftp_root: Some(root.to_path_buf()),
        home: ferrolink_io::mavlink::vehicle::HOME,
    };
    let stop = Arc::new(AtomicBool::new(false));
    let stopping = stop.clone();
    let endpoint = format!("udpin://127.0.0.1:{port}");
    let vehicle = thread::spawn(move || vehicle::run(&config, &[endpoint], None, &stopping, || {}));
    let relay = Relay::new(port, loss);
    let mut link = Connection::open(
        &format!("udpout://127.0.0.1:{}", relay.front),
        services::TABLE,
    )
    .expect("a connection to the relay");
    let peer = services::wait_for_vehicle(&mut link, Duration::from_secs(30))
        .expect("discovery")
        .expect("our vehicle's HEARTBEAT");
    let mut remote = Remote::new(&mut link, peer);
    let mission = items();
    let data = file_bytes();
    let out = vec![
        time(|| {
            let list = remote
                .fetch_params(TIMEOUT, |_| {})
                .map_err(|e| e.to_string())?;
            match (list.count as usize, list.missing()) {
                (PARAMS, 0) => Ok(()),
                (n, m) => Err(format!("{} of {n} parameters", n - m)),
            }
        }),
        time(|| {
            match remote
                .upload_mission(MavMissionType::Mission, &mission, |_, _| {})
                .map_err(|e| e.to_string())?
            {
                Some(MavMissionResult::MavMissionAccepted) => Ok(()),
                other => Err(format!("ended with {other:?}")),
            }
        }),
        time(|| {
            match remote
                .download_mission(MavMissionType::Mission, |_, _| {})
                .map_err(|e| e.to_string())?
            {
                Some(got) if got == mission => Ok(()),
                Some(got) => Err(format!("{} items, not the mission uploaded", got.len())),
                None => Err("no mission".into()),
            }
        }),
        time(|| {
            let got = remote
                .ftp_get("/big.bin", |_, _| {})
                .map_err(|e| e.to_string())?;
            if got == data {
                Ok(())
            } else {
                Err(format!("{} bytes differ from the file", got.len()))
            }
        }),
    ];
    drop(relay);
    stop.store(true, Ordering::Relaxed);
    let _ = vehicle.join();
    out
}

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/services/mavsdk_stack.py")
}

fn mavsdk(loss: u32, root: &Path, workdir: &Path) -> Option<Vec<Outcome>> {
    let port = free_port();
    let mut vehicle: Child = Command::new(harness::python())
        .arg(script())
        .args([
            "vehicle",
            "--port",
            &port.to_string(),
            "--params",
            &PARAMS.to_string(),
        ])
        .arg("--ftp-root")
        .arg(root)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let mut ready = String::new();
    let stdout = vehicle.stdout.take()?;
    let mut lines = BufReader::new(stdout).lines();
    if let Some(Ok(line)) = lines.next() {
        ready = line;
    }
    if ready != "ready" {
        let _ = vehicle.kill();
        return None;
    }
    let relay = Relay::new(port, loss);
    let client = Command::new(harness::python())
        .arg(script())
        .args(["client", "--port", &relay.front.to_string()])
        .args([
            "--params",
            &PARAMS.to_string(),
            "--items",
            &ITEMS.to_string(),
        ])
        .args([
            "--file",
            &FILE.to_string(),
            "--timeout",
            &TIMEOUT.as_secs().to_string(),
        ])
        .arg("--workdir")
        .arg(workdir)
        .stderr(Stdio::null())
        .output()
        .ok()?;
    drop(relay);
    if let Some(mut stdin) = vehicle.stdin.take() {
        let _ = stdin.write_all(b"");
    }
    let _ = vehicle.kill();
    let _ = vehicle.wait();
    let text = String::from_utf8_lossy(&client.stdout);
    let mut out = Vec::new();
    for op in OPS {
        let line = text
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .find(|v| v["op"] == op);
        out.push(match line {
            Some(v) if v["ok"] == true => Ok(v["seconds"].as_f64().unwrap_or(f64::NAN)),
            Some(v) => Err((
                v["seconds"].as_f64().unwrap_or(f64::NAN),
                v["error"].as_str().unwrap_or("failed").to_string(),
            )),
            None => Err((f64::NAN, "not run".into())),
        });
    }
    Some(out)
}

fn cell(o: &Outcome) -> String {
    match o {
        Ok(s) => format!("{s:.2} s"),
        Err((s, e)) => {
            // MAVSDK's errors repeat every argument; the reason comes first.
            let reason: String = e.split(';').next().unwrap_or(e).chars().take(60).collect();
            format!("failed after {s:.1} s ({reason})")
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let losses: Vec<u32> = match args
        .iter()
        .filter_map(|a| a.parse().ok())
        .collect::<Vec<_>>()
    {
        v if v.is_empty() => vec![0, 20],
        v => v,
    };
    let workdir =
        std::env::temp_dir().join(format!("ferrolink-services-bench-{}", std::process::id()));
    let root = workdir.join("root");
    std::fs::create_dir_all(&root).expect("a scratch directory");
    std::fs::write(root.join("big.bin"), file_bytes()).expect("the file to read");
    println!("machine: {}", harness::machine());
    println!(
        "work: {PARAMS} parameters, a {ITEMS}-item mission up and down, a {} KiB file read; \
         relay seed {SEED}, 1 ms each way",
        FILE / 1024
    );
    println!();
    println!("| work | loss | ferrolink | MAVSDK 4.1 | MAVSDK / ferrolink |");
    println!("|---|---:|---:|---:|---:|");
    for loss in losses {
        let a = ours(loss, &root);
        let b = mavsdk(loss, &root, &workdir);
        for (i, op) in OPS.iter().enumerate() {
            let theirs = b
                .as_ref()
                .map_or("not run (no mavsdk)".into(), |b| cell(&b[i]));
            let ratio = match (&a[i], b.as_ref().map(|b| &b[i])) {
                (Ok(x), Some(Ok(y))) => format!("{:.1}x", y / x),
                (Ok(_), Some(Err(_))) => "MAVSDK failed".into(),
                _ => "–".into(),
            };
            println!("| {op} | {loss} % | {} | {theirs} | {ratio} |", cell(&a[i]));
        }
    }
    let _ = std::fs::remove_dir_all(&workdir);
}
