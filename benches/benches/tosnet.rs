//! TosNet node throughput: what one software node spends on a DATA frame, against a plain
//! `copy_from_slice` (memcpy) of the frame's bytes.
//!
//! ```text
//! cargo bench -p ferrolink-bench --bench tosnet
//! ```
//!
//! Cases: the paper's rings of 4 nodes with 2 registers each (a 260-byte DATA frame) and of 15
//! nodes with every register (3844 bytes). A ring of real `Node`s is set up by passing frames
//! until it runs; then:
//!
//! - **slave**: a slave in the middle of the ring handles one DATA frame: CRC check, taking in
//!   every area, writing its own out areas into the frame, sealing it again;
//! - **master**: the master takes a returned DATA frame, fires its strobe and builds the next.
//!
//! The ratio is memcpy's time over the node's. The same harness as the other benchmarks.

#[allow(dead_code)]
mod harness;

use harness::{compare, BATCHES, BATCH_TARGET};
use std::hint::black_box;

use ferrolink_runtime::tosnet::frame::MAX_FRAME_LEN;
use ferrolink_runtime::tosnet::{Config, Node, Phase};

/// A running ring of `nodes` with `regs` registers each (both ways), and the DATA frame as it
/// arrives at each node.
fn running_ring(nodes: u8, regs: u8) -> (Vec<Node>, Vec<Vec<u8>>) {
    let mask = ((1u16 << regs) - 1) as u8;
    let mut ring: Vec<Node> = (1..=nodes)
        .map(|id| Node::new(Config::new(id).registers(mask, mask)))
        .collect();
    let n = ring.len();
    let mut buf = vec![0u8; MAX_FRAME_LEN];
    let mut in_flight: Vec<(usize, Vec<u8>)> = Vec::new();
    let mut arriving = vec![Vec::new(); n];
    let mut now = 0;
    for _ in 0..1000 {
        now += 10_000;
        for (i, node) in ring.iter_mut().enumerate() {
            while let Some(len) = node.poll(now, &mut buf) {
                in_flight.push(((i + 1) % n, buf[..len].to_vec()));
            }
        }
        for (to, frame) in std::mem::take(&mut in_flight) {
            if frame[0] >> 4 == 0xA {
                arriving[to] = frame.clone();
            }
            if let Some(len) = ring[to].receive(&frame, now, &mut buf) {
                in_flight.push(((to + 1) % n, buf[..len].to_vec()));
            }
        }
        if ring.iter().all(|n| n.status().phase == Phase::Running)
            && arriving.iter().all(|f| !f.is_empty())
        {
            return (ring, arriving);
        }
    }
    panic!("the ring did not set up");
}

fn main() {
    println!("machine: {}", harness::machine());
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    println!(
        "TosNet DATA frame handling against memcpy of the frame ({BATCHES} alternating batches of ~{} ms, medians)\n",
        BATCH_TARGET.as_millis()
    );
    println!(
        "{:<34} {:>7} {:>11} {:>11} {:>12} {:>10}",
        "case", "bytes", "node ns", "memcpy ns", "node MB/s", "memcpy/node"
    );
    for (nodes, regs) in [(4u8, 2u8), (15, 8)] {
        let (mut ring, arriving) = running_ring(nodes, regs);
        let master = 0;
        let slave = usize::from(nodes) / 2;
        for (role, i) in [("slave", slave), ("master", master)] {
            let name = format!("{role}, {nodes} nodes x {regs} registers");
            if !filter.is_empty() && !filter.iter().any(|f| name.contains(f.as_str())) {
                continue;
            }
            let frame = arriving[i].clone();
            let mut out = vec![0u8; MAX_FRAME_LEN];
            let mut copy = vec![0u8; frame.len()];
            let node = &mut ring[i];
            let mut now = 1_000_000_000u64;
            let (t_node, t_copy) = compare(
                |_| {
                    now += 100_000;
                    black_box(node.receive(black_box(&frame), now, &mut out));
                },
                |_| copy.copy_from_slice(black_box(&frame)),
            );
            assert_eq!(node.counters().errors, 0);
            println!(
                "{name:<34} {:>7} {:>11.1} {:>11.1} {:>12.0} {:>10.3}",
                frame.len(),
                t_node * 1e9,
                t_copy * 1e9,
                frame.len() as f64 / t_node / 1e6,
                t_copy / t_node
            );
        }
    }
}
