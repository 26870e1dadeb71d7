//! NDLCom bridges on a simulated network of UART links: routing from an all-UNKNOWN boot on
//! robot-shaped trees, crossing bandwidth domains, mirrors, pinned ids, invalidation, broken and
//! lost frames, and ping round trips against the spec's timing model.

mod sim;

use ferrolink_runtime::ndlcom::bridge::{Bridge, Mode};
use ferrolink_runtime::ndlcom::counters::Observation;
use ferrolink_runtime::ndlcom::{encoded_len, storage_len, Header};
use sim::{bridge, Fault, NodeId, Sim};

const UART: u32 = 921_600;

type Hub = Bridge<4, { storage_len(255) }, 2048>;
type Relay = Bridge<2, { storage_len(255) }, 1024>;

/// A message that is not a ping (ATTITUDE's id) with a sequence number.
fn data(seq: u8, len: usize) -> Vec<u8> {
    let mut p = vec![0x10; len];
    p[0] = 30;
    p[1] = seq;
    p
}

/// Asserts that no frame was broken, lost or stuck anywhere.
fn assert_clean(sim: &Sim) {
    let t = sim.totals();
    assert_eq!(
        (t.crc_failures, t.dropped, t.queue_overflows, t.timeouts),
        (0, 0, 0, 0),
        "{t:?}"
    );
    assert_eq!(sim.pending(), 0, "all queues drained");
}

/// A central computer with four legs, each a chain of `LEGS[k]` nodes, as in the paper's
/// walking robots. Leg k's nodes have ids 10 * (k + 1) + 1, + 2, ...; interface 0 of a leg node
/// faces the centre, interface 1 the next node out; the last node is an end device.
const LEGS: [usize; 4] = [4, 5, 6, 5];
const CENTRAL: u8 = 1;

fn leg_id(leg: usize, pos: usize) -> u8 {
    (10 * (leg + 1) + pos + 1) as u8
}

struct Robot {
    sim: Sim,
    central: NodeId,
    /// Node indices of every leg, centre outwards.
    legs: Vec<Vec<NodeId>>,
}

fn robot(mode: Mode) -> Robot {
    let mut sim = Sim::new();
    let central = sim.add(bridge::<4, 2048>(CENTRAL));
    let mut legs = Vec::new();
    for (leg, &len) in LEGS.iter().enumerate() {
        let mut nodes = Vec::new();
        let mut prev = (central, leg);
        for pos in 0..len {
            let node = if pos + 1 < len {
                sim.add(bridge::<2, 1024>(leg_id(leg, pos)))
            } else {
                sim.add(bridge::<1, 1024>(leg_id(leg, pos)))
            };
            sim.connect(prev.0, prev.1, node, 0, UART);
            prev = (node, 1);
            nodes.push(node);
        }
        legs.push(nodes);
    }
    sim.set_mode_all(mode);
    Robot { sim, central, legs }
}

