//! TosNet rings on the virtual clock: setup from cold, joins and leaves, CRC errors, double
//! buffering, sync strobes and cycle rates against the model.

use ferrolink_io::tosnet::sim::{model_rate, Forwarding, LinkModel, Ring};
use ferrolink_runtime::tosnet::{Config, Node, Phase, Role};

const MS: u64 = 1_000_000;

/// Nodes with ids `ids`, each with `regs` registers enabled both ways.
fn ring(ids: &[u8], regs: u8, model: LinkModel) -> Ring {
    ring_with(ids, &vec![regs; ids.len()], model)
}

/// Nodes with ids `ids`, node i with `regs[i]` registers enabled both ways.
fn ring_with(ids: &[u8], regs: &[u8], model: LinkModel) -> Ring {
    let nodes = ids
        .iter()
        .zip(regs)
        .map(|(&id, &regs)| {
            let mask = ((1u16 << regs) - 1) as u8;
            let mut cfg = Config::new(id).registers(mask, mask);
            cfg.watchdog_ns = 20 * MS;
            Node::new(cfg)
        })
        .collect();
    Ring::new(nodes, model)
}

fn all_running(ring: &Ring) -> bool {
    ring.nodes
        .iter()
        .all(|n| n.status().phase == Phase::Running)
}

/// Cycles per second at the master, from its strobes over at least `window` ns of running.
fn measured_rate(ring: &mut Ring, window: u64) -> f64 {
    let m = ring.master().expect("a master");
    let strobe = |r: &Ring| {
        let n = &r.nodes[m];
        (
            n.counters().syncs,
            n.status().last_sync_ns.expect("running"),
        )
    };
    let (c0, t0) = strobe(ring);
    ring.run_for(window);
    let (c1, t1) = strobe(ring);
    f64::from(c1 - c0) / ((t1 - t0) as f64 * 1e-9)
}

#[test]
fn setup_from_cold_with_2_to_15_nodes() {
    for n in 2..=15u8 {
        // Ids shuffled so that the master (the lowest) is not the first node.
        let ids: Vec<u8> = (0..n).map(|i| (i * 7 + 3) % 16).collect();
        let mut r = ring(&ids, 1, LinkModel::default());
        r.run_until(10 * MS);
        assert!(all_running(&r), "{n} nodes: {:?}", r.nodes[0].status());
        let lowest = *ids.iter().min().expect("ids");
        let m = r.master().expect("master");
        assert_eq!(ids[m], lowest);
        for (i, node) in r.nodes.iter().enumerate() {
            let s = node.status();
            assert_eq!(s.master, lowest);
            assert_eq!(usize::from(s.nodes), ids.len());
            assert_eq!(s.registers, n);
            assert_eq!(
                usize::from(s.position),
                (i + ids.len() - m) % ids.len(),
                "positions count from the master"
            );
            assert_eq!(node.counters().errors, 0);
            assert_eq!(node.counters().resets, 0, "node {i} reset");
            assert_eq!(node.ring()[0], lowest);
        }
    }
}

/// The paper's three examples: 4 nodes with 2 registers each, 15 nodes with every register, and
/// 2 nodes with one register between them.
#[test]
fn cycle_rate_matches_the_model_cut_through() {
    let cases: [(&[u8], f64); 3] = [(&[2; 4], 4351.0), (&[8; 15], 316.7), (&[1, 0], 25176.0)];
    for (regs, expected_hz) in cases {
        let ids: Vec<u8> = (1..=regs.len() as u8).collect();
        let mut r = ring_with(&ids, regs, LinkModel::default());
        r.run_until(30 * MS);
        assert!(all_running(&r));
        let registers: usize = regs.iter().map(|&r| usize::from(r)).sum();
        let model = model_rate(regs.len(), registers, 10e6, 5460.0);
        let measured = measured_rate(&mut r, 200 * MS);
        assert!((model - expected_hz).abs() / expected_hz < 0.001, "{model}");
        assert!(
            (measured - model).abs() / model < 0.001,
            "{} nodes, r = {registers}: model {model:.1} Hz, measured {measured:.1} Hz",
            regs.len()
        );
    }
}

#[test]
fn store_and_forward_pays_the_frame_time_per_hop() {
    let model = LinkModel {
        forwarding: Forwarding::StoreAndForward,
        ..LinkModel::default()
    };
    let mut r = ring(&[1, 2, 3, 4], 2, model);
    r.run_until(30 * MS);
    assert!(all_running(&r));
    let frame_s = (4.0 + 32.0 * 8.0) * 8.0 / 10e6;
    let expected = 1.0 / (4.0 * (frame_s + 5460e-9));
    let measured = measured_rate(&mut r, 200 * MS);
    assert!((measured - expected).abs() / expected < 0.01, "{measured}");
}

