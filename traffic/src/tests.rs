//! Unit tests of decoding, JSON and CSV on our minimal dialect.

use super::*;
use ferrolink_dictionary::ir::{Ir, Message};

use std::path::PathBuf;
use std::{fs, io};

fn minimal() -> Ir {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("definitions/mavlink/minimal.xml");
    ferrolink_dictionary::load(&[path])
        .expect("minimal.xml loads")
        .ir
}

fn message<'a>(ir: &'a Ir, name: &str) -> &'a Message {
    ir.modules
        .iter()
        .flat_map(|m| &m.messages)
        .find(|m| m.name.wire == name)
        .expect("message exists")
}

/// `(field, offset)` in XML order, and the payload length.
fn layout(message: &Message) -> (Vec<(&str, usize)>, usize) {
    let fields = message
        .fields
        .iter()
        .map(|f| (f.name.wire.as_str(), f.offset))
        .collect();
    (fields, message.max_len)
}

fn attitude_payload() -> Vec<u8> {
    let mut p = Vec::new();
    p.extend_from_slice(&123_456u32.to_le_bytes());
    for v in [0.1f32, -0.25, 3.0, 1e-3, -0.0, 1.5e7] {
        p.extend_from_slice(&v.to_le_bytes());
    }
    p
}

fn heartbeat_payload() -> Vec<u8> {
    let mut p = 0xDEAD_BEEFu32.to_le_bytes().to_vec();
    // type, autopilot, base_mode, system_status, mavlink_version
    p.extend_from_slice(&[11, 12, 0x81, 4, 3]);
    p
}

fn statustext_payload(text: &[u8]) -> Vec<u8> {
    let mut p = vec![4u8];
    let mut t = [0u8; 50];
    t[..text.len()].copy_from_slice(text);
    p.extend_from_slice(&t);
    p.extend_from_slice(&0x0102u16.to_le_bytes());
    p.push(7);
    p
}

fn rendered(decoded: &DecodedMessage<'_>) -> Vec<String> {
    decoded
        .values
        .iter()
        .map(|(c, v)| format!("{c}={v}"))
        .collect()
}

#[test]
fn layouts_are_the_ones_the_payloads_are_built_for() {
    let ir = minimal();
    assert_eq!(
        layout(message(&ir, "ATTITUDE")),
        (
            vec![
                ("time_boot_ms", 0),
                ("roll", 4),
                ("pitch", 8),
                ("yaw", 12),
                ("rollspeed", 16),
                ("pitchspeed", 20),
                ("yawspeed", 24),
            ],
            28
        )
    );
    assert_eq!(
        layout(message(&ir, "HEARTBEAT")),
        (
            vec![
                ("type", 4),
                ("autopilot", 5),
                ("base_mode", 6),
                ("custom_mode", 0),
                ("system_status", 7),
                ("mavlink_version", 8),
            ],
            9
        )
    );
    assert_eq!(
        layout(message(&ir, "STATUSTEXT")),
        (
            vec![("severity", 0), ("text", 1), ("id", 51), ("chunk_seq", 53)],
            54
        )
    );
    assert_eq!(
        layout(message(&ir, "COMMAND_ACK")),
        (
            vec![
                ("command", 0),
                ("result", 2),
                ("progress", 3),
                ("result_param2", 4),
                ("target_system", 8),
                ("target_component", 9),
            ],
            10
        )
    );
}

