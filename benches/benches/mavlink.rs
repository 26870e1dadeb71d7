//! Ferrolink against the `mavlink` crate (0.21, common dialect) in one run: MAVLink 2 encode,
//! decode and stream parsing of HEARTBEAT, ATTITUDE and FILE_TRANSFER_PROTOCOL.
//!
//! ```text
//! cargo bench -p ferrolink-bench --bench mavlink
//! ```
//!
//! A small harness instead of a framework: every case is calibrated to batches of about
//! `BATCH_TARGET`, then the two implementations run alternating batches (so load from other
//! processes hits both alike) and the median batch of each is reported. Before timing, both
//! sides are checked to produce identical frames and to decode each other's frames.
//!
//! The messages come from `ferrolink_generated::mavlink::minimal`, whose HEARTBEAT, ATTITUDE and
//! FILE_TRANSFER_PROTOCOL are byte-identical to MAVLink common's.

mod harness;

use harness::{compare, BATCHES, BATCH_TARGET};
use std::hint::black_box;
use std::io::ErrorKind;

use ferrolink_generated::mavlink::minimal as ours;
use ferrolink_runtime::mavlink::{v2, Dialect, Header, Parser};
use mavlink::dialects::common as theirs;
use mavlink::error::MessageReadError;
use mavlink::{MAVLinkV2MessageRaw, MavHeader, MavlinkReader, MavlinkVersion, Message as _};

/// Size of the stream-parsing input.
const STREAM_BYTES: usize = 1 << 20;

const SYSID: u8 = 1;
const COMPID: u8 = 1;

// ---------------------------------------------------------------------------------------------
// Test messages: the same field values in both representations.
// ---------------------------------------------------------------------------------------------

/// One message in both libraries' types.
struct Pair<O, T> {
    ours: O,
    theirs: T,
}

fn heartbeat(k: u32) -> Pair<ours::Heartbeat, theirs::HEARTBEAT_DATA> {
    let custom_mode = 0x0004_0000 | (k & 0xFFFF);
    let base_mode = 0x80 | 0x10 | 0x01; // armed, stabilised, custom mode
    Pair {
        ours: ours::Heartbeat {
            r#type: ours::MavType::Quadrotor,
            autopilot: ours::MavAutopilot::Px4,
            base_mode: ours::MavModeFlag::from_raw(base_mode),
            custom_mode,
            system_status: ours::MavState::from_raw(4), // ACTIVE
            mavlink_version: 3,
        },
        theirs: theirs::HEARTBEAT_DATA {
            custom_mode,
            mavtype: theirs::MavType::MAV_TYPE_QUADROTOR,
            autopilot: theirs::MavAutopilot::MAV_AUTOPILOT_PX4,
            base_mode: theirs::MavModeFlag::from_bits_retain(base_mode),
            system_status: theirs::MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        },
    }
}

fn attitude(k: u32) -> Pair<ours::Attitude, theirs::ATTITUDE_DATA> {
    let t = k as f32 * 0.001;
    let (time_boot_ms, roll, pitch, yaw) = (1_000 + k * 4, 0.1 + t, -0.05 - t, 1.5 + t);
    let (rollspeed, pitchspeed, yawspeed) = (0.01 * t, -0.02, 0.003 + t);
    Pair {
        ours: ours::Attitude {
            time_boot_ms,
            roll,
            pitch,
            yaw,
            rollspeed,
            pitchspeed,
            yawspeed,
        },
        theirs: theirs::ATTITUDE_DATA {
            time_boot_ms,
            roll,
            pitch,
            yaw,
            rollspeed,
            pitchspeed,
            yawspeed,
        },
    }
}

