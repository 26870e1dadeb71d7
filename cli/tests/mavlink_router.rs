//! `ferrolink mavlink router` against pymavlink-built nodes on loopback: the routing rules as a
//! table of checks (`tests/mavlink/router_rules.py`), each with its own router process:
//! broadcast and no echo, targeted, component-targeted, unknown target, unknown ids and signed
//! frames forwarded byte for byte, garbage that teaches no route, two ground stations on one
//! `udpin` port, several frames in one datagram, many `tcpin` clients, a `tcpout` peer that
//! restarts, and a serial device (a pty).
//!
//! Needs a Python with pymavlink (`tests/run-all.sh` installs it); without one the test says so
//! and passes, unless `FERROLINK_REQUIRE_PYMAVLINK` is set.

mod common;

use std::process::Command;

use common::{ferrolink, pymavlink, workspace};

#[test]
fn routing_rules_against_pymavlink_nodes() {
    let Some((python, dialects)) = pymavlink() else {
        common::skip("pymavlink is missing");
        return;
    };
    let workdir = tempfile::tempdir().expect("a scratch directory");
    let out = Command::new(python)
        .arg(workspace().join("tests/mavlink/router_rules.py"))
        .arg("--router")
        .arg(ferrolink())
        .arg("--dialect-dir")
        .arg(&dialects)
        .arg("--workdir")
        .arg(workdir.path())
        .output()
        .expect("run the pymavlink checks");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "some checks failed:\n{stdout}");
    assert!(stdout.contains(" 0 failed"), "{stdout}");
}
