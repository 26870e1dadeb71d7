//! The conformance runner: checks generated bindings against vectors made by pymavlink.
//!
//! ```text
//! FERROLINK_XML=<dialect.xml> cargo run --release -p ferrolink-conformance -- <vectors.jsonl>
//! FERROLINK_XML=<dialect.xml> cargo run --release -p ferrolink-conformance -- --stream <capture.bin>
//! ```
//!
//! For every vector, in both directions and byte-exact:
//! - `fields` (pymavlink's `to_dict()`) deserializes to a message that serializes back to exactly
//!   `fields`;
//! - the `v2` (and `v1`) frame decodes, through the frame view and through the stream parser, to
//!   that message;
//! - that message encodes, with the vector's seq/sysid/compid, to exactly `v2` (and `v1`).
//!
//! Prints `N passed, M failed` and exits non-zero on any failure.

#[allow(dead_code)]
mod dialects {
    include!(concat!(env!("OUT_DIR"), "/ferrolink.rs"));
}
include!(concat!(env!("OUT_DIR"), "/root.rs"));

use std::process::ExitCode;

use ferrolink_runtime::mavlink::parser::Parser;
use ferrolink_runtime::mavlink::{v1, v2, Dialect, Header, PayloadBuf};
use root::Message;

#[derive(serde::Deserialize)]
struct Vector {
    name: String,
    id: u32,
    crc_extra: u8,
    fields: serde_json::Value,
    seq: u8,
    sysid: u8,
    compid: u8,
    v2: String,
    v1: Option<String>,
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.as_slice() {
        [flag, file] if flag == "--stream" => stream(file),
        [file] => vectors(file),
        _ => Err("usage: ferrolink-conformance <vectors.jsonl> | --stream <capture.bin>".into()),
    };
    match result {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

type Error = Box<dyn std::error::Error>;

fn vectors(path: &str) -> Result<bool, Error> {
    let text = std::fs::read_to_string(path)?;
    let (mut passed, mut failed) = (0usize, 0usize);
    for (n, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        match check_vector(line) {
            Ok(()) => passed += 1,
            Err(e) => {
                failed += 1;
                if failed <= 20 {
                    eprintln!("{path}:{}: {e}", n + 1);
                }
            }
        }
    }
    eprintln!("dialect: {}", DIALECT_FILE);
    println!("{passed} passed, {failed} failed");
    Ok(failed == 0 && passed > 0)
}

fn check_vector(line: &str) -> Result<(), Error> {
    let v: Vector = serde_json::from_str(line)?;
    let meta = Message::meta_of(v.id)
        .ok_or_else(|| format!("{}: id {} not in the dialect", v.name, v.id))?;
    let expected: Message = serde_json::from_value(v.fields.clone())
        .map_err(|e| format!("{}: fields do not deserialize: {e}", v.name))?;
    if expected.name() != v.name || meta.crc_extra != v.crc_extra {
        return Err(format!(
            "{}: metadata differs: ours {} crc_extra {}, vector crc_extra {}",
            v.name,
            expected.name(),
            meta.crc_extra,
            v.crc_extra
        )
        .into());
    }
    // And back: the message serializes to exactly pymavlink's `to_dict()`.
    let shown = serde_json::to_value(&expected)?;
    if shown != v.fields {
        return Err(format!(
            "{}: serializes differently:\n  ours     {shown}\n  expected {}",
            v.name, v.fields
        )
        .into());
    }
    let header = Header::new(v.seq, v.sysid, v.compid);

    // Decode v2: frame view, then stream parser.
    let v2_bytes = hex::decode(&v.v2)?;
    let frame =
        v2::Frame::new_checked(&v2_bytes[..]).map_err(|e| format!("{}: v2 frame: {e}", v.name))?;
    if !frame.check_crc(meta.crc_extra) || frame.header() != header {
        return Err(format!("{}: v2 header or CRC mismatch", v.name).into());
    }
    let decoded: Message = frame.decode()?;
    if decoded != expected {
        return Err(format!(
            "{}: v2 decode differs:\n  ours     {decoded:?}\n  expected {expected:?}",
            v.name
        )
        .into());
    }
    // Into a message of another kind (HEARTBEAT, where the dialect has it): the same message.
    let mut into = Message::decode(0, &[]).unwrap_or_else(|_| decoded.clone());
    frame.decode_into(&mut into)?;
    if into != expected {
        return Err(format!("{}: decode_into differs: {into:?}", v.name).into());
    }
    // The dialect's id dispatch agrees with a search of its table.
    let found = ferrolink_runtime::mavlink::find_meta(Message::META, v.id);
    if Message::meta_of(v.id) != found
        || found.map(|m| m.id) != Some(v.id)
        || expected.meta() != found.unwrap_or(meta)
    {
        return Err(format!("{}: meta_of or meta disagrees with META", v.name).into());
    }
    let streamed = parse_all(&v2_bytes)?;
    if streamed != [(header, expected.clone())] {
        return Err(format!("{}: the stream parser gave {streamed:?}", v.name).into());
    }

    // Encode v2.
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_dialect(header, &expected, &mut out)?;
    if out[..n] != v2_bytes[..] {
        return Err(format!(
            "{}: v2 encode differs:\n  ours     {}\n  expected {}",
            v.name,
            hex::encode(&out[..n]),
            v.v2
        )
        .into());
    }

    // v1: base fields only.
    let mut full: PayloadBuf = [0; 255];
    let len = expected.encode(&mut full);
    let expected_v1 = Message::decode(v.id, &full[..usize::from(meta.min_len).min(len)])?;
    match (&v.v1, v.id <= 255) {
        (Some(hex_v1), true) => {
            let v1_bytes = hex::decode(hex_v1)?;
            let frame = v1::Frame::new_checked(&v1_bytes[..])
                .map_err(|e| format!("{}: v1 frame: {e}", v.name))?;
            if !frame.check_crc(meta.crc_extra) || frame.header() != header {
                return Err(format!("{}: v1 header or CRC mismatch", v.name).into());
            }
            let decoded: Message = frame.decode()?;
            if decoded != expected_v1 {
                return Err(format!("{}: v1 decode differs", v.name).into());
            }
            if parse_all(&v1_bytes)? != [(header, expected_v1)] {
                return Err(format!("{}: the stream parser disagrees on v1", v.name).into());
            }
            let n = v1::encode_dialect(header, &expected, &mut out)?;
            if out[..n] != v1_bytes[..] {
                return Err(format!(
                    "{}: v1 encode differs:\n  ours     {}\n  expected {hex_v1}",
                    v.name,
                    hex::encode(&out[..n])
                )
                .into());
            }
        }
        (None, false) => {
            if v1::encode_dialect(header, &expected, &mut out).is_ok() {
                return Err(
                    format!("{}: v1 encoding of an id > 255 must be refused", v.name).into(),
                );
            }
        }
        _ => return Err(format!("{}: v1 presence does not match the id", v.name).into()),
    }
    Ok(())
}

fn parse_all(bytes: &[u8]) -> Result<Vec<(Header, Message)>, Error> {
    let mut parser = Parser::<{ v2::MAX_FRAME_LEN }>::for_dialect::<Message>();
    let mut out = Vec::new();
    let mut err = None;
    parser.feed_all(bytes, |f| match f.decode::<Message>() {
        Ok(m) => out.push((f.header(), m)),
        Err(e) => err = Some(e),
    });
    match err {
        Some(e) => Err(e.into()),
        None => Ok(out),
    }
}

/// Decodes a raw capture and prints one JSON line per frame.
fn stream(path: &str) -> Result<bool, Error> {
    let bytes = std::fs::read(path)?;
    let mut parser = Parser::<{ v2::MAX_FRAME_LEN }>::for_dialect::<Message>();
    let mut lines = Vec::new();
    let mut failure = None;
    parser.feed_all(&bytes, |f| {
        let h = f.header();
        match f.decode::<Message>() {
            Ok(msg) => lines.push(serde_json::json!({
                "sysid": h.sysid, "compid": h.compid, "seq": h.seq, "msg": msg,
            })),
            Err(e) => failure = Some(e),
        }
    });
    for line in &lines {
        println!("{line}");
    }
    let s = parser.stats();
    eprintln!("{} frame(s); dropped: {s:?}", lines.len());
    Ok(failure.is_none())
}