#[test]
fn decodes_attitude_with_shortest_f32() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    let decoded = decoder.decode(30, &attitude_payload()).expect("known id");
    assert_eq!(decoded.message.name.wire, "ATTITUDE");
    assert_eq!(
        decoded.values,
        vec![
            ("time_boot_ms".to_owned(), Value::Unsigned(123_456)),
            ("roll".to_owned(), Value::Float(0.1)),
            ("pitch".to_owned(), Value::Float(-0.25)),
            ("yaw".to_owned(), Value::Float(3.0)),
            ("rollspeed".to_owned(), Value::Float(0.001)),
            ("pitchspeed".to_owned(), Value::Float(-0.0)),
            ("yawspeed".to_owned(), Value::Float(15_000_000.0)),
        ]
    );
    assert_eq!(
        rendered(&decoded),
        [
            "time_boot_ms=123456",
            "roll=0.1",
            "pitch=-0.25",
            "yaw=3",
            "rollspeed=0.001",
            "pitchspeed=-0",
            "yawspeed=15000000",
        ]
    );
    assert_eq!(decoded.get("roll"), Some(&Value::Float(0.1)));
    assert_eq!(
        columns(decoded.message),
        [
            "time_boot_ms",
            "roll",
            "pitch",
            "yaw",
            "rollspeed",
            "pitchspeed",
            "yawspeed"
        ]
    );
}

#[test]
fn f32_widening_round_trips() {
    for v in [
        0.1f32,
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        f32::MAX,
        -f32::EPSILON,
        16_777_217.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ] {
        let Value::Float(w) = Value::from_f32(v) else {
            unreachable!()
        };
        assert_eq!((w as f32).to_bits(), v.to_bits(), "{v}");
        assert_eq!(w.to_string(), v.to_string(), "{v}");
    }
    let Value::Float(nan) = Value::from_f32(f32::from_bits(0x7fc0_0123)) else {
        unreachable!()
    };
    assert_eq!((nan as f32).to_bits(), 0x7fc0_0123);
    assert_eq!(Value::from_f32(f32::NAN).to_string(), "NaN");
}

#[test]
fn decodes_heartbeat_and_enum_labels() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    let decoded = decoder.decode(0, &heartbeat_payload()).expect("known id");
    assert_eq!(
        rendered(&decoded),
        [
            "type=11",
            "autopilot=12",
            "base_mode=129",
            "custom_mode=3735928559",
            "system_status=4",
            "mavlink_version=3",
        ]
    );
    let labels: Vec<_> = (0..decoded.values.len())
        .map(|i| decoder.enum_label(decoded.field(i).expect("column"), &decoded.values[i].1))
        .collect();
    assert_eq!(
        labels,
        [
            Some("MAV_TYPE_SURFACE_BOAT".to_owned()),
            Some("MAV_AUTOPILOT_PX4".to_owned()),
            Some("MAV_MODE_FLAG_CUSTOM_MODE_ENABLED|MAV_MODE_FLAG_SAFETY_ARMED".to_owned()),
            None,
            Some("MAV_STATE_ACTIVE".to_owned()),
            None,
        ]
    );
    let base_mode = decoded.field(2).expect("column");
    assert_eq!(
        decoder
            .enum_label(base_mode, &Value::Unsigned(0x180))
            .as_deref(),
        Some("MAV_MODE_FLAG_SAFETY_ARMED|0x100")
    );
    assert_eq!(decoder.enum_label(base_mode, &Value::Unsigned(0)), None);
    let status = decoded.field(4).expect("column");
    assert_eq!(decoder.enum_label(status, &Value::Unsigned(99)), None);
}

#[test]
fn decodes_statustext_and_extensions() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    let decoded = decoder
        .decode(253, &statustext_payload(b"Low battery, \"RTL\"\0junk"))
        .expect("known id");
    assert_eq!(
        decoded.values,
        vec![
            ("severity".to_owned(), Value::Unsigned(4)),
            (
                "text".to_owned(),
                Value::Text("Low battery, \"RTL\"".to_owned())
            ),
            ("id".to_owned(), Value::Unsigned(0x0102)),
            ("chunk_seq".to_owned(), Value::Unsigned(7)),
        ]
    );

    // All 50 bytes used: no terminator; invalid UTF-8 is replaced.
    let mut full = [b'x'; 50];
    full[0] = 0xff;
    let decoded = decoder
        .decode(253, &statustext_payload(&full))
        .expect("known id");
    let Value::Text(text) = &decoded.values[1].1 else {
        panic!("text column")
    };
    assert_eq!(text.chars().count(), 50);
    assert!(text.starts_with("\u{fffd}xx"));

    // Signed extension field.
    let payload = [76, 1, 5, 42, 0xfe, 0xff, 0xff, 0xff, 1, 2];
    let decoded = decoder.decode(77, &payload).expect("known id");
    assert_eq!(
        rendered(&decoded),
        [
            "command=332",
            "result=5",
            "progress=42",
            "result_param2=-2",
            "target_system=1",
            "target_component=2",
        ]
    );
}

