//! `ferrolink modrob encode | decode`, run as users run them.

use std::io::Write;
use std::process::{Command, Stdio};

fn ferrolink(args: &[&str], stdin: &str) -> (String, String, bool) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ferrolink"))
        .args(args)
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

/// One message of every kind, in the JSON form `decode` prints.
const MESSAGES: &str = r#"{"type":"command","command":"set_value","module":258,"variable":3,"value":1.5}
{"type":"command","command":"set_frequency","module":258,"variable":255,"value":100.0}
{"type":"command","command":"set_subscription","module":48879,"variable":0,"source_module":4660,"source_variable":86}
{"type":"publication","module":65535,"variable":128,"value":-2.0}
{"type":"piecewise","module":1,"chunk":2,"chunks":3,"data":"68656c6c6f0000"}
"#;

/// The same messages on CAN-1, written from the specification: identifier = type << 24 |
/// MI << 8 | VI; floats little-endian; command type in byte 4; chunk count in byte 7.
const CAN: &str = "00010203 0000c03f0000
000102ff 0000c8420100
00beef00 003412560200
01ffff80 000000c00000
02000102 68656c6c6f000003
";

/// And on UART.B-1: 0x5A, (identifier << 4 | length) little-endian, data, CRC-8/SMBUS.
const UART: &str = "5a362010000000c03f000014
5af62f10000000c842010024
5a06f0ee0b003412560200a7
5a06f8ff1f000000c0000088
5a2810002068656c6c6f000003ec
";

const SUMMARY_CLEAN: &str =
    r#"{"frames":5,"crc_failures":0,"bad_length":0,"decode_errors":0,"dropped":0}"#;

#[test]
fn can_vectors_both_ways() {
    let (out, err, ok) = ferrolink(&["modrob", "encode", "--transport", "can"], MESSAGES);
    assert!(ok, "{err}");
    assert_eq!(out, CAN);
    let (out, err, ok) = ferrolink(&["modrob", "decode", "--transport", "can"], CAN);
    assert!(ok, "{err}");
    assert_eq!(out, MESSAGES);
}

#[test]
fn uart_and_spi_vectors_both_ways() {
    for transport in ["uart", "spi"] {
        let (out, err, ok) = ferrolink(&["modrob", "encode", "--transport", transport], MESSAGES);
        assert!(ok, "{err}");
        assert_eq!(out, UART);
        let (out, err, ok) = ferrolink(&["modrob", "decode", "--transport", transport], UART);
        assert!(ok, "{err}");
        assert_eq!(out, format!("{MESSAGES}{SUMMARY_CLEAN}\n"));
    }
}

#[test]
fn uart_stream_with_garbage() {
    // Noise, a bad length nibble, a false candidate with a real frame inside, a frame split
    // across lines, a reserved type with a valid CRC, a broken CRC, an unfinished frame.
    let lines: Vec<&str> = UART.lines().collect();
    let stream = format!(
        "00 ff 13\n5a07000000\n{}\n5a36201000{}\n{}\n{}\n5a06000030000000000000e1\n\
         5a362010000000c03f000015\n{}\n{}\n5a3620\n",
        lines[0],
        lines[4],
        &lines[1][..7],
        &lines[1][7..],
        lines[2],
        lines[3],
    );
    let (out, err, ok) = ferrolink(&["modrob", "decode", "--transport", "uart"], &stream);
    assert!(ok, "{err}");
    let expected: Vec<&str> = MESSAGES.lines().collect();
    let (messages, summary) = out.trim_end().rsplit_once('\n').expect("lines");
    assert_eq!(
        messages,
        [
            expected[0],
            expected[4],
            expected[1],
            expected[2],
            expected[3]
        ]
        .join("\n")
    );
    assert_eq!(
        summary,
        r#"{"frames":5,"crc_failures":2,"bad_length":1,"decode_errors":1,"dropped":40}"#
    );
}

#[test]
fn ethernet_round_trip_and_vector() {
    let uuid = "67e55044-10b1-426f-9247-bb680e5fe0c8";
    let ulid = "01ARZ3NDEKTSV4RRFFQ69G5FAV";
    let (out, err, ok) = ferrolink(
        &[
            "modrob",
            "encode",
            "--transport",
            "ethernet",
            "--module-uuid",
            uuid,
            "--message-ulid",
            ulid,
        ],
        MESSAGES,
    );
    assert!(ok, "{err}");
    // The ULID's 128 bits big-endian (48-bit time, 80 random bits), the UUID's 16 bytes, the
    // count 5 little-endian, then the UART.B-1 frames.
    let expected = format!(
        "01563e3ab5d3d6764c61efb99302bd5b67e5504410b1426f9247bb680e5fe0c80500{}\n",
        UART.replace('\n', "")
    );
    assert_eq!(out, expected);
    let (decoded, err, ok) = ferrolink(&["modrob", "decode", "--transport", "ethernet"], &out);
    assert!(ok, "{err}");
    assert_eq!(decoded, MESSAGES);

    // Without --message-ulid a new one is generated; the messages are the same.
    let (out, err, ok) = ferrolink(
        &[
            "modrob",
            "encode",
            "--transport",
            "ethernet",
            "--module-uuid",
            uuid,
        ],
        MESSAGES,
    );
    assert!(ok, "{err}");
    assert_eq!(out.len(), expected.len());
    assert_eq!(out[32..], expected[32..]);
}