#[test]
fn central_computer_pings_every_leg_from_an_unknown_boot() {
    for mode in [Mode::StoreForward, Mode::CutThrough] {
        let Robot {
            mut sim,
            central,
            legs,
        } = robot(mode);
        for node in 0..=legs.iter().flatten().count() {
            assert_eq!(sim.node(node).lookup(CENTRAL), None, "all UNKNOWN at boot");
        }
        // All four pings at once.
        let mut requests = Vec::new();
        for (leg, &len) in LEGS.iter().enumerate() {
            let leaf = leg_id(leg, len - 1);
            requests.push((leaf, sim.ping(central, CENTRAL, leaf, leg as u32, 20)));
        }
        sim.run();

        // Every ping answered, with its own payload.
        let answers: Vec<_> = sim.app(central).answers().cloned().collect();
        assert_eq!(answers.len(), LEGS.len(), "{mode:?}");
        for (leaf, request) in &requests {
            let answer = answers
                .iter()
                .find(|a| a.header.sender == *leaf)
                .unwrap_or_else(|| panic!("{mode:?}: no answer from {leaf}"));
            assert_eq!(answer.payload, sim::ping_answer(request, CENTRAL));
            assert_eq!(answer.header.receiver, CENTRAL);
        }

        // Tables along each leg point the right way.
        for (leg, nodes) in legs.iter().enumerate() {
            let leaf = leg_id(leg, LEGS[leg] - 1);
            for &node in &nodes[..nodes.len() - 1] {
                let n = sim.node(node);
                assert_eq!(n.lookup(CENTRAL), Some(0), "{mode:?} leg {leg}");
                assert_eq!(n.lookup(leaf), Some(1), "{mode:?} leg {leg}");
                // Other legs' leaves never sent anything here.
                for (other, &len) in LEGS.iter().enumerate().filter(|&(o, _)| o != leg) {
                    assert_eq!(n.lookup(leg_id(other, len - 1)), None);
                }
            }
            // The leaf learned the centre from the other legs' pings, which passed its way and
            // were dropped there, not from its own: frames for a node teach it nothing
            // (Algorithm 1, step 1).
            assert_eq!(sim.node(*nodes.last().unwrap()).lookup(CENTRAL), Some(0));
            // So the central computer never learns from the answers: it keeps flooding.
            assert_eq!(sim.node(central).lookup(leaf), None);
        }

        // Exactly what flooding predicts: every ping floods the whole tree (the centre knows
        // no route, and a chain node that does not know the receiver passes it outwards), one
        // frame per link; every answer comes straight back, one frame per link of its leg.
        let links: usize = LEGS.iter().sum();
        let expected = (LEGS.len() * links + links) as u64;
        let t = sim.totals();
        assert_eq!(t.tx_frames, expected, "{mode:?}");
        assert_eq!(t.rx_frames, expected, "{mode:?}");
        assert_eq!(sim.frames_on_lines(), expected, "{mode:?}");
        // Only the answers and the pings to their own leaf reach a leaf's application; a leaf
        // drops the other legs' pings without handing them up.
        for (leg, nodes) in legs.iter().enumerate() {
            let leaf = *nodes.last().unwrap();
            assert_eq!(sim.node(leaf).stats(0).rx_frames, LEGS.len() as u64);
            assert_eq!(sim.app(leaf).received.len(), 1, "leg {leg}");
        }
        // Cut-through streams every forwarded frame: a bridge's output runs two bytes behind its
        // input, so it is idle again by the time the next frame's receiver byte is in (two
        // flags separate back-to-back frames). Only the nodes' own frames are queued: the
        // centre's pings on its 4 interfaces and the 4 answers.
        let own = (LEGS.len() * LEGS.len() + LEGS.len()) as u64;
        let streamed = if mode == Mode::CutThrough {
            expected - own
        } else {
            0
        };
        assert_eq!(t.cut_through, streamed, "{mode:?}");
        assert_clean(&sim);
    }
}

