//! `ferrolink ndlcom encode | decode | export`, run as users run them.

use std::io::Write;
use std::process::{Command, Stdio};

fn ferrolink(args: &[&str], stdin: &str) -> (String, String, bool) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ferrolink"))
        .args(args)
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(stdin.as_bytes())
        .expect("writes");
    let out = child.wait_with_output().expect("finishes");
    (
        String::from_utf8(out.stdout).expect("utf-8"),
        String::from_utf8(out.stderr).expect("utf-8"),
        out.status.success(),
    )
}

/// The protocol's golden frames, as JSON lines and as hex.
const GOLDEN_JSON: &str = r#"{"receiver":0,"sender":0,"counter":0,"payload":""}
{"receiver":0,"sender":0,"counter":0,"payload":"000000000000"}
{"receiver":1,"sender":0,"counter":0,"payload":""}
{"receiver":126,"sender":1,"counter":0,"payload":"7e"}
{"receiver":93,"sender":121,"counter":252,"payload":"2f62a8"}
{"receiver":129,"sender":1,"counter":1,"payload":"000102030405060708090a0b0c0d0e0f"}
"#;

const GOLDEN_HEX: &str = "7e0000000021037e
7e000000060000000000004ac47e
7e010000009a1f7e
7e7d5e0100017d5e59db7e
7e5d79fc032f62a87d5d347e
7e81010110000102030405060708090a0b0c0d0e0f9ad07e
";

#[test]
fn encode_golden_frames() {
    let (out, err, ok) = ferrolink(&["ndlcom", "encode"], GOLDEN_JSON);
    assert!(ok, "{err}");
    assert_eq!(out, GOLDEN_HEX);
}

#[test]
fn decode_golden_frames_with_garbage() {
    // Garbage, the golden frames split across lines and with a flipped bit in one, a frame cut
    // short by a flag, and an unterminated one at the end.
    let mut stream = String::from("00 ff 12\n");
    for (i, line) in GOLDEN_HEX.lines().enumerate() {
        if i == 2 {
            stream.push_str("7e01000000aa1f7e\n"); // FCS broken
            stream.push_str("7e81010110000102\n");
        }
        let (a, b) = line.split_at(line.len() / 2);
        stream.push_str(&format!("{a}\n{b}\n"));
    }
    stream.push_str("7e050607");
    let (out, err, ok) = ferrolink(&["ndlcom", "decode"], &stream);
    assert!(ok, "{err}");
    let (frames, summary) = out.trim_end().rsplit_once('\n').expect("lines");
    assert_eq!(format!("{frames}\n"), GOLDEN_JSON);
    insta::assert_snapshot!(summary, @r#"{"crc_failures":1,"dropped":3}"#);
}

#[test]
fn bad_lines_are_reported_with_line_numbers_and_the_rest_is_kept() {
    let input = "{\"receiver\":1,\"sender\":2,\"counter\":3,\"payload\":\"0g\"}\n\
                 {\"receiver\":1,\"sender\":2,\"counter\":3,\"payload\":\"00\"}\n\
                 {\"receiver\":1,\"sender\":2,\"payload\":\"\",\"extra\":1}\n";
    let (out, err, ok) = ferrolink(&["ndlcom", "encode"], input);
    assert!(!ok);
    assert_eq!(out, "7e010203010006f47e\n");
    insta::assert_snapshot!(err, @r"
    stdin:1: payload is not hex: Invalid character 'g' at position 1
    stdin:3: unknown field `extra`, expected one of `receiver`, `sender`, `counter`, `payload` at line 1 column 45
    ");
    let (out, err, ok) = ferrolink(&["ndlcom", "decode"], "7e0x");
    assert!(!ok);
    assert_eq!(out, "{\"crc_failures\":0,\"dropped\":0}\n");
    insta::assert_snapshot!(err, @"stdin:1:4: `x` is not a hex digit");
}

#[test]
fn export_a_log_to_csv() {
    let dir = tempfile::tempdir().expect("tempdir");
    // ATTITUDE (id 30): time_boot_ms = 1000, roll = 0.5, the rest zero-filled.
    let mut payload = vec![30u8];
    payload.extend_from_slice(&1000u32.to_le_bytes());
    payload.extend_from_slice(&0.5f32.to_le_bytes());
    let json = format!(
        "{{\"receiver\":1,\"sender\":2,\"counter\":0,\"payload\":\"{}\"}}\n\
         {{\"receiver\":1,\"sender\":2,\"counter\":1,\"payload\":\"ee01\"}}\n",
        hex_encode(&payload)
    );
    let (frames, err, ok) = ferrolink(&["ndlcom", "encode"], &json);
    assert!(ok, "{err}");
    let log: String = frames
        .lines()
        .enumerate()
        .map(|(i, f)| {
            format!(
                "{{\"t_us\":{},\"interface\":\"udp://127.0.0.1:34000:34001\",\"frame\":\"{f}\"}}\n",
                100 + i
            )
        })
        .collect();
    let log_path = dir.path().join("capture.jsonl");
    std::fs::write(&log_path, log).expect("writes");
    let csv = dir.path().join("csv");
    let (_, err, ok) = ferrolink(
        &[
            "ndlcom",
            "export",
            log_path.to_str().expect("utf-8"),
            "--dict",
            "definitions/mavlink/minimal.xml",
            "--csv",
            csv.to_str().expect("utf-8"),
        ],
        "",
    );
    assert!(ok, "{err}");
    let attitude = std::fs::read_to_string(csv.join("ATTITUDE.csv")).expect("ATTITUDE.csv");
    insta::assert_snapshot!(attitude, @r"
    t_us,sender,receiver,counter,time_boot_ms,roll,pitch,yaw,rollspeed,pitchspeed,yawspeed
    100,2,1,0,1000,0.5,0,0,0,0,0
    ");
    let unknown = std::fs::read_to_string(csv.join("unknown.csv")).expect("unknown.csv");
    insta::assert_snapshot!(unknown, @r"
    t_us,sender,receiver,counter,id,payload_hex
    101,2,1,1,238,01
    ");
}

fn hex_encode(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
