//! The checked-in bindings in use: golden frames, unknown values, strings, the JSON form, and
//! property round trips over every message of every dialect.

use ferrolink_generated::mavlink::{bench, minimal, usv};
use ferrolink_runtime::mavlink::{v1, v2, Dialect, Header, Message as _, PayloadBuf};
use minimal::{Heartbeat, MavAutopilot, MavModeFlag, MavState, MavType, Statustext};
use proptest::prelude::*;

fn golden() -> Heartbeat {
    Heartbeat {
        r#type: MavType::Quadrotor,
        autopilot: MavAutopilot::Ardupilotmega,
        base_mode: MavModeFlag::from_raw(0x51),
        custom_mode: 4,
        system_status: MavState::Active,
        mavlink_version: 3,
    }
}

#[test]
fn heartbeat_golden_frames() {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode(Header::new(0, 1, 1), &golden(), &mut out).unwrap();
    assert_eq!(
        hex::encode(&out[..n]),
        "fd0900000001010000000400000002035104037bae"
    );
    let n = v1::encode(Header::new(0, 1, 1), &golden(), &mut out).unwrap();
    assert_eq!(hex::encode(&out[..n]), "fe0900010100040000000203510403e16d");
    let frame = v1::Frame::new_checked(&out[..n]).unwrap();
    assert_eq!(
        frame.decode::<minimal::Message>().unwrap(),
        minimal::Message::Heartbeat(golden())
    );
}

#[test]
fn known_crc_extras() {
    assert_eq!(Heartbeat::CRC_EXTRA, 50);
    assert_eq!(minimal::FileTransferProtocol::CRC_EXTRA, 84);
    assert_eq!(usv::RudderRaw::ID, 150);
    assert_eq!(usv::RudderRaw::MAX_LEN, 5);
}

