//! NDLCom frames: the spec's golden frames, property round trips, every chunk size, garbage.

use ferrolink_runtime::ndlcom::parser::{Feed, Parser, Stats};
use ferrolink_runtime::ndlcom::{
    encode, encode_parts, encode_with, encoded_len, max_encoded_len, storage_len, Header,
    MAX_FRAME_LEN,
};
use proptest::prelude::*;

#[path = "scripts/ndlcom.rs"]
mod scripts;

/// (receiver, sender, counter, payload, encoded).
type GoldenRow = (u8, u8, u8, Vec<u8>, Vec<u8>);

/// (receiver, sender, counter, payload, encoded), from the protocol facts.
fn golden() -> Vec<(Header, Vec<u8>, Vec<u8>)> {
    let rows: [GoldenRow; 6] = [
        (0, 0, 0, vec![], vec![126, 0, 0, 0, 0, 33, 3, 126]),
        (
            0,
            0,
            0,
            vec![0; 6],
            vec![126, 0, 0, 0, 6, 0, 0, 0, 0, 0, 0, 74, 196, 126],
        ),
        (1, 0, 0, vec![], vec![126, 1, 0, 0, 0, 154, 31, 126]),
        (
            126,
            1,
            0,
            vec![126],
            vec![126, 125, 94, 1, 0, 1, 125, 94, 89, 219, 126],
        ),
        (
            93,
            121,
            252,
            vec![47, 98, 168],
            vec![126, 93, 121, 252, 3, 47, 98, 168, 125, 93, 52, 126],
        ),
        (
            129,
            1,
            1,
            (0..16).collect(),
            [
                vec![126, 129, 1, 1, 16],
                (0..16).collect(),
                vec![154, 208, 126],
            ]
            .concat(),
        ),
    ];
    rows.into_iter()
        .map(|(r, s, c, p, e)| (Header::new(r, s, c, p.len() as u8), p, e))
        .collect()
}

/// Decodes a whole stream, fed in chunks of `chunk` bytes, into (header, payload) pairs.
fn decode_chunked(
    stream: &[u8],
    chunk: usize,
    max_payload: usize,
) -> (Vec<(Header, Vec<u8>)>, Stats) {
    // The const constructor a firmware's `static` uses; `caller_storage_works_too` covers `new`.
    let mut parser = Parser::<[u8; storage_len(255)]>::zeroed();
    parser.set_max_payload(max_payload);
    let mut out = Vec::new();
    for piece in stream.chunks(chunk.max(1)) {
        parser.feed_all(piece, |f| out.push((f.header(), f.payload().to_vec())));
    }
    parser.finish();
    (out, *parser.stats())
}

#[test]
fn golden_frames_encode() {
    for (header, payload, encoded) in golden() {
        let mut buf = [0xa5u8; MAX_FRAME_LEN];
        let n = encode(&header, &payload, &mut buf).unwrap();
        assert_eq!(&buf[..n], &encoded[..], "{header:?}");
        assert!(buf[n..].iter().all(|&b| b == 0xa5), "wrote past the frame");
        assert_eq!(encoded_len(&header, &[&payload]), n);
        let mut streamed = Vec::new();
        encode_with(&header, &[&payload], |run| streamed.extend_from_slice(run)).unwrap();
        assert_eq!(streamed, encoded);
    }
}

#[test]
fn golden_frames_decode_at_every_chunk_size() {
    let all: Vec<u8> = golden().iter().flat_map(|g| g.2.clone()).collect();
    let want: Vec<_> = golden().into_iter().map(|(h, p, _)| (h, p)).collect();
    for chunk in 1..=all.len() {
        let (got, stats) = decode_chunked(&all, chunk, 255);
        assert_eq!(got, want, "chunk {chunk}");
        assert_eq!(stats.dropped() + stats.crc_failures, 0);
        assert_eq!(stats.bytes, all.len());
    }
}

