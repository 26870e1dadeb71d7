use std::vec::Vec;

#[test]
fn move_to_front_moves_any_overlap() {
    for len in 0..40 {
        for start in 0..=len {
            for end in start..=len {
                let mut buf: Vec<u8> = (0..len as u8).collect();
                let mut want = buf.clone();
                want.copy_within(start..end, 0);
                super::move_to_front(&mut buf, start, end);
                assert_eq!(
                    buf[..end - start],
                    want[..end - start],
                    "{start}..{end} of {len}"
                );
            }
        }
    }
}

use super::*;
use crate::mavlink::testing::{
    golden_heartbeat, hex, Big, ExtMsg, TestDialect, GOLDEN_SIGNED, GOLDEN_V1, GOLDEN_V2,
};
use crate::mavlink::{Dialect, Message};

type P = Parser;

/// Feeds `stream` in chunks of `chunk` bytes and collects (frame bytes, checked) pairs.
fn collect(parser: &mut P, stream: &[u8], chunk: usize) -> Vec<(Vec<u8>, bool)> {
    let mut out = Vec::new();
    for piece in stream.chunks(chunk) {
        parser.feed_all(piece, |f| out.push((f.as_bytes().to_vec(), f.is_checked())));
    }
    out
}

fn accounted(parser: &P) -> usize {
    let s = parser.stats();
    s.garbage_bytes + s.rejected() + parser.buffered()
}

#[test]
fn golden_frames_come_out_whole() {
    let mut stream = hex(GOLDEN_V2);
    stream.extend(hex(GOLDEN_V1));
    stream.extend(hex(GOLDEN_SIGNED));
    for chunk in 1..=stream.len() {
        let mut p = P::for_dialect::<TestDialect>();
        let got = collect(&mut p, &stream, chunk);
        assert_eq!(
            got,
            [
                (hex(GOLDEN_V2), true),
                (hex(GOLDEN_V1), true),
                (hex(GOLDEN_SIGNED), true)
            ],
            "chunk {chunk}"
        );
        assert_eq!(p.stats().frames, 3);
        assert_eq!(accounted(&p), 0);
    }
}

/// A stray 0xFE before a frame reads as a MAVLink 1 header of a known message claiming 253
/// bytes: it is refused at once, and the frame behind it comes out without waiting for 261
/// bytes more.
#[test]
fn a_v1_header_longer_than_its_message_holds_nothing_back() {
    let mut stream = std::vec![0xFE];
    stream.extend(hex(GOLDEN_V2));
    let mut p = P::for_dialect::<TestDialect>();
    assert_eq!(stream[5], 0, "the header reads as HEARTBEAT's");
    let got = collect(&mut p, &stream, stream.len());
    assert_eq!(got, [(hex(GOLDEN_V2), true)]);
    assert_eq!(p.buffered(), 0);
    assert_eq!(p.stats().bad_crc, 1);
}

#[test]
fn frames_decode_and_carry_signatures() {
    let signed = hex(GOLDEN_SIGNED);
    let mut p = P::for_dialect::<TestDialect>();
    let Feed::Frame { frame, remaining } = p.feed(&signed) else {
        panic!("no frame")
    };
    assert!(remaining.is_empty());
    assert_eq!(frame.payload(), &signed[10..19]);
    assert_eq!(
        frame.decode::<TestDialect>(),
        Ok(TestDialect::Heartbeat(golden_heartbeat()))
    );
    assert_eq!(frame.meta().map(|m| m.id), Some(0));
    let v2 = frame.as_v2().unwrap();
    assert!(v2.is_signed());
    assert_eq!(v2.link_id(), Some(7));
    assert_eq!(v2.timestamp(), Some(0x12_3456_789A));
    assert!(frame.frame().is_signed());
}

#[test]
fn bad_crc_unknown_id_and_flags_are_counted() {
    let mut stream = Vec::new();
    let mut bad = hex(GOLDEN_V2);
    bad[19] ^= 1; // checksum
    stream.extend(&bad);
    let mut unknown = hex(GOLDEN_V2);
    unknown[7] = 1; // id 1
    stream.extend(&unknown);
    let mut flags = hex(GOLDEN_V2);
    flags[2] = 0x02;
    stream.extend(&flags);
    stream.extend(hex(GOLDEN_V2));
    let mut p = P::for_dialect::<TestDialect>();
    let got = collect(&mut p, &stream, stream.len());
    assert_eq!(got, [(hex(GOLDEN_V2), true)]);
    let s = *p.stats();
    assert_eq!(
        (s.bad_crc, s.unknown_id, s.bad_flags, s.frames),
        (1, 1, 1, 1)
    );
    // The rest of each rejected candidate was rescanned as garbage (no magic inside).
    assert_eq!(s.garbage_bytes, 3 * 20);
    assert_eq!(accounted(&p) + 21, stream.len());
}