#[test]
fn unknown_enum_values_and_flag_bits_survive() {
    let mut payload: PayloadBuf = [0; 255];
    let n = golden().encode(&mut payload);
    payload[4] = 200; // type: no such MAV_TYPE
    payload[6] = 0xFF; // base_mode: every bit
    let hb = Heartbeat::decode(&payload[..n]);
    assert_eq!(hb.r#type, MavType::Unknown(200));
    assert!(hb.base_mode.contains(MavModeFlag::SAFETY_ARMED));
    assert_eq!(hb.base_mode.raw(), 0xFF);
    let mut again: PayloadBuf = [0; 255];
    hb.encode(&mut again);
    assert_eq!(again[..n], payload[..n]);
}

#[test]
fn mavlink_version_is_always_the_dialects() {
    let hb = Heartbeat {
        mavlink_version: 9,
        ..golden()
    };
    let mut payload: PayloadBuf = [0; 255];
    hb.encode(&mut payload);
    assert_eq!(payload[8], 3);
}

#[test]
fn char_arrays_are_byte_exact() {
    let full = "x".repeat(50);
    let msg = Statustext {
        text: full.as_str().into(),
        ..Default::default()
    };
    assert_eq!(msg.text.as_str(), full);
    let mut payload: PayloadBuf = [0; 255];
    let n = msg.encode(&mut payload);
    assert_eq!(Statustext::decode(&payload[..n]), msg);
    let short = Statustext {
        text: "hi".into(),
        ..Default::default()
    };
    assert_eq!(short.text.as_bytes()[..3], *b"hi\0");
}

#[test]
fn short_payloads_zero_fill_and_long_ones_are_cut() {
    let ack = minimal::CommandAck::decode(&[0x90, 0x01, 0x00]);
    assert_eq!(ack.command, minimal::MavCmd::ComponentArmDisarm);
    assert_eq!(ack.result, minimal::MavResult::Accepted);
    assert_eq!(ack.progress, 0);
    let long = [1u8; 40];
    assert_eq!(usv::RudderRaw::decode(&long).starboard_limit, 1);
}

#[test]
fn dialect_dispatch_covers_included_messages() {
    let meta = usv::Message::meta_of(0).unwrap();
    assert_eq!((meta.id, meta.crc_extra), (0, 50));
    let heartbeat = usv::Message::decode(0, &[0; 9]).unwrap();
    assert_eq!((heartbeat.name(), heartbeat.meta().id), ("HEARTBEAT", 0));
    assert!(
        usv::Message::meta_of(180).is_none(),
        "bench messages are not in usv"
    );
    assert!(bench::Message::meta_of(180).is_some());
    let ping = minimal::Message::meta_of(4).unwrap();
    assert_eq!(
        (ping.target_system, ping.target_component),
        (Some(12), Some(13))
    );
    // Shared types: the usv dialect's HEARTBEAT is minimal's.
    let m: usv::Message = golden().into();
    assert_eq!(m.id(), 0);
}

#[cfg(feature = "serde")]
#[test]
fn json_is_pymavlinks_to_dict() {
    let json = serde_json::to_value(minimal::Message::from(golden())).unwrap();
    assert_eq!(
        json,
        serde_json::json!({"mavpackettype": "HEARTBEAT", "type": 2, "autopilot": 3, "base_mode": 81,
            "custom_mode": 4, "system_status": 4, "mavlink_version": 3})
    );
    let text = Statustext {
        text: "ok".into(),
        ..Default::default()
    };
    let json = serde_json::to_value(minimal::Message::from(text)).unwrap();
    assert_eq!(json["text"], "ok");
    let att = minimal::Attitude {
        roll: 0.1,
        ..Default::default()
    };
    let json = serde_json::to_value(minimal::Message::from(att)).unwrap();
    assert_eq!(json["roll"], serde_json::json!(0.10000000149011612));
    let back: minimal::Message = serde_json::from_value(json).unwrap();
    assert_eq!(back, minimal::Message::from(att));
}

/// Every message id of every dialect, for the property tests.
fn all_ids() -> Vec<u32> {
    bench::Message::META
        .iter()
        .chain(usv::Message::META)
        .map(|m| m.id)
        .collect()
}

fn round_trip<D: Dialect>(id: u32, payload: &[u8]) {
    let Ok(msg) = D::decode(id, payload) else {
        return;
    };
    let mut once: PayloadBuf = [0; 255];
    let n = msg.encode(&mut once);
    let meta = D::meta_of(id).unwrap();
    assert_eq!(n, usize::from(meta.max_len));
    let mut twice: PayloadBuf = [0; 255];
    D::decode(id, &once[..n]).unwrap().encode(&mut twice);
    assert_eq!(once[..n], twice[..n]);
    if id != 0 {
        // Every byte survives, except HEARTBEAT's version byte, which is always the dialect's.
        let mut expected = [0u8; 255];
        let k = payload.len().min(n);
        expected[..k].copy_from_slice(&payload[..k]);
        assert_eq!(once[..n], expected[..n]);
    }
}

proptest! {
    #[test]
    fn decode_encode_is_lossless(pick in any::<prop::sample::Index>(), payload in prop::collection::vec(any::<u8>(), 0..=255)) {
        let ids = all_ids();
        let id = ids[pick.index(ids.len())];
        round_trip::<bench::Message>(id, &payload);
        round_trip::<usv::Message>(id, &payload);
    }

    #[test]
    fn frames_round_trip(pick in any::<prop::sample::Index>(), payload in prop::collection::vec(any::<u8>(), 0..=255), seq in any::<u8>()) {
        let ids = all_ids();
        let id = ids[pick.index(ids.len())];
        let Ok(msg) = bench::Message::decode(id, &payload) else { return Ok(()) };
        let mut out = [0u8; v2::MAX_FRAME_LEN];
        let n = v2::encode_dialect(Header::new(seq, 1, 2), &msg, &mut out).unwrap();
        let frame = v2::Frame::new_checked(&out[..n]).unwrap();
        prop_assert!(frame.check_crc(msg.meta().crc_extra));
        let back: bench::Message = frame.decode().unwrap();
        let (mut a, mut b): (PayloadBuf, PayloadBuf) = ([0; 255], [0; 255]);
        prop_assert_eq!(msg.encode(&mut a), back.encode(&mut b));
        prop_assert_eq!(a, b);
    }
}