#[test]
fn frames_without_flags_between_them() {
    // The closing flag is optional: the length field delimits frames.
    let mut stream = Vec::new();
    for (_, _, encoded) in golden() {
        stream.extend_from_slice(&encoded[..encoded.len() - 1]);
    }
    let (got, stats) = decode_chunked(&stream, 5, 255);
    assert_eq!(got.len(), 6);
    assert_eq!(stats.dropped(), 0);
}

#[test]
fn residue_is_zero() {
    use ferrolink_runtime::crc::mcrf4xx;
    for (header, payload, _) in golden() {
        let mut bytes = header.emit().to_vec();
        bytes.extend_from_slice(&payload);
        let fcs = mcrf4xx(&bytes);
        bytes.extend_from_slice(&fcs.to_le_bytes());
        assert_eq!(mcrf4xx(&bytes), 0);
    }
}

#[test]
fn broken_frames_are_counted_never_returned() {
    let g = golden();
    let good = &g[5].2;
    let mut stream = Vec::new();
    // 1. garbage before the first flag: a truncated frame.
    stream.extend_from_slice(&[1, 2, 3]);
    stream.extend_from_slice(good);
    // 2. a flipped payload bit: an FCS failure.
    let mut bad = good.clone();
    bad[8] ^= 0x10;
    stream.extend_from_slice(&bad);
    // 3. cut short by the next frame's flag.
    stream.extend_from_slice(&good[..10]);
    stream.extend_from_slice(good);
    // 4. an invalid escape.
    stream.extend_from_slice(&[126, 1, 0x7d, 0x11, 5, 6, 7]);
    stream.extend_from_slice(good);
    // 5. oversize for a 15-byte limit: skipped whole, even without flags around it.
    let big = &g[4].2; // 3-byte payload, fine
    stream.extend_from_slice(big);
    stream.extend_from_slice(&good[1..good.len() - 1]); // 16-byte payload, no flags
    stream.extend_from_slice(big);
    // 6. unterminated at the end.
    stream.extend_from_slice(&good[..7]);
    for chunk in [1, 2, 3, 7, 64, stream.len()] {
        let (got, stats) = decode_chunked(&stream, chunk, 15);
        let receivers: Vec<u8> = got.iter().map(|(h, _)| h.receiver).collect();
        assert_eq!(receivers, [93, 93], "chunk {chunk}");
        assert_eq!(
            stats.crc_failures, 0,
            "oversize drops come before any FCS check"
        );
        assert_eq!(stats.oversize, 7, "every 16-byte frame, broken or not");
        let (got, stats) = decode_chunked(&stream, chunk, 255);
        let receivers: Vec<u8> = got.iter().map(|(h, _)| h.receiver).collect();
        assert_eq!(receivers, [129, 129, 129, 93, 129, 93], "chunk {chunk}");
        assert_eq!(
            (
                stats.crc_failures,
                stats.truncated,
                stats.bad_escape,
                stats.oversize
            ),
            (1, 3, 1, 0),
            "chunk {chunk}"
        );
    }
}

#[test]
fn oversize_frame_is_never_read_as_a_header() {
    // A 200-byte payload full of bytes that look like a valid frame.
    let mut inner = [0u8; 16];
    let n = encode(&Header::new(9, 9, 9, 0), &[], &mut inner).unwrap();
    let mut payload = Vec::new();
    while payload.len() + n <= 200 {
        payload.extend_from_slice(&inner[1..n - 1]); // without flags
    }
    payload.resize(200, 0);
    let mut frame = vec![0u8; MAX_FRAME_LEN];
    let len = encode(&Header::new(1, 2, 3, 200), &payload, &mut frame).unwrap();
    let (got, stats) = decode_chunked(&frame[..len - 1], 1, 64); // no closing flag either
    assert!(got.is_empty(), "{got:?}");
    assert_eq!(stats.oversize, 1);
    assert_eq!(stats.crc_failures, 0);
}