#[test]
fn sync_strobes_fire_together() {
    let mut r = ring(&[3, 1, 7, 5, 9], 2, LinkModel::default());
    r.run_until(20 * MS);
    assert!(all_running(&r));
    // Check every strobe over many cycles: run in small steps and look at the last strobes.
    for _ in 0..50 {
        r.run_for(50_000);
        let strobes: Vec<u64> = r
            .nodes
            .iter()
            .filter_map(|n| n.status().last_sync_ns)
            .collect();
        let cycles: Vec<u16> = r.nodes.iter().map(|n| n.status().cycle).collect();
        if cycles.iter().any(|&c| c != cycles[0]) {
            continue; // a cycle in flight
        }
        let spread = strobes.iter().max().unwrap() - strobes.iter().min().unwrap();
        assert!(spread <= 1000, "strobes {strobes:?}");
    }
}

#[test]
fn a_node_leaving_and_joining_is_picked_up_by_the_watchdog() {
    let mut r = ring(&[1, 2, 3, 4], 1, LinkModel::default());
    r.run_until(10 * MS);
    assert!(all_running(&r));
    // Node index 2 (id 3) is switched off: the ring is broken and nothing runs.
    r.kill(2);
    r.run_for(100 * MS);
    let live = [0usize, 1, 3];
    for &i in &live {
        assert_ne!(r.nodes[i].status().phase, Phase::Running, "node {i}");
        assert!(
            r.nodes[i].counters().resets >= 2,
            "the watchdog keeps trying"
        );
    }
    // Its upstream neighbour is replugged to its downstream one: three nodes run.
    r.link(1, 3);
    r.run_for(100 * MS);
    for &i in &live {
        let s = r.nodes[i].status();
        assert_eq!(s.phase, Phase::Running, "node {i}");
        assert_eq!(s.nodes, 3);
        assert_eq!(r.nodes[i].ring(), &[1, 2, 4]);
    }
    // A new node (id 6) is plugged in between ids 4 and 1.
    let mut cfg = Config::new(6).registers(1, 1);
    cfg.watchdog_ns = 20 * MS;
    let new = r.add(Node::new(cfg));
    r.link(3, new);
    r.link(new, 0);
    r.run_for(100 * MS);
    for i in [0usize, 1, 3, new] {
        let s = r.nodes[i].status();
        assert_eq!(s.phase, Phase::Running, "node {i}");
        assert_eq!(s.nodes, 4);
        assert_eq!(r.nodes[i].ring(), &[1, 2, 4, 6]);
    }
    let before = r.nodes[0].counters().cycles;
    r.run_for(20 * MS);
    assert!(r.nodes[0].counters().cycles > before + 100);
}

#[test]
fn a_corrupted_frame_is_rejected_downstream_and_the_cycle_goes_on() {
    let mut r = ring(&[1, 2, 3, 4], 1, LinkModel::default());
    r.run_until(10 * MS);
    assert!(all_running(&r));
    let errors: Vec<u32> = r.nodes.iter().map(|n| n.counters().errors).collect();
    assert_eq!(errors, [0, 0, 0, 0]);
    let cycles = r.nodes[0].counters().cycles;
    // Node index 1 sends one broken DATA frame: indices 2, 3 and the master (0) see it.
    r.corrupt_data_from(1, 1);
    r.run_for(5 * MS);
    let errors: Vec<u32> = r.nodes.iter().map(|n| n.counters().errors).collect();
    assert_eq!(errors, [1, 0, 1, 1]);
    assert!(
        r.nodes[0].counters().cycles > cycles + 10,
        "the cycle goes on"
    );
    assert!(all_running(&r));
    assert!(r.nodes.iter().all(|n| n.counters().resets == 0));
}

#[test]
fn roles_are_exclusive() {
    let r = {
        let mut r = ring(&[2, 5], 1, LinkModel::default());
        r.run_until(5 * MS);
        r
    };
    let roles: Vec<Role> = r.nodes.iter().map(|n| n.status().role).collect();
    assert_eq!(roles, [Role::Master, Role::Slave]);
}

struct Two;
impl ferrolink_runtime::tosnet::NodeId for Two {
    const ID: u8 = 2;
    const NAME: &'static str = "two";
    const OUT_MASK: u8 = 0b11;
    const IN_MASK: u8 = 0b11;
}

/// Ring 1 (master), 2, 3 with registers 0 and 1 both ways.
fn three() -> Ring {
    let mut r = ring(&[1, 2, 3], 2, LinkModel::default());
    r.run_until(10 * MS);
    assert!(all_running(&r));
    r
}

