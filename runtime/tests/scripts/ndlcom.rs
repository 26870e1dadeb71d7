//! Invariant checks shared by the NDLCom fuzz targets and the property tests.
//!
//! `check_parser`: the first input byte picks the maximum payload and seeds the chunk sizes;
//! the rest is the stream. Checked: no panic; every frame handed out has a checking FCS, a
//! length within the maximum, and re-encodes to bytes that decode to the same frame; every byte
//! fed is counted; chunking does not matter (the same frames and stats as feeding at once).
//!
//! `check_bridge`: the input is a script for a 3-interface bridge; each operation's first byte
//! picks receive (on an interface, the following bytes), poll (advance time), transmit (drain
//! an interface) or a configuration change (mode of a pair, mirror, pinned route, link down).
//! Checked: no panic; every byte received is counted in the interface's `rx_bytes`; `transmit`
//! never hands out more than `pending` said, and every byte it hands out is counted; frames
//! delivered locally are intact and addressed to an own id or the broadcast address; a poll
//! before `next_poll_us` (or while it is `None`) cuts nothing off, and after a poll nothing is
//! left due.

use ferrolink_runtime::crc::mcrf4xx;
use ferrolink_runtime::ndlcom::bridge::{Bridge, Mode};
use ferrolink_runtime::ndlcom::parser::{Parser, Stats};
use ferrolink_runtime::ndlcom::{encode, storage_len, Header, BROADCAST, MAX_FRAME_LEN};

fn run(
    stream: &[u8],
    max_payload: usize,
    chunks: impl Iterator<Item = usize>,
) -> (Vec<(Header, Vec<u8>)>, Stats) {
    let mut parser = Parser::new([0u8; storage_len(255)]);
    parser.set_max_payload(max_payload);
    let mut frames = Vec::new();
    let mut rest = stream;
    for size in chunks {
        if rest.is_empty() {
            break;
        }
        let (piece, tail) = rest.split_at(size.clamp(1, rest.len()));
        parser.feed_all(piece, |f| {
            assert_eq!(mcrf4xx(f.as_bytes()), 0);
            assert!(f.payload().len() <= max_payload);
            assert_eq!(usize::from(f.header().length), f.payload().len());
            frames.push((f.header(), f.payload().to_vec()));
        });
        rest = tail;
    }
    parser.feed_all(rest, |f| frames.push((f.header(), f.payload().to_vec())));
    parser.finish();
    (frames, *parser.stats())
}

/// Checks the parser invariants on one input.
pub fn check_parser(data: &[u8]) {
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    let max_payload = usize::from(seed);
    let whole = run(stream, max_payload, core::iter::once(stream.len()));
    let mut state = u32::from(seed) | 1;
    let chunks = core::iter::from_fn(|| {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        Some((state % 40) as usize + 1)
    });
    let chunked = run(stream, max_payload, chunks);
    assert_eq!(whole, chunked);
    assert_eq!(whole.1.bytes, stream.len());
    for (header, payload) in &whole.0 {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(header, payload, &mut buf).expect("a decoded frame re-encodes");
        let again = run(&buf[..n], max_payload, core::iter::once(n));
        assert_eq!(again.0, vec![(*header, payload.clone())]);
    }
}

/// Runs one bridge script and checks its invariants.
pub fn check_bridge(data: &[u8]) {
    let mut bridge = Bridge::<3, { storage_len(64) }, 300>::new();
    bridge.router_mut().add_own_id(1);
    bridge.set_byte_timeout_us(50);
    let mut now = 0u64;
    let mut rx = [0u64; 3];
    let mut tx = [0u64; 3];
    let mut ops = data;
    while let Some((&op, rest)) = ops.split_first() {
        ops = rest;
        let i = usize::from(op % 3);
        match op >> 5 {
            0..=3 => {
                let n = usize::from(op >> 2 & 7) * 4 + 1;
                let (bytes, rest) = ops.split_at(n.min(ops.len()));
                ops = rest;
                now += 3;
                bridge.receive(i, bytes, now, |frame| {
                    assert_eq!(mcrf4xx(frame.as_bytes()), 0);
                    let r = frame.header().receiver;
                    assert!(r == 1 || r == BROADCAST);
                });
                rx[i] += bytes.len() as u64;
            }
            4 => {
                now += u64::from(op & 0x1f) * 10;
                let due = bridge.next_poll_us();
                let timeouts = |b: &Bridge<3, { storage_len(64) }, 300>| {
                    (0..3).map(|k| b.stats(k).timeouts).sum::<u64>()
                };
                let before = timeouts(&bridge);
                bridge.poll(now);
                if due.is_none_or(|t| now < t) {
                    assert_eq!(
                        timeouts(&bridge),
                        before,
                        "a poll before it was due cut off"
                    );
                }
                assert!(bridge.next_poll_us().is_none_or(|t| t > now));
            }
            5 | 6 => {
                let pending = bridge.pending(i);
                let mut out = [0u8; 97];
                let n = bridge.transmit(i, &mut out[..usize::from(op & 0x3f) + 1]);
                assert!(n <= pending);
                tx[i] += n as u64;
            }
            _ => match op & 0x1c {
                0 => bridge.set_mode(i, (i + 1) % 3, Mode::CutThrough),
                4 => bridge.set_mode(i, (i + 2) % 3, Mode::StoreForward),
                8 => bridge.router_mut().set_mirror(i, true),
                12 => bridge.router_mut().pin(op, i),
                16 => bridge.link_down(i),
                _ => bridge.set_mode(i, (i + 2) % 3, Mode::CutThrough),
            },
        }
    }
    for i in 0..3 {
        assert_eq!(bridge.stats(i).rx_bytes, rx[i]);
        assert_eq!(bridge.stats(i).tx_bytes, tx[i]);
    }
}
