//! The stream parser against chunked, noisy and hostile input.

mod common;

use common::*;
use ferrolink_runtime::mavlink::parser::{Feed, Parser, Stats};
use ferrolink_runtime::mavlink::signing::{SecretKey, Signer};
use ferrolink_runtime::mavlink::{v1, v2, Dialect, MessageMeta};

/// A wider table for the torture stream: the test dialect plus two raw entries.
static TORTURE_META: &[MessageMeta] = &[
    meta_of::<Heartbeat>(),
    raw_meta(30, 39, 28, 28),
    meta_of::<ExtMsg>(),
    raw_meta(253, 83, 51, 54),
    meta_of::<Big>(),
];

const fn raw_meta(id: u32, crc_extra: u8, min_len: u8, max_len: u8) -> MessageMeta {
    MessageMeta {
        id,
        crc_extra,
        min_len,
        max_len,
        target_system: None,
        target_component: None,
    }
}

/// Feeds `chunks` one after the other; returns the frames (bytes, checked) and the stats.
fn run<'c>(
    parser: &mut Parser,
    chunks: impl IntoIterator<Item = &'c [u8]>,
) -> (Vec<(Vec<u8>, bool)>, Stats) {
    let mut frames = Vec::new();
    let mut fed = 0usize;
    let mut frame_bytes = 0usize;
    for chunk in chunks {
        fed += chunk.len();
        let mut input = chunk;
        loop {
            match parser.feed(input) {
                Feed::Consumed => break,
                Feed::Frame { frame, remaining } => {
                    assert!(remaining.len() <= input.len());
                    frame_bytes += frame.as_bytes().len();
                    if let Some(meta) = frame.meta() {
                        assert!(frame.frame().check_crc(meta.crc_extra));
                    }
                    frames.push((frame.as_bytes().to_vec(), frame.is_checked()));
                    input = remaining;
                }
            }
        }
        let s = parser.stats();
        assert_eq!(
            s.garbage_bytes + s.rejected() + frame_bytes + parser.buffered(),
            fed,
            "every byte is accounted for"
        );
    }
    (frames, *parser.stats())
}

fn run_chunked(
    table: &'static [MessageMeta],
    stream: &[u8],
    chunk: usize,
) -> (Vec<Vec<u8>>, Stats) {
    let mut parser = Parser::new(table);
    let (frames, stats) = run(&mut parser, stream.chunks(chunk));
    (frames.into_iter().map(|(f, _)| f).collect(), stats)
}

/// A stream of many frames of every kind, with a little noise between some of them.
fn mixed_stream() -> (Vec<u8>, Vec<Vec<u8>>) {
    let mut rng = XorShift::new(0x5EED_0001);
    let mut signer = Signer::new(SecretKey::new(GOLDEN_KEY), 3);
    let mut stream = hex("00fdfe55");
    let mut expected = Vec::new();
    for i in 0..36 {
        let meta = if i == 17 {
            &TestDialect::META[2] // one frame with the largest payload
        } else {
            &TestDialect::META[i % 2]
        };
        let kind = [Kind::V1, Kind::V2, Kind::Signed][i % 3];
        let frame = random_frame(&mut rng, meta, kind, &mut signer);
        stream.extend_from_slice(&frame);
        expected.push(frame);
        if i % 5 == 0 {
            stream.extend_from_slice(&[0xFD, 0x07, 0x00, 0xFE, 0x13]);
        }
    }
    (stream, expected)
}

#[test]
fn every_chunk_size_gives_the_same_frames() {
    let (stream, expected) = mixed_stream();
    let (whole, reference) = run_chunked(TestDialect::META, &stream, stream.len());
    assert_eq!(whole, expected);
    assert_eq!(reference.frames, expected.len());
    eprintln!("{} bytes, {:?}", stream.len(), reference);
    for chunk in 1..=stream.len() {
        let (frames, stats) = run_chunked(TestDialect::META, &stream, chunk);
        assert_eq!(frames, expected, "chunk size {chunk}");
        assert_eq!(stats, reference, "chunk size {chunk}");
    }
}

#[test]
fn random_splits_give_the_same_frames() {
    let (stream, expected) = mixed_stream();
    let mut rng = XorShift::new(99);
    for _ in 0..200 {
        let mut chunks = Vec::new();
        let mut rest = &stream[..];
        while !rest.is_empty() {
            let n = (rng.below(40) as usize).min(rest.len());
            let (a, b) = rest.split_at(n);
            chunks.push(a); // empty chunks included
            rest = b;
        }
        let mut parser = Parser::new(TestDialect::META);
        let (frames, _) = run(&mut parser, chunks);
        let frames: Vec<_> = frames.into_iter().map(|(f, _)| f).collect();
        assert_eq!(frames, expected);
    }
}

#[derive(Debug, Default)]
struct Inserted {
    garbage: usize,
    false_magic: usize,
    truncated: usize,
    bad_crc: usize,
    unknown_id: usize,
    bad_flags: usize,
    signed: usize,
}

struct Torture {
    stream: Vec<u8>,
    expected: Vec<Vec<u8>>,
    inserted: Inserted,
}

