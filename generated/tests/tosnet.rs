//! The checked-in TosNet register map (`definitions/tosnet/minivgt.toml`): area structs against
//! hand-written byte offsets, node constants, and the accessors' types.

use ferrolink_generated::tosnet::minivgt::{
    self, Master, MotorState, MotorTarget, Section1, Section2, Section3,
};
use ferrolink_runtime::tosnet::{Block, InWriter, NodeId, OutWriter};
use proptest::prelude::*;

#[test]
fn motor_target_layout() {
    let target = MotorTarget {
        position: 1.5,
        speed: -0.25,
    };
    // Pre-filled so that unwritten bytes show.
    let mut area = [0xA5u8; 16];
    target.write(&mut area);
    assert_eq!(area[0..4], 1.5f32.to_le_bytes());
    assert_eq!(area[4..8], (-0.25f32).to_le_bytes());
    assert_eq!(area[8..], [0xA5; 8]);
    assert_eq!(MotorTarget::read(&area), target);
    assert_eq!(
        (
            MotorTarget::LEN,
            MotorTarget::POSITION_OFFSET,
            MotorTarget::SPEED_OFFSET
        ),
        (8, 0, 4)
    );
    assert_eq!(MotorTarget::NAME, "motor_target");
}

#[test]
fn motor_state_from_hand_written_bytes() {
    let mut area = [0u8; 16];
    area[0..4].copy_from_slice(&0.75f32.to_le_bytes());
    area[4..8].copy_from_slice(&2.0f32.to_le_bytes());
    assert_eq!(
        MotorState::read(&area),
        MotorState {
            position: 0.75,
            current: 2.0
        }
    );
    assert_eq!(MotorState::CURRENT_OFFSET, 4);
}

#[test]
fn node_constants() {
    assert_eq!((Master::ID, Master::NAME), (0, "master"));
    assert_eq!((Master::OUT_MASK, Master::IN_MASK), (0, 0));
    assert_eq!((Section1::ID, Section1::NAME), (1, "section1"));
    assert_eq!((Section2::ID, Section3::ID), (2, 3));
    for (out_mask, in_mask) in [
        (Section1::OUT_MASK, Section1::IN_MASK),
        (Section2::OUT_MASK, Section2::IN_MASK),
        (Section3::OUT_MASK, Section3::IN_MASK),
    ] {
        assert_eq!((out_mask, in_mask), (0b111, 0b111));
    }
    assert_eq!(
        (Section1::MOTOR1, Section1::MOTOR2, Section1::MOTOR3),
        (0, 1, 2)
    );
    assert_eq!(
        minivgt::NODES,
        &[
            (0, "master"),
            (1, "section1"),
            (2, "section2"),
            (3, "section3")
        ]
    );
    // Three sections of three motors; the master has none.
    assert_eq!(minivgt::REGISTERS, 9);
}

#[test]
fn accessors_read_the_block_and_setters_take_the_right_writer() {
    let block = Block::new();
    assert_eq!(Section2::motor3_out(&block), MotorState::default());
    assert_eq!(Section3::motor1_in(&block), MotorTarget::default());
    // Out areas are written through the node's own writer, in areas through the master's.
    let _: fn(&mut OutWriter<'_, Section1>, &MotorState) = Section1::set_motor1_out;
    let _: fn(&mut InWriter<'_>, &MotorTarget) = Section1::set_motor1_in;
}

proptest! {
    #[test]
    fn areas_round_trip_and_keep_other_bytes(
        position in any::<f32>().prop_filter("NaN", |v| !v.is_nan()),
        current in any::<f32>().prop_filter("NaN", |v| !v.is_nan()),
        fill in any::<[u8; 16]>(),
    ) {
        let state = MotorState { position, current };
        let mut area = fill;
        state.write(&mut area);
        prop_assert_eq!(MotorState::read(&area), state);
        prop_assert_eq!(&area[8..], &fill[8..]);
        prop_assert_eq!(&area[0..4], &position.to_le_bytes()[..]);
    }
}

/// Two real nodes (the master and section 1) passing frames to each other.
struct TwoNodes {
    nodes: [ferrolink_runtime::tosnet::Node; 2],
    in_flight: Vec<(usize, Vec<u8>)>,
    now: u64,
}

impl TwoNodes {
    fn running() -> Self {
        use ferrolink_runtime::tosnet::{Config, Node, Phase};
        let mut ring = Self {
            nodes: [
                Node::new(Config::for_node::<Master>()),
                Node::new(Config::for_node::<Section1>()),
            ],
            in_flight: Vec::new(),
            now: 0,
        };
        ring.step(40);
        assert!(ring
            .nodes
            .iter()
            .all(|n| n.status().phase == Phase::Running));
        ring
    }

    /// Delivers every frame in flight and polls both nodes, `steps` times, 10 µs apart.
    fn step(&mut self, steps: usize) {
        let mut buf = vec![0u8; ferrolink_runtime::tosnet::frame::MAX_FRAME_LEN];
        for _ in 0..steps {
            self.now += 10_000;
            for (i, node) in self.nodes.iter_mut().enumerate() {
                while let Some(n) = node.poll(self.now, &mut buf) {
                    self.in_flight.push((1 - i, buf[..n].to_vec()));
                }
            }
            for (to, frame) in std::mem::take(&mut self.in_flight) {
                if let Some(n) = self.nodes[to].receive(&frame, self.now, &mut buf) {
                    self.in_flight.push((1 - to, buf[..n].to_vec()));
                }
            }
        }
    }
}

#[test]
fn generated_setters_reach_the_other_node_at_the_hand_written_offsets() {
    let mut ring = TwoNodes::running();
    let [master, section] = &mut ring.nodes;
    let state = MotorState {
        position: 0.5,
        current: 1.25,
    };
    let target = MotorTarget {
        position: -1.0,
        speed: 2.0,
    };
    Section1::set_motor2_out(&mut section.out_writer::<Section1>().expect("own"), &state);
    assert!(section.out_writer::<Section2>().is_none(), "not section 2");
    assert!(section.in_writer().is_none(), "not the master");
    Section1::set_motor3_in(&mut master.in_writer().expect("master"), &target);
    section.commit_out();
    master.commit_in();
    ring.step(10);
    // The data went round; the views refresh at the next commit.
    ring.nodes[0].commit_in();
    ring.nodes[1].commit_out();
    ring.step(10);
    let [master, section] = &ring.nodes;
    // Node 1, register 1, out area: bytes 1 * 256 + 1 * 32 ..; register 2's in area: + 2 * 32
    // + 16.
    let bytes = master.view().as_bytes();
    assert_eq!(bytes[288..292], 0.5f32.to_le_bytes());
    assert_eq!(bytes[292..296], 1.25f32.to_le_bytes());
    let bytes = section.view().as_bytes();
    assert_eq!(bytes[256 + 64 + 16..256 + 64 + 20], (-1.0f32).to_le_bytes());
    assert_eq!(bytes[256 + 64 + 20..256 + 64 + 24], 2.0f32.to_le_bytes());
    assert_eq!(Section1::motor2_out(master.view()), state);
    assert_eq!(Section1::motor3_in(section.view()), target);
    // Word addressing as in the C driver: out word (1 << 6) + (1 << 3) + 0.
    assert_eq!(
        master
            .view()
            .word(ferrolink_runtime::tosnet::block::out_word(1, 1, 0)),
        0.5f32.to_bits()
    );
}
