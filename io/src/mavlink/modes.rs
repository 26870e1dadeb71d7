//! Flight modes by name, both ways: PX4's (main and sub mode in `custom_mode`) and
//! ArduPilot's, per vehicle family (copter, plane, rover, sub, tracker, blimp), as pymavlink's
//! `mavutil` tables have them (a test checks every entry against them).
//!
//! ```
//! use ferrolink_dialects::common::{MavAutopilot, MavType};
//! use ferrolink_io::mavlink::modes;
//!
//! let guided = modes::lookup(MavAutopilot::Ardupilotmega, MavType::Quadrotor, "guided").unwrap();
//! assert_eq!(guided.custom_mode, 4);
//! assert_eq!(modes::name(MavAutopilot::Ardupilotmega, MavType::FixedWing, 4), Some("ACRO"));
//! let hold = modes::lookup(MavAutopilot::Px4, MavType::Quadrotor, "HOLD").unwrap();
//! assert_eq!(modes::display(MavAutopilot::Px4, MavType::Quadrotor, hold.custom_mode), "HOLD");
//! assert_eq!(modes::display(MavAutopilot::Px4, MavType::Quadrotor, 0), "CUSTOM(0)");
//! ```
//!
//! PX4's names are pymavlink's but for `HOLD`, which pymavlink calls `LOITER` (PX4's
//! AUTO_LOITER; QGroundControl and MAVSDK say Hold): both are taken, `HOLD` is shown.

use ferrolink_dialects::common::{MavAutopilot, MavType};

/// What MAV_CMD_DO_SET_MODE needs to put a vehicle in a mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mode {
    /// The mode's name, upper case.
    pub name: &'static str,
    /// The HEARTBEAT's `custom_mode` in that mode: ArduPilot's mode number, or PX4's main mode
    /// in bits 16 to 23 and sub mode in bits 24 to 31.
    pub custom_mode: u32,
}

impl Mode {
    /// DO_SET_MODE's param2 (ArduPilot's mode, PX4's main mode).
    pub fn main(self) -> u32 {
        if self.custom_mode > 0xffff {
            (self.custom_mode >> 16) & 0xff
        } else {
            self.custom_mode
        }
    }

    /// DO_SET_MODE's param3 (PX4's sub mode; 0 for ArduPilot).
    pub fn sub(self) -> u32 {
        self.custom_mode >> 24
    }
}

/// PX4's `custom_mode` of main mode `main` and sub mode `sub`.
const fn px4(main: u32, sub: u32) -> u32 {
    (main << 16) | (sub << 24)
}

/// PX4's modes (px4_custom_mode.h): MANUAL 1, ALTCTL 2, POSCTL 3, AUTO 4 (with sub modes
/// READY 1, TAKEOFF 2, LOITER 3, MISSION 4, RTL 5, LAND 6, RTGS 7, FOLLOW_TARGET 8, PRECLAND 9),
/// ACRO 5, OFFBOARD 6, STABILIZED 7, RATTITUDE 8.
const PX4: &[(&str, u32)] = &[
    ("MANUAL", px4(1, 0)),
    ("ALTCTL", px4(2, 0)),
    ("POSCTL", px4(3, 0)),
    ("TAKEOFF", px4(4, 2)),
    ("HOLD", px4(4, 3)),
    ("MISSION", px4(4, 4)),
    ("RTL", px4(4, 5)),
    ("LAND", px4(4, 6)),
    ("RTGS", px4(4, 7)),
    ("FOLLOWME", px4(4, 8)),
    ("PRECLAND", px4(4, 9)),
    ("ACRO", px4(5, 0)),
    ("OFFBOARD", px4(6, 0)),
    ("STABILIZED", px4(7, 0)),
    ("RATTITUDE", px4(8, 0)),
];

/// Other names PX4's modes go by: pymavlink's `LOITER` for AUTO_LOITER.
const PX4_ALIASES: &[(&str, &str)] = &[("LOITER", "HOLD")];

