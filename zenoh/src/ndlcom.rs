//! The NDLCom bridge's Zenoh interface: one interface of the bridge whose far side is every
//! other bridge and client on the same Zenoh network.
//!
//! - **Out.** Every frame the bridge sends to this interface is put on
//!   `<prefix>/ndlcom/<sender>/<receiver>/<MESSAGE_NAME>` (the name of the payload's message id
//!   in the dictionary; `UNKNOWN_<id>` if it has none, `EMPTY` for an empty payload), as the
//!   encoded frame (flags, escaping and FCS, as on a serial line) or as JSON:
//!   `{"sender":..,"receiver":..,"counter":..,"msg":{<to_dict() form>}}`, or `"msg":null,
//!   "payload":"<hex>"` for a payload the dictionary does not know.
//! - **In.** Samples other sessions put under `<prefix>/ndlcom/**` are frames received on this
//!   interface, encoded (first byte 0x7E) or JSON (`counter` defaults to 0). The bridge's own puts
//!   never come back, and the bridge never sends a frame back to the interface it came from.

use std::io;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use ferrolink_io::link::{self, Event, Sender};
use ferrolink_io::ndlcom::bridge::Attached;
use ferrolink_runtime::ndlcom::{self, parser::Parser, storage_len, Header, FLAG};
use ferrolink_traffic::PayloadDecoder;
use zenoh::Wait;

use crate::session::{Rejections, Running};
use crate::uri::{Encoding, ZenohUri};

type FrameParser = Parser<[u8; storage_len(ndlcom::MAX_PAYLOAD_LEN)]>;

/// The Zenoh interface of `uri` as an interface the bridge attaches; `decoder` names payloads
/// and writes and reads JSON.
pub fn attached(uri: ZenohUri, decoder: Arc<PayloadDecoder>) -> Attached {
    Attached {
        name: uri.to_string(),
        open: Box::new(move |index, sink, _status| {
            let running = open(index, &uri, decoder, sink)?;
            Ok(Box::new(running) as Box<dyn Send>)
        }),
    }
}

/// The name a payload is published under.
fn message_name(decoder: &PayloadDecoder, payload: &[u8]) -> String {
    match payload.first() {
        None => "EMPTY".into(),
        Some(&id) => decoder
            .message(u32::from(id))
            .map_or_else(|| format!("UNKNOWN_{id}"), |m| m.name.wire.clone()),
    }
}

/// A frame as JSON.
pub fn frame_json(decoder: &PayloadDecoder, header: &Header, payload: &[u8]) -> String {
    let msg = payload
        .split_first()
        .and_then(|(&id, body)| decoder.to_dict(u32::from(id), body))
        .map_or_else(
            || format!("null,\"payload\":\"{}\"", hex::encode(payload)),
            |dict| dict.to_string(),
        );
    format!(
        "{{\"sender\":{},\"receiver\":{},\"counter\":{},\"msg\":{msg}}}",
        header.sender, header.receiver, header.counter
    )
}

/// A JSON sample as an encoded NDLCom frame.
pub fn frame_from_json(decoder: &PayloadDecoder, bytes: &[u8]) -> Result<Vec<u8>, String> {
    let value: serde_json::Value =
        serde_json::from_slice(bytes).map_err(|e| format!("neither a frame nor JSON: {e}"))?;
    let number = |name: &str, default: Option<u8>| -> Result<u8, String> {
        match value.get(name) {
            None => default.ok_or_else(|| format!("\"{name}\" is missing")),
            Some(v) => v
                .as_u64()
                .and_then(|v| u8::try_from(v).ok())
                .ok_or_else(|| format!("\"{name}\" must be 0 to 255")),
        }
    };
    let msg = value.get("msg").ok_or("\"msg\" is missing")?;
    if msg.is_null() {
        return Err(
            "a payload the dictionary does not know (\"msg\": null) is not re-encoded".into(),
        );
    }
    let (id, body) = decoder.from_dict(msg, &[])?;
    let id = u8::try_from(id).map_err(|_| format!("message id {id} does not fit NDLCom's byte"))?;
    let mut payload = vec![id];
    payload.extend_from_slice(&body);
    let length = u8::try_from(payload.len()).map_err(|_| "the payload is too long".to_owned())?;
    let header = Header {
        receiver: number("receiver", None)?,
        sender: number("sender", None)?,
        counter: number("counter", Some(0))?,
        length,
    };
    let mut out = [0u8; ndlcom::MAX_FRAME_LEN];
    let n = ndlcom::encode(&header, &payload, &mut out).map_err(|e| format!("{e:?}"))?;
    Ok(out[..n].to_vec())
}