#[test]
fn store_and_forward_crosses_from_a_fast_to_a_slow_domain() {
    const FAST: u32 = 10_000_000;
    const BURST: usize = 40;
    const SENSOR: u8 = 5;
    const HOST: u8 = 6;

    // sensor --10 MBd-- gateway --921600 Bd-- host; a burst of 40 frames of 50 bytes from the
    // sensor arrives 10.85 times faster than the UART can take it.
    fn run<const Q: usize>() -> (Sim, [NodeId; 3]) {
        let mut sim = Sim::new();
        let sensor = sim.add(bridge::<1, 4096>(SENSOR));
        let gateway = sim.add(bridge::<2, Q>(7));
        let host = sim.add(bridge::<1, 1024>(HOST));
        sim.connect(sensor, 0, gateway, 0, FAST);
        sim.connect(gateway, 1, host, 0, UART);
        for k in 0..BURST {
            sim.send(sensor, HOST, SENSOR, &data(k as u8, 50));
        }
        sim.run();
        (sim, [sensor, gateway, host])
    }
    // Encoded bytes of the whole burst (an FCS may need escaping).
    let burst_len: usize = (0..BURST as u8)
        .map(|k| encoded_len(&Header::new(HOST, SENSOR, k, 50), &[&data(k, 50)]))
        .sum();

    // A queue for the whole burst: all 40 delivered intact and in order, re-encoded byte for
    // byte as sent.
    let (sim, [sensor, gateway, host]) = run::<4096>();
    let got: Vec<_> = sim
        .app(host)
        .received
        .iter()
        .map(|r| r.payload[1])
        .collect();
    assert_eq!(got, (0..BURST as u8).collect::<Vec<_>>());
    for r in &sim.app(host).received {
        assert_eq!(r.payload, data(r.payload[1], 50));
        assert_eq!(r.header.counter, r.payload[1]);
    }
    assert_eq!(sim.app(host).misses.missed(), 0);
    let g = sim.node(gateway).stats(1);
    assert_eq!((g.tx_frames, g.queue_overflows), (BURST as u64, 0));
    assert_eq!(g.tx_bytes, burst_len as u64);
    assert_eq!(sim.node(sensor).stats(0).tx_bytes, burst_len as u64);
    assert_clean(&sim);
    // The slow side set the pace: 40 frames back to back at 10.85 us a byte, while the fast
    // side was done in under a tenth of that.
    let slow = sim.line_stats(sim.line(gateway, host));
    let fast = sim.line_stats(sim.line(sensor, gateway));
    let busy = slow.last_delivery_ns.unwrap() - slow.first_start_ns.unwrap();
    assert_eq!(busy, burst_len as u64 * sim::byte_ns(UART));
    assert!(fast.last_delivery_ns.unwrap() * 10 < busy);

    // A queue for four frames: what does not fit is counted, never sent half.
    let (sim, [_, gateway, host]) = run::<256>();
    let received = &sim.app(host).received;
    let g = sim.node(gateway).stats(1);
    assert!(g.queue_overflows > 0);
    assert_eq!(received.len() as u64 + g.queue_overflows, BURST as u64);
    assert_eq!(g.tx_frames, received.len() as u64);
    // The delivered frames are intact, in order, and the host's counters see the gaps.
    for r in received {
        assert_eq!(r.payload, data(r.header.counter, 50));
    }
    assert!(received
        .windows(2)
        .all(|w| w[0].header.counter < w[1].header.counter));
    let last = received.last().unwrap().header.counter;
    assert_eq!(
        sim.app(host).misses.missed(),
        u64::from(last) + 1 - received.len() as u64
    );
    let t = sim.totals();
    assert_eq!((t.crc_failures, t.dropped), (0, 0));
    assert_eq!(sim.pending(), 0);
}