fn ftp(k: u32) -> Pair<ours::FileTransferProtocol, theirs::FILE_TRANSFER_PROTOCOL_DATA> {
    let mut payload = [0u8; 251];
    for (i, b) in payload.iter_mut().enumerate() {
        // Never zero, so the frame always carries the full 254-byte payload.
        *b = ((i as u32 + k) % 255 + 1) as u8;
    }
    Pair {
        ours: ours::FileTransferProtocol {
            target_network: 0,
            target_system: 1,
            target_component: 190,
            payload,
        },
        theirs: theirs::FILE_TRANSFER_PROTOCOL_DATA {
            target_network: 0,
            target_system: 1,
            target_component: 190,
            payload,
        },
    }
}

fn ours_header(seq: u8) -> Header {
    Header::new(seq, SYSID, COMPID)
}

fn theirs_header(seq: u8) -> MavHeader {
    MavHeader {
        system_id: u32::from(SYSID),
        component_id: COMPID,
        sequence: seq,
    }
}

/// Encodes with Ferrolink into a fresh `Vec`.
fn ours_frame<M: ferrolink_runtime::mavlink::Message>(seq: u8, msg: &M) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode(ours_header(seq), msg, &mut out).expect("encode");
    out[..n].to_vec()
}

/// Encodes with the mavlink crate into a fresh `Vec`.
fn theirs_frame<M: mavlink::Message>(seq: u8, msg: &M) -> Vec<u8> {
    let mut raw = MAVLinkV2MessageRaw::new();
    raw.serialize_message(theirs_header(seq), msg);
    raw.raw_bytes().to_vec()
}

// ---------------------------------------------------------------------------------------------
// The operations being compared. Each takes its input through `black_box` and hands its result
// to `black_box`, so neither can be folded away.
// ---------------------------------------------------------------------------------------------

/// Ferrolink: typed message -> frame (`v2::encode`, in place into a max-size buffer).
fn ours_encoder<M: ferrolink_runtime::mavlink::Message>(msg: M) -> impl FnMut(u64) {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    move |i| {
        let n = v2::encode(ours_header(i as u8), black_box(&msg), &mut out).expect("encode");
        black_box(out.get(..n));
    }
}

/// mavlink: typed message -> frame (`MAVLinkV2MessageRaw::serialize_message_data` into a reused
/// raw frame; this is what `write_v2_msg` does, minus the copy to a writer).
fn theirs_encoder<D: mavlink::MessageData>(msg: D) -> impl FnMut(u64) {
    let mut raw = MAVLinkV2MessageRaw::new();
    move |i| {
        raw.serialize_message_data(theirs_header(i as u8), black_box(&msg));
        black_box(raw.raw_bytes());
    }
}

/// Ferrolink: frame bytes -> dialect enum, with length, magic and checksum checked.
fn ours_decode(bytes: &[u8]) -> ours::Message {
    let frame = v2::Frame::new_checked(bytes).expect("frame");
    let meta = ours::Message::meta_of(frame.msg_id()).expect("known id");
    assert!(frame.check_crc(meta.crc_extra), "checksum");
    frame.decode::<ours::Message>().expect("decode")
}

fn ours_decoder(frame: Vec<u8>) -> impl FnMut(u64) {
    move |_| {
        black_box(ours_decode(black_box(&frame)));
    }
}

/// mavlink: frame bytes -> dialect enum: the frame is loaded into a reused
/// `MAVLinkV2MessageRaw` (as their reader does), its checksum checked, then parsed.
fn theirs_decode(raw: &mut MAVLinkV2MessageRaw, bytes: &[u8]) -> theirs::MavMessage {
    raw.as_mut_slice()[..bytes.len()].copy_from_slice(bytes);
    assert!(raw.has_valid_crc::<theirs::MavMessage>(), "checksum");
    theirs::MavMessage::parse(MavlinkVersion::V2, raw.message_id(), raw.payload()).expect("parse")
}

fn theirs_decoder(frame: Vec<u8>) -> impl FnMut(u64) {
    let mut raw = MAVLinkV2MessageRaw::new();
    move |_| {
        black_box(theirs_decode(&mut raw, black_box(&frame)));
    }
}