fn intact(rng: &mut XorShift, signer: &mut Signer) -> (Vec<u8>, Kind) {
    let meta = rng.pick(TORTURE_META);
    let kind = match rng.below(3) {
        0 if meta.id <= v1::MAX_MSG_ID => Kind::V1,
        1 => Kind::Signed,
        _ => Kind::V2,
    };
    (random_frame(rng, meta, kind, signer), kind)
}

/// Builds the torture stream: `wanted` intact frames among garbage, false magic bytes claiming
/// long lengths, truncated frames (cut before the checksum ends), bad checksums, unknown ids and
/// unknown incompat flags.
fn torture(seed: u64, wanted: usize) -> Torture {
    let mut rng = XorShift::new(seed);
    let mut signer = Signer::new(SecretKey::new(GOLDEN_KEY), 9);
    let mut t = Torture {
        stream: Vec::new(),
        expected: Vec::new(),
        inserted: Inserted::default(),
    };
    while t.expected.len() < wanted {
        match rng.below(10) {
            0..=3 => {
                let (frame, kind) = intact(&mut rng, &mut signer);
                t.inserted.signed += usize::from(kind == Kind::Signed);
                t.stream.extend_from_slice(&frame);
                t.expected.push(frame);
            }
            4 => {
                let n = 1 + rng.below(64) as usize;
                t.stream.extend(rng.bytes(n));
                t.inserted.garbage += 1;
            }
            5 => {
                // A header that passes every early check and claims a long payload.
                let meta = rng.pick(TORTURE_META);
                let len = 128 + rng.below(128) as u8;
                let [a, b, c, _] = meta.id.to_le_bytes();
                if meta.id <= v1::MAX_MSG_ID && rng.below(2) == 0 {
                    t.stream.extend_from_slice(&[v1::MAGIC, len, 1, 2, 3, a]);
                } else {
                    let flags = rng.below(2) as u8;
                    t.stream
                        .extend_from_slice(&[v2::MAGIC, len, flags, 0, 1, 2, 3, a, b, c]);
                }
                t.inserted.false_magic += 1;
            }
            6 => {
                let (frame, _) = intact(&mut rng, &mut signer);
                let head = if frame[0] == v1::MAGIC {
                    v1::HEADER_LEN
                } else {
                    v2::HEADER_LEN
                };
                let crc_end = head + usize::from(frame[1]) + 2;
                let cut = 1 + rng.below(crc_end as u64 - 1) as usize;
                t.stream.extend_from_slice(&frame[..cut]);
                t.inserted.truncated += 1;
            }
            7 => {
                let (mut frame, _) = intact(&mut rng, &mut signer);
                let head = if frame[0] == v1::MAGIC {
                    v1::HEADER_LEN
                } else {
                    v2::HEADER_LEN
                };
                let crc_end = head + usize::from(frame[1]) + 2;
                let at = head + rng.below((crc_end - head) as u64) as usize;
                frame[at] ^= 1 << rng.below(8);
                t.stream.extend_from_slice(&frame);
                t.inserted.bad_crc += 1;
            }
            8 => {
                let id = *rng.pick(&UNKNOWN_IDS);
                let len = 1 + rng.below(40) as usize;
                let payload = rng.bytes(len);
                let mut out = [0u8; v2::MAX_FRAME_LEN];
                let header = random_header(&mut rng);
                let n = if id <= v1::MAX_MSG_ID && rng.below(2) == 0 {
                    v1::encode_raw(header, id, rng.byte(), &payload, &mut out)
                } else {
                    v2::encode_raw(header, id, rng.byte(), &payload, &mut out)
                }
                .unwrap();
                t.stream.extend_from_slice(&out[..n]);
                t.inserted.unknown_id += 1;
            }
            _ => {
                let meta = rng.pick(TORTURE_META);
                let kind = if rng.below(2) == 0 {
                    Kind::V2
                } else {
                    Kind::Signed
                };
                let mut frame = random_frame(&mut rng, meta, kind, &mut signer);
                frame[2] |= 2 << rng.below(7);
                fix_crc(&mut frame, meta.crc_extra);
                t.stream.extend_from_slice(&frame);
                t.inserted.bad_flags += 1;
            }
        }
    }
    // Let every pending candidate complete (and fail).
    t.stream.extend_from_slice(&[0; v2::MAX_FRAME_LEN]);
    t
}

