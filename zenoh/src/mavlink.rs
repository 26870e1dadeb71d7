//! The router's Zenoh endpoint: one link of the router whose far side is every other router and
//! client on the same Zenoh network.
//!
//! - **Out.** Every frame routing sends to this link is put on
//!   `<prefix>/mavlink/<sysid>/<compid>/<MESSAGE_NAME>` (`UNKNOWN_<id>` for an id the router does
//!   not know), as the raw frame or as JSON, as the endpoint's encoding says.
//! - **In.** Samples other sessions put under `<prefix>/mavlink/**` are frames received on this
//!   link, raw (first byte 0xFD or 0xFE) or JSON, whatever the endpoint's own encoding. The
//!   router's own puts never come back (the subscriber takes remote samples only), and routing
//!   never sends a frame back to the link it came from, so nothing received from Zenoh is put on
//!   Zenoh again.
//! - **Commands.** A put on `<prefix>/mavlink/<sysid>/<compid>/tx` is taken like any other
//!   sample. In JSON, the object is either the envelope `{"sysid":..,"compid":..,"seq":..,
//!   "msg":{..}}` or the message alone (`{"mavpackettype":"COMMAND_LONG",..}`); the sender
//!   defaults to 255/190 and the sequence number to a counter of the endpoint's own, and
//!   `target_system`/`target_component` left out of the message are the key's `<sysid>` and
//!   `<compid>`.
//! - **Discovery.** The endpoint answers queries on `<prefix>/fleet/<zenoh id>` with the router's
//!   links and the systems behind them (`ferrolink mavlink fleet`).
//!
//! JSON re-encodes: a frame that went through JSON arrives as an unsigned MAVLink 2 frame with
//! the same header and payload; an id the dictionaries lack cannot be re-encoded and is counted
//! as rejected.

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::io;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use ferrolink_io::link::Status;
use ferrolink_io::link::{self, Event, Sender};
use ferrolink_io::mavlink::router::Attached;
use ferrolink_runtime::mavlink::router::LinkConfig;
use ferrolink_runtime::mavlink::{AnyFrame, MessageMeta};
use ferrolink_traffic::{FrameDefaults, PayloadDecoder};
use zenoh::Wait;

use crate::session::{Rejections, Running};
use crate::uri::{Encoding, ZenohUri};

/// The sender of a JSON command that names none (a ground station's ids).
pub const DEFAULT_SYSID: u8 = 255;
/// See [`DEFAULT_SYSID`].
pub const DEFAULT_COMPID: u8 = 190;

/// What the endpoint knows of MAVLink: the router's message table, and the dictionaries to
/// write and read JSON with.
#[derive(Debug, Clone)]
pub struct Dictionaries {
    /// The messages' CRC_EXTRA and lengths, sorted by id.
    pub table: Arc<[MessageMeta]>,
    /// The same dictionaries, for names and JSON.
    pub decoder: Arc<PayloadDecoder>,
}

/// The Zenoh endpoint of `uri` as an endpoint the router daemon attaches, its links configured
/// by `link` (filters, group, signing; a sample is always one whole frame).
pub fn attached(uri: ZenohUri, link: LinkConfig, dictionaries: Dictionaries) -> Attached {
    Attached {
        // Every sample is one whole frame.
        link: LinkConfig {
            datagrams: true,
            ..link
        },
        open: Box::new(move |index, sink, status| {
            let running = open(index, &uri, dictionaries, sink, status)?;
            Ok(Box::new(running) as Box<dyn Send>)
        }),
    }
}

/// The key a frame from `sysid`/`compid` with message `name` is put on.
pub fn key(root: &str, sysid: u8, compid: u8, name: &str) -> String {
    format!("{root}/{sysid}/{compid}/{name}")
}

