//! The MAVLink router core: every routing rule as a scenario, counters, bounded tables, signing
//! at the edge, and a property test of the invariants (no echo, nothing unchecked that failed
//! its checksum, counters add up).

use ferrolink_runtime::mavlink::router::{
    DropReason, Filter, LinkConfig, LinkMask, NoFilter, Router, DEFAULT_ROUTE_TTL_US,
};
use ferrolink_runtime::mavlink::signing::{timestamp_from_unix_micros, SecretKey, Signer};
use ferrolink_runtime::mavlink::{v1, v2, Header, MessageMeta};
use proptest::prelude::*;

/// The routing-relevant part of common.xml for the messages used here (CRC_EXTRA and target
/// offsets as mavgen computes them) is `scripts::META`.
#[path = "scripts/router.rs"]
mod scripts;

const HEARTBEAT: u32 = 0;
const PING: u32 = 4;
const PARAM_REQUEST_LIST: u32 = 21;
const COMMAND_LONG: u32 = 76;
const UNKNOWN: u32 = 4242;

use scripts::META;

fn meta(id: u32) -> &'static MessageMeta {
    META.iter().find(|m| m.id == id).expect("test message")
}

/// A MAVLink 2 frame of `id` from `(sysid, compid)`; addressed messages get the target.
fn frame(id: u32, sysid: u8, compid: u8, seq: u8, target: (u8, u8)) -> Vec<u8> {
    let (crc_extra, len, offsets) = match id {
        UNKNOWN => (0, 12, (None, None)),
        _ => {
            let m = meta(id);
            (
                m.crc_extra,
                usize::from(m.max_len),
                (m.target_system, m.target_component),
            )
        }
    };
    let mut payload = vec![0x11u8; len];
    if let Some(o) = offsets.0 {
        payload[usize::from(o)] = target.0;
    }
    if let Some(o) = offsets.1 {
        payload[usize::from(o)] = target.1;
    }
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(
        Header::new(seq, sysid, compid),
        id,
        crc_extra,
        &payload,
        &mut out,
    )
    .unwrap();
    out[..n].to_vec()
}

fn heartbeat(sysid: u8, compid: u8) -> Vec<u8> {
    frame(HEARTBEAT, sysid, compid, 0, (0, 0))
}

type R = Router<8, 16, 16, 16>;

fn router(links: usize) -> R {
    let mut r = R::new(META);
    for _ in 0..links {
        r.open_link(LinkConfig::default()).unwrap();
    }
    r
}

/// Feeds `bytes` on `from` at time `t` and returns (mask, drop) per frame.
fn feed(r: &mut R, from: usize, bytes: &[u8], t: u64) -> Vec<(LinkMask, Option<DropReason>)> {
    let mut out = Vec::new();
    r.receive(from, bytes, t, t, |routed| {
        assert_eq!(routed.from, from);
        assert_eq!(routed.to & (1 << from), 0, "never back to the source");
        out.push((routed.to, routed.dropped));
    });
    out
}

fn one(r: &mut R, from: usize, bytes: &[u8], t: u64) -> (LinkMask, Option<DropReason>) {
    let got = feed(r, from, bytes, t);
    assert_eq!(got.len(), 1, "one frame");
    got[0]
}

#[test]
fn broadcast_goes_to_every_other_link() {
    let mut r = router(4);
    assert_eq!(one(&mut r, 2, &heartbeat(1, 1), 0), (0b1011, None));
    // target_system 0 is a broadcast too.
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (0, 0));
    assert_eq!(one(&mut r, 0, &cmd, 0), (0b1110, None));
}

/// A false start holds the heartbeat behind it until the link pauses; then it is routed and
/// teaches its route, and the false start is counted as garbage.
#[test]
fn a_pause_routes_the_frame_behind_a_false_start() {
    let mut r = router(2);
    let mut bytes = vec![0xFD, 0xFF, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00];
    bytes.extend(heartbeat(7, 1));
    assert!(feed(&mut r, 0, &bytes, 1_000).is_empty());
    let mut routed = Vec::new();
    r.receive_stalled(0, 2_000, 2_000, |f| routed.push((f.to, f.bytes.to_vec())));
    assert_eq!(routed, [(0b10, heartbeat(7, 1))]);
    assert!(r.routes().any(|route| route.sysid == 7 && route.link == 0));
    assert_eq!(r.link_counters(0).unwrap().garbage_bytes, 10);
    // Nothing held: a pause does nothing.
    r.receive_stalled(0, 3_000, 3_000, |_| panic!("nothing to route"));
}