#[test]
fn learning_mirrors_pinned_ids_and_invalidation() {
    const A: u8 = 1;
    const B: u8 = 2;
    const C: u8 = 3;
    const D: u8 = 20;
    const MONITOR: u8 = 9;

    // a -- b -- c, b -- d, and a monitor on b's mirror interface 3.
    let mut sim = Sim::new();
    let a = sim.add(bridge::<1, 1024>(A));
    let b = sim.add(bridge::<4, 2048>(B));
    let c = sim.add(bridge::<1, 1024>(C));
    let d = sim.add(bridge::<1, 1024>(D));
    let monitor = sim.add(bridge::<1, 1024>(MONITOR));
    sim.connect(a, 0, b, 0, UART);
    sim.connect(b, 1, c, 0, UART);
    sim.connect(b, 2, d, 0, UART);
    sim.connect(b, 3, monitor, 0, UART);
    sim.bridge_mut::<Hub>(b).router_mut().set_mirror(3, true);
    // D is an internal id of b's: pinned to interface 2.
    sim.bridge_mut::<Hub>(b).router_mut().pin(D, 2);
    let routes = |sim: &mut Sim| -> Vec<(u8, usize)> {
        sim.bridge_mut::<Hub>(b).router().routes().collect()
    };
    let rx = |sim: &Sim, n: NodeId| sim.node(n).stats(0).rx_frames;
    assert_eq!(routes(&mut sim), [(D, 2)], "only the pinned id at boot");

    // a pings c: the unknown receiver floods to c and d (and the mirror); the answer teaches b
    // where c is and goes straight to a.
    sim.ping(a, A, C, 1, 20);
    sim.run();
    assert_eq!(sim.app(a).answers().count(), 1);
    assert_eq!(routes(&mut sim), [(A, 0), (C, 1), (D, 2)]);
    assert_eq!((rx(&sim, a), rx(&sim, d), rx(&sim, monitor)), (1, 1, 2));

    // Once known, no more flooding: d sees nothing, the mirror still sees both frames.
    sim.ping(a, A, C, 2, 20);
    sim.run();
    assert_eq!(sim.app(a).answers().count(), 2);
    assert_eq!((rx(&sim, a), rx(&sim, d), rx(&sim, monitor)), (2, 1, 4));

    // A frame injected on the mirror is forwarded but teaches nothing: b does not learn where
    // the monitor is, so the answer floods back to a, d and the monitor.
    sim.ping(monitor, MONITOR, C, 3, 20);
    sim.run();
    assert_eq!(sim.app(monitor).answers().count(), 1);
    assert_eq!(sim.app(monitor).answers().next().unwrap().header.sender, C);
    assert_eq!(sim.node(b).lookup(MONITOR), None);
    assert_eq!((rx(&sim, a), rx(&sim, d), rx(&sim, monitor)), (3, 2, 5));
    assert_eq!(sim.node(b).stats(3).rx_frames, 1);

    // A frame with the pinned id as sender arriving from a does not move the pin.
    sim.send(a, C, D, &data(0, 4));
    sim.run();
    assert_eq!(sim.app(c).received.last().unwrap().header.sender, D);
    assert_eq!(sim.node(b).lookup(D), Some(2));
    // And c's ping to d goes to d alone.
    sim.ping(c, C, D, 4, 20);
    sim.run();
    assert_eq!(sim.app(c).answers().count(), 1);
    assert_eq!(rx(&sim, a), 3, "a got no copy");

    // c's link goes down (and comes back): its routes are forgotten, the others stay.
    sim.bridge_mut::<Hub>(b).link_down(1);
    assert_eq!(routes(&mut sim), [(A, 0), (D, 2)]);
    // The next frame to c floods again (d gets a copy), and the answer re-teaches b.
    let d_before = rx(&sim, d);
    sim.ping(a, A, C, 5, 20);
    sim.run();
    assert_eq!(sim.app(a).answers().count(), 3);
    assert_eq!(rx(&sim, d), d_before + 1);
    assert_eq!(routes(&mut sim), [(A, 0), (C, 1), (D, 2)]);
    // Invalidating a's interface forgets a but keeps the pin even if it pointed there.
    sim.bridge_mut::<Hub>(b).router_mut().invalidate(0);
    sim.bridge_mut::<Hub>(b).router_mut().invalidate(2);
    assert_eq!(routes(&mut sim), [(C, 1), (D, 2)]);

    // The mirror got a copy of every frame that passed b and was not its own.
    let passed: u64 = (0..3).map(|i| sim.node(b).stats(i).rx_frames).sum();
    assert_eq!(sim.node(b).stats(3).tx_frames, passed);
    assert_eq!(rx(&sim, monitor), passed);
    assert_clean(&sim);
}

