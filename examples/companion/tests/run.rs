//! The companion example against a pymavlink vehicle over UDP: it sees the heartbeat and the
//! attitude, and its command is acknowledged.
//!
//! Needs a Python with pymavlink (`FERROLINK_PYTHON`, else `.venv/bin/python`, which
//! `tests/run-all.sh` installs); without one the test says so and passes, unless
//! `FERROLINK_REQUIRE_PYMAVLINK` is set.

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::Command;

fn python() -> Option<PathBuf> {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = std::env::var_os("FERROLINK_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join(".venv/bin/python"));
    let ok = Command::new(&python)
        .args(["-c", "import pymavlink"])
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(python)
}

#[test]
fn companion_against_a_pymavlink_vehicle() {
    let Some(python) = python() else {
        assert!(
            std::env::var_os("FERROLINK_REQUIRE_PYMAVLINK").is_none(),
            "pymavlink is required"
        );
        eprintln!("skipped: no pymavlink");
        return;
    };
    let port = UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free port")
        .port();
    let companion = Command::new(env!("CARGO_BIN_EXE_ferrolink-example-companion"))
        .args([&format!("udpin://127.0.0.1:{port}"), "--seconds", "4"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("start the companion");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/mavlink/vehicle.py");
    let vehicle = Command::new(python)
        .arg(script)
        .args([&format!("udpout:127.0.0.1:{port}"), "--seconds", "5"])
        .output()
        .expect("run the vehicle");
    let out = companion.wait_with_output().expect("companion output");
    let text = String::from_utf8_lossy(&out.stdout);
    let vehicle_text = String::from_utf8_lossy(&vehicle.stdout);
    assert!(
        out.status.success(),
        "companion:\n{text}\nvehicle:\n{vehicle_text}"
    );
    assert!(
        text.contains("heartbeat from 1/1: Quadrotor Ardupilotmega"),
        "{text}"
    );
    assert!(text.contains("attitude: roll"), "{text}");
    assert!(text.contains("ack: Unknown(511) Accepted"), "{text}");
    assert!(
        vehicle_text.contains("command 511 from 1/191 acknowledged"),
        "{vehicle_text}"
    );
}