#[test]
fn targeted_goes_only_where_the_target_was_seen() {
    let mut r = router(4);
    one(&mut r, 1, &heartbeat(1, 1), 0); // vehicle 1 behind link 1
    one(&mut r, 2, &heartbeat(2, 1), 0); // vehicle 2 behind link 2
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (2, 1));
    assert_eq!(one(&mut r, 0, &cmd, 1), (0b0100, None));
    let cmd = frame(COMMAND_LONG, 255, 190, 1, (1, 0));
    assert_eq!(one(&mut r, 0, &cmd, 1), (0b0010, None));
}

#[test]
fn component_targeted_prefers_the_exact_pair() {
    let mut r = router(4);
    one(&mut r, 1, &heartbeat(1, 1), 0); // autopilot
    one(&mut r, 2, &heartbeat(1, 100), 0); // camera of the same system, elsewhere
    let to_camera = frame(COMMAND_LONG, 255, 190, 0, (1, 100));
    assert_eq!(one(&mut r, 0, &to_camera, 1), (0b0100, None));
    // A component never seen: every link where the system was seen.
    let to_gimbal = frame(COMMAND_LONG, 255, 190, 1, (1, 154));
    assert_eq!(one(&mut r, 0, &to_gimbal, 1), (0b0110, None));
    // Component 0: the whole system.
    let to_system = frame(PARAM_REQUEST_LIST, 255, 190, 2, (1, 0));
    assert_eq!(one(&mut r, 0, &to_system, 1), (0b0110, None));
}

#[test]
fn unknown_target_is_dropped_and_counted() {
    let mut r = router(3);
    one(&mut r, 1, &heartbeat(1, 1), 0);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (9, 1));
    assert_eq!(one(&mut r, 0, &cmd, 1), (0, Some(DropReason::NoRoute)));
    assert_eq!(r.link_counters(0).unwrap().drops.no_route, 1);
}

#[test]
fn no_echo_even_when_the_target_sits_on_the_source_link() {
    let mut r = router(3);
    one(&mut r, 0, &heartbeat(1, 1), 0);
    one(&mut r, 0, &heartbeat(255, 190), 0);
    // The GCS addresses the vehicle on its own link: nothing to forward.
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (1, 1));
    assert_eq!(one(&mut r, 0, &cmd, 1), (0, Some(DropReason::NoRoute)));
}

#[test]
fn unknown_ids_are_broadcast_unchecked_and_teach_nothing() {
    let mut r = router(3);
    let unknown = frame(UNKNOWN, 7, 1, 0, (0, 0));
    let mut seen = Vec::new();
    r.receive(1, &unknown, 0, 0, |routed| {
        assert!(!routed.frame.is_checked());
        assert_eq!(routed.bytes, &unknown[..], "forwarded byte for byte");
        seen.push(routed.to);
    });
    assert_eq!(seen, [0b101]);
    assert_eq!(r.link_counters(1).unwrap().unchecked, 1);
    // Its sender fields are unproven: no route, no source.
    assert_eq!(r.routes().count(), 0);
    assert_eq!(r.sources().count(), 0);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (7, 1));
    assert_eq!(one(&mut r, 0, &cmd, 1), (0, Some(DropReason::NoRoute)));
    // Once system 7 sends a frame that checks, it is routed to.
    one(&mut r, 1, &heartbeat(7, 1), 0b101);
    assert_eq!(one(&mut r, 0, &cmd, 1), (0b010, None));
}

#[test]
fn unknown_ids_can_be_dropped_per_link() {
    let mut r = R::new(META);
    r.open_link(LinkConfig {
        drop_unknown_ids: true,
        ..LinkConfig::default()
    });
    r.open_link(LinkConfig::default());
    assert!(feed(&mut r, 0, &frame(UNKNOWN, 7, 1, 0, (0, 0)), 0).is_empty());
}

#[test]
fn bad_crc_and_garbage_teach_no_route() {
    let mut r = router(3);
    let mut bad = heartbeat(9, 1);
    let last = bad.len() - 1;
    bad[last] ^= 0xff;
    let mut noise = vec![0x00, 0xfd, 0x55, 0xfe, 0x01];
    noise.extend_from_slice(&bad);
    assert!(feed(&mut r, 1, &noise, 0).is_empty());
    assert_eq!(r.routes().count(), 0);
    assert!(r.link_counters(1).unwrap().crc_failures >= 1);
    assert!(r.link_counters(1).unwrap().garbage_bytes > 0);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (9, 1));
    assert_eq!(one(&mut r, 0, &cmd, 1), (0, Some(DropReason::NoRoute)));
}