#[test]
fn torture_stream_recovers_every_intact_frame() {
    for seed in [1, 0xDEAD_BEEF, 373] {
        let t = torture(seed, 373);
        let (frames, stats) = run_chunked(TORTURE_META, &t.stream, t.stream.len());
        assert_eq!(frames.len(), t.expected.len(), "seed {seed}");
        assert_eq!(frames, t.expected, "seed {seed}");
        eprintln!(
            "seed {seed}: {} bytes, {:?}, {:?}",
            t.stream.len(),
            t.inserted,
            stats
        );

        // Plausible counters.
        let ins = &t.inserted;
        assert!(
            ins.garbage > 20 && ins.false_magic > 20 && ins.truncated > 20,
            "{ins:?}"
        );
        assert!(
            ins.bad_crc > 20 && ins.unknown_id > 20 && ins.bad_flags > 20,
            "{ins:?}"
        );
        assert!(ins.signed > 50, "{ins:?}");
        assert_eq!(stats.frames, 373);
        assert_eq!(stats.unchecked, 0);
        assert!(stats.bad_flags >= ins.bad_flags, "{stats:?} {ins:?}");
        assert!(stats.unknown_id >= ins.unknown_id, "{stats:?} {ins:?}");
        assert!(
            stats.bad_crc >= ins.bad_crc + ins.false_magic,
            "{stats:?} {ins:?}"
        );
        let magic_bytes = t.stream.iter().filter(|&&b| b == 0xFD || b == 0xFE).count();
        assert!(stats.rejected() <= magic_bytes);
        assert!(stats.garbage_bytes >= v2::MAX_FRAME_LEN);
        let frame_bytes: usize = t.expected.iter().map(|f| f.len()).sum();
        assert_eq!(
            stats.garbage_bytes + stats.rejected() + frame_bytes,
            t.stream.len()
        );

        for chunk in [1, 2, 3, 7, 10, 64, 255, 279, 280, 281, 1000, 4096] {
            let (frames, chunked) = run_chunked(TORTURE_META, &t.stream, chunk);
            assert_eq!(frames, t.expected, "seed {seed} chunk {chunk}");
            assert_eq!(chunked, stats, "seed {seed} chunk {chunk}");
        }
    }
}

/// What a parser that trusts the length byte (skipping a whole claimed length after a false
/// magic byte) would recover, to show the torture stream actually hides frames.
fn skip_claimed_length(stream: &[u8]) -> usize {
    let mut i = 0;
    let mut n = 0;
    while i < stream.len() {
        let Some(f) = ferrolink_runtime::mavlink::AnyFrame::new_checked(&stream[i..]).ok() else {
            i += 1;
            continue;
        };
        let ok = ferrolink_runtime::mavlink::find_meta(TORTURE_META, f.msg_id()).is_some_and(|m| {
            f.check_crc(m.crc_extra) && !f.as_v2().is_some_and(|v| v.has_unknown_flags())
        });
        n += usize::from(ok);
        i += f.frame_len();
    }
    n
}

#[test]
fn torture_stream_defeats_a_length_trusting_parser() {
    let t = torture(1, 373);
    let naive = skip_claimed_length(&t.stream);
    eprintln!("length-trusting parser: {naive} of 373 frames");
    assert!(naive < 373 * 9 / 10, "naive parser recovered {naive}");
}

#[test]
fn unknown_ids_pass_through_unchecked_when_enabled() {
    let mut rng = XorShift::new(5);
    let mut stream = Vec::new();
    let mut expected = Vec::new();
    let mut signer = Signer::new(SecretKey::new([1; 32]), 0);
    for (i, &id) in UNKNOWN_IDS.iter().enumerate() {
        let frame = random_frame(&mut rng, &TestDialect::META[0], Kind::V2, &mut signer);
        stream.extend_from_slice(&frame);
        expected.push((frame, true));
        let mut out = [0u8; 64];
        let n = v2::encode_raw(random_header(&mut rng), id, i as u8, &[1, 2, 3], &mut out).unwrap();
        stream.extend_from_slice(&out[..n]);
        expected.push((out[..n].to_vec(), false));
    }
    for chunk in [1, 5, stream.len()] {
        let mut parser: Parser = Parser::for_dialect::<TestDialect>().pass_unknown_ids(true);
        let (frames, stats) = run(&mut parser, stream.chunks(chunk));
        assert_eq!(frames, expected);
        assert_eq!(stats.unchecked, 4);
        assert_eq!(stats.unknown_id, 0);

        let mut strict: Parser = Parser::for_dialect::<TestDialect>();
        let (frames, stats) = run(&mut strict, stream.chunks(chunk));
        assert_eq!(frames.len(), 4);
        assert_eq!(stats.unknown_id, 4);
    }
}

#[test]
fn decoded_messages_survive_the_parser() {
    let ext = ExtMsg {
        base_i32: -5,
        base_u16: 0xBEEF,
        base_u8: 1,
        ext_u8: 2,
        ext_f32: 1.5,
    };
    let mut out = [0u8; 600];
    let n1 = v2::encode(common_header(), &ext, &mut out).unwrap();
    let n2 = v1::encode(common_header(), &ext, &mut out[n1..]).unwrap();
    let mut parser: Parser = Parser::for_dialect::<TestDialect>();
    let mut got = Vec::new();
    parser.feed_all(&out[..n1 + n2], |f| {
        got.push(f.decode::<TestDialect>().unwrap())
    });
    let base_only = ExtMsg {
        ext_u8: 0,
        ext_f32: 0.0,
        ..ext
    };
    assert_eq!(got, [TestDialect::Ext(ext), TestDialect::Ext(base_only)]);
}

fn common_header() -> ferrolink_runtime::mavlink::Header {
    ferrolink_runtime::mavlink::Header::new(42, 7, 190)
}