#[test]
fn cut_through_passes_a_broken_frame_to_the_next_checking_hop() {
    // a -- b (cut-through) -- c (cut-through) -- e (`last` mode) -- d. One payload byte of the
    // first frame is corrupted on the first link.
    for last in [Mode::StoreForward, Mode::CutThrough] {
        let mut sim = Sim::new();
        let a = sim.add(bridge::<1, 1024>(1));
        let b = sim.add(bridge::<2, 1024>(2));
        let c = sim.add(bridge::<2, 1024>(3));
        let e = sim.add(bridge::<2, 1024>(5));
        let d = sim.add(bridge::<1, 1024>(4));
        sim.connect(a, 0, b, 0, UART);
        sim.connect(b, 1, c, 0, UART);
        sim.connect(c, 1, e, 0, UART);
        sim.connect(e, 1, d, 0, UART);
        for n in [b, c] {
            sim.bridge_mut::<Relay>(n).set_mode(0, 1, Mode::CutThrough);
        }
        sim.bridge_mut::<Relay>(e).set_mode(0, 1, last);
        let payload = data(0, 8); // bytes 0x10: 0x11 after the flip, nothing to escape
        let line = sim.line(a, b);
        sim.fault(
            line,
            Fault::Corrupt {
                frame: 0,
                offset: 8,
                xor: 1,
            },
        );
        sim.send(a, 4, 1, &payload);
        sim.run();
        assert_eq!(sim.line_stats(line).corrupted, 1);
        let len = encoded_len(&Header::new(4, 1, 0, 8), &[&payload]) as u64;

        // b and c both check it too late to stop it: they stream it on and count the failure.
        for n in [b, c] {
            let (i, o) = (sim.node(n).stats(0), sim.node(n).stats(1));
            assert_eq!((i.crc_failures, i.rx_frames), (1, 0), "{last:?}");
            assert_eq!((o.cut_through, o.tx_bytes), (1, len), "{last:?}");
        }
        let (e_in, e_out) = (sim.node(e).stats(0), sim.node(e).stats(1));
        assert_eq!(e_in.crc_failures, 1, "{last:?}");
        match last {
            // The store & forward hop drops it: d sees not a byte.
            Mode::StoreForward => {
                assert_eq!(e_out.tx_bytes, 0);
                assert_eq!(sim.node(d).stats(0).rx_bytes, 0);
            }
            // Or it passes once more and the receiver drops it.
            Mode::CutThrough => {
                assert_eq!(e_out.tx_bytes, len);
                assert_eq!(sim.node(d).stats(0).crc_failures, 1);
            }
        }
        assert!(sim.app(d).received.is_empty(), "{last:?}");
        // Nobody learned from it.
        for n in [b, c, e] {
            assert_eq!(sim.node(n).lookup(1), None, "{last:?}");
        }

        // The next, intact frame gets through and teaches the route.
        sim.send(a, 4, 1, &payload);
        sim.run();
        assert_eq!(sim.app(d).received.len(), 1, "{last:?}");
        assert_eq!(sim.app(d).received[0].header.counter, 1);
        assert_eq!(
            sim.app(d).received[0].observation,
            Observation::First,
            "the first frame of a pair is not a miss"
        );
        for n in [b, c, e] {
            assert_eq!(sim.node(n).lookup(1), Some(0), "{last:?}");
        }
        let t = sim.totals();
        let broken_at = if last == Mode::CutThrough { 4 } else { 3 };
        assert_eq!(t.crc_failures, broken_at, "{last:?}");
        assert_eq!((t.dropped, t.queue_overflows, t.timeouts), (0, 0, 0));
        assert_eq!(sim.pending(), 0);
    }
}

#[test]
fn a_frame_lost_in_flight_is_exactly_one_miss() {
    // a -- b -- c, store & forward; a sends 6 frames to c and 3 to b; the third frame on b's
    // line to c is lost whole.
    let mut sim = Sim::new();
    let a = sim.add(bridge::<1, 1024>(1));
    let b = sim.add(bridge::<2, 1024>(2));
    let c = sim.add(bridge::<1, 1024>(3));
    sim.connect(a, 0, b, 0, UART);
    sim.connect(b, 1, c, 0, UART);
    let line = sim.line(b, c);
    sim.fault(line, Fault::DropFrame { frame: 2 });
    for k in 0..6 {
        sim.send(a, 3, 1, &data(k, 12));
        if k < 3 {
            sim.send(a, 2, 1, &data(k, 12));
        }
    }
    sim.run();

    let app = sim.app(c);
    let counters: Vec<_> = app.received.iter().map(|r| r.header.counter).collect();
    assert_eq!(counters, [0, 1, 3, 4, 5]);
    let observations: Vec<_> = app.received.iter().map(|r| r.observation).collect();
    assert_eq!(
        observations,
        [
            Observation::First,
            Observation::InOrder,
            Observation::Missed(1),
            Observation::InOrder,
            Observation::InOrder
        ]
    );
    assert_eq!(app.misses.missed(), 1);
    // b's own pair is counted apart and lost nothing.
    assert_eq!(sim.app(b).received.len(), 3);
    assert_eq!(sim.app(b).misses.missed(), 0);
    // Lost whole, flags included: c's parser saw nothing wrong.
    assert_eq!(sim.line_stats(line).frames, 6);
    assert_eq!(sim.node(c).stats(0).rx_frames, 5);
    assert_clean(&sim);
}