#[test]
fn several_frames_in_one_read_are_all_routed() {
    let mut r = router(2);
    let mut datagram = heartbeat(1, 1);
    datagram.extend(frame(UNKNOWN, 1, 1, 1, (0, 0)));
    let mut v1_frame = [0u8; v1::MAX_FRAME_LEN];
    let n = v1::encode_raw(Header::new(2, 1, 1), HEARTBEAT, 50, &[0; 9], &mut v1_frame).unwrap();
    datagram.extend_from_slice(&v1_frame[..n]);
    assert_eq!(feed(&mut r, 0, &datagram, 0).len(), 3);
    assert_eq!(r.link_counters(1).unwrap().tx_frames, 3);
}

#[test]
fn groups_share_routes_and_never_feed_each_other() {
    let mut r = R::new(META);
    let gcs = r.open_link(LinkConfig::default()).unwrap();
    let radio_a = r
        .open_link(LinkConfig {
            group: 1,
            dedup_window_us: 500_000,
            ..LinkConfig::default()
        })
        .unwrap();
    let radio_b = r
        .open_link(LinkConfig {
            group: 1,
            dedup_window_us: 500_000,
            ..LinkConfig::default()
        })
        .unwrap();
    // The vehicle was only heard on radio A, but radio B is the same path.
    let hb = heartbeat(1, 1);
    assert_eq!(one(&mut r, radio_a, &hb, 0), (1 << gcs, None));
    // The same frame through the other radio is a duplicate.
    assert_eq!(
        one(&mut r, radio_b, &hb, 10),
        (0, Some(DropReason::Duplicate))
    );
    assert_eq!(r.link_counters(radio_b).unwrap().drops.duplicate, 1);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (1, 1));
    assert_eq!(
        one(&mut r, gcs, &cmd, 20),
        ((1 << radio_a) | (1 << radio_b), None)
    );
    // After the window the same bytes pass again.
    assert_eq!(one(&mut r, radio_b, &hb, 600_000), (1 << gcs, None));
}

/// A broadcast address or multicast group (link 1) and two hosts heard there (links 2 and 3):
/// a host never gets a frame twice, nor its own frames back, and a frame for one host's system
/// goes to that host alone.
#[test]
fn a_host_reached_through_a_group_link_is_sent_each_frame_once() {
    let mut r = router(4);
    let (gcs, group, host_a, host_b) = (0, 1, 2, 3);
    r.reached_through(host_a, group);
    r.reached_through(host_b, group);
    // Refused: a link is not reached through itself, nor through a closed link.
    r.reached_through(gcs, gcs);
    r.reached_through(gcs, 7);
    assert_eq!(
        one(&mut r, gcs, &heartbeat(255, 190), 0),
        (1 << group, None)
    );
    // Vehicle 1 answers from host A: to the ground station, not back to the group.
    assert_eq!(one(&mut r, host_a, &heartbeat(1, 1), 0), (1 << gcs, None));
    one(&mut r, host_b, &heartbeat(2, 1), 0);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (1, 1));
    assert_eq!(one(&mut r, gcs, &cmd, 1), (1 << host_a, None));
    assert_eq!(r.link_counters(host_a).unwrap().tx_frames, 1);
    // Host B's vehicle commands host A's: host A alone.
    let cmd = frame(COMMAND_LONG, 2, 1, 0, (1, 1));
    assert_eq!(one(&mut r, host_b, &cmd, 2), (1 << host_a, None));
    // Once the group link closes, the hosts are links like any other.
    r.close_link(group);
    assert_eq!(
        one(&mut r, gcs, &heartbeat(255, 190), 3),
        ((1 << host_a) | (1 << host_b), None)
    );
}

/// A sniffer gets every frame: broadcasts, frames for a system behind another link, and
/// frames for a system nobody has seen; never its own.
#[test]
fn a_sniffer_link_gets_every_frame() {
    let mut r = router(3);
    let sniffer = r
        .open_link(LinkConfig {
            sniffer: true,
            ..LinkConfig::default()
        })
        .unwrap();
    one(&mut r, 1, &heartbeat(1, 1), 0);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (1, 1));
    assert_eq!(one(&mut r, 0, &cmd, 1), ((1 << 1) | (1 << sniffer), None));
    let lost = frame(COMMAND_LONG, 255, 190, 1, (9, 1));
    assert_eq!(one(&mut r, 0, &lost, 2), (1 << sniffer, None));
    assert_eq!(
        one(&mut r, sniffer, &heartbeat(200, 1), 3),
        (0b111, None),
        "what it sends is routed as any link's"
    );
    r.close_link(sniffer);
    assert_eq!(one(&mut r, 0, &lost, 4), (0, Some(DropReason::NoRoute)));
}