/// Opens the session, reports the one peer up to `sink`, and starts the subscriber.
pub fn open(
    index: usize,
    uri: &ZenohUri,
    decoder: Arc<PayloadDecoder>,
    sink: link::Sink,
) -> io::Result<Running> {
    let mut running = Running::open(uri)?;
    let root = format!("{}/ndlcom", uri.prefix);
    let sender = publisher(running.session(), &root, uri.encoding, decoder.clone());
    let peer = running.report_up(index, sender, &sink)?;
    let mut rejected = Rejections::default();
    let mut listened = true;
    running.on_remote_sample(format!("{root}/**"), move |sample| {
        let bytes = sample.payload().to_bytes();
        let frame = if bytes.first() == Some(&FLAG) {
            Ok(bytes.to_vec())
        } else {
            frame_from_json(&decoder, &bytes)
        };
        match frame {
            Ok(frame) => {
                listened = listened
                    && sink(Event::Rx {
                        peer,
                        bytes: &frame,
                        at: Instant::now(),
                    });
            }
            Err(e) => rejected.note(sample.key_expr().as_str(), &e),
        }
    })?;
    Ok(running)
}

/// The interface's sender: the bridge hands it encoded bytes (one or more frames); each frame is
/// put on its key.
fn publisher(
    session: &zenoh::Session,
    root: &str,
    encoding: Encoding,
    decoder: Arc<PayloadDecoder>,
) -> Sender {
    let (session, root) = (session.clone(), root.to_owned());
    let parser = Mutex::new(Box::new(FrameParser::new(
        [0; storage_len(ndlcom::MAX_PAYLOAD_LEN)],
    )));
    Sender::from_fn(move |bytes| {
        let mut parser = parser.lock().unwrap_or_else(PoisonError::into_inner);
        let mut result = Ok(());
        parser.feed_all(bytes, |frame| {
            let header = frame.header();
            let payload = frame.payload();
            let key = format!(
                "{root}/{}/{}/{}",
                header.sender,
                header.receiver,
                message_name(&decoder, payload)
            );
            let put = match encoding {
                Encoding::Raw => {
                    // The parser hands frames unescaped; the sample is the frame as on the wire.
                    let mut out = [0u8; ndlcom::MAX_FRAME_LEN];
                    match ndlcom::encode(&header, payload, &mut out) {
                        Ok(n) => session.put(key, out[..n].to_vec()).wait(),
                        Err(e) => Err(format!("{e:?}").into()),
                    }
                }
                Encoding::Json => session
                    .put(key, frame_json(&decoder, &header, payload))
                    .wait(),
            };
            if let Err(e) = put {
                result = Err(io::Error::other(e.to_string()));
            }
        });
        result
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decoder() -> Arc<PayloadDecoder> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../definitions/mavlink/minimal.xml");
        let ir = ferrolink_dictionary::load(&[path]).expect("minimal.xml").ir;
        Arc::new(PayloadDecoder::new(ir))
    }

    #[test]
    fn json_and_frames_both_ways() {
        let d = &decoder();
        let json =
            br#"{"sender":3,"receiver":4,"counter":9,"msg":{"mavpackettype":"PING","seq":5}}"#;
        let frame = frame_from_json(d, json).expect("a frame");
        let mut parser = FrameParser::new([0; storage_len(ndlcom::MAX_PAYLOAD_LEN)]);
        let mut seen = Vec::new();
        parser.feed_all(&frame, |f| {
            let h = f.header();
            assert_eq!((h.sender, h.receiver, h.counter), (3, 4, 9));
            assert_eq!(message_name(d, f.payload()), "PING");
            let back: serde_json::Value =
                serde_json::from_str(&frame_json(d, &h, f.payload())).expect("json");
            assert_eq!(back["msg"]["seq"], 5);
            assert_eq!(back["sender"], 3);
            seen.push(());
        });
        assert_eq!(seen.len(), 1, "one frame with a good FCS");
        assert_eq!(message_name(d, &[]), "EMPTY");
        assert_eq!(message_name(d, &[250, 1]), "UNKNOWN_250");
        let unknown = frame_json(d, &Header::default(), &[250, 1]);
        assert!(
            unknown.ends_with(r#""msg":null,"payload":"fa01"}"#),
            "{unknown}"
        );
        for bad in [
            &br#"{"receiver":4,"msg":{"mavpackettype":"PING"}}"#[..],
            br#"{"sender":1,"receiver":4,"msg":null}"#,
            br#"{"sender":1,"receiver":4}"#,
            b"junk",
        ] {
            assert!(frame_from_json(d, bad).is_err());
        }
    }
}