#[test]
fn ethernet_splits_at_the_datagram_size() {
    let input: String = (0..130)
        .map(|i| {
            format!("{{\"type\":\"publication\",\"module\":1,\"variable\":{i},\"value\":{i}}}\n")
        })
        .collect();
    let (out, err, ok) = ferrolink(
        &[
            "modrob",
            "encode",
            "--transport",
            "ethernet",
            "--module-uuid",
            "00000000-0000-0000-0000-000000000001",
            "--message-ulid",
            "00000000000000000000000001",
        ],
        &input,
    );
    assert!(ok, "{err}");
    let packets: Vec<&str> = out.lines().collect();
    assert_eq!(packets.len(), 2);
    // 119 publications fill 1462 of 1472 bytes; the next 11 go into a second packet whose
    // message id is one more.
    assert_eq!(packets[0].len(), 2 * 1462);
    assert_eq!(&packets[0][64..68], "7700");
    assert_eq!(&packets[1][..32], "00000000000000000000000000000002");
    assert_eq!(&packets[1][64..68], "0b00");
    let (decoded, err, ok) = ferrolink(&["modrob", "decode", "--transport", "ethernet"], &out);
    assert!(ok, "{err}");
    let values: Vec<String> = (0..130)
        .map(|i| {
            format!("{{\"type\":\"publication\",\"module\":1,\"variable\":{i},\"value\":{i}.0}}\n")
        })
        .collect();
    assert_eq!(decoded, values.concat());
}

#[test]
fn bad_lines_are_reported_with_line_numbers_and_the_rest_is_kept() {
    let input = r#"{"type":"publication","module":1,"variable":2,"value":0.5}
{"type":"command","command":"set_value","module":1,"variable":2}
{"type":"command","command":"set_subscription","module":1,"variable":2,"source_module":3,"source_variable":4}

{"type":"piecewise","module":1,"chunk":0,"chunks":1,"data":"0102030405060708"}
{"type":"publication","module":65536,"variable":2,"value":0.5}
{"type":"publication","module":1,"variable":2,"value":"fast"}
"#;
    let (out, err, ok) = ferrolink(&["modrob", "encode", "--transport", "can"], input);
    assert!(!ok);
    assert_eq!(out, "01000102 0000003f0000\n00000102 000300040200\n");
    let err: Vec<&str> = err.lines().collect();
    assert_eq!(err.len(), 4, "{err:?}");
    assert_eq!(
        err[0],
        "stdin:2: set_value and set_frequency take `value` and no `source_module` or `source_variable`"
    );
    assert_eq!(err[1], "stdin:5: data of 8 bytes exceeds a chunk's 7");
    assert!(err[2].starts_with("stdin:6: "), "{}", err[2]);
    assert_eq!(
        err[3],
        "stdin:7: value `fast` is neither a number nor NaN, inf or -inf"
    );

    let can = "03000000 000000000000\n00000000 000000000300\n01000000 0000000000000000\n\
               zz 00\n01000001 000000000000\n0400000000 000000000000\n";
    let (out, err, ok) = ferrolink(&["modrob", "decode", "--transport", "can"], can);
    assert!(!ok);
    assert_eq!(
        out,
        "{\"type\":\"publication\",\"module\":0,\"variable\":1,\"value\":0.0}\n"
    );
    let err: Vec<&str> = err.lines().collect();
    assert_eq!(err[0], "stdin:1: message type 3 is reserved");
    assert_eq!(err[1], "stdin:2: command type 3 is reserved");
    assert_eq!(err[2], "stdin:3: 8 data bytes where the message type has 6");
    assert!(
        err[3].starts_with("stdin:4: identifier `zz` is not hex"),
        "{}",
        err[3]
    );
    assert!(err[4].starts_with("stdin:6: "), "{}", err[4]);

    let (out, err, ok) = ferrolink(&["modrob", "decode", "--transport", "uart"], "5a0x");
    assert!(!ok);
    // Decoding stops at the line with the bad digit, as `ndlcom decode` does.
    assert_eq!(
        out,
        r#"{"frames":0,"crc_failures":0,"bad_length":0,"decode_errors":0,"dropped":0}"#.to_owned()
            + "\n"
    );
    assert_eq!(err, "stdin:1:4: `x` is not a hex digit\n");

    let packet = "0000000000000000000000000000000000000000000000000000000000000000 0100\
                  5a362010000000c03f000015\n00\n";
    let (out, err, ok) = ferrolink(&["modrob", "decode", "--transport", "ethernet"], packet);
    assert!(!ok);
    assert_eq!(out, "");
    assert_eq!(
        err,
        "stdin:1: message 0: CRC mismatch: received 0x15, computed 0x14\n\
         stdin:2: 1 bytes, shorter than the 34-byte header\n"
    );
}

#[test]
fn non_finite_values_round_trip() {
    let input = r#"{"type":"publication","module":1,"variable":2,"value":"NaN"}
{"type":"publication","module":1,"variable":2,"value":"inf"}
{"type":"command","command":"set_frequency","module":1,"variable":2,"value":"-inf"}
"#;
    let (out, err, ok) = ferrolink(&["modrob", "encode", "--transport", "can"], input);
    assert!(ok, "{err}");
    assert_eq!(
        out,
        "01000102 0000c07f0000\n01000102 0000807f0000\n00000102 000080ff0100\n"
    );
    let (back, err, ok) = ferrolink(&["modrob", "decode", "--transport", "can"], &out);
    assert!(ok, "{err}");
    assert_eq!(back, input);
}
