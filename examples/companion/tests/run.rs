//! The companion example against a pymavlink vehicle over UDP: it sees the heartbeat and the
//! attitude, and its command is acknowledged.
//!
//! Needs a Python with pymavlink (`FERROLINK_PYTHON`, else `.venv/bin/python`, which
//! `tests/run-all.sh` installs); without one the test says so and passes, unless
//! `FERROLINK_REQUIRE_PYMAVLINK` is set.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A Python that can import `module`.
fn python(module: &str) -> Option<PathBuf> {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = std::env::var_os("FERROLINK_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join(".venv/bin/python"));
    let ok = Command::new(&python)
        .args(["-c", &format!("import {module}")])
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(python)
}

/// Runs the companion for 4 s (6 s with `seconds`) against `vehicle` (a script of
/// `tests/mavlink/` started with the URL to reach the companion at) and returns what both
/// printed, after checking the companion succeeded.
fn against(
    python: PathBuf,
    vehicle: &str,
    url: impl Fn(u16) -> String,
    seconds: u32,
) -> (String, String) {
    let port = ferrolink_test_support::free_port();
    let companion = Command::new(env!("CARGO_BIN_EXE_ferrolink-example-companion"))
        .args([
            &format!("udpin://127.0.0.1:{port}"),
            "--seconds",
            &seconds.to_string(),
        ])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("start the companion");
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/mavlink")
        .join(vehicle);
    let vehicle = Command::new(python)
        .arg(script)
        .args([&url(port), "--seconds", &(seconds + 1).to_string()])
        .output()
        .expect("run the vehicle");
    let out = companion.wait_with_output().expect("companion output");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let vehicle_text = String::from_utf8_lossy(&vehicle.stdout).into_owned();
    assert!(
        out.status.success(),
        "companion:\n{text}\nvehicle:\n{vehicle_text}"
    );
    (text, vehicle_text)
}

#[test]
fn companion_against_a_pymavlink_vehicle() {
    let Some(python) = python("pymavlink") else {
        assert!(
            std::env::var_os("FERROLINK_REQUIRE_PYMAVLINK").is_none(),
            "pymavlink is required"
        );
        eprintln!("skipped: no pymavlink");
        return;
    };
    let (text, vehicle) = against(python, "vehicle.py", |p| format!("udpout:127.0.0.1:{p}"), 4);
    assert!(
        text.contains("heartbeat from 1/1: Quadrotor Ardupilotmega"),
        "{text}"
    );
    assert!(text.contains("attitude: roll"), "{text}");
    assert!(
        text.contains("ack: SET_MESSAGE_INTERVAL ACCEPTED"),
        "{text}"
    );
    assert!(
        vehicle.contains("command 511 from 1/191 acknowledged"),
        "{vehicle}"
    );
}

/// The same against a vehicle built from MAVSDK's server plugins: MAVSDK acknowledges the
/// interval request itself, and the vehicle streams ATTITUDE at the interval asked for.
#[test]
fn companion_against_a_mavsdk_vehicle() {
    let Some(python) = python("mavsdk") else {
        assert!(
            std::env::var_os("FERROLINK_REQUIRE_GCS").is_none(),
            "mavsdk is required"
        );
        eprintln!("skipped: no mavsdk");
        return;
    };
    let (text, vehicle) = against(
        python,
        "mavsdk_vehicle.py",
        |p| format!("udpout://127.0.0.1:{p}"),
        6,
    );
    assert!(text.contains("heartbeat from 1/1"), "{text}");
    assert!(
        text.contains("ack: SET_MESSAGE_INTERVAL ACCEPTED"),
        "{text}"
    );
    assert!(text.contains("attitude: roll"), "{text}");
    assert!(vehicle.contains("got command 511 from 1/191"), "{vehicle}");
}