const COPTER: &[(&str, u32)] = &[
    ("STABILIZE", 0),
    ("ACRO", 1),
    ("ALT_HOLD", 2),
    ("AUTO", 3),
    ("GUIDED", 4),
    ("LOITER", 5),
    ("RTL", 6),
    ("CIRCLE", 7),
    ("POSITION", 8),
    ("LAND", 9),
    ("OF_LOITER", 10),
    ("DRIFT", 11),
    ("SPORT", 13),
    ("FLIP", 14),
    ("AUTOTUNE", 15),
    ("POSHOLD", 16),
    ("BRAKE", 17),
    ("THROW", 18),
    ("AVOID_ADSB", 19),
    ("GUIDED_NOGPS", 20),
    ("SMART_RTL", 21),
    ("FLOWHOLD", 22),
    ("FOLLOW", 23),
    ("ZIGZAG", 24),
    ("SYSTEMID", 25),
    ("AUTOROTATE", 26),
    ("AUTO_RTL", 27),
    ("TURTLE", 28),
    ("RATE_ACRO", 29),
];

const PLANE: &[(&str, u32)] = &[
    ("MANUAL", 0),
    ("CIRCLE", 1),
    ("STABILIZE", 2),
    ("TRAINING", 3),
    ("ACRO", 4),
    ("FBWA", 5),
    ("FBWB", 6),
    ("CRUISE", 7),
    ("AUTOTUNE", 8),
    ("AUTO", 10),
    ("RTL", 11),
    ("LOITER", 12),
    ("TAKEOFF", 13),
    ("AVOID_ADSB", 14),
    ("GUIDED", 15),
    ("INITIALISING", 16),
    ("QSTABILIZE", 17),
    ("QHOVER", 18),
    ("QLOITER", 19),
    ("QLAND", 20),
    ("QRTL", 21),
    ("QAUTOTUNE", 22),
    ("QACRO", 23),
    ("THERMAL", 24),
    ("LOITERALTQLAND", 25),
    ("AUTOLAND", 26),
];

const ROVER: &[(&str, u32)] = &[
    ("MANUAL", 0),
    ("ACRO", 1),
    ("LEARNING", 2),
    ("STEERING", 3),
    ("HOLD", 4),
    ("LOITER", 5),
    ("FOLLOW", 6),
    ("SIMPLE", 7),
    ("DOCK", 8),
    ("CIRCLE", 9),
    ("AUTO", 10),
    ("RTL", 11),
    ("SMART_RTL", 12),
    ("GUIDED", 15),
    ("INITIALISING", 16),
];

const SUB: &[(&str, u32)] = &[
    ("STABILIZE", 0),
    ("ACRO", 1),
    ("ALT_HOLD", 2),
    ("AUTO", 3),
    ("GUIDED", 4),
    ("CIRCLE", 7),
    ("SURFACE", 9),
    ("POSHOLD", 16),
    ("MANUAL", 19),
];

const TRACKER: &[(&str, u32)] = &[
    ("MANUAL", 0),
    ("STOP", 1),
    ("SCAN", 2),
    ("GUIDED", 4),
    ("AUTO", 10),
    ("INITIALISING", 16),
];

const BLIMP: &[(&str, u32)] = &[
    ("LAND", 0),
    ("MANUAL", 1),
    ("VELOCITY", 2),
    ("LOITER", 3),
    ("RTL", 4),
    ("AUTO", 5),
    ("HOLD", 6),
];

/// An ArduPilot vehicle's family, by its MAV_TYPE, as pymavlink's `AP_MAV_TYPE_MODE_MAP`
/// picks its table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// ArduCopter and helicopters.
    Copter,
    /// ArduPlane, QuadPlanes too.
    Plane,
    /// Rover and boats.
    Rover,
    /// ArduSub.
    Sub,
    /// AntennaTracker.
    Tracker,
    /// Blimp.
    Blimp,
}

