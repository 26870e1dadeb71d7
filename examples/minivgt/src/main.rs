//! MiniVGT on a TosNet ring: a master and three sections, each section running three simulated
//! motor controllers. Every node is a real UDP socket on loopback, sending to the next node's
//! port; by default all four run as threads of this process, `--node` runs only some of them
//! (start the others in other processes).
//!
//! The master writes every motor's target position and speed limit into the in areas (a slow
//! sweep, unless `--no-sweep`), and takes targets from UDP: `minivgt send SECTION MOTOR
//! POSITION [SPEED]`, or any datagram `SECTION MOTOR POSITION [SPEED]` to the control port. The
//! sections move their motors and write position and current into their out areas. Once a
//! second it prints the cycle rate, the error counters and every motor's position.

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use ferrolink_generated::tosnet::minivgt::{
    Master, MotorState, MotorTarget, Section1, Section2, Section3,
};
use ferrolink_io::printer::{self, Printer};
use ferrolink_io::tosnet::UdpNode;
use ferrolink_runtime::tosnet::{Block, Config, Counters, Node, NodeId, Phase, Status};

/// Node ids in ring order.
const RING: [u8; 4] = [Master::ID, Section1::ID, Section2::ID, Section3::ID];

#[derive(Parser)]
#[command(about = "MiniVGT on a TosNet ring over UDP")]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Run only these node ids here (default: all four).
    #[arg(long = "node", value_name = "ID")]
    nodes: Vec<u8>,
    /// Node i listens on BASE_PORT + i and sends to the next node's port.
    #[arg(long, default_value_t = 35100, value_parser = clap::value_parser!(u16).range(1..=65532))]
    base_port: u16,
    /// The master takes targets on this UDP port.
    #[arg(long, default_value_t = 35200)]
    control_port: u16,
    /// The master starts a cycle at most every this many µs.
    #[arg(long, default_value_t = 1000)]
    cycle_us: u64,
    /// Stop after this many seconds (default: run until interrupted).
    #[arg(long)]
    run_for: Option<f64>,
    /// Hold targets at 0 instead of sweeping (targets from UDP still apply).
    #[arg(long)]
    no_sweep: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Send a target to a running master.
    Send {
        /// Section 1..=3.
        section: u8,
        /// Motor 1..=3.
        motor: u8,
        /// Target position in rad.
        position: f32,
        /// Speed limit in rad/s.
        #[arg(default_value_t = 1.0)]
        speed: f32,
    },
}