#[test]
fn short_payloads_are_zero_filled_long_ones_cut() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    // ATTITUDE cut after roll.
    let mut payload = 1u32.to_le_bytes().to_vec();
    payload.extend_from_slice(&0.5f32.to_le_bytes());
    let decoded = decoder.decode(30, &payload).expect("known id");
    assert_eq!(
        rendered(&decoded),
        [
            "time_boot_ms=1",
            "roll=0.5",
            "pitch=0",
            "yaw=0",
            "rollspeed=0",
            "pitchspeed=0",
            "yawspeed=0",
        ]
    );
    // COMMAND_ACK cut inside result_param2: the missing high bytes are zero, not sign bits.
    let decoded = decoder.decode(77, &[76, 1, 5, 42, 0xfe]).expect("known id");
    assert_eq!(decoded.get("result_param2"), Some(&Value::Signed(254)));
    assert_eq!(decoded.get("target_system"), Some(&Value::Unsigned(0)));
    // Nothing but the id: every field zero, extensions and text too.
    let decoded = decoder.decode(253, &[]).expect("known id");
    assert_eq!(
        rendered(&decoded),
        ["severity=0", "text=", "id=0", "chunk_seq=0"]
    );
    // Trailing bytes beyond max_len are ignored.
    let mut long = heartbeat_payload();
    long.extend_from_slice(&[0xaa; 8]);
    let decoded = decoder.decode(0, &long).expect("known id");
    assert_eq!(
        decoded.values.last().map(|(_, v)| v),
        Some(&Value::Unsigned(3))
    );
}

#[test]
fn unknown_ids_and_empty_frames() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    assert!(decoder.decode(31, &attitude_payload()).is_none());
    assert!(decoder.decode(1 << 20, &[]).is_none());
    assert!(decoder.decode_frame(&[]).is_none());
    assert!(decoder.decode_frame(&[99, 1, 2]).is_none());
    let decoded = decoder.decode_frame(&[0, 1]).expect("HEARTBEAT");
    assert_eq!(decoded.get("custom_mode"), Some(&Value::Unsigned(1)));
}

#[test]
fn arrays_expand_to_one_column_per_element() {
    let ir = minimal();
    let ftp = message(&ir, "FILE_TRANSFER_PROTOCOL");
    let cols = columns(ftp);
    assert_eq!(cols.len(), 3 + 251);
    assert_eq!(
        &cols[..5],
        [
            "target_network",
            "target_system",
            "target_component",
            "payload[0]",
            "payload[1]"
        ]
    );
    assert_eq!(cols.last().map(String::as_str), Some("payload[250]"));

    let decoder = PayloadDecoder::new(ir.clone());
    let decoded = decoder.decode(110, &[1, 2, 3, 10, 11]).expect("known id");
    let names: Vec<_> = decoded.values.iter().map(|(n, _)| n.clone()).collect();
    assert_eq!(names, cols);
    assert_eq!(decoded.get("payload[1]"), Some(&Value::Unsigned(11)));
    assert_eq!(decoded.get("payload[2]"), Some(&Value::Unsigned(0)));
    assert_eq!(
        decoded.field(200).map(|f| f.name.wire.as_str()),
        Some("payload")
    );
    assert!(decoded.field(cols.len()).is_none());
}

