//! Two `ferrolink mavlink router`s joined only by Zenoh (`tests/mavlink/fleet.py`): a pymavlink
//! vehicle behind each, a ground station on one commanding the vehicle behind the other, a
//! subscriber from the Python `eclipse-zenoh` package reading both vehicles' telemetry, commands
//! put on Zenoh, `ferrolink mavlink fleet`, JSON encoding, and (as root) the same across network
//! namespaces.
//!
//! Needs a Python with pymavlink and eclipse-zenoh (`tests/run-all.sh` installs them). With
//! `FERROLINK_REQUIRE_ZENOH` set (the full run sets it when the install worked) a check skipped
//! for a missing package fails the test.
#![cfg(feature = "zenoh")]

mod common;

#[test]
fn two_routers_joined_by_zenoh() {
    let Some(stdout) = common::run_router_checks("fleet.py") else {
        return;
    };
    if std::env::var_os("FERROLINK_REQUIRE_ZENOH").is_some() {
        assert!(
            !stdout.contains("eclipse-zenoh package is missing"),
            "a check was skipped:\n{stdout}"
        );
    }
}