#[test]
fn unknown_ids_pass_through_when_asked() {
    let mut unknown = hex(GOLDEN_V2);
    unknown[7] = 1;
    unknown[19] ^= 0x55; // cannot be checked anyway
    let mut p = P::for_dialect::<TestDialect>().pass_unknown_ids(true);
    let got = collect(&mut p, &unknown, 4);
    assert_eq!(got, [(unknown.clone(), false)]);
    assert_eq!(p.stats().unchecked, 1);
    let mut v1 = hex(GOLDEN_V1);
    v1[5] = 9;
    let got = collect(&mut p, &v1, 1);
    assert_eq!(got, [(v1.clone(), false)]);
    // Known ids are still checked.
    let mut bad = hex(GOLDEN_V1);
    bad[16] ^= 1;
    p.set_pass_unknown_ids(false);
    assert!(collect(&mut p, &bad, 3).is_empty());
    assert_eq!(p.stats().bad_crc, 1);
}

/// A false start that passes every early check waits for its claimed length; when the
/// input pauses, it is given up and the frames behind it come out, while a frame still
/// arriving at the end of the buffer is given up too (all there is of it has come).
#[test]
fn a_pause_gives_up_false_starts_and_frees_the_frames_behind() {
    use crate::framing::Deframer;
    let mut out = [0u8; 300];
    let mut frames = Vec::new();
    for seq in 0..3u8 {
        let n = v2::encode(Header::new(seq, 1, 1), &golden_heartbeat(), &mut out).unwrap();
        frames.push(out[..n].to_vec());
    }
    // Two false starts (MAVLink 2 headers of a known id claiming 255 and 240 bytes), then two
    // frames, then the first 7 bytes of a third.
    let mut stream = std::vec![0xFD, 0xFF, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00];
    stream.extend_from_slice(&[0xFD, 0xF0, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00]);
    stream.extend_from_slice(&frames[0]);
    stream.extend_from_slice(&frames[1]);
    stream.extend_from_slice(&frames[2][..7]);
    for chunk in [1, 2, 5, 21, stream.len()] {
        let mut p = P::for_dialect::<TestDialect>();
        assert!(collect(&mut p, &stream, chunk).is_empty(), "chunk {chunk}");
        let mut got = Vec::new();
        let n = p.drain_stalled(|f| got.push(f.as_bytes().to_vec()));
        assert_eq!((n, &got[..]), (2, &frames[..2]), "chunk {chunk}");
        assert_eq!(p.buffered(), 0, "chunk {chunk}");
        assert_eq!(accounted(&p), 20 + 7, "chunk {chunk}");
        // Nothing buffered: a pause gives up nothing, and the stream goes on.
        assert!(!p.give_up_stalled());
        assert_eq!(
            collect(&mut p, &frames[2], chunk),
            [(frames[2].clone(), true)]
        );
    }
    // A frame handed out of the buffer is not given up by a pause right after it.
    let mut p = P::for_dialect::<TestDialect>();
    let (head, tail) = frames[0].split_at(5);
    assert!(collect(&mut p, head, head.len()).is_empty());
    assert!(matches!(p.feed(tail), Feed::Frame { .. }));
    assert!(!p.give_up_stalled());
    assert_eq!(p.stats().frames, 1);
}

#[test]
fn false_magic_with_long_length_does_not_swallow_frames() {
    // A header that passes every early check (known id, no flags) and claims 255 bytes.
    let mut stream = std::vec![0xFD, 0xFF, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00];
    let mut expected = Vec::new();
    let mut out = [0u8; 300];
    for seq in 0..12u8 {
        let n = v2::encode(Header::new(seq, 1, 1), &golden_heartbeat(), &mut out).unwrap();
        stream.extend_from_slice(&out[..n]);
        expected.push((out[..n].to_vec(), true));
    }
    // The MAVLink 2 false start above hides the frames inside its claimed length until the
    // stream completes it and its checksum fails.
    let mut hiding = stream.clone();
    hiding.truncate(10 + 5 * 21);
    for chunk in [1, 2, 5, 21, 64, 255, hiding.len()] {
        let mut p = P::for_dialect::<TestDialect>();
        assert!(collect(&mut p, &hiding, chunk).is_empty(), "chunk {chunk}");
        assert_eq!(p.buffered(), hiding.len());
    }
    // A MAVLink 1 false start right before the end: a known message claiming more than its
    // longest payload is refused at once, and the frame after it comes out.
    stream.extend_from_slice(&[0xFE, 0xFF, 0, 1, 1, 0]);
    let n = v1::encode(Header::new(99, 1, 1), &golden_heartbeat(), &mut out).unwrap();
    stream.extend_from_slice(&out[..n]);
    expected.push((out[..n].to_vec(), true));
    for chunk in [1, 2, 5, 21, 64, 255, stream.len()] {
        let mut p = P::for_dialect::<TestDialect>();
        let got = collect(&mut p, &stream, chunk);
        assert_eq!(got, expected, "chunk {chunk}");
        assert_eq!(p.stats().bad_crc, 2, "chunk {chunk}");
        assert_eq!(p.buffered(), 0);
    }
}