#[test]
fn filters_in_and_out() {
    let mut r = R::new(META);
    let mut inbound = Filter::OPEN;
    inbound.block_src_sys.insert(66);
    let a = r
        .open_link(LinkConfig {
            inbound,
            ..LinkConfig::default()
        })
        .unwrap();
    let mut outbound = Filter::OPEN;
    outbound.allow_msg.insert(HEARTBEAT).unwrap();
    let b = r
        .open_link(LinkConfig {
            outbound,
            ..LinkConfig::default()
        })
        .unwrap();
    let c = r.open_link(LinkConfig::default()).unwrap();

    assert_eq!(
        one(&mut r, a, &heartbeat(66, 1), 0),
        (0, Some(DropReason::FilteredIn))
    );
    assert_eq!(r.routes().count(), 0, "a filtered frame teaches nothing");
    assert_eq!(
        one(&mut r, a, &heartbeat(1, 1), 0),
        ((1 << b) | (1 << c), None)
    );
    let ping = frame(PING, 1, 1, 1, (0, 0));
    assert_eq!(one(&mut r, a, &ping, 0), (1 << c, None));
    assert_eq!(r.link_counters(b).unwrap().drops.filtered_out, 1);
    // Everything stopped on the way out.
    let only_b = frame(COMMAND_LONG, 1, 1, 2, (5, 0));
    one(&mut r, b, &heartbeat(5, 1), 0);
    assert_eq!(
        one(&mut r, a, &only_b, 0),
        (0, Some(DropReason::FilteredOut))
    );
}

#[test]
fn late_frames_are_not_sent_on_a_bounded_link() {
    let mut r = R::new(META);
    let src = r.open_link(LinkConfig::default()).unwrap();
    let slow = r
        .open_link(LinkConfig {
            max_delay_us: 1_000,
            ..LinkConfig::default()
        })
        .unwrap();
    let fast = r.open_link(LinkConfig::default()).unwrap();
    let mut got = Vec::new();
    r.receive(src, &heartbeat(1, 1), 0, 5_000, |routed| {
        got.push(routed.to)
    });
    assert_eq!(got, [1 << fast]);
    assert_eq!(r.link_counters(slow).unwrap().drops.late, 1);
}

#[test]
fn routes_age_out_and_closed_links_forget_theirs() {
    let mut r = router(3);
    one(&mut r, 1, &heartbeat(1, 1), 0);
    one(&mut r, 2, &heartbeat(2, 1), 0);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (1, 1));
    assert_eq!(one(&mut r, 0, &cmd, DEFAULT_ROUTE_TTL_US), (0b010, None));
    assert_eq!(
        one(&mut r, 0, &cmd, DEFAULT_ROUTE_TTL_US + 1),
        (0, Some(DropReason::NoRoute))
    );
    r.expire(DEFAULT_ROUTE_TTL_US + 1);
    assert!(r.counters().routes_expired >= 1);
    one(&mut r, 2, &heartbeat(2, 1), DEFAULT_ROUTE_TTL_US + 2);
    r.close_link(2);
    assert!(!r.is_open(2));
    assert!(r.routes().all(|route| route.link != 2));
    // Bytes for a closed link are ignored.
    assert!(feed(&mut r, 2, &heartbeat(2, 1), 0).is_empty());
    // The slot is reused, with fresh counters.
    assert_eq!(r.open_link(LinkConfig::default()), Some(2));
    assert_eq!(r.link_counters(2).unwrap().rx_frames, 0);
}