/// Ferrolink's frame checksum, kept out of line like `mavlink::calculate_crc` is.
#[inline(never)]
fn ours_checksum(frame: &[u8], crc_extra: u8) -> u16 {
    v2::Frame::new_unchecked(frame).compute_checksum(crc_extra)
}

/// Ferrolink: parses and decodes every frame of `stream`; returns how many.
fn ours_stream(stream: &[u8]) -> usize {
    let mut parser: Parser = Parser::for_dialect::<ours::Message>();
    parser.feed_all(stream, |frame| {
        black_box((
            frame.header(),
            frame.decode::<ours::Message>().expect("decode"),
        ));
    })
}

/// mavlink: reads and decodes every frame of `stream` through `MavlinkReader`; returns how many.
fn theirs_stream(stream: &[u8]) -> usize {
    let mut reader = MavlinkReader::new(stream);
    let mut n = 0;
    loop {
        match reader.read_any_message::<theirs::MavMessage>() {
            Ok(msg) => {
                black_box(msg);
                n += 1;
            }
            Err(MessageReadError::Io(e)) if e.kind() == ErrorKind::UnexpectedEof => return n,
            Err(e) => panic!("stream: {e}"),
        }
    }
}

fn fmt_rate(per_sec: f64) -> String {
    if per_sec >= 1e9 {
        format!("{:.2} G", per_sec / 1e9)
    } else if per_sec >= 1e6 {
        format!("{:.2} M", per_sec / 1e6)
    } else {
        format!("{:.1} k", per_sec / 1e3)
    }
}

/// One table row.
struct Row {
    case: String,
    ours_s: f64,
    theirs_s: f64,
    msgs: f64,
    bytes: f64,
}

impl Row {
    fn print(&self, with_bytes: bool) {
        let (o, t) = (self.msgs / self.ours_s, self.msgs / self.theirs_s);
        let mut line = format!(
            "| {} | {:.1} | {:.1} | {}msg/s | {}msg/s |",
            self.case,
            self.ours_s * 1e9 / self.msgs,
            self.theirs_s * 1e9 / self.msgs,
            fmt_rate(o),
            fmt_rate(t),
        );
        if with_bytes {
            let mb = |s: f64| self.bytes / s / 1e6;
            line += &format!(" {:.0} | {:.0} |", mb(self.ours_s), mb(self.theirs_s));
        }
        line += &format!(" **{:.2}x** |", o / t);
        println!("{line}");
    }
}

// ---------------------------------------------------------------------------------------------
// Cross-checks.
// ---------------------------------------------------------------------------------------------

/// Both sides encode `pair` to the same bytes and decode each other's frames to the original.
fn cross_check<O, T>(name: &str, pair: &Pair<O, T>, wrap_ours: fn(O) -> ours::Message)
where
    O: ferrolink_runtime::mavlink::Message + Copy + PartialEq + std::fmt::Debug,
    T: mavlink::MessageData<Message = theirs::MavMessage> + IntoTheirs + Clone,
{
    let seq = 42;
    let mine = ours_frame(seq, &pair.ours);
    let other = theirs_frame(seq, &pair.theirs.clone().into_theirs());
    assert_eq!(mine, other, "{name}: frames differ");
    let mut raw = MAVLinkV2MessageRaw::new();
    raw.serialize_message_data(theirs_header(seq), &pair.theirs);
    assert_eq!(raw.raw_bytes(), &mine[..], "{name}: typed encode differs");
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_dialect(ours_header(seq), &wrap_ours(pair.ours), &mut out).expect("enc");
    assert_eq!(&out[..n], &mine[..], "{name}: dialect encode differs");

    assert_eq!(
        ours_decode(&other),
        wrap_ours(pair.ours),
        "{name}: ours decoding theirs"
    );
    assert_eq!(
        theirs_decode(&mut raw, &mine),
        pair.theirs.clone().into_theirs(),
        "{name}: theirs decoding ours"
    );
    println!(
        "- {name}: {}-byte frames identical, decoded both ways",
        mine.len()
    );
}