/// Opens the session, reports the one peer up to `sink`, and starts the subscriber and the
/// discovery queryable.
pub fn open(
    index: usize,
    uri: &ZenohUri,
    dictionaries: Dictionaries,
    sink: link::Sink,
    status: Status,
) -> io::Result<Running> {
    let mut running = Running::open(uri)?;
    let name = uri.to_string();
    let root = uri.mavlink_root();
    let zid = running.session().zid().to_string();
    let fleet_key = format!("{}/{zid}", uri.fleet_root());
    let sender = publisher(running.session(), &root, uri.encoding, dictionaries.clone());
    let peer = running.report_up(index, sender, &sink)?;
    let mut frames = FrameMaker::new(dictionaries);
    let mut listened = true;
    running.on_remote_sample(format!("{root}/**"), move |sample| {
        let key = sample.key_expr().as_str();
        if let Some(frame) = frames.frame(&root, key, &sample.payload().to_bytes()) {
            listened = listened
                && sink(Event::Rx {
                    peer,
                    bytes: &frame,
                    at: Instant::now(),
                });
        }
    })?;
    let answer_key = fleet_key.clone();
    running.on_query(&fleet_key, move |query| {
        let mut answer = status();
        answer["router"] = zid.clone().into();
        answer["endpoint"] = name.clone().into();
        let _ = query.reply(&answer_key, answer.to_string()).wait();
    })?;
    Ok(running)
}

/// The most keys the sender keeps a declared publisher for; past that, the table starts over.
const MAX_PUBLISHERS: usize = 4096;

/// The link's sender: puts every frame routing hands it on its key, through a publisher
/// declared once per key.
fn publisher(
    session: &zenoh::Session,
    root: &str,
    encoding: Encoding,
    dictionaries: Dictionaries,
) -> Sender {
    let (session, root) = (session.clone(), root.to_owned());
    let publishers = Mutex::new(HashMap::<(u8, u8, u32), zenoh::pubsub::Publisher<'static>>::new());
    Sender::from_fn(move |bytes| {
        let frame = AnyFrame::new_checked(bytes)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, format!("{e:?}")))?;
        let (sysid, compid, id) = (frame.sysid(), frame.compid(), frame.msg_id());
        let mut publishers = publishers.lock().unwrap_or_else(PoisonError::into_inner);
        if publishers.len() >= MAX_PUBLISHERS {
            publishers.clear();
        }
        let publisher = match publishers.entry((sysid, compid, id)) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(e) => {
                let key = match dictionaries.decoder.message(id) {
                    Some(message) => key(&root, sysid, compid, &message.name.wire),
                    None => key(&root, sysid, compid, &format!("UNKNOWN_{id}")),
                };
                let declared = session
                    .declare_publisher(key)
                    .wait()
                    .map_err(|e| io::Error::other(e.to_string()))?;
                e.insert(declared)
            }
        };
        let put = match encoding {
            Encoding::Raw => publisher.put(bytes.to_vec()).wait(),
            Encoding::Json => {
                let (members, _) = dictionaries.decoder.frame_json_members(
                    sysid,
                    compid,
                    frame.seq(),
                    id,
                    frame.payload(),
                );
                publisher.put(format!("{{{members}}}")).wait()
            }
        };
        put.map_err(|e| io::Error::other(e.to_string()))
    })
}

/// Turns samples into frames.
struct FrameMaker {
    dictionaries: Dictionaries,
    /// The sequence number of the next JSON command that names none.
    seq: u8,
    /// Samples that carried no frame.
    rejected: Rejections,
}

impl FrameMaker {
    fn new(dictionaries: Dictionaries) -> Self {
        Self {
            dictionaries,
            seq: 0,
            rejected: Rejections::default(),
        }
    }

    /// The frame a sample on `key` carries, or `None` (reported on stderr at most once a
    /// second, and counted) if it carries none.
    fn frame(&mut self, root: &str, key: &str, bytes: &[u8]) -> Option<Vec<u8>> {
        if matches!(bytes.first(), Some(0xFD | 0xFE)) {
            return Some(bytes.to_vec());
        }
        match self.json_frame(root, key, bytes) {
            Ok(frame) => Some(frame),
            Err(e) => {
                self.rejected.note(key, &e);
                None
            }
        }
    }

