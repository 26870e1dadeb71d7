//! The README's first program, both faces, against `ferrolink mavlink vehicle`: it finds the
//! vehicle, prints its position, and the vehicle accepts the arm and the take-off.

use std::process::{Command, Stdio};

use ferrolink_test_support::free_port;

fn ferrolink() -> std::path::PathBuf {
    let target = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/debug");
    target.join("ferrolink")
}

fn fly(face: &[&str]) {
    let port = free_port();
    // The CLI is built by the workspace's tests; build it here when run alone.
    if !ferrolink().exists() {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let built = Command::new(cargo)
            .args(["build", "-q", "-p", "ferrolink-cli"])
            .status()
            .expect("cargo");
        assert!(built.success());
    }
    let mut vehicle = Command::new(ferrolink())
        .args([
            "mavlink",
            "vehicle",
            "--autopilot",
            "px4",
            "--run-for",
            "30",
        ])
        .arg(format!("udpout://127.0.0.1:{port}"))
        .stdout(Stdio::null())
        .spawn()
        .expect("the vehicle");
    let out = Command::new(env!("CARGO_BIN_EXE_ferrolink-example-fly"))
        .arg(format!("udpin://127.0.0.1:{port}"))
        .args(face)
        .output()
        .expect("run the example");
    let _ = vehicle.kill();
    let _ = vehicle.wait();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("position: Some(Position { lat: 47.397742"),
        "{text}"
    );
    assert!(
        text.contains("arm: Accepted") && text.contains("takeoff: Accepted"),
        "{text}"
    );
}

#[test]
fn blocking() {
    fly(&[]);
}

#[test]
fn asynchronous() {
    fly(&["--async"]);
}
