//! Invariant checks of the MAVLink router core, shared by the `mavlink_router` fuzz target and
//! the property tests.
//!
//! `check_router`: the input is a script for a 4-link router; each operation's first byte picks
//! raw bytes on a link, a well-formed frame (known or unknown id, v1 or v2, addressed or not,
//! maybe corrupted) on a link, a clock step (maybe with a pause on a link, which gives up a
//! false start its parser holds), or closing and reopening a link with another
//! configuration (group, deduplication, required signing, filters, datagrams). Checked: no
//! panic; no frame goes back to its link or to a closed one; every frame handed out as checked
//! passes its CRC with its table entry, and every unchecked one has an id the table lacks; a
//! frame goes out exactly when it was not dropped; the counters add up (frames in = callbacks,
//! frames out per link = copies routed to it, frames counted per source + inbound drops +
//! unproven frames = frames in); only proven frames teach (every route is a sender heard on
//! that link in a frame whose checksum or signature was checked); on a link of datagrams no
//! frame spans two (each lies whole in the bytes of one receive).

use std::collections::HashSet;

use ferrolink_runtime::mavlink::router::{DropReason, Filter, LinkConfig, Routed, Router};
use ferrolink_runtime::mavlink::signing::SecretKey;
use ferrolink_runtime::mavlink::{find_meta, v1, v2, Header, MessageMeta};

pub static META: &[MessageMeta] = &[
    MessageMeta {
        id: 0,
        crc_extra: 50,
        min_len: 9,
        max_len: 9,
        target_system: None,
        target_component: None,
    },
    MessageMeta {
        id: 4,
        crc_extra: 237,
        min_len: 14,
        max_len: 14,
        target_system: Some(12),
        target_component: Some(13),
    },
    MessageMeta {
        id: 21,
        crc_extra: 159,
        min_len: 2,
        max_len: 2,
        target_system: Some(0),
        target_component: Some(1),
    },
    MessageMeta {
        id: 76,
        crc_extra: 152,
        min_len: 33,
        max_len: 33,
        target_system: Some(30),
        target_component: Some(31),
    },
];

const LINKS: usize = 4;

/// A frame built from script bytes: id, sender, sequence, target, version, corruption.
fn build(op: u8, args: &[u8]) -> Vec<u8> {
    let arg = |i: usize| args.get(i).copied().unwrap_or(0);
    let (id, crc_extra, len, offsets) = match arg(0) % 5 {
        4 => (4242, 0, 12, (None, None)),
        k => {
            let m = &META[usize::from(k)];
            (
                m.id,
                m.crc_extra,
                usize::from(m.max_len),
                (m.target_system, m.target_component),
            )
        }
    };
    let mut payload = vec![arg(6); len];
    if let Some(o) = offsets.0 {
        payload[usize::from(o)] = arg(4) % 4;
    }
    if let Some(o) = offsets.1 {
        payload[usize::from(o)] = arg(5) % 3;
    }
    let header = Header::new(arg(3), arg(1) % 6, arg(2) % 3);
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = if op & 0x40 != 0 && id < 256 {
        v1::encode_raw(header, id, crc_extra, &payload, &mut out)
    } else {
        v2::encode_raw(header, id, crc_extra, &payload, &mut out)
    }
    .unwrap_or(0);
    let mut frame = out[..n].to_vec();
    if op & 0x80 != 0 {
        if let Some(b) = frame.get_mut(usize::from(arg(7)) % n.max(1)) {
            *b ^= 0x20;
        }
    }
    frame
}

fn config(bits: u8) -> LinkConfig {
    let mut c = LinkConfig {
        group: bits & 0x03,
        dedup_window_us: if bits & 0x04 != 0 { 100_000 } else { 0 },
        drop_unknown_ids: bits & 0x08 != 0,
        require_signing: (bits & 0x10 != 0).then(|| SecretKey::new([7; 32])),
        datagrams: bits & 0x80 != 0,
        ..LinkConfig::default()
    };
    if bits & 0x20 != 0 {
        c.inbound = Filter::OPEN;
        c.inbound.block_src_sys.insert(3);
    }
    if bits & 0x40 != 0 {
        let _ = c.outbound.allow_msg.insert(0);
    }
    c
}

