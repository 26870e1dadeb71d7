//! The microservices against MAVSDK (`tests/mavlink/services_mavsdk.py`), in both directions:
//! MAVSDK's Param and Action plugins against `ferrolink mavlink vehicle` (claiming PX4, then
//! ArduPilot), and `ferrolink mavlink param|command` against vehicles built from MAVSDK's
//! ParamServer and ActionServer plugins; then parameter lists both ways through a UDP relay
//! that loses 20 %, repeats 5 % and reorders; missions and FTP both ways, clean and lossy.
//!
//! Needs a Python with mavsdk (`tests/run-all.sh` installs it). Without it the checks say
//! `skip`; with `FERROLINK_REQUIRE_GCS` set a skip fails the test.

mod common;

#[test]
fn the_services_against_mavsdk() {
    let Some((python, _)) = common::pymavlink() else {
        common::skip("pymavlink is missing");
        return;
    };
    let stdout = common::run_checks(
        &python,
        "mavlink/services_mavsdk.py",
        &["--ferrolink".as_ref(), common::ferrolink().as_ref()],
    );
    if std::env::var_os("FERROLINK_REQUIRE_GCS").is_some() {
        assert!(!stdout.contains("skip "), "a check was skipped:\n{stdout}");
    }
}

/// pymavlink's mavwp and mavftp against `ferrolink mavlink vehicle`, and MAVProxy's parameter
/// download and `wp list` through `ferrolink mavlink router`
/// (`tests/mavlink/services_pymavlink.py`).
#[test]
fn the_services_against_pymavlink_and_mavproxy() {
    let Some((python, _)) = common::pymavlink() else {
        common::skip("pymavlink is missing");
        return;
    };
    let stdout = common::run_checks(
        &python,
        "mavlink/services_pymavlink.py",
        &["--ferrolink".as_ref(), common::ferrolink().as_ref()],
    );
    if std::env::var_os("FERROLINK_REQUIRE_GCS").is_some() {
        assert!(!stdout.contains("skip "), "a check was skipped:\n{stdout}");
    }
}
