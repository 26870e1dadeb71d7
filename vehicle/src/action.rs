//! Actions: each one or a few commands through the command service (its retries, its
//! `IN_PROGRESS` reports), done the way each autopilot expects them.
//!
//! | action | PX4 | ArduPilot |
//! |---|---|---|
//! | arm, disarm | COMPONENT_ARM_DISARM | the same |
//! | force disarm | COMPONENT_ARM_DISARM with 21196 | the same |
//! | take off to ALT m | NAV_TAKEOFF to home's altitude + ALT (AMSL) | mode GUIDED, then NAV_TAKEOFF to ALT (above home) |
//! | land | NAV_LAND | the same |
//! | return to launch | NAV_RETURN_TO_LAUNCH | the same |
//! | hold | mode HOLD | mode LOITER (copter, plane, blimp), HOLD (rover), POSHOLD (sub) |
//! | go to LAT, LON, ALT (AMSL) | DO_REPOSITION (COMMAND_INT, global frame, mode change allowed) | mode GUIDED, then the same |
//! | set mode NAME | DO_SET_MODE (custom mode enabled, main and sub mode) | DO_SET_MODE (custom mode enabled, mode number) |
//! | reboot | PREFLIGHT_REBOOT_SHUTDOWN 1 | the same |
//!
//! A step that is not accepted ends the action with its result. A vehicle already in the mode
//! a step would set skips that step.

use ferrolink_dialects::common::{MavAutopilot, MavType};
use ferrolink_runtime::mavlink::service::command::{Ack, Command};
use ferrolink_runtime::mavlink::service::messages::{MavCmd, MavFrame, MavResult};

use crate::modes::{self, Family, Mode};
use crate::telemetry::Identity;

/// What to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// Arm.
    Arm,
    /// Disarm.
    Disarm,
    /// Disarm even in flight.
    ForceDisarm,
    /// Take off to `alt` metres above home.
    Takeoff {
        /// Metres above home.
        alt: f32,
    },
    /// Land where it is.
    Land,
    /// Return to launch.
    ReturnToLaunch,
    /// Stop and hold position.
    Hold,
    /// Fly to a position.
    Goto {
        /// Latitude, degrees.
        lat: f64,
        /// Longitude, degrees.
        lon: f64,
        /// Altitude above mean sea level, metres.
        alt_amsl: f32,
    },
    /// Switch to a flight mode by its name (any case).
    SetMode(String),
    /// Reboot the autopilot.
    Reboot,
}

impl Action {
    /// The name the CLI takes and prints: `arm`, `disarm`, `takeoff`, `land`, `rtl`, `hold`,
    /// `goto`, `mode`, `reboot`.
    pub fn name(&self) -> &'static str {
        match self {
            Action::Arm => "arm",
            Action::Disarm | Action::ForceDisarm => "disarm",
            Action::Takeoff { .. } => "takeoff",
            Action::Land => "land",
            Action::ReturnToLaunch => "rtl",
            Action::Hold => "hold",
            Action::Goto { .. } => "goto",
            Action::SetMode(_) => "mode",
            Action::Reboot => "reboot",
        }
    }
}

/// How an action ended: its last command's answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ActionResult {
    /// Done.
    Accepted,
    /// Refused, for good.
    Denied,
    /// Refused for now (disarmed, no position yet...).
    TemporarilyRejected,
    /// The vehicle does not know the command.
    Unsupported,
    /// Tried and failed.
    Failed,
    /// Cancelled.
    Cancelled,
    /// Still running when the vehicle stopped reporting (the last percentage reported).
    InProgress(u8),
    /// Nothing answered after the retries.
    NoAnswer,
    /// Another MAV_RESULT.
    Other(u8),
}

impl ActionResult {
    /// The answer `ack` (`None`: nothing answered).
    pub fn of(ack: Option<Ack>) -> Self {
        let Some(ack) = ack else {
            return ActionResult::NoAnswer;
        };
        match ack.result {
            MavResult::Accepted => ActionResult::Accepted,
            MavResult::Denied => ActionResult::Denied,
            MavResult::TemporarilyRejected => ActionResult::TemporarilyRejected,
            MavResult::Unsupported => ActionResult::Unsupported,
            MavResult::Failed => ActionResult::Failed,
            MavResult::Cancelled => ActionResult::Cancelled,
            MavResult::InProgress => ActionResult::InProgress(ack.progress),
            other => ActionResult::Other(other.raw()),
        }
    }

