//! The flying software vehicle and the vehicle API against MAVSDK
//! (`tests/mavlink/flight_mavsdk.py`): MAVSDK's Telemetry, Action and MissionRaw clients fly
//! `ferrolink mavlink vehicle` as PX4 and as ArduPilot (arm, take off, go to a point, a
//! mission, return and land), on a clean link and through one that loses 20 % each way; our
//! `ferrolink mavlink action` against the vehicle, each action ending with its true result,
//! clean and lossy; and `ferrolink mavlink telemetry|action` against a vehicle built from
//! MAVSDK's TelemetryServer and ActionServer.
//!
//! Needs a Python with mavsdk (`tests/run-all.sh` installs it). Without it the checks say
//! `skip`; with `FERROLINK_REQUIRE_GCS` set a skip fails the test.

mod common;

fn run(extra: &[&str]) {
    let Some((python, _)) = common::pymavlink() else {
        common::skip("pymavlink is missing");
        return;
    };
    let mut args: Vec<&std::ffi::OsStr> = vec![
        std::ffi::OsStr::new("--ferrolink"),
        std::ffi::OsStr::new(common::ferrolink()),
    ];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    let stdout = common::run_checks(&python, "mavlink/flight_mavsdk.py", &args);
    common::require_no_skip(&stdout, "FERROLINK_REQUIRE_GCS", "mavsdk");
}

/// examples/fly's program, for the API's async face, when it is built (`cargo test
/// --workspace` builds it).
fn fly() -> Option<String> {
    let path = std::path::Path::new(common::ferrolink()).with_file_name("ferrolink-example-fly");
    path.exists().then(|| path.to_string_lossy().into_owned())
}

#[test]
fn mavsdk_flies_our_vehicle_and_our_api_drives_mavsdks() {
    match fly() {
        Some(fly) => run(&["--fly", &fly]),
        None => {
            eprintln!("examples/fly is not built: the async face's check is left out");
            run(&[]);
        }
    }
}

#[test]
fn mavsdk_flies_our_vehicle_through_a_lossy_link() {
    run(&[
        "--loss",
        "0.2",
        "--only",
        "our_actions,mavsdk_flies_px4,mavsdk_flies_ardupilot",
    ]);
}
