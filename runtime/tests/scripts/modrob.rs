//! Invariant checks shared by the ModRob-1 fuzz target and the property tests.
//!
//! `check_parser`: the first input byte seeds the chunk sizes; the rest is a UART.B-1 stream.
//! Checked: no panic; chunking does not matter (the same messages and counters as feeding at
//! once); every byte fed is counted, and is in a handed-out message, dropped or pending; every
//! message handed out re-encodes to a frame that decodes to the same wire form.
//!
//! `check_packet`: the input is read as an Ethernet-1 packet. Checked: no panic; a packet that
//! passes `new_checked` yields exactly `count` items, each a message or a frame error, and its
//! messages re-encode to the same length.

use ferrolink_runtime::modrob::ethernet::{Packet, HEADER_LEN};
use ferrolink_runtime::modrob::parser::{Parser, Stats};
use ferrolink_runtime::modrob::{uart, Message};

/// Decodes a whole stream fed in the given chunk sizes (the rest at once), then finishes.
pub fn decode(stream: &[u8], chunks: &mut dyn Iterator<Item = usize>) -> (Vec<Message>, Stats) {
    let mut parser = Parser::new();
    let mut messages = Vec::new();
    let mut rest = stream;
    for size in chunks {
        if rest.is_empty() {
            break;
        }
        let (piece, tail) = rest.split_at(size.clamp(1, rest.len()));
        parser.feed_all(piece, |m| messages.push(m));
        rest = tail;
    }
    parser.feed_all(rest, |m| messages.push(m));
    let framed: usize = messages.iter().map(uart::encoded_len).sum();
    let stats = *parser.stats();
    assert_eq!(
        stats.bytes,
        (framed + parser.pending()) as u64 + stats.dropped
    );
    assert!(parser.pending() < uart::MAX_FRAME_LEN);
    parser.finish();
    assert_eq!(parser.pending(), 0);
    (messages, *parser.stats())
}

/// Wire forms, so that NaNs compare equal.
fn wire(messages: &[Message]) -> Vec<(u32, [u8; 8])> {
    messages
        .iter()
        .map(|m| {
            let can = m.to_can();
            (can.id, can.bytes)
        })
        .collect()
}

/// Checks the parser invariants on one input.
pub fn check_parser(data: &[u8]) {
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    let whole = decode(stream, &mut core::iter::empty());
    let mut state = u32::from(seed) | 1;
    let mut chunks = core::iter::from_fn(|| {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        Some((state % 20) as usize + 1)
    });
    let chunked = decode(stream, &mut chunks);
    assert_eq!(wire(&whole.0), wire(&chunked.0));
    assert_eq!(whole.1, chunked.1);
    assert_eq!(whole.1.bytes, stream.len() as u64);
    assert_eq!(whole.1.frames, whole.0.len() as u64);
    for message in &whole.0 {
        let mut buf = [0u8; uart::MAX_FRAME_LEN];
        let n = uart::encode(message, &mut buf).expect("a decoded message re-encodes");
        let again = decode(&buf[..n], &mut core::iter::empty());
        assert_eq!(wire(&again.0), wire(core::slice::from_ref(message)));
        assert_eq!(again.1.dropped, 0);
    }
}

/// Reads the input as an Ethernet-1 packet and checks the reader's invariants.
pub fn check_packet(data: &[u8]) {
    let Ok(packet) = Packet::new_checked(data) else {
        return;
    };
    let mut len = HEADER_LEN;
    let mut items = 0usize;
    for item in packet.messages() {
        items += 1;
        match item {
            Ok(message) => len += uart::encoded_len(&message),
            Err(_) => {
                let rest = data.get(len..).unwrap_or_default();
                len += uart::frame_len(rest).expect("framing was checked");
            }
        }
    }
    assert_eq!(items, usize::from(packet.count()));
    assert_eq!(len, data.len());
}