#[test]
fn whole_frames_in_the_input_are_not_copied() {
    let golden = hex(GOLDEN_V2);
    let mut p = P::for_dialect::<TestDialect>();
    let Feed::Frame { frame, remaining } = p.feed(&golden) else {
        panic!()
    };
    assert!(core::ptr::eq(frame.as_bytes().as_ptr(), golden.as_ptr()));
    assert!(remaining.is_empty());
}

#[test]
fn frame_from_buffer_stays_until_next_feed() {
    let golden = hex(GOLDEN_V2);
    let mut doubled = golden.clone();
    doubled.extend(&golden);
    let mut p = P::for_dialect::<TestDialect>();
    assert!(matches!(p.feed(&doubled[..15]), Feed::Consumed));
    assert_eq!(p.buffered(), 15);
    match p.feed(&doubled[15..]) {
        Feed::Frame { frame, remaining } => {
            assert_eq!(frame.as_bytes(), &golden[..]);
            assert_eq!(remaining, &golden[..]);
        }
        Feed::Consumed => panic!(),
    }
    assert_eq!(p.buffered(), 0);
    assert_eq!(p.feed_all(&golden, |_| {}), 1);
    p.reset();
    assert_eq!(p.stats().garbage_bytes, 0);
    assert!(matches!(p.feed(&golden[..3]), Feed::Consumed));
    p.reset();
    assert_eq!(p.take_stats().garbage_bytes, 3);
    assert_eq!(*p.stats(), Stats::default());
}

#[test]
fn largest_frames_with_minimal_buffer() {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let mut stream = std::vec![0xFD, 0xFD, 0x00];
    let big = Big([0xFD; 255]);
    let n = v2::encode(Header::new(1, 2, 3), &big, &mut out).unwrap();
    for _ in 0..3 {
        stream.extend_from_slice(&out[..n]);
    }
    let ext = ExtMsg {
        ext_f32: 5.0,
        ..Default::default()
    };
    let m = v2::encode(Header::new(1, 2, 3), &ext, &mut out[..100]).unwrap();
    stream.extend_from_slice(&out[..m]);
    for chunk in [1, 3, 100, 279, 280, 281, stream.len()] {
        let mut p = Parser::<280>::new(TestDialect::META);
        let mut ids = Vec::new();
        for piece in stream.chunks(chunk) {
            p.feed_all(piece, |f| {
                assert!(f.is_checked());
                ids.push(f.msg_id());
            });
        }
        assert_eq!(
            ids,
            [Big::ID, Big::ID, Big::ID, ExtMsg::ID],
            "chunk {chunk}"
        );
    }
}

#[test]
fn feed_all_hands_out_what_a_feed_loop_does() {
    // Frames back to back (the in-place loop), then noise, false starts, bad frames and
    // frames cut by the chunks (the general path), both kinds of unknown-id handling.
    let mut stream = Vec::new();
    for _ in 0..3 {
        stream.extend(hex(GOLDEN_V2));
        stream.extend(hex(GOLDEN_SIGNED));
        stream.extend(hex(GOLDEN_V1));
    }
    let mut bad = hex(GOLDEN_V2);
    bad[19] ^= 1;
    let mut unknown = hex(GOLDEN_V2);
    unknown[7] = 1;
    for noise in [&[0x00, 0xFD, 0x13][..], &bad, &unknown, &[0xFE, 0x00, 0xFD]] {
        stream.extend(noise);
        stream.extend(hex(GOLDEN_V2));
        stream.extend(hex(GOLDEN_V1));
    }
    stream.extend(&hex(GOLDEN_V2)[..7]);
    for pass in [false, true] {
        for chunk in 1..=stream.len() {
            let mut looped = P::for_dialect::<TestDialect>().pass_unknown_ids(pass);
            let mut want = Vec::new();
            for mut input in stream.chunks(chunk) {
                while let Feed::Frame { frame, remaining } = looped.feed(input) {
                    want.push((frame.as_bytes().to_vec(), frame.is_checked()));
                    input = remaining;
                }
            }
            let mut all = P::for_dialect::<TestDialect>().pass_unknown_ids(pass);
            let got = collect(&mut all, &stream, chunk);
            assert_eq!(got, want, "chunk {chunk}");
            assert_eq!(all.stats(), looped.stats(), "chunk {chunk}");
            assert_eq!(all.buffered(), looped.buffered(), "chunk {chunk}");
        }
    }
}

#[test]
fn debug_output_is_short() {
    let p = P::for_dialect::<TestDialect>();
    let s = std::format!("{p:?}");
    assert!(s.starts_with("Parser { capacity: 280"), "{s}");
}
