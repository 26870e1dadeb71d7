//! Runs the ModRob-1 example robot and prints a summary every second.
//!
//! ```text
//! robot [--seconds S] [--fast]                  simulated CAN bus (1 Mbit/s), paced to the wall clock
//! robot --transport ethernet [--base-port P]    Ethernet-1 over UDP loopback, one thread per module
//!       [--upstream zenoh://...]                the leader's upstream port on Zenoh (feature zenoh)
//! ```

use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use clap::{Parser, ValueEnum};
use ferrolink_example_robot::can::CanRobot;
use ferrolink_example_robot::ethernet;
use ferrolink_generated::modrob::robot;

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Transport {
    /// A simulated CAN bus carrying CAN-1 frames, in this thread.
    Can,
    /// Ethernet-1 packets over UDP on 127.0.0.1, one thread per module.
    Ethernet,
}

#[derive(Debug, Parser)]
#[command(about = "The ModRob-1 example robot: 14 modules and their leader")]
struct Args {
    /// Which network carries the robot.
    #[arg(long, value_enum, default_value = "can")]
    transport: Transport,
    /// How long to run, in (simulated, for CAN) seconds.
    #[arg(long, default_value_t = 10)]
    seconds: u64,
    /// CAN: run the simulation as fast as the CPU allows instead of at wall-clock pace.
    #[arg(long)]
    fast: bool,
    /// Ethernet: the first UDP port (module i at base + i, then the leader's upstream socket and
    /// the host).
    #[arg(long, default_value_t = 47000)]
    base_port: u16,
    /// Ethernet: the leader's upstream port on Zenoh instead of the host thread
    /// (`zenoh://?mode=peer&listen=tcp/HOST:PORT...`; needs the `zenoh` feature).
    #[arg(long, value_name = "URI")]
    upstream: Option<String>,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let result = match args.transport {
        Transport::Can => {
            run_can(&args);
            Ok(())
        }
        Transport::Ethernet => run_ethernet(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("robot: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run_can(args: &Args) {
    let bus = &robot::NETWORKS[0];
    println!(
        "{} modules on CAN bus `{}` at {} kbit/s, led by `{}`; simulated, {}",
        robot::INSTANCES.len(),
        bus.name,
        bus.bitrate / 1000,
        robot::INSTANCES[robot::ROBOT.leader].name,
        if args.fast {
            "as fast as possible"
        } else {
            "at wall-clock pace"
        }
    );
    let mut sim = CanRobot::new();
    let wall = Instant::now();
    let mut last = *sim.bus();
    let mut last_up = 0;
    for second in 1..=args.seconds {
        sim.run_until(second * 1_000_000);
        if !args.fast {
            let target = Duration::from_secs(second);
            std::thread::sleep(target.saturating_sub(wall.elapsed()));
        }
        let now = *sim.bus();
        let per = |i: usize| now.by_type[i] - last.by_type[i];
        let configured = (0..robot::INSTANCES.len())
            .filter(|&i| i != robot::ROBOT.leader && sim.configured(i))
            .count();
        println!(
            "t={second:>3} s  commands {:>4}/s  publications {:>5}/s  piecewise {:>4}/s  bus load {:>5.1} %  longest wait {:>5.2} ms  configured {configured}/{}  upstream {:>5}/s",
            per(0),
            per(1),
            per(2),
            (now.busy_ns - last.busy_ns) as f64 / 1e7,
            now.max_wait_ns as f64 / 1e6,
            robot::INSTANCES.len() - 1,
            sim.upstream() - last_up,
        );
        last = now;
        last_up = sim.upstream();
    }
}

fn run_ethernet(args: &Args) -> std::io::Result<()> {
    println!(
        "{} modules on Ethernet-1 over UDP 127.0.0.1:{}.., one thread each, for {} s",
        robot::INSTANCES.len(),
        args.base_port,
        args.seconds
    );
    let upstream = match &args.upstream {
        None => ethernet::Upstream::Host,
        #[cfg(feature = "zenoh")]
        Some(uri) => ethernet::Upstream::Zenoh(uri.parse().map_err(std::io::Error::other)?),
        #[cfg(not(feature = "zenoh"))]
        Some(uri) => {
            return Err(std::io::Error::other(format!(
                "{uri}: built without the zenoh feature (cargo run -p ferrolink-example-robot --features zenoh)"
            )))
        }
    };
    let mut last = [0u64; 5];
    ethernet::run(
        args.base_port,
        Duration::from_secs(args.seconds),
        upstream,
        |at, shared| {
            let now = [
                shared.sent[0].load(Ordering::Relaxed),
                shared.sent[1].load(Ordering::Relaxed),
                shared.sent[2].load(Ordering::Relaxed),
                shared.packets.load(Ordering::Relaxed),
                shared.upstream.load(Ordering::Relaxed),
            ];
            let d: Vec<u64> = now.iter().zip(last).map(|(a, b)| a - b).collect();
            let configured = (0..robot::INSTANCES.len())
                .filter(|&i| i != robot::ROBOT.leader)
                .filter(|&i| shared.configured[i].load(Ordering::Relaxed))
                .count();
            println!(
                "t={:>3} s  commands {:>4}/s  publications {:>5}/s  piecewise {:>4}/s  packets {:>5}/s ({:.1} messages each)  configured {configured}/{}  upstream {:>5}/s",
                at.as_secs(),
                d[0],
                d[1],
                d[2],
                d[3],
                (d[0] + d[1] + d[2]) as f64 / d[3].max(1) as f64,
                robot::INSTANCES.len() - 1,
                d[4],
            );
            last = now;
        },
    )?;
    Ok(())
}