macro_rules! from_data {
    ($($data:ident => $variant:ident),*) => {
        // The mavlink crate has no `From<*_DATA> for MavMessage`; a local trait stands in.
        trait IntoTheirs {
            fn into_theirs(self) -> theirs::MavMessage;
        }
        $(impl IntoTheirs for theirs::$data {
            fn into_theirs(self) -> theirs::MavMessage {
                theirs::MavMessage::$variant(self)
            }
        })*
    };
}
from_data!(HEARTBEAT_DATA => HEARTBEAT, ATTITUDE_DATA => ATTITUDE,
    FILE_TRANSFER_PROTOCOL_DATA => FILE_TRANSFER_PROTOCOL);

/// About `STREAM_BYTES` of concatenated frames: per round one HEARTBEAT, ten ATTITUDE and one
/// FILE_TRANSFER_PROTOCOL, with changing field values. Encoded by both sides, checked equal.
fn build_stream() -> (Vec<u8>, usize) {
    let mut mine = Vec::with_capacity(STREAM_BYTES + 1024);
    let mut other = Vec::with_capacity(STREAM_BYTES + 1024);
    let mut n = 0usize;
    let mut k = 0u32;
    while mine.len() < STREAM_BYTES {
        let seq = n as u8;
        let (o, t) = match n % 12 {
            0 => {
                let p = heartbeat(k);
                (
                    ours_frame(seq, &p.ours),
                    theirs_frame(seq, &p.theirs.into_theirs()),
                )
            }
            11 => {
                let p = ftp(k);
                (
                    ours_frame(seq, &p.ours),
                    theirs_frame(seq, &p.theirs.into_theirs()),
                )
            }
            _ => {
                let p = attitude(k);
                (
                    ours_frame(seq, &p.ours),
                    theirs_frame(seq, &p.theirs.into_theirs()),
                )
            }
        };
        mine.extend_from_slice(&o);
        other.extend_from_slice(&t);
        n += 1;
        k = k.wrapping_add(7);
    }
    assert_eq!(mine, other, "stream encodings differ");
    (mine, n)
}

/// Runs the cases whose name contains one of the filters (all when there are none) and
/// prints one table row each.
struct Runner {
    filters: Vec<String>,
}

impl Runner {
    fn wanted(&self, case: &str) -> bool {
        self.filters.is_empty() || self.filters.iter().any(|f| case.contains(f.as_str()))
    }

    /// Compares single-message operations.
    fn per_msg(&self, case: &str, ours: impl FnMut(u64), theirs: impl FnMut(u64)) {
        if self.wanted(case) {
            let (o, t) = compare(ours, theirs);
            Row {
                case: case.to_owned(),
                ours_s: o,
                theirs_s: t,
                msgs: 1.0,
                bytes: 0.0,
            }
            .print(false);
        }
    }
}