// ---------------------------------------------------------------------------------------------
// Ping round trip per hop, both modes, against the spec's timing model.
//
// n ("hops") is the number of forwarding bridges between the pinging and the answering node, so
// the ping crosses n + 1 links: the only reading under which the spec's 4-hop figures come out
// (store & forward: 2 * 4 * 306.0 + 2 * 306.0 = 3060 us, one full transmission per link).
//
// The model is not a lower bound for this bridge; the simulation comes out below it, by an
// amount that follows exactly from three differences (`sim::predicted_byte_times`):
//
// 1. Cut-through: the bridge starts the outgoing frame once flag and receiver byte are in, 2
//    byte times after the incoming frame started, not 3: the model's 6n byte times per round
//    trip are 4n here.
// 2. Every node acts on a frame when its last FCS byte is in (the length field says where it
//    ends) instead of after the closing flag: each store & forward hop and the answering node
//    save one byte time. Only the answer's closing flag is waited for, because the round trip
//    is measured to the last byte received (the application has the answer one byte time
//    earlier, see `decoded_ns`).
// 3. The 20-byte ping encodes to 28 bytes, the model's average for uniform bytes is 28.2.
//
// For n = 4: cut-through 71 byte times = 770.4 us against 872.5 us (model - measured =
// 2n + 1 + 2 * 0.2 byte times); store & forward 271 byte times = 2940.6 us against 3060 us
// ((n + 1) * 2.4 - 1 byte times).
// ---------------------------------------------------------------------------------------------

#[test]
fn ping_round_trips_against_the_timing_model() {
    use sim::{model_us, predicted_byte_times, TIMING_BAUD, TIMING_PAYLOAD};

    // The spec's worked figures.
    assert!((model_us(4, Mode::CutThrough, TIMING_BAUD, TIMING_PAYLOAD) - 872.5).abs() < 0.05);
    assert!((model_us(4, Mode::StoreForward, TIMING_BAUD, TIMING_PAYLOAD) - 3060.0).abs() < 0.5);
    assert!((model_us(0, Mode::StoreForward, TIMING_BAUD, TIMING_PAYLOAD) - 612.0).abs() < 0.1);

    let rows = sim::timing_rows(TIMING_BAUD, TIMING_PAYLOAD, 1..=6);
    println!(
        "{}",
        sim::timing_markdown(TIMING_BAUD, TIMING_PAYLOAD, &rows)
    );
    let t_byte = sim::model_byte_us(TIMING_BAUD);
    for row in &rows {
        let n = row.hops;
        for (rtt, model) in [(row.ct, row.model_ct_us), (row.sf, row.model_sf_us)] {
            // This payload needs no escaping in either direction: 2 + 4 + 20 + 2 bytes.
            assert_eq!((rtt.ping_len, rtt.answer_len), (28, 28));
            // Exactly what the bridge's forwarding rules predict, to the nanosecond.
            let byte_times = predicted_byte_times(n, rtt.mode, rtt.ping_len, rtt.answer_len);
            assert_eq!(rtt.measured_ns, byte_times * rtt.byte_ns, "{rtt:?}");
            assert_eq!(rtt.decoded_ns + rtt.byte_ns, rtt.measured_ns, "{rtt:?}");
            // Below the model by the stated margin: (2n + 2) byte times cut-through,
            // 2.5 (n + 1) store & forward. The simulated byte time is 0.3 ns long per byte.
            let measured = rtt.measured_ns as f64 / 1000.0;
            let margin = match rtt.mode {
                Mode::CutThrough => (2 * n + 2) as f64,
                Mode::StoreForward => 2.5 * (n + 1) as f64,
            } * t_byte;
            let rounding = byte_times as f64 * 0.0005;
            assert!(measured <= model + rounding, "{rtt:?} vs {model}");
            assert!(measured >= model - margin, "{rtt:?} vs {model}");
        }
        // Each hop costs l - 1 byte times each way store & forward and 2 cut-through.
        let saved = (n * (row.sf.ping_len + row.sf.answer_len - 6)) as u64;
        assert_eq!(
            row.sf.measured_ns - row.ct.measured_ns,
            saved * row.ct.byte_ns
        );
    }
    // The spec's 4-hop row.
    let four = &rows[3];
    assert_eq!(four.ct.measured_ns, 71 * 10851);
    assert_eq!(four.sf.measured_ns, 271 * 10851);
}