#[test]
fn no_swap_without_a_commit() {
    let mut r = three();
    {
        let master = &mut r.nodes[0];
        let mut w = master.in_writer().expect("the master writes in areas");
        w.area::<Two>(0).fill(7);
        master.commit_in();
    }
    r.run_for(MS);
    // The master's data reached node 2's network copy, but node 2 has not committed: its view
    // stays as it was.
    assert_eq!(r.nodes[1].view().in_area(2, 0), &[0; 16]);
    assert_eq!(r.nodes[1].counters().swaps, 0);
    // Node 3 has not committed either.
    assert_eq!(r.nodes[2].view().in_area(2, 0), &[0; 16]);
    // A commit (even with nothing written) swaps at the next strobe.
    r.nodes[1].commit_out();
    r.run_for(MS);
    assert_eq!(r.nodes[1].view().in_area(2, 0), &[7; 16]);
    assert_eq!(r.nodes[1].counters().swaps, 1);
    // Slave writes: only its own out areas, and only once committed.
    {
        let node = &mut r.nodes[1];
        node.out_writer::<Two>()
            .expect("node 2 is Two")
            .area(1)
            .fill(9);
        assert!(node.in_writer().is_none(), "a slave cannot write in areas");
    }
    assert!(
        r.nodes[2].out_writer::<Two>().is_none(),
        "node 3 cannot write node 2's out areas"
    );
    r.nodes[2].commit_out();
    r.nodes[0].commit_in();
    r.run_for(MS);
    assert_eq!(
        r.nodes[2].view().out_area(2, 1),
        &[0; 16],
        "not committed yet"
    );
    r.nodes[1].commit_out();
    r.run_for(MS);
    r.nodes[2].commit_out();
    r.nodes[0].commit_in();
    r.run_for(MS);
    assert_eq!(r.nodes[2].view().out_area(2, 1), &[9; 16]);
    assert_eq!(r.nodes[0].view().out_area(2, 1), &[9; 16]);
}

#[test]
fn reads_never_tear_and_errored_cycles_do_not_swap() {
    let mut r = three();
    let mut value = 0u8;
    let mut corrupted = 0;
    for step in 0..400u32 {
        // The master writes one consistent record over two registers and commits it.
        {
            let master = &mut r.nodes[0];
            value = value.wrapping_add(1);
            let mut w = master.in_writer().expect("master");
            w.area::<Two>(0).fill(value);
            w.area::<Two>(1).fill(value);
            master.commit_in();
        }
        r.nodes[2].commit_out();
        if step % 50 == 25 {
            r.corrupt_data_from(1, 1);
            corrupted += 1;
        }
        r.run_for(37_000);
        let view = r.nodes[2].view();
        let a = view.in_area(2, 0);
        let b = view.in_area(2, 1);
        assert!(a.iter().chain(b).all(|&x| x == a[0]), "torn: {a:?} {b:?}");
    }
    let node = &r.nodes[2];
    assert_eq!(node.counters().errors, corrupted);
    assert!(node.counters().swaps > 0);
    assert!(
        node.counters().swaps <= node.counters().syncs - corrupted,
        "a cycle with an error never swaps"
    );
}

#[test]
fn the_side_channel_reaches_one_node_or_everyone() {
    let mut r = three();
    r.nodes[1].send_async(3, b"to three").expect("queued");
    assert_eq!(
        r.nodes[1].send_async(3, b"again"),
        Err(ferrolink_runtime::tosnet::node::AsyncError::Busy)
    );
    r.run_for(MS);
    let got = r.nodes[2].take_async().expect("delivered");
    assert_eq!((got.source, got.dest, got.data()), (2, 3, &b"to three"[..]));
    assert!(r.nodes[0].take_async().is_none(), "not for the master");
    r.nodes[2].send_async(0, b"all").expect("queued");
    r.run_for(MS);
    for i in [0, 1] {
        assert_eq!(r.nodes[i].take_async().expect("broadcast").data(), b"all");
    }
    assert!(
        r.nodes[2].take_async().is_none(),
        "the sender drops its own"
    );
    assert!(all_running(&r), "the cycle is not disturbed");
}

#[test]
fn halt_stops_the_ring_and_the_network_register_tells_where_a_node_is() {
    let mut r = ring(&[4, 2, 9], 2, LinkModel::default());
    r.run_until(10 * MS);
    assert!(all_running(&r));
    // Id 2 is the master at position 0; id 9 comes after it, at position 1; id 4 at 2.
    let n = &r.nodes[0];
    assert_eq!(
        n.status().network_register(n.config()),
        4 | 2 << 4 | 0b11 << 8 | 0b11 << 16
    );
    r.nodes[1].halt();
    r.run_for(MS);
    assert!(r.nodes.iter().all(|n| n.status().phase == Phase::Halted));
    let cycles: Vec<u32> = r.nodes.iter().map(|n| n.counters().cycles).collect();
    r.run_for(200 * MS);
    let after: Vec<u32> = r.nodes.iter().map(|n| n.counters().cycles).collect();
    assert_eq!(
        cycles, after,
        "no cycles and no watchdog restarts once halted"
    );
    assert!(r.nodes.iter().all(|n| n.counters().resets == 0));
}
