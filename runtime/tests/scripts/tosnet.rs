//! Invariant checks shared by the TosNet fuzz targets and the property tests.
//!
//! `check_frame`: any bytes as a frame. Checked: no panic; a frame that parses re-emits to the
//! same bytes (CRC included when the CRC was good); `parse` accepts exactly the frames whose
//! CRC leaves residue 0 and that `parse_unchecked` accepts.
//!
//! `check_stream`: the first byte picks a chunk size, the rest is fed in chunks of it to the
//! byte-stream parser. Checked: no panic; every byte is counted; the frames do not depend on
//! the chunking; each is 2 to 64 bytes long; each re-encodes and parses back to itself; no more
//! CRC failures than frames.
//!
//! `check_node`: the input is a script for one node; each operation's first byte picks receive
//! (a frame whose CRC is optionally fixed up, so that valid frames get through), poll (advance
//! the clock), commit, or queue a side-channel message. Checked: no panic; nothing handed out
//! is longer than a frame can be; every frame the node starts itself (from `poll`, or a master's
//! answer to a frame coming back) parses; a frame a slave forwards from a good frame has a good
//! CRC and one forwarded from a broken frame has a broken CRC; the packet counter counts every
//! frame received.

use ferrolink_runtime::framing::Deframer;
use ferrolink_runtime::tosnet::frame::{crc_ok, seal, Repr, MAX_FRAME_LEN};
use ferrolink_runtime::tosnet::stream;
use ferrolink_runtime::tosnet::{Config, Node, Role};

pub fn check_frame(data: &[u8]) {
    let unchecked = Repr::parse_unchecked(data);
    let checked = Repr::parse(data);
    assert_eq!(checked.is_ok(), unchecked.is_ok() && crc_ok(data));
    if let Ok(repr) = unchecked {
        let mut buf = vec![0xa5; data.len() + 1];
        let len = repr.emit(&mut buf).expect("fits its own length");
        assert_eq!(len, data.len());
        assert_eq!(buf[..len - 1], data[..len - 1]);
        if checked.is_ok() {
            assert_eq!(buf[..len], data[..]);
        }
        assert_eq!(buf[len], 0xa5, "wrote past the frame");
    }
}

fn stream_frames(data: &[u8], chunk: usize) -> (Vec<Vec<u8>>, stream::Stats) {
    let mut parser = stream::Parser::<64>::new();
    let mut frames = Vec::new();
    for piece in data.chunks(chunk.max(1)) {
        parser.feed_all(piece, |f| frames.push(f.to_vec()));
    }
    (frames, *parser.stats())
}

pub fn check_stream(data: &[u8]) {
    let Some((&chunk, data)) = data.split_first() else {
        return;
    };
    let (frames, stats) = stream_frames(data, usize::from(chunk));
    assert_eq!(stats.bytes, data.len());
    assert_eq!(stats.frames, frames.len());
    assert!(stats.crc_failures <= stats.frames);
    assert_eq!(
        stream_frames(data, data.len()).0,
        frames,
        "chunking changed the frames"
    );
    for frame in &frames {
        assert!((2..=64).contains(&frame.len()), "{frame:?}");
        let mut wire = vec![0u8; stream::encoded_len(frame)];
        let n = stream::encode(frame, &mut wire).expect("sized by encoded_len");
        assert_eq!(stream_frames(&wire[..n], n).0, std::slice::from_ref(frame));
    }
}

pub fn check_node(script: &[u8]) {
    let Some((&cfg_byte, mut rest)) = script.split_first() else {
        return;
    };
    let mut cfg = Config::new(cfg_byte & 0x0F).registers(cfg_byte >> 4, cfg_byte.rotate_left(2));
    cfg.master_candidate = cfg_byte & 0x40 != 0;
    cfg.watchdog_ns = 1_000_000;
    let mut node = Node::new(cfg);
    let mut out = vec![0u8; MAX_FRAME_LEN];
    let mut now = 0u64;
    let mut received = 0u32;
    while let Some((&op, tail)) = rest.split_first() {
        rest = tail;
        match op % 4 {
            0 => {
                let len = usize::from(rest.first().copied().unwrap_or(0))
                    .min(rest.len().saturating_sub(1));
                let mut frame = rest.get(1..1 + len).unwrap_or(&[]).to_vec();
                rest = rest.get(1 + len..).unwrap_or(&[]);
                if op & 0x80 != 0 {
                    seal(&mut frame);
                }
                let good = crc_ok(&frame);
                received += 1;
                let was_master = node.status().role == Role::Master;
                if let Some(n) = node.receive(&frame, now, &mut out) {
                    assert!(n <= MAX_FRAME_LEN);
                    if was_master || node.status().role == Role::Master {
                        // A master forwards nothing: what it sends after a frame came back
                        // (the next cycle, or a new setup after a broken one) is its own.
                        assert!(
                            Repr::parse(&out[..n]).is_ok(),
                            "a master's own frames parse"
                        );
                    } else {
                        assert_eq!(crc_ok(&out[..n]), good, "CRC state must carry through");
                    }
                }
                assert_eq!(node.counters().packets, received);
            }
            1 => {
                now += u64::from(op) * 50_000;
                while let Some(n) = node.poll(now, &mut out) {
                    assert!(n <= MAX_FRAME_LEN);
                    assert!(Repr::parse(&out[..n]).is_ok(), "own frames parse");
                }
            }
            2 => {
                node.commit_in();
                node.commit_out();
            }
            _ => {
                let _ = node.send_async(op >> 4, &rest[..rest.len().min(usize::from(op >> 2))]);
            }
        }
    }
}