#[test]
fn routes_around_and_after_freed_slots_are_all_found() {
    let mut r = router(4);
    let to = |r: &mut R, sysid: u8| one(r, 0, &frame(COMMAND_LONG, 255, 190, 0, (sysid, 1)), 1);
    for link in 1..=3u8 {
        one(&mut r, usize::from(link), &heartbeat(link, 1), 0);
    }
    // A freed slot before the others, then the last one.
    r.close_link(1);
    assert_eq!(to(&mut r, 3), (1 << 3, None));
    r.close_link(3);
    assert_eq!(to(&mut r, 2), (1 << 2, None));
    assert_eq!(to(&mut r, 3), (0, Some(DropReason::NoRoute)));
    // New routes fill the freed slots, and the one past them.
    for sysid in [4, 5, 6] {
        one(&mut r, 2, &heartbeat(sysid, 1), 1);
    }
    for sysid in [2, 4, 5, 6] {
        assert_eq!(to(&mut r, sysid), (1 << 2, None), "system {sysid}");
    }
    let mut systems: Vec<u8> = r.routes().map(|r| r.sysid).collect();
    systems.sort_unstable();
    // (255, the sender of the commands, is learned too.)
    assert_eq!(systems, [2, 4, 5, 6, 255]);
    // All aged out, then learned again.
    r.expire(DEFAULT_ROUTE_TTL_US + 2);
    assert_eq!(r.routes().count(), 0);
    one(&mut r, 2, &heartbeat(6, 1), DEFAULT_ROUTE_TTL_US + 3);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (6, 1));
    assert_eq!(
        one(&mut r, 0, &cmd, DEFAULT_ROUTE_TTL_US + 3),
        (1 << 2, None)
    );
}

#[test]
fn full_tables_evict_the_oldest_and_keep_working() {
    let mut r: Router<2, 4, 4, 4> = Router::new(META);
    r.open_link(LinkConfig::default());
    r.open_link(LinkConfig::default());
    for sysid in 1..=10u8 {
        let mut n = 0;
        r.receive(
            1,
            &heartbeat(sysid, 1),
            u64::from(sysid),
            u64::from(sysid),
            |_| n += 1,
        );
        assert_eq!(n, 1);
    }
    assert_eq!(r.routes().count(), 4);
    assert_eq!(r.counters().routes_evicted, 6);
    assert_eq!(r.counters().sources_evicted, 6);
    let mut systems: Vec<u8> = r.routes().map(|r| r.sysid).collect();
    systems.sort_unstable();
    assert_eq!(systems, [7, 8, 9, 10]);
}

#[test]
fn sequence_loss_is_counted_per_source() {
    let mut r = router(2);
    // Two systems interleaved on one link: their sequences are independent.
    for seq in [0u8, 1, 2, 5, 6] {
        one(&mut r, 0, &frame(HEARTBEAT, 1, 1, seq, (0, 0)), 0);
        one(
            &mut r,
            0,
            &frame(HEARTBEAT, 2, 1, seq.wrapping_mul(3), (0, 0)),
            0,
        );
    }
    // Wrap-around is no loss.
    one(&mut r, 0, &frame(HEARTBEAT, 3, 1, 255, (0, 0)), 0);
    one(&mut r, 0, &frame(HEARTBEAT, 3, 1, 0, (0, 0)), 0);
    let lost = |sysid| r.sources().find(|s| s.sysid == sysid).unwrap().lost;
    assert_eq!(lost(1), 2);
    assert_eq!(lost(2), 2 + 2 + 2 + 8);
    assert_eq!(lost(3), 0);
    let s1 = r.sources().find(|s| s.sysid == 1).unwrap();
    assert_eq!((s1.rx_frames, s1.tx_frames), (5, 5));
}

fn key() -> SecretKey {
    SecretKey::new([7; 32])
}

fn signed_heartbeat(signer: &mut Signer, unix_us: u64, sysid: u8) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = signer
        .encode_raw(
            timestamp_from_unix_micros(unix_us),
            Header::new(0, sysid, 1),
            HEARTBEAT,
            50,
            &[1; 9],
            &mut out,
        )
        .unwrap();
    out[..n].to_vec()
}