impl Family {
    /// The family of an ArduPilot vehicle of type `kind`; `None` for types without a table.
    pub fn of(kind: MavType) -> Option<Family> {
        Some(match kind {
            MavType::Helicopter
            | MavType::Tricopter
            | MavType::Quadrotor
            | MavType::Hexarotor
            | MavType::Octorotor
            | MavType::Decarotor
            | MavType::Dodecarotor
            | MavType::Coaxial => Family::Copter,
            MavType::FixedWing
            | MavType::VtolTiltrotor
            | MavType::VtolDuorotor
            | MavType::VtolQuadrotor => Family::Plane,
            MavType::GroundRover | MavType::SurfaceBoat => Family::Rover,
            MavType::Submarine => Family::Sub,
            MavType::AntennaTracker => Family::Tracker,
            MavType::Airship => Family::Blimp,
            _ => return None,
        })
    }

    fn table(self) -> &'static [(&'static str, u32)] {
        match self {
            Family::Copter => COPTER,
            Family::Plane => PLANE,
            Family::Rover => ROVER,
            Family::Sub => SUB,
            Family::Tracker => TRACKER,
            Family::Blimp => BLIMP,
        }
    }
}

/// The mode table of a vehicle: PX4's, or ArduPilot's for its family.
fn table(autopilot: MavAutopilot, kind: MavType) -> &'static [(&'static str, u32)] {
    match autopilot {
        MavAutopilot::Px4 => PX4,
        MavAutopilot::Ardupilotmega => Family::of(kind).map_or(&[], Family::table),
        _ => &[],
    }
}

/// The name of mode `custom_mode` of a vehicle.
pub fn name(autopilot: MavAutopilot, kind: MavType, custom_mode: u32) -> Option<&'static str> {
    table(autopilot, kind)
        .iter()
        .find(|(_, m)| *m == custom_mode)
        .map(|(n, _)| *n)
}

/// The name of mode `custom_mode`, or `CUSTOM(N)` for a mode without one.
pub fn display(autopilot: MavAutopilot, kind: MavType, custom_mode: u32) -> String {
    name(autopilot, kind, custom_mode)
        .map_or_else(|| format!("CUSTOM({custom_mode})"), str::to_owned)
}

/// The mode called `name` (any case) of a vehicle.
pub fn lookup(autopilot: MavAutopilot, kind: MavType, name: &str) -> Option<Mode> {
    let upper = name.to_ascii_uppercase();
    let wanted = match autopilot {
        MavAutopilot::Px4 => PX4_ALIASES
            .iter()
            .find(|(alias, _)| *alias == upper)
            .map_or(upper.as_str(), |(_, to)| to),
        _ => upper.as_str(),
    };
    table(autopilot, kind)
        .iter()
        .find(|(n, _)| *n == wanted)
        .map(|&(name, custom_mode)| Mode { name, custom_mode })
}

/// Every mode name of a vehicle, in mode order.
pub fn names(autopilot: MavAutopilot, kind: MavType) -> Vec<&'static str> {
    table(autopilot, kind).iter().map(|(n, _)| *n).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_goes_both_ways() {
        for (autopilot, kind) in [
            (MavAutopilot::Px4, MavType::Quadrotor),
            (MavAutopilot::Ardupilotmega, MavType::Quadrotor),
            (MavAutopilot::Ardupilotmega, MavType::FixedWing),
            (MavAutopilot::Ardupilotmega, MavType::GroundRover),
            (MavAutopilot::Ardupilotmega, MavType::Submarine),
            (MavAutopilot::Ardupilotmega, MavType::AntennaTracker),
            (MavAutopilot::Ardupilotmega, MavType::Airship),
        ] {
            let names = names(autopilot, kind);
            assert!(!names.is_empty());
            for n in names {
                let mode = lookup(autopilot, kind, &n.to_lowercase()).unwrap();
                assert_eq!(name(autopilot, kind, mode.custom_mode), Some(n));
            }
        }
        assert_eq!(
            lookup(MavAutopilot::Generic, MavType::Quadrotor, "AUTO"),
            None
        );
        let loiter = lookup(MavAutopilot::Px4, MavType::Quadrotor, "loiter").unwrap();
        assert_eq!((loiter.name, loiter.main(), loiter.sub()), ("HOLD", 4, 3));
        let guided = lookup(MavAutopilot::Ardupilotmega, MavType::Hexarotor, "GUIDED").unwrap();
        assert_eq!((guided.main(), guided.sub()), (4, 0));
    }
}
