//! The MAVLink vehicle firmware (`examples/mavlink-vehicle`) in QEMU's Cortex-M4 board, end to
//! end: `examples/mavlink-vehicle/check.sh` builds it for `thumbv7em-none-eabihf` (adding the
//! target with rustup when it is missing), runs it in `qemu-system-arm` and checks it through
//! `ferrolink mavlink router` with MAVSDK, pymavlink and this CLI
//! (`tests/mavlink/firmware_qemu.py`): HEARTBEAT, parameters, missions, commands, FTP (the
//! parameters as `@PARAM/param.pck`) and the stack it used.
//!
//! Needs `qemu-system-arm`, the target (or rustup to add it) and a Python with pymavlink and
//! mavsdk (`tests/run-all.sh` installs them). Without one of them the test says why and does
//! nothing; with `FERROLINK_REQUIRE_GCS` set (the full run, which installs them) that fails it,
//! as a check of the script that says `skip` does.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

const TARGET: &str = "thumbv7em-none-eabihf";

fn firmware_dir() -> PathBuf {
    common::workspace().join("examples/mavlink-vehicle")
}

/// Says why the test does nothing; fails when the full run requires the ground-station tools.
/// (Not `common::skip`, which fails under `FERROLINK_REQUIRE_PYMAVLINK`: a run with pymavlink
/// but without QEMU or mavsdk, say offline, is not a failure.)
fn skip(why: &str) {
    assert!(
        std::env::var_os("FERROLINK_REQUIRE_GCS").is_none(),
        "{why}, but FERROLINK_REQUIRE_GCS is set"
    );
    eprintln!("skipped: {why}");
}

/// Whether `program ARGS` runs and succeeds (in `dir`).
fn runs(program: &str, args: &[&str], dir: &Path) -> bool {
    Command::new(program)
        .args(args)
        .current_dir(dir)
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Whether the firmware's toolchain has the target, or rustup is there to add it.
fn target_available(dir: &Path) -> bool {
    let libdir = Command::new("rustc")
        .args(["--print", "target-libdir", "--target", TARGET])
        .current_dir(dir)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
    libdir.is_some_and(|d| d.is_dir()) || runs("rustup", &["--version"], dir)
}

#[test]
fn the_vehicle_firmware_in_qemu() {
    let Some((python, _)) = common::pymavlink() else {
        common::skip("pymavlink is missing");
        return;
    };
    let dir = firmware_dir();
    if !runs("qemu-system-arm", &["--version"], &dir) {
        skip("qemu-system-arm is not installed");
        return;
    }
    if !target_available(&dir) {
        skip(&format!(
            "the {TARGET} target is not installed and there is no rustup"
        ));
        return;
    }
    if !runs(
        python.to_str().unwrap_or("python3"),
        &["-c", "import mavsdk"],
        &dir,
    ) {
        skip("Python's mavsdk is missing");
        return;
    }

    let mut check = Command::new("bash");
    check
        .arg(dir.join("check.sh"))
        .env("FERROLINK", common::ferrolink())
        .env("PYTHON", &python)
        // The firmware builds in its own target directory, whatever the workspace uses.
        .env_remove("CARGO_TARGET_DIR");
    // check.sh takes a lock around cargo (so that builds beside it wait their turn). A caller
    // that runs these tests holding the default lock would wait for itself: unless told
    // otherwise, the firmware's build takes a lock of its own.
    if std::env::var_os("FERROLINK_CARGO_LOCK").is_none() {
        check.env(
            "FERROLINK_CARGO_LOCK",
            std::env::temp_dir().join("ferrolink-firmware-check.lock"),
        );
    }
    let out = check
        .output()
        .unwrap_or_else(|e| panic!("cannot run check.sh: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "check.sh failed:\n{stdout}");
    assert!(stdout.contains(" 0 failed"), "{stdout}");
    if std::env::var_os("FERROLINK_REQUIRE_GCS").is_some() {
        assert!(
            !stdout.lines().any(|l| l.starts_with("skip")),
            "a check was skipped:\n{stdout}"
        );
    }
}