#[test]
fn later_module_wins_on_duplicate_ids() {
    let mut ir = minimal();
    let mut dialect = ir.modules[0].clone();
    dialect.messages.retain(|m| m.id == 30);
    dialect.messages[0].name.wire = "ATTITUDE_OVERRIDE".to_owned();
    ir.modules.push(dialect);
    let decoder = PayloadDecoder::new(ir.clone());
    let decoded = decoder.decode(30, &attitude_payload()).expect("known id");
    assert_eq!(decoded.message.name.wire, "ATTITUDE_OVERRIDE");
    assert_eq!(
        decoder.message(0).map(|m| m.name.wire.as_str()),
        Some("HEARTBEAT")
    );
}

#[test]
fn csv_export() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path().join("export");
    let mut export = CsvExport::new(&dir).expect("export dir");

    let frame = |id: u8, payload: Vec<u8>| [vec![id], payload].concat();
    let meta = |t_us, counter| RowMeta {
        t_us,
        sender: 1,
        receiver: 2,
        counter,
    };
    let log: Vec<(RowMeta, Vec<u8>)> = vec![
        (meta(1_000, 0), frame(0, heartbeat_payload())),
        (meta(1_500, 1), frame(30, attitude_payload())),
        (
            meta(2_000, 2),
            frame(253, statustext_payload(b"Low battery, \"RTL\"")),
        ),
        (meta(2_500, 3), frame(200, vec![0xde, 0xad])),
        (meta(3_000, 4), vec![]),
        (meta(3_500, 5), frame(30, vec![2, 0, 0, 0])),
        (
            meta(4_000, 6),
            frame(253, statustext_payload(b"line one\nline two")),
        ),
    ];
    let mut decoded = 0;
    for (meta, payload) in &log {
        decoded += u32::from(export.record(&decoder, meta, payload).expect("write"));
    }
    assert_eq!(decoded, 5);

    let report = export.finish().expect("finish");
    let report: Vec<_> = report
        .into_iter()
        .map(|(path, rows)| {
            let name = path
                .strip_prefix(&dir)
                .expect("in dir")
                .display()
                .to_string();
            (name, rows)
        })
        .collect();
    assert_eq!(
        report,
        [
            ("ATTITUDE.csv".to_owned(), 2),
            ("HEARTBEAT.csv".to_owned(), 1),
            ("STATUSTEXT.csv".to_owned(), 2),
            ("unknown.csv".to_owned(), 2),
        ]
    );

    let read = |name: &str| fs::read_to_string(dir.join(name)).expect("written");
    insta::assert_snapshot!(read("ATTITUDE.csv"), @r"
    t_us,sender,receiver,counter,time_boot_ms,roll,pitch,yaw,rollspeed,pitchspeed,yawspeed
    1500,1,2,1,123456,0.1,-0.25,3,0.001,-0,15000000
    3500,1,2,5,2,0,0,0,0,0,0
    ");
    insta::assert_snapshot!(read("HEARTBEAT.csv"), @r"
    t_us,sender,receiver,counter,type,autopilot,base_mode,custom_mode,system_status,mavlink_version
    1000,1,2,0,11,12,129,3735928559,4,3
    ");
    insta::assert_snapshot!(read("STATUSTEXT.csv"), @r#"
    t_us,sender,receiver,counter,severity,text,id,chunk_seq
    2000,1,2,2,4,"Low battery, ""RTL""",258,7
    4000,1,2,6,4,"line one
    line two",258,7
    "#);
    insta::assert_snapshot!(read("unknown.csv"), @r"
    t_us,sender,receiver,counter,id,payload_hex
    2500,1,2,3,200,dead
    3000,1,2,4,,
    ");
}

#[test]
fn csv_export_rejects_a_second_layout_under_one_name() {
    let ir = minimal();
    let mut changed = ir.clone();
    let mut dialect = changed.modules[0].clone();
    dialect.messages.retain(|m| m.id == 0);
    dialect.messages[0].fields.pop();
    changed.modules.push(dialect);

    let tmp = tempfile::tempdir().expect("tempdir");
    let mut export = CsvExport::new(tmp.path()).expect("export dir");
    let meta = RowMeta::default();
    let (full, short) = (
        PayloadDecoder::new(ir.clone()),
        PayloadDecoder::new(changed),
    );
    let full = full.decode(0, &heartbeat_payload());
    export
        .write(&meta, &full.expect("known id"))
        .expect("first layout");
    let short = short.decode(0, &heartbeat_payload()).expect("known id");
    assert_eq!(short.values.len(), 5);
    let err = export.write(&meta, &short).expect_err("second layout");
    assert_eq!(err.kind(), io::ErrorKind::Other);
}

#[test]
fn from_dict_inverts_to_dict() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    let statustext = statustext_payload(b"GPS: no fix");
    for (id, payload) in [
        (0, heartbeat_payload()),
        (30, attitude_payload()),
        (253, statustext),
    ] {
        let dict = decoder.to_dict(id, &payload).expect("known id");
        // Through text: floats are written so that they read back to the same value.
        let text = dict.to_string();
        let dict: serde_json::Value = serde_json::from_str(&text).expect("json");
        let (back_id, back) = decoder.from_dict(&dict, &[]).expect("reads back");
        assert_eq!(back_id, id);
        assert_eq!(back[..payload.len()], payload[..], "{dict}");
        assert!(back[payload.len()..].iter().all(|&b| b == 0));
    }
}

#[test]
fn from_dict_fills_defaults_and_names_bad_fields() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    let ping = serde_json::json!({"mavpackettype": "PING", "seq": 7});
    let (id, payload) = decoder
        .from_dict(&ping, &[("target_system", 3), ("seq", 99)])
        .expect("encodes");
    assert_eq!(id, 4);
    let dict = decoder.to_dict(id, &payload).expect("known");
    assert_eq!(dict["seq"], 7, "given fields win over defaults");
    assert_eq!(dict["target_system"], 3);
    assert_eq!(dict["time_usec"], 0);
    let bad = |value: serde_json::Value| decoder.from_dict(&value, &[]).expect_err("bad");
    assert_eq!(
        bad(serde_json::json!({"mavpackettype": "PING", "target_system": 300})),
        "PING.target_system: 300 does not fit 8 bits"
    );
    assert_eq!(
        bad(serde_json::json!({"mavpackettype": "PING", "speed": 1})),
        "PING has no field speed"
    );
    assert_eq!(
        bad(serde_json::json!({"mavpackettype": "NOPE"})),
        "no message NOPE in the dictionaries"
    );
    assert_eq!(
        bad(serde_json::json!({"seq": 1})),
        "\"mavpackettype\" (the message name) is missing"
    );
}

#[test]
fn frame_json_members_for_known_and_unknown_ids() {
    let ir = minimal();
    let decoder = PayloadDecoder::new(ir.clone());
    let (known, is_known) = decoder.frame_json_members(1, 2, 3, 0, &heartbeat_payload());
    assert!(is_known);
    let value: serde_json::Value = serde_json::from_str(&format!("{{{known}}}")).expect("json");
    assert_eq!(value["msg"]["mavpackettype"], "HEARTBEAT");
    assert!(
        known.starts_with(r#""sysid":1,"compid":2,"seq":3,"msg":"#),
        "{known}"
    );
    let (unknown, is_known) = decoder.frame_json_members(1, 2, 3, 60_000, &[0xde, 0xad]);
    assert!(!is_known);
    assert_eq!(
        unknown,
        r#""sysid":1,"compid":2,"seq":3,"msg":null,"id":60000,"payload":"dead""#
    );
}
