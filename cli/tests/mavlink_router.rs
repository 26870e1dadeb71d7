//! `ferrolink mavlink router` against pymavlink nodes on loopback: the routing rules as a table
//! of checks (`tests/mavlink/router_peers.py`), each with its own router process: broadcast and
//! no echo, targeted, component-targeted, unknown target, unknown ids and signed frames
//! forwarded byte for byte, PARAM_* and MISSION_* routed by their targets with the built-in
//! dialects (no `--dialect`), garbage that teaches no route, two ground stations on one `udpin`
//! port, a `tcpout` peer that restarts, many `tcpin` clients, several frames in one datagram, a
//! serial device (a pty), and the tlog read back by pymavlink.
//!
//! Needs a Python with pymavlink (`tests/run-all.sh` installs it); without one the test says so
//! and passes, unless `FERROLINK_REQUIRE_PYMAVLINK` is set.

mod common;

#[test]
fn routing_rules_against_pymavlink_nodes() {
    common::run_router_checks("router_peers.py");
}