#[test]
fn signing_at_the_edge() {
    let now = 1_700_000_000_000_000;
    let mut r = R::new(META);
    let trusted = r
        .open_link(LinkConfig {
            require_signing: Some(key()),
            ..LinkConfig::default()
        })
        .unwrap();
    let open = r.open_link(LinkConfig::default()).unwrap();

    let mut signer = Signer::new(key(), 3);
    let good = signed_heartbeat(&mut signer, now, 1);
    let mut got = Vec::new();
    r.receive(trusted, &good, now, now, |routed| {
        assert_eq!(routed.bytes, &good[..], "signed frames go out untouched");
        got.push(routed.to);
    });
    assert_eq!(got, [1 << open]);
    // A replay of the same frame.
    assert_eq!(
        one(&mut r, trusted, &good, now),
        (0, Some(DropReason::BadSignature))
    );
    // Unsigned, and signed with another key.
    assert_eq!(
        one(&mut r, trusted, &heartbeat(2, 1), now),
        (0, Some(DropReason::Unsigned))
    );
    let mut stranger = Signer::new(SecretKey::new([8; 32]), 3);
    let forged = signed_heartbeat(&mut stranger, now + 10, 4);
    assert_eq!(
        one(&mut r, trusted, &forged, now),
        (0, Some(DropReason::BadSignature))
    );
    let drops = r.link_counters(trusted).unwrap().drops;
    assert_eq!((drops.unsigned, drops.bad_signature), (1, 2));
    assert!(
        r.routes().all(|route| route.sysid == 1),
        "drops teach nothing"
    );
    // A signed frame from an open link is forwarded as it is, and never re-signed.
    let other = signed_heartbeat(&mut stranger, now + 20, 5);
    let mut forwarded = Vec::new();
    r.receive(open, &other, now, now, |routed| {
        forwarded = routed.bytes.to_vec()
    });
    assert_eq!(forwarded, other);
}

/// Links with one signing key share its replay state: a frame replayed through a new link
/// with the key (a new UDP port, TCP connection or reopened device, another endpoint with the
/// same key) is dropped, and a new stream must start within the spec's minute of the state's
/// clock.
#[test]
fn replays_are_caught_across_the_links_of_a_key() {
    let now = 1_700_000_000_000_000;
    let mut r = R::new(META);
    let signing = |key| LinkConfig {
        require_signing: Some(key),
        ..LinkConfig::default()
    };
    let first = r.open_link(signing(key())).unwrap();
    let vehicle = r.open_link(LinkConfig::default()).unwrap();
    let mut signer = Signer::new(key(), 3);
    let command = signed_heartbeat(&mut signer, now, 1);
    assert_eq!(one(&mut r, first, &command, now), (1 << vehicle, None));

    // The peer goes away; the attacker replays from a new port: a new link, same key.
    r.close_link(first);
    let second = r.open_link(signing(key())).unwrap();
    assert_eq!(
        one(&mut r, second, &command, now + 1_000),
        (0, Some(DropReason::BadSignature))
    );
    // Beside it, at the same time, another peer of the endpoint.
    let third = r.open_link(signing(key())).unwrap();
    assert_eq!(
        one(&mut r, third, &command, now + 2_000),
        (0, Some(DropReason::BadSignature))
    );
    // The real peer carries on with newer timestamps, from any of them.
    let next = signed_heartbeat(&mut signer, now + 10_000, 1);
    assert_eq!(one(&mut r, third, &next, now + 10_000).1, None);

    // A new stream (link id 9) whose timestamp is more than a minute behind the domain's
    // clock is refused; one within the minute is taken.
    let mut late = Signer::new(key(), 9);
    let stale = signed_heartbeat(&mut late, now - 61_000_000, 2);
    assert_eq!(
        one(&mut r, second, &stale, now + 20_000),
        (0, Some(DropReason::BadSignature))
    );
    let recent = signed_heartbeat(&mut late, now - 30_000_000, 2);
    assert_eq!(one(&mut r, second, &recent, now + 20_000).1, None);

    // Every link with the key, whatever it is, shares the state: the frame is a replay there.
    let another = r.open_link(signing(key())).unwrap();
    assert_eq!(
        one(&mut r, another, &command, now + 30_000),
        (0, Some(DropReason::BadSignature))
    );
    // A link with another key has a state of its own: the frame is not signed with its key.
    let mut stranger = Signer::new(SecretKey::new([9; 32]), 3);
    let own = signed_heartbeat(&mut stranger, now, 1);
    let alone = r.open_link(signing(SecretKey::new([9; 32]))).unwrap();
    assert_eq!(one(&mut r, alone, &own, now + 40_000).1, None);
    assert_eq!(
        one(&mut r, alone, &command, now + 50_000),
        (0, Some(DropReason::BadSignature))
    );
}