    /// A JSON sample as an unsigned MAVLink 2 frame.
    fn json_frame(&mut self, root: &str, key: &str, bytes: &[u8]) -> Result<Vec<u8>, String> {
        let value: serde_json::Value =
            serde_json::from_slice(bytes).map_err(|e| format!("neither a frame nor JSON: {e}"))?;
        // `<root>/<sysid>/<compid>/tx`: the key names the target.
        let parts: Vec<&str> = key
            .strip_prefix(root)
            .unwrap_or(key)
            .trim_start_matches('/')
            .split('/')
            .collect();
        let target = match parts[..] {
            [sysid, compid, "tx"] => sysid.parse().ok().zip(compid.parse().ok()),
            _ => None,
        };
        let defaults = FrameDefaults {
            sysid: DEFAULT_SYSID,
            compid: DEFAULT_COMPID,
            seq: self.seq,
            target,
        };
        let frame = self
            .dictionaries
            .decoder
            .frame_from_json(&value, defaults)?;
        // The counter numbers the samples that bring no sequence number of their own.
        if value.get("msg").is_none() || value.get("seq").is_none() {
            self.seq = self.seq.wrapping_add(1);
        }
        Ok(frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ferrolink_runtime::mavlink::parser::Parser;

    fn dictionaries() -> Dictionaries {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../definitions/mavlink/minimal.xml");
        let ir = ferrolink_dictionary::load(&[path]).expect("minimal.xml").ir;
        Dictionaries {
            table: ferrolink_traffic::message_table(&ir),
            decoder: Arc::new(PayloadDecoder::new(ir)),
        }
    }

    /// (sysid, compid, seq, id, JSON of the payload) of the one frame in `bytes`.
    fn parse(d: &Dictionaries, bytes: &[u8]) -> (u8, u8, u8, u32, serde_json::Value) {
        let mut parser = Parser::<280, _>::new(d.table.clone());
        let mut got = Vec::new();
        parser.feed_all(bytes, |f| {
            let dict = d.decoder.to_dict(f.msg_id(), f.payload()).expect("known");
            let h = f.header();
            got.push((h.sysid, h.compid, h.seq, f.msg_id(), dict));
        });
        assert_eq!(got.len(), 1, "one frame, CRC checked");
        got.remove(0)
    }

    #[test]
    fn json_samples_become_frames() {
        let d = dictionaries();
        let mut maker = FrameMaker::new(d.clone());
        // The envelope, as a router with encoding=json puts it.
        let envelope = br#"{"sysid":3,"compid":1,"seq":77,"msg":{"mavpackettype":"PING","seq":5,"time_usec":9,"target_system":0,"target_component":0}}"#;
        let frame = maker
            .frame("p/mavlink", "p/mavlink/3/1/PING", envelope)
            .expect("a frame");
        let (sysid, compid, seq, id, dict) = parse(&d, &frame);
        assert_eq!((sysid, compid, seq, id), (3, 1, 77, 4));
        assert_eq!(
            (dict["seq"].as_u64(), dict["time_usec"].as_u64()),
            (Some(5), Some(9))
        );

        // A bare message on a tx key: a ground station's ids, a counter, the key's target.
        let bare = br#"{"mavpackettype":"PING","seq":1}"#;
        for expected_seq in 0..2 {
            let frame = maker
                .frame("p/mavlink", "p/mavlink/2/7/tx", bare)
                .expect("a frame");
            let (sysid, compid, seq, _, dict) = parse(&d, &frame);
            assert_eq!(
                (sysid, compid, seq),
                (DEFAULT_SYSID, DEFAULT_COMPID, expected_seq)
            );
            assert_eq!(dict["target_system"], 2);
            assert_eq!(dict["target_component"], 7);
        }

        // Raw frames pass unchanged.
        let raw = maker
            .frame("p/mavlink", "p/mavlink/2/7/tx", &frame)
            .expect("raw");
        assert_eq!(raw, frame);
    }

    #[test]
    fn samples_without_a_frame_are_counted() {
        let mut maker = FrameMaker::new(dictionaries());
        let unknown = br#"{"sysid":1,"compid":1,"seq":0,"msg":null,"id":60000,"payload":"00"}"#;
        let junk: [&[u8]; 4] = [
            b"not json",
            unknown,
            br#"{"mavpackettype":"NOPE"}"#,
            br#"{"sysid":300,"msg":{"mavpackettype":"PING"}}"#,
        ];
        for bytes in junk {
            assert!(maker.frame("p/mavlink", "p/mavlink/1/1/X", bytes).is_none());
        }
        assert_eq!(maker.rejected.count(), 4);
    }

    #[test]
    fn keys_name_source_and_message() {
        assert_eq!(
            key("f/mavlink", 3, 1, "HEARTBEAT"),
            "f/mavlink/3/1/HEARTBEAT"
        );
    }
}
