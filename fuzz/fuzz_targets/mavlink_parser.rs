//! Feeds arbitrary bytes to the MAVLink stream parser in arbitrary chunks.
//!
//! The first input byte seeds the chunk sizes and picks whether unknown ids pass through; the
//! rest is the stream. Checked invariants:
//!
//! - no panic;
//! - every checked frame's CRC verifies against its table entry, and every unchecked frame has
//!   an id missing from the table (and only appears when unknown ids pass through);
//! - handed-out frames are whole, valid frame views with known incompat flags only;
//! - the stats add up: every byte fed is garbage, a rejected magic byte, part of a frame, or
//!   still buffered;
//! - chunking does not matter: the same frames and stats as when feeding the stream at once;
//! - `feed_all` hands out the same frames, with the same stats, as a loop over `feed`;
//! - after a pause (`drain_stalled`, after some chunks), frames handed out are checked as
//!   above, the stats still add up, and nothing is left buffered.
//!
//! Run with `cargo fuzz run mavlink_parser corpus/mavlink_parser seeds/mavlink_parser`.
#![no_main]

use ferrolink_runtime::framing::Deframer;
use ferrolink_runtime::mavlink::parser::{Feed, ParsedFrame, Parser, Stats};
use ferrolink_runtime::mavlink::{find_meta, v2, MessageMeta};
use libfuzzer_sys::fuzz_target;

const fn meta(id: u32, crc_extra: u8, min_len: u8, max_len: u8) -> MessageMeta {
    MessageMeta {
        id,
        crc_extra,
        min_len,
        max_len,
        target_system: None,
        target_component: None,
    }
}

/// HEARTBEAT and a few other shapes, including a 24-bit id and the largest payload.
static META: &[MessageMeta] = &[
    meta(0, 50, 9, 9),
    meta(30, 39, 28, 28),
    meta(253, 83, 51, 54),
    meta(300, 123, 7, 12),
    meta(0x00AB_CDEF, 7, 255, 255),
];

/// xorshift32 for the chunk sizes.
struct Chunks(u32);

impl Chunks {
    fn next(&mut self, max: usize) -> usize {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        // Mostly small chunks, sometimes empty ones, sometimes a frame or more.
        let n = match x % 8 {
            0 => 0,
            1..=4 => (x >> 8) as usize % 8 + 1,
            _ => (x >> 8) as usize % 400 + 1,
        };
        n.min(max)
    }
}

/// Checks a frame handed out; returns its length.
fn check_frame(frame: &ParsedFrame<'_>, pass_unknown: bool) -> usize {
    let bytes = frame.as_bytes();
    assert_eq!(bytes.len(), frame.frame().frame_len());
    match frame.meta() {
        Some(m) => {
            assert_eq!(m.id, frame.msg_id());
            assert!(frame.frame().check_crc(m.crc_extra));
        }
        None => {
            assert!(pass_unknown);
            assert!(find_meta(META, frame.msg_id()).is_none());
        }
    }
    if let Some(f) = frame.as_v2() {
        assert!(!f.has_unknown_flags());
        assert!(v2::Frame::new_checked(bytes).is_ok());
    }
    bytes.len()
}

fn check_frames(
    parser: &mut Parser,
    chunks: &mut dyn Iterator<Item = &[u8]>,
    pass_unknown: bool,
) -> (Vec<Vec<u8>>, Stats) {
    let mut frames = Vec::new();
    let mut fed = 0usize;
    let mut frame_bytes = 0usize;
    for chunk in chunks {
        fed += chunk.len();
        let mut input = chunk;
        while let Feed::Frame { frame, remaining } = parser.feed(input) {
            assert!(remaining.len() <= input.len());
            frame_bytes += check_frame(&frame, pass_unknown);
            frames.push(frame.as_bytes().to_vec());
            input = remaining;
        }
        let s = parser.stats();
        assert_eq!(
            s.garbage_bytes + s.rejected() + frame_bytes + parser.buffered(),
            fed
        );
        assert_eq!(s.frames, frames.len());
    }
    (frames, *parser.stats())
}

fuzz_target!(|data: &[u8]| {
    let Some((&control, stream)) = data.split_first() else {
        return;
    };
    let pass_unknown = control & 1 != 0;

    let mut sizes = Chunks(u32::from(control) | 0x100);
    let mut rest = stream;
    let split = core::iter::from_fn(|| {
        if rest.is_empty() {
            return None;
        }
        let (chunk, tail) = rest.split_at(sizes.next(rest.len()));
        rest = tail;
        Some(chunk)
    });
    let chunks: Vec<&[u8]> = split.collect();
    let mut parser: Parser = Parser::new(META).pass_unknown_ids(pass_unknown);
    let chunked = check_frames(&mut parser, &mut chunks.iter().copied(), pass_unknown);

    let mut parser: Parser = Parser::new(META).pass_unknown_ids(pass_unknown);
    let mut frames = Vec::new();
    for chunk in &chunks {
        parser.feed_all(chunk, |frame| frames.push(frame.as_bytes().to_vec()));
    }
    assert_eq!((frames, *parser.stats()), chunked);

    let mut parser: Parser = Parser::new(META).pass_unknown_ids(pass_unknown);
    let whole = check_frames(&mut parser, &mut core::iter::once(stream), pass_unknown);
    assert_eq!(chunked, whole);

    // Pauses: after every chunk (control bit 1) or every third.
    let mut parser: Parser = Parser::new(META).pass_unknown_ids(pass_unknown);
    let (mut fed, mut frame_bytes) = (0usize, 0usize);
    for (i, chunk) in chunks.iter().enumerate() {
        fed += chunk.len();
        parser.feed_all(chunk, |frame| frame_bytes += check_frame(&frame, pass_unknown));
        if control & 2 != 0 || i % 3 == 2 {
            parser.drain_stalled(|frame| frame_bytes += check_frame(&frame, pass_unknown));
            assert_eq!(parser.buffered(), 0);
        }
        let s = parser.stats();
        assert_eq!(
            s.garbage_bytes + s.rejected() + frame_bytes + parser.buffered(),
            fed
        );
    }
});
