//! Property tests: whatever is encoded comes back out of the frame views and the stream parser.

mod common;

use common::*;
use ferrolink_runtime::mavlink::parser::{Feed, Parser};
use ferrolink_runtime::mavlink::signing::{SecretKey, Signer, Verifier};
use ferrolink_runtime::mavlink::{v1, v2, AnyFrame, Header, MessageMeta, Version};
use proptest::prelude::*;

/// A one-message table for an arbitrary id, owned by the parser it is given to.
fn table(id: u32, crc_extra: u8) -> [MessageMeta; 1] {
    [MessageMeta {
        id,
        crc_extra,
        min_len: 0,
        max_len: 255,
        target_system: None,
        target_component: None,
    }]
}

fn header() -> impl Strategy<Value = Header> {
    (any::<u8>(), any::<u8>(), any::<u8>()).prop_map(|(s, y, c)| Header::new(s, y, c))
}

fn parse_one(table: [MessageMeta; 1], bytes: &[u8]) -> Vec<u8> {
    let mut parser = Parser::<{ v2::MAX_FRAME_LEN }, _>::new(table);
    match parser.feed(bytes) {
        Feed::Frame { frame, remaining } => {
            assert!(remaining.is_empty());
            assert!(frame.is_checked());
            frame.as_bytes().to_vec()
        }
        Feed::Consumed => panic!("no frame"),
    }
}

fn zero_extended(p: &[u8]) -> [u8; 255] {
    ferrolink_runtime::wire::zero_extend(p)
}

proptest! {
    #[test]
    fn v2_round_trip(
        h in header(),
        id in 0u32..=v2::MAX_MSG_ID,
        crc_extra: u8,
        payload in proptest::collection::vec(any::<u8>(), 0..=255),
    ) {
        let mut out = [0xA5u8; v2::MAX_UNSIGNED_FRAME_LEN];
        let n = v2::encode_raw(h, id, crc_extra, &payload, &mut out).unwrap();
        let frame = v2::Frame::new_checked(&out[..n]).unwrap();
        prop_assert_eq!(frame.header(), h);
        prop_assert_eq!(frame.msg_id(), id);
        prop_assert_eq!((frame.incompat_flags(), frame.compat_flags()), (0, 0));
        prop_assert!(frame.check_crc(crc_extra));
        prop_assert!(!frame.payload().is_empty());
        prop_assert!(frame.payload().last() != Some(&0) || frame.payload().len() == 1);
        prop_assert_eq!(zero_extended(frame.payload()), zero_extended(&payload));

        let parsed = parse_one(table(id, crc_extra), &out[..n]);
        prop_assert_eq!(&parsed[..], &out[..n]);
    }

    #[test]
    fn v1_round_trip(
        h in header(),
        id in 0u32..=v1::MAX_MSG_ID,
        crc_extra: u8,
        payload in proptest::collection::vec(any::<u8>(), 0..=255),
    ) {
        let mut out = [0xA5u8; v1::MAX_FRAME_LEN];
        let n = v1::encode_raw(h, id, crc_extra, &payload, &mut out).unwrap();
        prop_assert_eq!(n, payload.len() + 8);
        let frame = AnyFrame::new_checked(&out[..n]).unwrap();
        prop_assert_eq!(frame.version(), Version::V1);
        prop_assert_eq!(frame.header(), h);
        prop_assert_eq!(frame.msg_id(), id);
        prop_assert!(frame.check_crc(crc_extra));
        prop_assert_eq!(frame.payload(), &payload[..]);
        let parsed = parse_one(table(id, crc_extra), &out[..n]);
        prop_assert_eq!(&parsed[..], &out[..n]);
    }

    #[test]
    fn signed_round_trip(
        h in header(),
        id in 0u32..=v2::MAX_MSG_ID,
        crc_extra: u8,
        payload in proptest::collection::vec(any::<u8>(), 0..=255),
        key: [u8; 32],
        link: u8,
        now in 0u64..(1 << 48),
    ) {
        let mut signer = Signer::new(SecretKey::new(key), link);
        let mut out = [0u8; v2::MAX_FRAME_LEN];
        let n = signer.encode_raw(now, h, id, crc_extra, &payload, &mut out).unwrap();
        let parsed = parse_one(table(id, crc_extra), &out[..n]);
        let frame = v2::Frame::new_checked(&parsed[..]).unwrap();
        prop_assert!(frame.is_signed());
        prop_assert_eq!(frame.link_id(), Some(link));
        prop_assert_eq!(frame.timestamp(), Some(now.max(1)));
        prop_assert_eq!(zero_extended(frame.payload()), zero_extended(&payload));
        let mut verifier = Verifier::<1>::new(SecretKey::new(key));
        prop_assert_eq!(verifier.verify(&frame, now), Ok(()));
    }

    #[test]
    fn typed_messages_round_trip(
        h in header(),
        base_i32: i32, base_u16: u16, base_u8: u8, ext_u8: u8, ext_bits: u32,
    ) {
        let msg = ExtMsg { base_i32, base_u16, base_u8, ext_u8, ext_f32: f32::from_bits(ext_bits) };
        let mut out = [0u8; 64];
        let n = v2::encode(h, &msg, &mut out).unwrap();
        let back: ExtMsg = v2::Frame::new_checked(&out[..n]).unwrap().decode_message();
        prop_assert_eq!(back.ext_f32.to_bits(), ext_bits);
        prop_assert_eq!((back.base_i32, back.base_u16, back.base_u8, back.ext_u8),
                        (base_i32, base_u16, base_u8, ext_u8));
        let n = v1::encode(h, &msg, &mut out).unwrap();
        prop_assert_eq!(n, 8 + <ExtMsg as ferrolink_runtime::mavlink::Message>::MIN_LEN);
        let back: ExtMsg = v1::Frame::new_checked(&out[..n]).unwrap().decode_message();
        prop_assert_eq!((back.base_i32, back.ext_u8, back.ext_f32.to_bits()), (base_i32, 0, 0));
    }

    /// Any bytes in any split: no panic, the same frames as in one piece, every byte accounted.
    #[test]
    fn arbitrary_bytes_any_split(
        segments in proptest::collection::vec(
            prop_oneof![
                proptest::collection::vec(
                    prop_oneof![any::<u8>(), Just(0xFDu8), Just(0xFEu8), Just(0u8)], 0..40),
                Just(hex(GOLDEN_V2)),
                Just(hex(GOLDEN_V1)),
                Just(hex(GOLDEN_SIGNED)),
            ],
            0..60,
        ),
        cuts in proptest::collection::vec(0usize..2000, 0..20),
        pass_unknown: bool,
    ) {
        let data: Vec<u8> = segments.concat();
        let collect = |pieces: &[&[u8]]| {
            let mut parser: Parser = Parser::for_dialect::<TestDialect>().pass_unknown_ids(pass_unknown);
            let mut frames = Vec::new();
            for piece in pieces {
                parser.feed_all(piece, |f| frames.push(f.as_bytes().to_vec()));
            }
            let s = *parser.stats();
            let frame_bytes: usize = frames.iter().map(Vec::len).sum();
            assert_eq!(
                s.garbage_bytes + s.rejected() + frame_bytes + parser.buffered(),
                data.len()
            );
            (frames, s)
        };
        let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c.min(data.len())).collect();
        cuts.sort_unstable();
        let mut pieces = Vec::new();
        let mut at = 0;
        for c in cuts.into_iter().chain([data.len()]) {
            pieces.push(&data[at..c]);
            at = c;
        }
        prop_assert_eq!(collect(&pieces), collect(&[&data[..]]));
    }
}