proptest! {
    /// Random frames (some corrupted) from random links: no echo, nothing that failed its
    /// checksum comes out, and the counters add up.
    #[test]
    fn invariants(steps in prop::collection::vec(
        (0usize..4, 0u8..5, prop::sample::select(vec![HEARTBEAT, PING, PARAM_REQUEST_LIST, COMMAND_LONG, UNKNOWN]),
         0u8..4, 0u8..3, any::<bool>(), any::<u8>()),
        1..200,
    )) {
        let mut r = router(4);
        let mut out_frames = [0u64; 4];
        let mut delivered = 0u64;
        let mut intact = Vec::new();
        for (t, (from, sysid, id, tsys, tcomp, corrupt, seq)) in steps.into_iter().enumerate() {
            let mut bytes = frame(id, sysid, 1, seq, (tsys, tcomp));
            if corrupt {
                let i = bytes.len() - 1;
                bytes[i] ^= 0x5a;
            } else {
                intact.push(bytes.clone());
            }
            let mut outcome = Ok(());
            r.receive(from, &bytes, t as u64, t as u64, |routed| {
                let check = (|| {
                    prop_assert_eq!(routed.to & (1 << from), 0);
                    prop_assert_eq!(routed.to == 0, routed.dropped.is_some());
                    // A stream link may hand out an earlier frame late (a corrupted one can
                    // leave a false magic byte waiting), but never a corrupted known frame.
                    if routed.frame.is_checked() {
                        prop_assert!(intact.contains(&routed.bytes.to_vec()));
                    }
                    Ok(())
                })();
                outcome = outcome.clone().and(check);
                for (i, n) in out_frames.iter_mut().enumerate() {
                    *n += (routed.to >> i) & 1;
                }
                delivered += 1;
            });
            outcome?;
        }
        let mut rx = 0;
        for (i, n) in out_frames.iter().enumerate() {
            let c = r.link_counters(i).unwrap();
            prop_assert_eq!(c.tx_frames, *n);
            rx += c.rx_frames;
        }
        prop_assert_eq!(rx, delivered);
        let sources: u64 = r.sources().map(|s| s.rx_frames).sum();
        let dropped_in: u64 = (0..4).map(|i| {
            let d = r.link_counters(i).unwrap().drops;
            d.unsigned + d.bad_signature + d.duplicate + d.filtered_in
        }).sum();
        // Frames with unknown ids pass unproven: they teach nothing, sources included.
        let unchecked: u64 = (0..4).map(|i| r.link_counters(i).unwrap().unchecked).sum();
        prop_assert_eq!(sources + dropped_in + unchecked, delivered);
    }
}

proptest! {
    /// Arbitrary scripts: the invariants the `mavlink_router` fuzz target checks.
    #[test]
    fn scripts_keep_the_invariants(script in prop::collection::vec(any::<u8>(), 0..1500)) {
        scripts::check_router(&script);
    }

    /// Scripts made mostly of well-formed frames, so that routes are learnt and used.
    #[test]
    fn frame_scripts_keep_the_invariants(ops in prop::collection::vec((0u8..64, any::<[u8; 8]>()), 0..200)) {
        let mut script = Vec::new();
        for (op, args) in ops {
            script.push(op << 2 | 1);
            script.extend_from_slice(&args);
        }
        scripts::check_router(&script);
    }
}

/// A router without filters or source counters (what a small radio bridge builds) routes a
/// scripted exchange exactly as the full one does, in far less memory.
#[test]
fn a_router_without_filters_routes_the_same() {
    let mut lean: Router<3, 16, 0, 0, NoFilter> = Router::new(META);
    let mut full: Router<3, 16, 16, 16> = Router::new(META);
    for _ in 0..3 {
        lean.open_link(LinkConfig::default()).unwrap();
        full.open_link(LinkConfig::default()).unwrap();
    }
    let traffic = [
        (0, heartbeat(1, 1)),
        (1, heartbeat(255, 190)),
        (1, frame(COMMAND_LONG, 255, 190, 1, (1, 1))),
        (0, frame(COMMAND_LONG, 1, 1, 1, (255, 0))),
        (2, frame(COMMAND_LONG, 9, 9, 0, (7, 7))),
        (2, heartbeat(7, 7)),
        (1, frame(COMMAND_LONG, 255, 190, 2, (7, 7))),
    ];
    for (from, bytes) in &traffic {
        let mut lean_out = Vec::new();
        lean.receive(*from, bytes, 0, 0, |r| lean_out.push((r.to, r.dropped)));
        let mut full_out = Vec::new();
        full.receive(*from, bytes, 0, 0, |r| full_out.push((r.to, r.dropped)));
        assert_eq!(lean_out, full_out, "from link {from}");
        assert_eq!(lean_out.len(), 1);
    }
    let (lean, full) = (
        core::mem::size_of::<Router<3, 16, 0, 0, NoFilter>>(),
        core::mem::size_of::<Router<3, 16, 16, 16>>(),
    );
    // Half, give or take the signing state both keep (a few bytes per link).
    assert!(
        lean * 2 <= full + 64,
        "{lean} B against {full} B: about half"
    );
}