/// What the printer shows, per node run here.
#[derive(Default)]
struct Shared {
    nodes: Vec<(u8, Status, Counters)>,
    view: Option<Block>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let cli = Cli::parse();
    if let Some(Command::Send {
        section,
        motor,
        position,
        speed,
    }) = cli.command
    {
        let socket = UdpSocket::bind("127.0.0.1:0")?;
        let line = format!("{section} {motor} {position} {speed}");
        socket.send_to(line.as_bytes(), ("127.0.0.1", cli.control_port))?;
        return Ok(());
    }
    let local: Vec<u8> = if cli.nodes.is_empty() {
        RING.to_vec()
    } else {
        cli.nodes.clone()
    };
    if let Some(bad) = local.iter().find(|id| !RING.contains(id)) {
        return Err(format!("node {bad} is not in the MiniVGT ring (ids 0..=3)").into());
    }
    let stop = Arc::new(AtomicBool::new(false));
    let shared = Arc::new(Mutex::new(Shared::default()));
    let mut threads = Vec::new();
    for &id in &local {
        let position = RING.iter().position(|&r| r == id).unwrap_or(0);
        let port = |p: usize| -> SocketAddr {
            SocketAddr::from(([127, 0, 0, 1], cli.base_port + RING[p % RING.len()] as u16))
        };
        let mut cfg = match id {
            0 => Config::for_node::<Master>(),
            1 => Config::for_node::<Section1>(),
            2 => Config::for_node::<Section2>(),
            _ => Config::for_node::<Section3>(),
        };
        cfg.watchdog_ns = 300_000_000;
        cfg.cycle_ns = cli.cycle_us * 1000;
        let udp = UdpNode::bind(Node::new(cfg), port(position), port(position + 1))?;
        let control = if id == Master::ID {
            let s = UdpSocket::bind(("127.0.0.1", cli.control_port))?;
            s.set_nonblocking(true)?;
            Some(s)
        } else {
            None
        };
        let (stop, shared, sweep) = (stop.clone(), shared.clone(), !cli.no_sweep);
        threads.push(std::thread::spawn(move || {
            run_node(udp, control, sweep, &stop, &shared)
        }));
    }
    // Printed by a thread of its own: a terminal paused with Ctrl-S loses lines, never cycles
    // (the nodes share the lock the report is made under).
    let out = Printer::stdout();
    out.line(format!(
        "MiniVGT: node(s) {local:?} on UDP ports {}.., targets on port {}",
        cli.base_port, cli.control_port
    ))?;
    let start = Instant::now();
    let mut last = (Instant::now(), 0u32);
    loop {
        std::thread::sleep(Duration::from_secs(1));
        let done = cli
            .run_for
            .is_some_and(|s| start.elapsed().as_secs_f64() >= s);
        let line = {
            let shared = shared.lock().map_err(|_| "a node thread panicked")?;
            let cycles = shared
                .nodes
                .iter()
                .map(|(_, _, c)| c.cycles)
                .max()
                .unwrap_or(0);
            let rate = f64::from(cycles.wrapping_sub(last.1)) / last.0.elapsed().as_secs_f64();
            last = (Instant::now(), cycles);
            report(&shared, rate, done)
        };
        out.line(line)?;
        if done {
            break;
        }
    }
    stop.store(true, Ordering::Relaxed);
    for t in threads {
        t.join().map_err(|_| "a node thread panicked")??;
    }
    // What is printed goes out, unless nobody reads it.
    let _ = out.flush(printer::FLUSH_PATIENCE);
    let _ = printer::flush_stderr(printer::FLUSH_PATIENCE);
    Ok(())
}

fn report(shared: &Shared, rate: f64, last: bool) -> String {
    let errors: u32 = shared.nodes.iter().map(|(_, _, c)| c.errors).sum();
    let resets: u32 = shared.nodes.iter().map(|(_, _, c)| c.resets).sum();
    let mut nodes: Vec<_> = shared.nodes.iter().collect();
    nodes.sort_by_key(|(id, _, _)| *id);
    let phase = nodes
        .iter()
        .map(|(id, s, _)| format!("{id}:{:?}", s.phase))
        .collect::<Vec<_>>()
        .join(" ");
    let mut line = format!(
        "{}{rate:7.1} Hz | crc errors {errors} | resets {resets} | {phase}",
        if last { "final: " } else { "" }
    );
    if let Some(view) = &shared.view {
        for (s, section) in [Section1::ID, Section2::ID, Section3::ID]
            .into_iter()
            .enumerate()
        {
            line.push_str(&format!(" | s{}:", s + 1));
            for reg in 0..3 {
                let state = MotorState::read(view.out_area(section, reg));
                line.push_str(&format!(" {:+.3}", state.position));
            }
        }
    }
    line
}

/// One simulated motor: moves towards its target at most at the target's speed.
#[derive(Default, Clone, Copy)]
struct Motor {
    position: f32,
    velocity: f32,
}

impl Motor {
    fn step(&mut self, target: MotorTarget, dt: f32) {
        let max = target.speed.abs() * dt;
        let delta = (target.position - self.position).clamp(-max, max);
        self.velocity = if dt > 0.0 { delta / dt } else { 0.0 };
        self.position += delta;
    }

    fn state(&self) -> MotorState {
        MotorState {
            position: self.position,
            current: 0.05 + 0.8 * self.velocity.abs(),
        }
    }
}

