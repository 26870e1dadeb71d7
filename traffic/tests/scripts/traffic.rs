//! Invariants of turning JSON into MAVLink frames (`PayloadDecoder::frame_from_json`), shared by
//! `traffic/tests/json_frame.rs` and the fuzz target `json_frame`, and of mavlink2rest's JSON
//! form (`check_rest_json`), shared with the fuzz target `rest_json`.
//!
//! For any bytes: if they are JSON and make a frame, that frame is one whole MAVLink 2 frame the
//! runtime's parser accepts with its CRC, of a message the dictionary knows, whose decoded form
//! names that message; nothing panics either way.

use std::path::Path;
use std::sync::{Arc, OnceLock};

use ferrolink_runtime::mavlink::parser::Parser;
use ferrolink_runtime::mavlink::{v2, MessageMeta};
use ferrolink_traffic::{message_table, FrameDefaults, PayloadDecoder};

/// Our minimal dialect, loaded once.
fn dictionary() -> &'static (PayloadDecoder, Arc<[MessageMeta]>) {
    static LOADED: OnceLock<(PayloadDecoder, Arc<[MessageMeta]>)> = OnceLock::new();
    LOADED.get_or_init(|| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../definitions/mavlink/minimal.xml");
        let path = if path.exists() {
            path
        } else {
            // The fuzz crate's manifest sits one level down.
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../definitions/mavlink/minimal.xml")
        };
        let ir = ferrolink_dictionary::load(&[path]).expect("minimal.xml").ir;
        let table = message_table(&ir);
        (PayloadDecoder::new(ir), table)
    })
}

/// Checks the invariants for one input: the first three bytes pick the defaults, the rest is
/// the JSON text.
pub fn check_json_frame(data: &[u8]) {
    let (decoder, table) = dictionary();
    let [a, b, c, text @ ..] = data else {
        return;
    };
    let Ok(value) = serde_json::from_slice::<serde_json::Value>(text) else {
        return;
    };
    let defaults = FrameDefaults {
        sysid: *a,
        compid: *b,
        seq: *c,
        target: (a & 1 == 1).then_some((*b, *c)),
    };
    let Ok(frame) = decoder.frame_from_json(&value, defaults) else {
        return;
    };
    let mut parser = Parser::<{ v2::MAX_FRAME_LEN }, _>::new(table.clone());
    let mut frames = Vec::new();
    parser.feed_all(&frame, |f| {
        frames.push((f.msg_id(), f.as_bytes().len(), f.payload().to_vec()))
    });
    assert_eq!(frames.len(), 1, "one frame from {value}");
    let (id, len, payload) = &frames[0];
    assert_eq!(*len, frame.len(), "the whole frame");
    let dict = decoder.to_dict(*id, payload).expect("a known message");
    let name = value
        .get("msg")
        .unwrap_or(&value)
        .get("mavpackettype")
        .cloned();
    assert_eq!(dict.get("mavpackettype").cloned(), name);
}

/// mavlink2rest's JSON form, for any bytes: the first byte picks what the rest is. Even: JSON
/// text for [`PayloadDecoder::from_rest`]. Odd: a message (the second byte, an index into the
/// dictionary) and its payload, for [`PayloadDecoder::to_rest`]. Either way, whatever reads is
/// written back the same: `to_rest(from_rest(R))` is `R` for every `R` that `to_rest` writes,
/// unless its text had bytes that are not UTF-8 (shown as U+FFFD, three bytes each, which may
/// not fit the field again).
pub fn check_rest_json(data: &[u8]) {
    let (decoder, _) = dictionary();
    let [mode, rest @ ..] = data else {
        return;
    };
    let written = if mode % 2 == 0 {
        let Ok(value) = serde_json::from_slice::<serde_json::Value>(rest) else {
            return;
        };
        let Ok((id, payload)) = decoder.from_rest(&value) else {
            return;
        };
        decoder
            .to_rest(id, &payload)
            .expect("a message from_rest knows")
    } else {
        let [pick, payload @ ..] = rest else {
            return;
        };
        let ids: Vec<u32> = decoder.messages().map(|m| m.id).collect();
        let id = ids[usize::from(*pick) % ids.len()];
        decoder.to_rest(id, payload).expect("a known message")
    };
    if written.to_string().contains('\u{fffd}') {
        return;
    }
    let (id, payload) = decoder
        .from_rest(&written)
        .unwrap_or_else(|e| panic!("{written} does not read back: {e}"));
    assert_eq!(decoder.to_rest(id, &payload).as_ref(), Some(&written));
}