fn main() {
    // `cargo bench` passes `--bench`; other arguments select cases by substring.
    let runner = Runner {
        filters: std::env::args()
            .skip(1)
            .filter(|a| !a.starts_with("--"))
            .collect(),
    };
    let (hb, att, ft) = (heartbeat(1), attitude(1), ftp(1));
    println!("Cross-checks:");
    cross_check("HEARTBEAT", &hb, ours::Message::Heartbeat);
    cross_check("ATTITUDE", &att, ours::Message::Attitude);
    cross_check(
        "FILE_TRANSFER_PROTOCOL",
        &ft,
        ours::Message::FileTransferProtocol,
    );

    let (stream, frames) = build_stream();
    assert_eq!(ours_stream(&stream), frames, "ours: stream frame count");
    assert_eq!(theirs_stream(&stream), frames, "theirs: stream frame count");
    let mut parser: Parser = Parser::for_dialect::<ours::Message>();
    let mut reader = MavlinkReader::new(&stream[..]);
    parser.feed_all(&stream, |f| {
        let (h, m) = reader
            .read_any_message::<theirs::MavMessage>()
            .expect("read");
        let same_header = Header::new(h.sequence, h.system_id as u8, h.component_id);
        assert_eq!(f.header(), same_header, "stream headers differ");
        let (mut a, mut b) = ([0u8; 255], [0u8; 255]);
        let n = Dialect::encode(&f.decode::<ours::Message>().expect("decode"), &mut a);
        let m = m.ser(MavlinkVersion::V1, &mut b); // V1: untruncated, like ours
        assert_eq!(a[..n], b[..m], "stream messages differ");
    });
    println!(
        "- stream: {frames} frames, {} bytes, same messages from both parsers\n",
        stream.len()
    );

    println!(
        "Median of {BATCHES} alternating batches of ~{BATCH_TARGET:?} each; \
         ours/theirs = throughput ratio (>1: Ferrolink faster).\n"
    );
    println!("| case | ours ns/msg | theirs ns/msg | ours | theirs | ours/theirs |");
    println!("|---|---:|---:|---:|---:|---:|");
    runner.per_msg(
        "encode HEARTBEAT",
        ours_encoder(hb.ours),
        theirs_encoder(hb.theirs.clone()),
    );
    runner.per_msg(
        "encode ATTITUDE",
        ours_encoder(att.ours),
        theirs_encoder(att.theirs.clone()),
    );
    runner.per_msg(
        "encode FILE_TRANSFER_PROTOCOL",
        ours_encoder(ft.ours),
        theirs_encoder(ft.theirs.clone()),
    );
    for (name, frame) in [
        ("decode HEARTBEAT", ours_frame(1, &hb.ours)),
        ("decode ATTITUDE", ours_frame(1, &att.ours)),
        ("decode FILE_TRANSFER_PROTOCOL", ours_frame(1, &ft.ours)),
    ] {
        runner.per_msg(name, ours_decoder(frame.clone()), theirs_decoder(frame));
    }

    // The checksum alone, over the same frame body (both libraries' public CRC entry points):
    // it is most of the cost of encoding or decoding a long frame.
    for (name, frame, extra) in [
        (
            "checksum only HEARTBEAT",
            ours_frame(1, &hb.ours),
            ours::Heartbeat::CRC_EXTRA,
        ),
        (
            "checksum only ATTITUDE",
            ours_frame(1, &att.ours),
            ours::Attitude::CRC_EXTRA,
        ),
        (
            "checksum only FILE_TRANSFER_PROTOCOL",
            ours_frame(1, &ft.ours),
            ours::FileTransferProtocol::CRC_EXTRA,
        ),
    ] {
        let body = frame.len() - v2::CHECKSUM_LEN;
        let theirs_body = frame[1..body].to_vec();
        let sent = u16::from_le_bytes([frame[body], frame[body + 1]]);
        assert_eq!(
            v2::Frame::new_unchecked(&frame[..]).compute_checksum(extra),
            sent
        );
        assert_eq!(mavlink::calculate_crc(&theirs_body, extra), sent);
        runner.per_msg(
            name,
            move |_| {
                black_box(ours_checksum(black_box(&frame), extra));
            },
            move |_| {
                black_box(mavlink::calculate_crc(black_box(&theirs_body), extra));
            },
        );
    }

    let case = format!("stream parse+decode ({frames} mixed frames)");
    if runner.wanted(&case) {
        println!();
        println!("| case | ours ns/msg | theirs ns/msg | ours | theirs | ours MB/s | theirs MB/s | ours/theirs |");
        println!("|---|---:|---:|---:|---:|---:|---:|---:|");
        let (o, t) = compare(
            |_| {
                black_box(ours_stream(black_box(&stream)));
            },
            |_| {
                black_box(theirs_stream(black_box(&stream)));
            },
        );
        let (msgs, bytes) = (frames as f64, stream.len() as f64);
        Row {
            case,
            ours_s: o,
            theirs_s: t,
            msgs,
            bytes,
        }
        .print(true);
    }
}