    /// The name the CLI prints: `ACCEPTED`, `DENIED`, `TEMPORARILY_REJECTED`, `UNSUPPORTED`,
    /// `FAILED`, `CANCELLED`, `IN_PROGRESS`, `NO_ANSWER`, or `RESULT(N)`.
    pub fn name(self) -> String {
        match self {
            ActionResult::Accepted => "ACCEPTED".into(),
            ActionResult::Denied => "DENIED".into(),
            ActionResult::TemporarilyRejected => "TEMPORARILY_REJECTED".into(),
            ActionResult::Unsupported => "UNSUPPORTED".into(),
            ActionResult::Failed => "FAILED".into(),
            ActionResult::Cancelled => "CANCELLED".into(),
            ActionResult::InProgress(_) => "IN_PROGRESS".into(),
            ActionResult::NoAnswer => "NO_ANSWER".into(),
            ActionResult::Other(n) => format!("RESULT({n})"),
        }
    }
}

/// What an action did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Outcome {
    /// How it ended.
    pub result: ActionResult,
    /// The MAV_CMD of the last command sent.
    pub command: u16,
    /// Every `IN_PROGRESS` percentage reported, in order.
    pub progress: Vec<u8>,
}

/// Why an action could not start.
#[derive(Debug)]
#[non_exhaustive]
pub enum ActionError {
    /// The mode has no such name on this vehicle.
    UnknownMode {
        /// The name asked for.
        name: String,
        /// The vehicle's mode names.
        known: Vec<&'static str>,
    },
    /// The connection failed.
    Io(std::io::Error),
}

impl std::fmt::Display for ActionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ActionError::UnknownMode { name, known } if known.is_empty() => write!(
                f,
                "mode `{name}`: this vehicle's autopilot has no mode names we know"
            ),
            ActionError::UnknownMode { name, known } => write!(
                f,
                "mode `{name}` is not one of this vehicle's: {}",
                known.join(", ")
            ),
            ActionError::Io(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for ActionError {}

impl From<std::io::Error> for ActionError {
    fn from(e: std::io::Error) -> Self {
        ActionError::Io(e)
    }
}

/// `MAV_CMD_COMPONENT_ARM_DISARM`'s param2 that disarms in flight too.
const FORCE: f32 = 21196.0;

/// `MAV_MODE_FLAG_CUSTOM_MODE_ENABLED`, DO_SET_MODE's param1.
const CUSTOM_MODE_ENABLED: f32 = 1.0;

/// `MAV_DO_REPOSITION_FLAGS_CHANGE_MODE`: DO_REPOSITION may switch the vehicle to a mode that
/// flies there.
const CHANGE_MODE: f32 = 1.0;

fn long(cmd: u16, p: [f32; 7]) -> Command {
    Command::long(MavCmd::from_raw(cmd), p)
}

/// The mode called `name` of `vehicle`.
pub(crate) fn mode(vehicle: &Identity, name: &str) -> Result<Mode, ActionError> {
    modes::lookup(vehicle.autopilot, vehicle.kind, name).ok_or_else(|| ActionError::UnknownMode {
        name: name.to_owned(),
        known: modes::names(vehicle.autopilot, vehicle.kind),
    })
}

/// DO_SET_MODE to `mode`, unless the vehicle is in it already.
fn set_mode(vehicle: &Identity, mode: Mode) -> Option<Command> {
    (vehicle.custom_mode != mode.custom_mode).then(|| {
        long(
            176,
            [
                CUSTOM_MODE_ENABLED,
                mode.main() as f32,
                mode.sub() as f32,
                0.0,
                0.0,
                0.0,
                0.0,
            ],
        )
    })
}

/// The commands that do `action` on `vehicle`, whose home is at `home_amsl` metres (if known).
pub(crate) fn plan(
    action: &Action,
    vehicle: &Identity,
    home_amsl: Option<f32>,
) -> Result<Vec<Command>, ActionError> {
    let ardupilot = vehicle.autopilot == MavAutopilot::Ardupilotmega;
    let guided = || -> Result<Option<Command>, ActionError> {
        Ok(if ardupilot {
            set_mode(vehicle, mode(vehicle, "GUIDED")?)
        } else {
            None
        })
    };
    let nan = f32::NAN;
    let steps = match action {
        Action::Arm => vec![long(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])],
        Action::Disarm => vec![long(400, [0.0; 7])],
        Action::ForceDisarm => vec![long(400, [0.0, FORCE, 0.0, 0.0, 0.0, 0.0, 0.0])],
        Action::Takeoff { alt } => {
            let mut steps: Vec<Command> = guided()?.into_iter().collect();
            let to = if ardupilot {
                *alt
            } else {
                // PX4 takes an altitude above sea level; without home, its own default.
                home_amsl.map_or(nan, |h| h + alt)
            };
            steps.push(long(22, [0.0, 0.0, 0.0, nan, nan, nan, to]));
            steps
        }
        Action::Land => vec![long(21, [0.0, 0.0, 0.0, nan, nan, nan, nan])],
        Action::ReturnToLaunch => vec![long(20, [0.0; 7])],
        Action::Hold => {
            let name = match (vehicle.autopilot, Family::of(vehicle.kind)) {
                (MavAutopilot::Ardupilotmega, Some(Family::Rover)) => "HOLD",
                (MavAutopilot::Ardupilotmega, Some(Family::Sub)) => "POSHOLD",
                (MavAutopilot::Ardupilotmega, _) => "LOITER",
                _ => "HOLD",
            };
            let hold = mode(vehicle, name)?;
            set_mode(vehicle, hold).into_iter().collect()
        }
        Action::Goto { lat, lon, alt_amsl } => {
            let mut steps: Vec<Command> = guided()?.into_iter().collect();
            steps.push(Command::int(
                MavCmd::DoReposition,
                MavFrame::Global,
                [-1.0, CHANGE_MODE, 0.0, nan],
                *lat,
                *lon,
                *alt_amsl,
            ));
            steps
        }
        Action::SetMode(name) => {
            let to = mode(vehicle, name)?;
            set_mode(vehicle, to).into_iter().collect()
        }
        Action::Reboot => vec![long(246, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])],
    };
    Ok(steps)
}

