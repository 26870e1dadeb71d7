//! The telemetry stream both parsers read: an autopilot's default message mix, encoded by both
//! sides and checked equal.

use super::*;

/// A telemetry link's mix: messages and how many of each per second, as an autopilot streams
/// them to a ground station at its default rates.
pub const MIX: &[(&str, u32)] = &[
    ("HEARTBEAT", 1),
    ("SYS_STATUS", 2),
    ("SYSTEM_TIME", 1),
    ("GPS_RAW_INT", 2),
    ("RAW_IMU", 2),
    ("SCALED_PRESSURE", 2),
    ("ATTITUDE", 10),
    ("GLOBAL_POSITION_INT", 3),
    ("SERVO_OUTPUT_RAW", 2),
    ("RC_CHANNELS", 2),
    ("MISSION_CURRENT", 2),
    ("NAV_CONTROLLER_OUTPUT", 2),
    ("VFR_HUD", 4),
    ("BATTERY_STATUS", 1),
    ("POWER_STATUS", 2),
    ("TIMESYNC", 1),
];

/// A payload of message `id` as both sides encode it: random base fields, with the agreed
/// values in enum and `mavlink_version` fields, and zero extensions.
pub fn sample_payload(id: u32, seed: &mut u64) -> Vec<u8> {
    let meta = ours::Message::meta_of(id).expect("a common message");
    // Extension fields stay zero: the two copies of common.xml differ in some messages'
    // extensions, never in their base fields (see tests/diff_common.rs).
    let mut payload: Vec<u8> = (0..meta.min_len)
        .map(|_| {
            // xorshift64*
            *seed ^= *seed >> 12;
            *seed ^= *seed << 25;
            *seed ^= *seed >> 27;
            (seed.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 56) as u8
        })
        .collect();
    payload.resize(usize::from(meta.max_len), 0);
    for &(_, offset, size, count, value) in facts::FIXED_FIELDS
        .iter()
        .filter(|f| f.0 == id && f.1 < usize::from(meta.min_len))
    {
        for k in 0..usize::from(count) {
            let at = offset + k * size;
            payload[at..at + size].copy_from_slice(&value.to_le_bytes()[..size]);
        }
    }
    payload
}

/// Message `id` with `payload`, framed by each side: the frames must be identical.
pub fn frame_both(id: u32, payload: &[u8], seq: u8) -> Vec<u8> {
    let msg = <ours::Message as Dialect>::decode(id, payload).expect("ours decodes");
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_dialect(ours_header(seq), &msg, &mut out).expect("encode");
    let theirs_msg = theirs::MavMessage::parse(MavlinkVersion::V2, id, payload)
        .unwrap_or_else(|e| panic!("theirs parses message {id}: {e:?}"));
    assert_eq!(
        theirs_frame(seq, &theirs_msg),
        &out[..n],
        "message {id}: frames differ"
    );
    out[..n].to_vec()
}

/// About `STREAM_BYTES` of concatenated frames of the telemetry mix, in the mix's proportions,
/// each with fresh field values. Encoded by both sides, checked equal.
pub fn build_stream() -> (Vec<u8>, usize) {
    let mut order = Vec::new();
    for &(name, per_second) in MIX {
        let id = <theirs::MavMessage as mavlink::Message>::message_id_from_name(name)
            .filter(|&id| ours::Message::meta_of(id).is_some())
            .unwrap_or_else(|| panic!("{name} is not in common.xml"));
        order.extend(std::iter::repeat_n(id, per_second as usize));
    }
    // Interleave: every second's messages spread over the second, not in blocks.
    order.sort_by_key(|&id| (id.wrapping_mul(2_654_435_761)) % 97);
    let mut stream = Vec::with_capacity(STREAM_BYTES + 1024);
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut n = 0usize;
    while stream.len() < STREAM_BYTES {
        let id = order[n % order.len()];
        let payload = sample_payload(id, &mut seed);
        stream.extend_from_slice(&frame_both(id, &payload, n as u8));
        n += 1;
    }
    (stream, n)
}