/// A section's work each cycle: its motors follow the master's targets, and their state goes
/// into the section's own out areas (only `N`'s writer can write them).
fn run_section<N: NodeId>(node: &mut Node, motors: &mut [Motor; 3], dt: f32) {
    for (reg, motor) in (0u8..).zip(motors.iter_mut()) {
        motor.step(MotorTarget::read(node.view().in_area(N::ID, reg)), dt);
    }
    if let Some(mut out) = node.out_writer::<N>() {
        for (reg, motor) in (0u8..).zip(motors.iter()) {
            motor.state().write(out.area(reg));
        }
    }
    node.commit_out();
}

/// The master's work each cycle: targets from UDP, or the sweep, into every in area.
fn run_master(node: &mut Node, targets: &mut [[Option<MotorTarget>; 3]; 3], t: f32, sweep: bool) {
    let Some(mut w) = node.in_writer() else {
        return;
    };
    for (s, section) in [Section1::ID, Section2::ID, Section3::ID]
        .into_iter()
        .enumerate()
    {
        for reg in 0..3u8 {
            let phase = (s * 3 + usize::from(reg)) as f32 * 0.7;
            let swept = MotorTarget {
                position: if sweep {
                    0.5 * (0.5 * t + phase).sin()
                } else {
                    0.0
                },
                speed: 1.0,
            };
            let target = targets[s][usize::from(reg)].unwrap_or(swept);
            target.write(w.area_of(section, reg));
        }
    }
    node.commit_in();
}

fn read_targets(control: &UdpSocket, targets: &mut [[Option<MotorTarget>; 3]; 3]) {
    let mut buf = [0u8; 256];
    while let Ok(len) = control.recv(&mut buf) {
        let text = String::from_utf8_lossy(&buf[..len]);
        let words: Vec<&str> = text.split_whitespace().collect();
        let parsed = (|| {
            let section: usize = words.first()?.parse().ok()?;
            let motor: usize = words.get(1)?.parse().ok()?;
            let position: f32 = words.get(2)?.parse().ok()?;
            let speed: f32 = words.get(3).map_or(Some(1.0), |w| w.parse().ok())?;
            let slot = targets
                .get_mut(section.checked_sub(1)?)?
                .get_mut(motor.checked_sub(1)?)?;
            *slot = Some(MotorTarget { position, speed });
            Some(())
        })();
        if parsed.is_none() {
            // Through the printer: the master's cycle must not wait on stderr.
            let _ = printer::stderr().line(format!(
                "ignored target `{}` (want: SECTION MOTOR POSITION [SPEED])",
                text.trim()
            ));
        }
    }
}

fn run_node(
    mut udp: UdpNode,
    control: Option<UdpSocket>,
    sweep: bool,
    stop: &AtomicBool,
    shared: &Mutex<Shared>,
) -> std::io::Result<()> {
    let id = udp.node().config().id;
    let mut motors = [Motor::default(); 3];
    let mut targets = [[None; 3]; 3];
    let mut last_sync = 0;
    let mut last_step = Instant::now();
    let start = Instant::now();
    let mut last_share = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        udp.step()?;
        let node = udp.node_mut();
        let syncs = node.counters().syncs;
        if syncs != last_sync && node.status().phase == Phase::Running {
            last_sync = syncs;
            let dt = last_step.elapsed().as_secs_f32();
            last_step = Instant::now();
            match id {
                1 => run_section::<Section1>(node, &mut motors, dt),
                2 => run_section::<Section2>(node, &mut motors, dt),
                3 => run_section::<Section3>(node, &mut motors, dt),
                _ => {
                    if let Some(control) = &control {
                        read_targets(control, &mut targets);
                    }
                    run_master(node, &mut targets, start.elapsed().as_secs_f32(), sweep);
                }
            }
        }
        if last_share.elapsed() > Duration::from_millis(100) {
            last_share = Instant::now();
            let mut shared = shared
                .lock()
                .map_err(|_| std::io::Error::other("poisoned"))?;
            let node = udp.node();
            let entry = (id, node.status(), *node.counters());
            match shared.nodes.iter_mut().find(|(i, _, _)| *i == id) {
                Some(slot) => *slot = entry,
                None => shared.nodes.push(entry),
            }
            if id == Master::ID || shared.view.is_none() {
                shared.view = Some(node.view().clone());
            }
        }
    }
    Ok(())
}
