//! Our flight-mode tables against pymavlink 2.4.50's `mavutil` (`px4_map`, and
//! `mode_mapping_bynumber` per MAV_TYPE for ArduPilot): every name and number both ways.
//!
//! Needs a Python with pymavlink (`FERROLINK_PYTHON`, else the workspace's `.venv`); without
//! one the test says so and passes, unless `FERROLINK_REQUIRE_PYMAVLINK` is set.

use std::path::PathBuf;
use std::process::Command;

use ferrolink_dialects::common::{MavAutopilot, MavType};
use ferrolink_io::mavlink::modes;

const TABLES: &str = r#"
import json
from pymavlink import mavutil
out = {"px4": {name: [main, sub] for name, (_, main, sub) in mavutil.px4_map.items()},
       "ardupilot": {str(t): m for t, m in mavutil.AP_MAV_TYPE_MODE_MAP.items()}}
print(json.dumps(out))
"#;

fn python() -> Option<PathBuf> {
    let python = std::env::var_os("FERROLINK_PYTHON").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../.venv/bin/python"),
        PathBuf::from,
    );
    let ok = Command::new(&python)
        .args(["-c", "import pymavlink"])
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(python)
}

#[test]
fn our_mode_tables_are_pymavlinks() {
    let Some(python) = python() else {
        assert!(
            std::env::var_os("FERROLINK_REQUIRE_PYMAVLINK").is_none(),
            "pymavlink is missing, but FERROLINK_REQUIRE_PYMAVLINK is set"
        );
        eprintln!("skipped: pymavlink is missing");
        return;
    };
    let out = Command::new(python)
        .args(["-c", TABLES])
        .output()
        .expect("run python");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tables: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    // PX4: every pymavlink name (its LOITER is our HOLD) has the same main and sub mode.
    let px4 = tables["px4"].as_object().unwrap();
    for (name, modes_) in px4 {
        let ours = modes::lookup(MavAutopilot::Px4, MavType::Quadrotor, name)
            .unwrap_or_else(|| panic!("PX4 {name}"));
        assert_eq!(
            [u64::from(ours.main()), u64::from(ours.sub())],
            [modes_[0].as_u64().unwrap(), modes_[1].as_u64().unwrap()],
            "PX4 {name}"
        );
        let shown = modes::name(MavAutopilot::Px4, MavType::Quadrotor, ours.custom_mode);
        let expected = if name == "LOITER" { "HOLD" } else { name };
        assert_eq!(shown, Some(expected));
    }
    // ArduPilot: per vehicle type, the same numbers with the same names, and no more.
    let ardupilot = tables["ardupilot"].as_object().unwrap();
    for (kind, table) in ardupilot {
        let kind = MavType::from_raw(kind.parse().unwrap());
        let theirs: Vec<(u32, &str)> = table
            .as_object()
            .unwrap()
            .iter()
            .map(|(n, name)| (n.parse().unwrap(), name.as_str().unwrap()))
            .collect();
        let names = modes::names(MavAutopilot::Ardupilotmega, kind);
        assert_eq!(names.len(), theirs.len(), "{kind:?}");
        for (number, name) in theirs {
            assert_eq!(
                modes::name(MavAutopilot::Ardupilotmega, kind, number),
                Some(name),
                "{kind:?} {number}"
            );
        }
    }
    eprintln!(
        "{} PX4 modes, {} ArduPilot vehicle types: as pymavlink has them",
        px4.len(),
        ardupilot.len()
    );
}
