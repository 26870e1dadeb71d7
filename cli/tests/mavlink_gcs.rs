//! `ferrolink mavlink router` with real ground-station software on loopback
//! (`tests/mavlink/router_gcs.py`): a MAVSDK vehicle built from its server plugins and a MAVSDK
//! ground station that lists and sets parameters, uploads and downloads a mission and reads
//! telemetry through the router; MAVProxy fetching a vehicle's parameters through it; and every
//! tlog the router wrote decoding with pymavlink to exactly the frames it received.
//!
//! Needs a Python with pymavlink, mavsdk and MAVProxy (`tests/run-all.sh` installs them). A
//! missing package makes its check say `skip`; with `FERROLINK_REQUIRE_GCS` set (the full run
//! sets it when the installs worked) a skip fails the test.

mod common;

use std::process::Command;

use common::{ferrolink, pymavlink, workspace};

#[test]
fn ground_stations_through_the_router() {
    let Some((python, dialects)) = pymavlink() else {
        common::skip("pymavlink is missing");
        return;
    };
    let workdir = tempfile::tempdir().expect("a scratch directory");
    let out = Command::new(python)
        .arg(workspace().join("tests/mavlink/router_gcs.py"))
        .arg("--router")
        .arg(ferrolink())
        .arg("--dialect-dir")
        .arg(&dialects)
        .arg("--workdir")
        .arg(workdir.path())
        .output()
        .expect("run the ground-station checks");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "some checks failed:\n{stdout}");
    assert!(stdout.contains(" 0 failed"), "{stdout}");
    if std::env::var_os("FERROLINK_REQUIRE_GCS").is_some() {
        assert!(!stdout.contains("skip "), "a check was skipped:\n{stdout}");
    }
}
