//! `ferrolink tosnet ...`: the cycle-rate model against a simulated ring.

use std::io::Write as _;
use std::process::ExitCode;

use clap::Subcommand;
use ferrolink_io::tosnet::sim::{model_rate, Forwarding, LinkModel, Ring};
use ferrolink_runtime::tosnet::{Config, Node, Phase};

#[derive(Subcommand)]
pub enum Command {
    /// The model's cycle rate, 1 / ((32 + 256 r) / B + i d), next to the rate a simulated
    /// ring with the same parameters runs at (cut-through like the FPGA, and store & forward
    /// like software nodes).
    Cycle {
        /// Nodes in the ring (i), 1..=15.
        #[arg(long, value_parser = clap::value_parser!(u8).range(1..=15))]
        nodes: u8,
        /// Enabled registers in the whole ring (r), up to 8 per node.
        #[arg(long)]
        registers: u16,
        /// Bit rate in bit/s (`10M`, `921600`, `2.5e6`).
        #[arg(long, default_value = "10M", value_parser = parse_rate)]
        bitrate: f64,
        /// Node-to-node delay in µs.
        #[arg(long, default_value_t = 5.46)]
        node_delay: f64,
        /// Print the model only.
        #[arg(long)]
        no_simulation: bool,
    },
}

fn parse_rate(s: &str) -> Result<f64, String> {
    let (num, scale) = match s.strip_suffix(['k', 'K']) {
        Some(n) => (n, 1e3),
        None => match s.strip_suffix('M') {
            Some(n) => (n, 1e6),
            None => (s, 1.0),
        },
    };
    let v: f64 = num
        .parse()
        .map_err(|_| format!("`{s}` is not a bit rate (examples: 10M, 921600, 2.5e6)"))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(format!("`{s}`: the bit rate must be positive"));
    }
    Ok(v * scale)
}

pub fn run(command: Command) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let Command::Cycle {
        nodes,
        registers,
        bitrate,
        node_delay,
        no_simulation,
    } = command;
    if registers > u16::from(nodes) * 8 {
        return Err(format!(
            "{nodes} node(s) have at most {} registers (8 each)",
            u16::from(nodes) * 8
        )
        .into());
    }
    if !(node_delay.is_finite() && node_delay >= 0.0) {
        return Err("the node delay must be 0 or more µs".into());
    }
    let i = usize::from(nodes);
    let r = usize::from(registers);
    let rate = model_rate(i, r, bitrate, node_delay * 1e3);
    let bits = 32 + 256 * r;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "model: {i} node(s), r = {r}, {} bit/s, {node_delay} µs per node",
        bitrate
    )?;
    writeln!(
        out,
        "  DATA frame {} bytes ({bits} bits), cycle {:.2} µs -> {:.1} Hz",
        bits / 8,
        1e6 / rate,
        rate
    )?;
    if no_simulation {
        return Ok(ExitCode::SUCCESS);
    }
    for forwarding in [Forwarding::CutThrough, Forwarding::StoreAndForward] {
        let model = LinkModel {
            bitrate,
            node_delay_ns: (node_delay * 1e3).round() as u64,
            forwarding,
        };
        let label = match forwarding {
            Forwarding::CutThrough => "cut-through",
            Forwarding::StoreAndForward => "store & forward",
        };
        match simulate(nodes, registers, model) {
            Some(measured) => writeln!(
                out,
                "simulated, {label}: cycle {:.2} µs -> {measured:.1} Hz ({:+.2} % from the model)",
                1e6 / measured,
                (measured / rate - 1.0) * 100.0
            )?,
            None => writeln!(out, "simulated, {label}: the ring did not set up")?,
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Sets up a ring of `nodes` with `registers` spread over them and measures its cycle rate
/// from the master's sync strobes over about 200 cycles.
pub fn simulate(nodes: u8, registers: u16, model: LinkModel) -> Option<f64> {
    let ring_nodes = (0..nodes)
        .map(|k| {
            let share = registers / u16::from(nodes)
                + u16::from(u16::from(k) < registers % u16::from(nodes));
            let mask = ((1u16 << share) - 1) as u8;
            let mut cfg = Config::new(k + 1).registers(mask, mask);
            cfg.watchdog_ns = 1_000_000_000;
            Node::new(cfg)
        })
        .collect();
    let mut ring = Ring::new(ring_nodes, model);
    // Setup takes eight round trips; wait for the first strobes.
    let mut step = 1_000_000;
    while ring
        .nodes
        .iter()
        .any(|n| n.status().phase != Phase::Running || n.status().last_sync_ns.is_none())
    {
        if ring.now() > 60_000_000_000 {
            return None;
        }
        ring.run_for(step);
        step *= 2;
    }
    let m = ring.master()?;
    let strobe = |r: &Ring| {
        let n = &r.nodes[m];
        (n.counters().syncs, n.status().last_sync_ns.unwrap_or(0))
    };
    let (c0, t0) = strobe(&ring);
    let rate = model_rate(
        usize::from(nodes),
        usize::from(registers),
        model.bitrate,
        model.node_delay_ns as f64,
    );
    let per_hop = match model.forwarding {
        Forwarding::CutThrough => 1.0,
        Forwarding::StoreAndForward => f64::from(nodes),
    };
    ring.run_for((200.0 * per_hop / rate * 1e9) as u64);
    let (c1, t1) = strobe(&ring);
    (t1 > t0).then(|| f64::from(c1 - c0) / ((t1 - t0) as f64 * 1e-9))
}