#[test]
fn storage_too_small_for_a_frame_drops_it_and_goes_on() {
    // Five bytes hold a header but not the two FCS bytes of even an empty frame.
    let mut parser = Parser::new([0u8; 5]);
    let empty = &golden()[0].2;
    let mut frames = 0;
    parser.feed_all(empty, |_| frames += 1);
    parser.feed_all(empty, |_| frames += 1);
    assert_eq!(frames, 0);
    assert_eq!(parser.stats().oversize, 2);
    assert_eq!(parser.stats().bytes, 2 * empty.len());
}

#[test]
fn caller_storage_works_too() {
    let mut storage = [0u8; 32];
    let mut parser = Parser::new(&mut storage[..]);
    assert_eq!(parser.max_payload(), 26);
    // A limit above what the storage holds is capped by it; a lower one holds.
    parser.set_max_payload(1000);
    assert_eq!(parser.max_payload(), 26);
    parser.set_max_payload(20);
    assert_eq!(parser.max_payload(), 20);
    parser.set_max_payload(26);
    let encoded = &golden()[5].2;
    let Feed::Frame { frame, remaining } = parser.feed(encoded) else {
        panic!("no frame")
    };
    assert_eq!(frame.payload().len(), 16);
    assert_eq!(frame.fcs(), u16::from_le_bytes([154, 208]));
    assert!(remaining.is_empty() || remaining == [126]);
}

fn arb_frame() -> impl Strategy<Value = (Header, Vec<u8>)> {
    let special = prop_oneof![Just(0x7eu8), Just(0x7d), any::<u8>()];
    (
        any::<(u8, u8, u8)>(),
        prop::collection::vec(special, 0..=255),
    )
        .prop_map(|((r, s, c), p)| (Header::new(r, s, c, p.len() as u8), p))
}

proptest! {
    #[test]
    fn round_trip(frames in prop::collection::vec(arb_frame(), 1..6), chunk in 1usize..40,
                  garbage in prop::collection::vec(any::<u8>(), 0..20)) {
        let mut stream = Vec::new();
        for (h, p) in &frames {
            let mut buf = [0xa5u8; MAX_FRAME_LEN];
            let n = encode(h, p, &mut buf).unwrap();
            prop_assert!(n <= max_encoded_len(p.len()));
            prop_assert_eq!(n, encoded_len(h, &[p]));
            // Only the flags are 0x7E.
            prop_assert!(buf[1..n - 1].iter().all(|&b| b != 0x7e));
            stream.extend_from_slice(&buf[..n]);
            // Garbage between frames is cut off by the next flag.
            stream.extend_from_slice(&garbage);
        }
        let (got, stats) = decode_chunked(&stream, chunk, 255);
        prop_assert_eq!(got, frames.clone());
        prop_assert_eq!(stats.frames, frames.len());
    }

    #[test]
    fn parts_are_one_payload(p in prop::collection::vec(any::<u8>(), 0..=255), cut in any::<prop::sample::Index>()) {
        let h = Header::new(1, 2, 3, p.len() as u8);
        let at = cut.index(p.len() + 1);
        let (a, b) = p.split_at(at);
        let mut x = [0u8; MAX_FRAME_LEN];
        let mut y = [0u8; MAX_FRAME_LEN];
        let n = encode(&h, &p, &mut x).unwrap();
        let m = encode_parts(&h, &[a, b], &mut y).unwrap();
        prop_assert_eq!(&x[..n], &y[..m]);
    }

    #[test]
    fn parser_invariants(data in prop::collection::vec(any::<u8>(), 0..700)) {
        scripts::check_parser(&data);
    }

    #[test]
    fn bridge_invariants(data in prop::collection::vec(any::<u8>(), 0..700)) {
        scripts::check_bridge(&data);
    }

    #[test]
    fn parser_invariants_on_frames(frames in prop::collection::vec(arb_frame(), 1..4), seed in any::<u8>()) {
        // Mostly valid frames, so the re-encoding checks see real frames.
        let mut data = vec![seed];
        for (h, p) in &frames {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let n = encode(h, p, &mut buf).unwrap();
            data.extend_from_slice(&buf[..n]);
        }
        scripts::check_parser(&data);
    }

    #[test]
    fn any_input_is_safe(bytes in prop::collection::vec(any::<u8>(), 0..600), chunk in 1usize..64) {
        let (_, stats) = decode_chunked(&bytes, chunk, 100);
        prop_assert_eq!(stats.bytes, bytes.len());
    }
}

