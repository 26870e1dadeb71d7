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

#[test]
fn ground_stations_through_the_router() {
    let Some(stdout) = common::run_router_checks("router_gcs.py") else {
        return;
    };
    if std::env::var_os("FERROLINK_REQUIRE_GCS").is_some() {
        assert!(!stdout.contains("skip "), "a check was skipped:\n{stdout}");
    }
}
