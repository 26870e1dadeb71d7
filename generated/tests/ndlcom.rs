//! Generated messages riding in NDLCom payloads: one call sends, one call decodes into the
//! dialect's message enum.

use ferrolink_generated::mavlink::minimal::{self, Attitude, Heartbeat, Ping};
use ferrolink_runtime::ndlcom::counters::TxCounters;
use ferrolink_runtime::ndlcom::parser::Parser;
use ferrolink_runtime::ndlcom::payload::{self, PayloadError};
use ferrolink_runtime::ndlcom::{storage_len, MAX_FRAME_LEN};
use proptest::prelude::*;

#[test]
fn ping_over_ndlcom_byte_exact() {
    let mut counters = TxCounters::<256>::new();
    let ping = Ping {
        time_usec: 0x0102_0304_0506_0708,
        seq: 9,
        target_system: 0,
        target_component: 0,
    };
    let mut wire = [0u8; MAX_FRAME_LEN];
    let n = payload::send(&mut counters, 1, 3, &ping, &mut wire).unwrap();
    // Header 03 01 00 0f, then the id byte 04, then PING's wire layout (time_usec, seq,
    // target_system, target_component), then the FCS, between flags.
    assert_eq!(
        hex::encode(&wire[..n]),
        format!(
            "7e0301000f04{}{}0000{}7e",
            "0807060504030201",
            "09000000",
            fcs_hex(&[3, 1, 0, 15, 4, 8, 7, 6, 5, 4, 3, 2, 1, 9, 0, 0, 0, 0, 0])
        )
    );
    let mut parser = Parser::new([0u8; storage_len(255)]);
    let mut got = Vec::new();
    parser.feed_all(&wire[..n], |f| {
        got.push(payload::decode::<minimal::Message>(f.payload()))
    });
    assert_eq!(got, [Ok(minimal::Message::Ping(ping))]);
    // The next frame to 3 takes the next counter.
    let n = payload::send(&mut counters, 1, 3, &ping, &mut wire).unwrap();
    assert_eq!(wire[3], 1);
    assert!(n > 0);
}

fn fcs_hex(bytes: &[u8]) -> String {
    hex::encode(ferrolink_runtime::crc::mcrf4xx(bytes).to_le_bytes())
}

#[test]
fn short_payloads_decode_zero_filled_and_unknown_ids_are_errors() {
    let att = payload::decode::<minimal::Message>(&[Attitude::ID as u8, 0x10, 0x27]).unwrap();
    assert_eq!(
        att,
        minimal::Message::Attitude(Attitude {
            time_boot_ms: 10_000,
            ..Default::default()
        })
    );
    assert_eq!(
        payload::decode::<minimal::Message>(&[200]),
        Err(PayloadError::UnknownId(200))
    );
    assert_eq!(
        payload::decode::<minimal::Message>(&[]),
        Err(PayloadError::Empty)
    );
    assert_eq!(
        payload::decode_message::<Heartbeat>(&[Ping::ID as u8]),
        Err(PayloadError::UnknownId(4))
    );
}

#[test]
fn a_full_buffer_takes_no_counter() {
    let mut counters = TxCounters::<256>::new();
    let mut small = [0u8; 10];
    let err = payload::send(&mut counters, 1, 2, &Heartbeat::default(), &mut small);
    assert!(matches!(err, Err(PayloadError::Encode(_))));
    assert_eq!(counters.peek(2), 0);
}

proptest! {
    #[test]
    fn attitude_round_trip(t in any::<u32>(), roll in any::<f32>(), yaw in any::<f32>(),
                           receiver in any::<u8>(), sender in any::<u8>()) {
        let msg = Attitude { time_boot_ms: t, roll, yaw, ..Default::default() };
        let mut counters = TxCounters::<256>::new();
        let mut sent = Vec::new();
        payload::send_with(&mut counters, sender, receiver, &msg, |run| sent.extend_from_slice(run)).unwrap();
        let mut parser = Parser::new([0u8; storage_len(64)]);
        let mut got = None;
        parser.feed_all(&sent, |f| {
            got = Some((f.header().receiver, payload::decode_message::<Attitude>(f.payload())));
        });
        let (to, got) = got.expect("one frame");
        prop_assert_eq!(to, receiver);
        let got = got.unwrap();
        prop_assert_eq!(got.time_boot_ms, t);
        prop_assert_eq!(got.roll.to_bits(), roll.to_bits());
        prop_assert_eq!(got.yaw.to_bits(), yaw.to_bits());
    }
}

/// The NDLCom bridge answers pings with its own PING, so that the CLI needs no generated code:
/// it must be the generated one, byte for byte.
#[test]
fn bridge_ping_is_the_generated_ping() {
    use ferrolink_runtime::mavlink::{Message, PayloadBuf};
    type Ours = ferrolink_generated::mavlink::minimal::Ping;
    type Bridge = ferrolink_io::ndlcom::bridge::Ping;
    assert_eq!(
        (Ours::ID, Ours::CRC_EXTRA, Ours::MIN_LEN, Ours::MAX_LEN),
        (
            Bridge::ID,
            Bridge::CRC_EXTRA,
            Bridge::MIN_LEN,
            Bridge::MAX_LEN
        )
    );
    let ours = Ours {
        time_usec: 0x0102_0304_0506_0708,
        seq: 0x0a0b_0c0d,
        target_system: 7,
        target_component: 9,
    };
    let (mut a, mut b): (PayloadBuf, PayloadBuf) = ([0xa5; 255], [0xa5; 255]);
    let n = ours.encode(&mut a);
    let bridge = Bridge::decode(&a[..n]);
    assert_eq!(bridge.encode(&mut b), n);
    assert_eq!(a[..n], b[..n]);
    assert_eq!(
        (
            bridge.time_usec,
            bridge.seq,
            bridge.target_system,
            bridge.target_component
        ),
        (
            ours.time_usec,
            ours.seq,
            ours.target_system,
            ours.target_component
        )
    );
}