/// Whether `kind` is a vehicle that flies (a take-off means something).
pub fn flies(kind: MavType) -> bool {
    !matches!(
        kind,
        MavType::GroundRover | MavType::SurfaceBoat | MavType::Submarine | MavType::AntennaTracker
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use ferrolink_dialects::common::{MavModeFlag, MavState};

    fn vehicle(autopilot: MavAutopilot, custom_mode: u32) -> Identity {
        Identity {
            autopilot,
            kind: MavType::Quadrotor,
            base_mode: MavModeFlag(1),
            custom_mode,
            status: MavState::Standby,
        }
    }

    fn ids(steps: &[Command]) -> Vec<u16> {
        steps.iter().map(|c| c.command.raw()).collect()
    }

    #[test]
    fn ardupilot_takes_off_in_guided_and_px4_above_sea_level() {
        let copter = vehicle(MavAutopilot::Ardupilotmega, 0);
        let steps = plan(&Action::Takeoff { alt: 10.0 }, &copter, Some(488.0)).unwrap();
        assert_eq!(ids(&steps), [176, 22]);
        assert_eq!((steps[0].params[1], steps[1].z), (4.0, 10.0));
        // Already in GUIDED: the mode step is skipped.
        let guided = vehicle(MavAutopilot::Ardupilotmega, 4);
        assert_eq!(
            ids(&plan(&Action::Takeoff { alt: 10.0 }, &guided, None).unwrap()),
            [22]
        );
        let px4 = vehicle(MavAutopilot::Px4, 0);
        let steps = plan(&Action::Takeoff { alt: 10.0 }, &px4, Some(488.0)).unwrap();
        assert_eq!((ids(&steps), steps[0].z), (vec![22], 498.0));
    }

    #[test]
    fn modes_by_name_and_unknown_ones() {
        let px4 = vehicle(MavAutopilot::Px4, 0);
        let steps = plan(&Action::SetMode("mission".into()), &px4, None).unwrap();
        assert_eq!(ids(&steps), [176]);
        assert_eq!(&steps[0].params[..3], &[1.0, 4.0, 4.0]);
        let err = plan(&Action::SetMode("GUIDED".into()), &px4, None).unwrap_err();
        assert!(err.to_string().contains("HOLD, MISSION"), "{err}");
        let hold = plan(
            &Action::Hold,
            &vehicle(MavAutopilot::Ardupilotmega, 0),
            None,
        )
        .unwrap();
        assert_eq!(hold[0].params[1], 5.0, "copter LOITER");
    }
}