/// A router whose first `links` links take datagrams (UDP peers).
fn datagram_router(links: usize) -> R {
    let mut r = R::new(META);
    for _ in 0..links {
        r.open_link(LinkConfig {
            datagrams: true,
            ..LinkConfig::default()
        })
        .unwrap();
    }
    r
}

/// Random datagrams, as a scanner or a bad radio sends: some pass as frames with unknown ids
/// (the spec wants those forwarded), none teaches a route or counts as a source, and commands
/// still reach the vehicle.
#[test]
fn garbage_teaches_nothing() {
    let mut r = datagram_router(3);
    one(&mut r, 0, &heartbeat(1, 1), 0b110);
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut forwarded = 0;
    for t in 0..5_000u64 {
        let len = 1 + (seed % 300) as usize;
        let datagram: Vec<u8> = (0..len)
            .map(|_| {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                // Plenty of magic bytes, so that frames with unknown ids do turn up.
                if seed.is_multiple_of(7) {
                    0xFD
                } else {
                    seed as u8
                }
            })
            .collect();
        r.receive(1, &datagram, t, t, |routed| {
            assert!(!routed.frame.is_checked(), "random bytes passed a checksum");
            forwarded += u64::from(routed.to != 0);
        });
    }
    assert!(
        forwarded > 0,
        "no unknown-id frame turned up: the test proves nothing"
    );
    assert!(
        r.routes().all(|route| route.link == 0),
        "garbage taught a route"
    );
    assert!(r.sources().all(|s| (s.sysid, s.compid) == (1, 1)));
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (1, 1));
    assert_eq!(one(&mut r, 2, &cmd, 1), (0b001, None));
}

/// On a link of datagrams a frame cut off at a datagram's end is dropped and counted, never
/// joined with the next datagram; a stream link keeps it waiting for the rest.
#[test]
fn a_datagram_is_a_boundary() {
    let whole = heartbeat(1, 1);
    let mut r = datagram_router(2);
    let mut out = Vec::new();
    r.receive(0, &whole[..10], 0, 0, |routed| {
        out.push(routed.bytes.to_vec())
    });
    r.receive(0, &whole[10..], 0, 0, |routed| {
        out.push(routed.bytes.to_vec())
    });
    r.receive(0, &whole, 0, 0, |routed| out.push(routed.bytes.to_vec()));
    assert_eq!(
        out,
        std::slice::from_ref(&whole),
        "only the whole datagram's frame"
    );
    let c = r.link_counters(0).unwrap();
    assert_eq!((c.truncated_datagrams, c.rx_frames), (1, 1));
    assert_eq!(
        c.garbage_bytes,
        whole.len() as u64,
        "the piece and the rest dropped"
    );

    let mut stream = router(2);
    let mut out = Vec::new();
    stream.receive(0, &whole[..10], 0, 0, |routed| {
        out.push(routed.bytes.to_vec())
    });
    stream.receive(0, &whole[10..], 0, 0, |routed| {
        out.push(routed.bytes.to_vec())
    });
    assert_eq!(out, [whole], "a stream joins the pieces");
}

/// One link floods (system, component) pairs it made up, in frames that check: it can only push
/// out its own routes, never the vehicle's on another link.
#[test]
fn a_spoof_flood_cannot_evict_another_links_routes() {
    let mut r = router(3);
    one(&mut r, 0, &heartbeat(1, 1), 0b110);
    one(&mut r, 2, &heartbeat(255, 190), 0b011);
    for i in 0..1_000u32 {
        let spoofed = heartbeat((i % 250) as u8 + 2, (i / 250) as u8 + 1);
        r.receive(1, &spoofed, u64::from(i), u64::from(i), |_| {});
    }
    assert!(r.counters().routes_evicted > 900);
    let cmd = frame(COMMAND_LONG, 255, 190, 0, (1, 1));
    assert_eq!(
        one(&mut r, 2, &cmd, 2),
        (0b001, None),
        "the vehicle is still routed"
    );
    let back = frame(COMMAND_LONG, 1, 1, 0, (255, 190));
    assert_eq!(
        one(&mut r, 0, &back, 1),
        (0b100, None),
        "and so is the ground station"
    );
    // The flood may fill what the other links leave free, and churns through that.
    let held = r.routes().filter(|route| route.link == 1).count();
    assert_eq!(held, 16 - 2);
}
