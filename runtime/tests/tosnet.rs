//! TosNet frames and the node engine: property round trips and the fuzz invariants on random
//! input.

#[path = "scripts/tosnet.rs"]
mod scripts;

use ferrolink_runtime::tosnet::frame::{data_len, Repr};
use ferrolink_runtime::tosnet::{crc8, Config, Node, Phase, Role};
use proptest::prelude::*;

fn repr_strategy() -> impl Strategy<Value = (u8, u8, u8, Vec<u8>)> {
    (
        0u8..12,
        0u8..16,
        any::<u8>(),
        prop::collection::vec(any::<u8>(), 0..64),
    )
}

proptest! {
    #[test]
    fn frames_round_trip((kind, arg, byte, bytes) in repr_strategy()) {
        let areas: Vec<u8> = bytes.iter().copied().cycle().take(bytes.len() / 32 * 32).collect();
        let ids: Vec<u8> = bytes.iter().take(15).copied().collect();
        let masks: Vec<u8> = bytes.iter().take(30 & !1).copied().collect();
        let masks = &masks[..masks.len() & !1];
        let data = &bytes[..bytes.len().min(64)];
        let repr = match kind {
            0 => Repr::Idle { sender: arg },
            1 => Repr::MasterDsc { candidate: arg, hops: byte },
            2 => Repr::MasterSet { master: arg },
            3 => Repr::Net { master: arg, complete: byte & 1 == 1, ids: &ids },
            4 => Repr::Reg { master: arg, complete: byte & 1 == 1, masks },
            5 => Repr::SyncDsc { master: arg, len: bytes.len() },
            6 => Repr::SyncSet { master: arg, delay_ns: u32::from(byte) * 1000 },
            7 => Repr::Data { master: arg, cycle: u16::from(byte) << 3, areas: &areas },
            8 => Repr::Async { dest: arg, source: byte, data },
            _ => Repr::Halt { master: arg },
        };
        let mut buf = vec![0xa5; repr.buffer_len() + 1];
        let len = repr.emit(&mut buf).expect("sized");
        prop_assert_eq!(Repr::parse(&buf[..len]), Ok(repr));
        prop_assert_eq!(crc8(&buf[..len]), 0, "residue 0");
        prop_assert_eq!(buf[len], 0xa5);
        scripts::check_frame(&buf[..len]);
    }

    #[test]
    fn any_bytes_as_a_frame(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        scripts::check_frame(&bytes);
    }

    #[test]
    fn any_bytes_on_a_stream(
        bytes in prop::collection::vec(prop_oneof![Just(0x7E), Just(0x7D), any::<u8>()], 0..400)
    ) {
        scripts::check_stream(&bytes);
    }

    #[test]
    fn any_script_for_a_node(script in prop::collection::vec(any::<u8>(), 0..600)) {
        scripts::check_node(&script);
    }
}

#[test]
fn crc_check_value_and_residue() {
    assert_eq!(crc8(b"123456789"), 0xDF);
    assert_eq!(crc8(b"123456789\xDF"), 0);
}

/// One node alone is a ring of one: its frames come straight back.
#[test]
fn a_ring_of_one_sets_itself_up() {
    let mut node = Node::new(Config::new(4).registers(0b1, 0b1));
    let mut buf = [0u8; 64];
    let mut frame = Vec::new();
    let mut now = 0;
    let mut len = node.poll(now, &mut buf);
    for _ in 0..20 {
        let Some(n) = len else { break };
        frame.clear();
        frame.extend_from_slice(&buf[..n]);
        now += 1000;
        len = node.receive(&frame, now, &mut buf);
    }
    let s = node.status();
    assert_eq!(
        (s.role, s.phase, s.nodes, s.registers),
        (Role::Master, Phase::Running, 1, 1)
    );
    assert_eq!(len, Some(data_len(1)));
    assert_eq!(s.delay_ns, 1000, "one hop per round trip");
}

/// A SYNC_SET from another master than the one that set the ring up must not leave the node
/// running without a ring (a DATA frame then used to underflow its position arithmetic).
#[test]
fn a_sync_set_from_another_master_does_not_start_a_node_without_a_ring() {
    let mut node = Node::new(Config::new(5).registers(1, 1));
    let mut out = [0u8; 128];
    let mut buf = [0u8; 128];
    let mut send = |node: &mut Node, repr: Repr<'_>| {
        let len = repr.emit(&mut buf).expect("fits");
        node.receive(&buf[..len], 1, &mut out);
    };
    send(&mut node, Repr::MasterSet { master: 1 });
    send(
        &mut node,
        Repr::Net {
            master: 1,
            complete: true,
            ids: &[1, 5],
        },
    );
    send(
        &mut node,
        Repr::Reg {
            master: 1,
            complete: true,
            masks: &[0, 0, 1, 1],
        },
    );
    send(
        &mut node,
        Repr::SyncSet {
            master: 2,
            delay_ns: 100,
        },
    );
    assert_ne!(node.status().phase, Phase::Running);
    send(
        &mut node,
        Repr::Data {
            master: 2,
            cycle: 1,
            areas: &[0; 32],
        },
    );
    assert_eq!(node.counters().packets, 5);
}

/// Found by `cargo fuzz run tosnet_node`: a broken frame was forwarded with a good CRC.
#[test]
fn fuzz_regression_broken_frame_stays_broken() {
    let script = hex::decode("ff88032ffe09880300770301000001a6fe0000").expect("hex");
    scripts::check_node(&script);
}

/// A frame an upstream node marked broken (its CRC off by exactly the low nibble) stays broken
/// through every node downstream: each seals the CRC of what it forwards, inverted, rather than
/// flipping the received one back.
#[test]
fn broken_frames_stay_broken_downstream() {
    use ferrolink_runtime::tosnet::frame::{crc_ok, seal_broken, MAX_FRAME_LEN};
    let mut frame = [0u8; 8];
    let len = Repr::Idle { sender: 3 }.emit(&mut frame).expect("fits");
    let mut frame = frame[..len].to_vec();
    assert!(crc_ok(&frame));
    seal_broken(&mut frame);
    assert!(!crc_ok(&frame));
    let mut out = vec![0u8; MAX_FRAME_LEN];
    for id in 1..=4 {
        let mut node = Node::new(Config::new(id));
        let n = node.receive(&frame, 0, &mut out).expect("forwarded");
        assert_eq!(
            out[..n - 1],
            frame[..len - 1],
            "the body is forwarded as it came"
        );
        assert!(
            !crc_ok(&out[..n]),
            "node {id} forwarded a broken frame as good"
        );
        assert_eq!(node.counters().errors, 1);
        frame = out[..n].to_vec();
    }
}