/// Found by `cargo fuzz run ndlcom_bridge`: interface 0 went cut-through, store & forward and
/// cut-through again while frames arrived; the plan of a cut-off broadcast was applied to the
/// next frame, and a frame for 0 was handed to `on_local` of node 1.
#[test]
fn fuzz_regression_mode_change_mid_frame() {
    let script =
        hex::decode("00ffff0000e7007e30ff7a7e012c7e00ffffffff007e000000000021ff0003").expect("hex");
    scripts::check_bridge(&script);
}

/// A frame is forwarded in the mode its pair had when the frame began: changing the mode while a
/// frame is arriving finishes that frame whole, once, in the old mode, and the next frame goes in
/// the new one. For every interface pair and both directions of the change.
#[test]
fn a_mode_change_mid_frame_finishes_the_frame_in_the_mode_it_began() {
    use ferrolink_runtime::ndlcom::bridge::{Bridge, Mode};
    type B = Bridge<3, { storage_len(255) }, 600>;
    let encoded = |counter: u8| {
        let payload = [0x7E, 0x7D, counter, 0x7E, 1, 2, 3, 4];
        let mut buf = [0u8; 64];
        let n = encode(&Header::new(20, 30, counter, 8), &payload, &mut buf).expect("fits");
        buf[..n].to_vec()
    };
    let drain = |b: &mut B, i: usize| {
        let mut out = [0u8; 1024];
        let n = b.transmit(i, &mut out);
        out[..n].to_vec()
    };
    for from in 0..3 {
        for to in (0..3).filter(|&to| to != from) {
            let other = 3 - from - to;
            for (before, after) in [
                (Mode::StoreForward, Mode::CutThrough),
                (Mode::CutThrough, Mode::StoreForward),
            ] {
                let case = format!("{from} -> {to}, {before:?} -> {after:?}");
                let mut b = B::new();
                b.router_mut().add_own_id(1);
                b.router_mut().seed(20, to);
                b.set_mode(from, to, before);
                let first = encoded(1);
                let half = first.len() / 2;
                b.receive(from, &first[..half], 0, |_| {
                    panic!("{case}: not for this node")
                });
                let streaming = b.pending(to) > 0;
                assert_eq!(streaming, before == Mode::CutThrough, "{case}: first half");
                b.set_mode(from, to, after);
                b.receive(from, &first[half..], 10, |_| {
                    panic!("{case}: not for this node")
                });
                assert_eq!(
                    drain(&mut b, to),
                    first,
                    "{case}: the frame, whole and once"
                );
                assert!(drain(&mut b, other).is_empty(), "{case}: nothing elsewhere");
                assert!(drain(&mut b, from).is_empty(), "{case}: nothing back");
                assert_eq!(b.router().lookup(30), Some(from), "{case}: learned");

                // The next frame goes in the new mode.
                let second = encoded(2);
                b.receive(from, &second[..2], 20, |_| {
                    panic!("{case}: not for this node")
                });
                assert_eq!(b.pending(to) > 0, after == Mode::CutThrough, "{case}: next");
                b.receive(from, &second[2..], 30, |_| {
                    panic!("{case}: not for this node")
                });
                assert_eq!(drain(&mut b, to), second, "{case}: the next frame");
                assert_eq!(b.stats(from).rx_frames, 2, "{case}");
            }
        }
    }
}
