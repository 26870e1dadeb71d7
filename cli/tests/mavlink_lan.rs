//! The router on a shared network (`tests/mavlink/lan.py`): `udpbcast` and `udpmcast` (IPv4 and
//! IPv6) across network namespaces joined by a bridge, against pymavlink's `udpin:`,
//! `udpbcast:` and `mcast:`, with two vehicles in one group each commanded from its own ground
//! station. Needs root for the namespaces; skipped (and says so) without.

mod common;

#[test]
fn broadcast_and_multicast_across_hosts() {
    common::run_router_checks("lan.py");
}