pub fn check_router(script: &[u8]) {
    let mut router: Router<LINKS, 8, 8, 8> = Router::new(META);
    for _ in 0..LINKS {
        router.open_link(LinkConfig::default());
    }
    let mut now = 1_700_000_000_000_000u64;
    let mut rest = script;
    // Per link: frames in, and copies routed out, as seen from outside; reset on reopening.
    let mut frames_in = [0u64; LINKS];
    let mut copies_out = [0u64; LINKS];
    let mut reopened = false;
    // Per link: whether it requires signing and takes datagrams (from its configuration).
    let mut signing = [false; LINKS];
    let mut datagrams = [false; LINKS];
    // Senders of proven frames, per link; and frames that passed inbound unproven.
    let mut proven: HashSet<(usize, u8, u8)> = HashSet::new();
    let mut unproven_in = 0u64;
    while let Some((&op, tail)) = rest.split_first() {
        rest = tail;
        let link = usize::from(op >> 2) % LINKS;
        let (bytes, pause) = match op % 4 {
            0 => {
                let len = usize::from(rest.first().copied().unwrap_or(0))
                    .min(rest.len().saturating_sub(1));
                let bytes = rest.get(1..1 + len).unwrap_or(&[]).to_vec();
                rest = rest.get(1 + len..).unwrap_or(&[]);
                (bytes, false)
            }
            1 => {
                let args = rest.get(..8).unwrap_or(rest);
                let frame = build(op, args);
                rest = rest.get(8..).unwrap_or(&[]);
                (frame, false)
            }
            2 => {
                now += u64::from(op) * 20_000;
                if op & 0x40 == 0 {
                    continue;
                }
                (Vec::new(), true)
            }
            _ => {
                let bits = rest.first().copied().unwrap_or(0);
                rest = rest.get(1..).unwrap_or(&[]);
                router.close_link(link);
                assert!(!router.is_open(link));
                assert!(router.routes().all(|r| r.link != link));
                assert_eq!(router.open_link(config(bits)), Some(link));
                signing[link] = bits & 0x10 != 0;
                datagrams[link] = bits & 0x80 != 0;
                frames_in[link] = 0;
                copies_out[link] = 0;
                reopened = true;
                continue;
            }
        };
        let open: u64 = (0..LINKS)
            .filter(|&i| router.is_open(i))
            .fold(0, |m, i| m | 1 << i);
        let on_routed = |routed: Routed<'_>| {
            assert_eq!(routed.from, link);
            assert_eq!(routed.to & (1 << link), 0, "echo");
            assert_eq!(routed.to & !open, 0, "sent to a closed link");
            assert_eq!(routed.to == 0, routed.dropped.is_some());
            match routed.frame.meta() {
                Some(meta) => assert!(routed.frame.frame().check_crc(meta.crc_extra)),
                None => assert!(find_meta(META, routed.frame.msg_id()).is_none()),
            }
            assert_eq!(routed.bytes, routed.frame.as_bytes());
            if datagrams[link] {
                assert!(
                    bytes.windows(routed.bytes.len()).any(|w| w == routed.bytes),
                    "a frame spans two datagrams"
                );
            }
            let inbound_drop = matches!(
                routed.dropped,
                Some(
                    DropReason::Unsigned
                        | DropReason::BadSignature
                        | DropReason::Duplicate
                        | DropReason::FilteredIn
                )
            );
            if !inbound_drop {
                let h = routed.frame.header();
                if routed.frame.is_checked() || signing[link] {
                    proven.insert((link, h.sysid, h.compid));
                } else {
                    unproven_in += 1;
                }
            }
            frames_in[link] += 1;
            for (i, n) in copies_out.iter_mut().enumerate() {
                *n += (routed.to >> i) & 1;
            }
        };
        if pause {
            router.receive_stalled(link, now, now, on_routed);
        } else {
            router.receive(link, &bytes, now, now, on_routed);
        }
        for r in router.routes() {
            assert!(
                proven.contains(&(r.link, r.sysid, r.compid)),
                "route {r:?} learned from no proven frame"
            );
        }
    }
    let mut delivered_in = 0;
    let mut dropped_in = 0;
    for i in 0..LINKS {
        let c = router.link_counters(i).expect("link");
        assert_eq!(c.rx_frames, frames_in[i], "rx_frames of link {i}");
        assert_eq!(c.tx_frames, copies_out[i], "tx_frames of link {i}");
        delivered_in += c.rx_frames;
        let d = c.drops;
        dropped_in += d.unsigned + d.bad_signature + d.duplicate + d.filtered_in;
    }
    // Reopened links start their counters afresh while sources keep theirs, and an evicted
    // source takes its count along: compare only when neither happened.
    let counted: u64 = router.sources().map(|s| s.rx_frames).sum();
    if !reopened && router.counters().sources_evicted == 0 {
        assert_eq!(counted + dropped_in + unproven_in, delivered_in);
    }
}
