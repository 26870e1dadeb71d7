//! The software vehicle's flight: a simple aircraft that arms, takes off, flies to positions
//! and missions, holds, returns and lands, in the modes of the autopilot it claims, and reports
//! it all as telemetry.
//!
//! Kinematics with fixed speeds, good enough to test ground software against:
//!
//! - it moves straight at a target: horizontally at [`SPEED`] m/s, vertically at [`CLIMB`]
//!   m/s up and [`DESCENT`] m/s down, both at once, and is there (exactly, snapped) once within
//!   0.5 m horizontally and 0.2 m vertically;
//! - it faces where it goes, level (no roll, no pitch);
//! - the ground is home's altitude; landing ends on it, disarmed;
//! - its battery drains 0.05 % a second armed on the ground and 0.2 % a second in the air, its
//!   voltage falling from 16.8 V to 14.0 V (a 4S pack) as the charge goes.
//!
//! What each autopilot's modes do here:
//!
//! | behaviour | PX4 | ArduPilot copter (plane, rover) |
//! |---|---|---|
//! | on the ground | HOLD | STABILIZE (MANUAL, MANUAL) |
//! | take off | TAKEOFF, then HOLD | GUIDED (TAKEOFF, refused) |
//! | hold | HOLD | LOITER (LOITER, HOLD) |
//! | go to | HOLD | GUIDED |
//! | mission | MISSION | AUTO |
//! | return | RTL | RTL |
//! | land | LAND | LAND (AUTOLAND, HOLD) |

use std::collections::VecDeque;
use std::time::Instant;

use ferrolink_dialects::common::{
    Attitude, BatteryStatus, ExtendedSysState, GlobalPositionInt, GpsFixType, GpsRawInt, Heartbeat,
    HomePosition, MavAutopilot, MavBatteryFunction, MavBatteryType, MavLandedState, MavModeFlag,
    MavSeverity, MavState, MavSysStatusSensor, MavType, MissionCurrent, MissionItemReached,
    MissionState, Statustext, SysStatus,
};
use ferrolink_runtime::mavlink::service::command::Command;
use ferrolink_runtime::mavlink::service::messages::{MavCmd, MavFrame, MavResult};
use ferrolink_runtime::mavlink::service::mission::Item;

use super::modes::{self, Family};

/// Whether altitudes in `frame` are above mean sea level (MAV_FRAME_GLOBAL and its deprecated
/// `_INT` twin, 0 and 5); the other global frames count from home.
fn amsl(frame: MavFrame) -> bool {
    matches!(frame.raw(), 0 | 5)
}

/// Horizontal speed, m/s.
pub const SPEED: f64 = 10.0;
/// Climb rate, m/s.
pub const CLIMB: f64 = 3.0;
/// Descent rate, m/s.
pub const DESCENT: f64 = 2.0;
/// Metres a degree of latitude spans (and of longitude at the equator).
const M_PER_DEG: f64 = 111_320.0;

/// A position: degrees, and metres above mean sea level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude above mean sea level, metres.
    pub alt: f64,
}

/// What the vehicle is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Doing {
    /// On the ground.
    Ground,
    /// Climbing to a take-off altitude, then holding.
    Takeoff,
    /// Holding where it is.
    Hold,
    /// Going to a position, then holding.
    Goto,
    /// Flying the mission.
    Mission,
    /// Going home, then landing.
    Return,
    /// Going down where it is.
    Land,
}

/// The flight: see the [module documentation](self).
#[derive(Debug)]
pub struct Flight {
    autopilot: MavAutopilot,
    kind: MavType,
    home: Point,
    at: Point,
    yaw: f64,
    velocity: [f64; 3],
    armed: bool,
    doing: Doing,
    target: Option<Point>,
    /// The mode shown when the behaviour's own has no name in the autopilot's table.
    custom_mode: u32,
    battery: f64,
    /// How high a PX4 take-off without an altitude climbs (MIS_TAKEOFF_ALT), metres.
    takeoff_default: f64,
    /// The mission item flown.
    current: u16,
    /// What happened that every endpoint reports once: items reached, status texts.
    notes: VecDeque<(u64, Note)>,
    noted: u64,
    last: Instant,
}

/// Something every endpoint reports once.
#[derive(Debug, Clone, PartialEq)]
pub enum Note {
    /// MISSION_ITEM_REACHED.
    Reached(u16),
    /// STATUSTEXT.
    Text(MavSeverity, String),
}

/// How many notes are kept for endpoints that have not taken them yet.
const NOTES: usize = 64;

impl Flight {
    /// On the ground at `home`, disarmed.
    pub fn new(autopilot: MavAutopilot, kind: MavType, home: Point) -> Self {
        let mut flight = Flight {
            autopilot,
            kind,
            home,
            at: home,
            yaw: 0.0,
            velocity: [0.0; 3],
            armed: false,
            doing: Doing::Ground,
            target: None,
            custom_mode: 0,
            battery: 100.0,
            takeoff_default: 2.5,
            current: 0,
            notes: VecDeque::new(),
            noted: 0,
            last: Instant::now(),
        };
        flight.custom_mode = flight.mode_of(Doing::Ground);
        flight
    }

    fn ardupilot(&self) -> bool {
        self.autopilot == MavAutopilot::Ardupilotmega
    }

    /// The autopilot's mode for a behaviour.
    fn mode_of(&self, doing: Doing) -> u32 {
        let family = Family::of(self.kind);
        let name = match (self.ardupilot(), doing) {
            (false, Doing::Takeoff) => "TAKEOFF",
            (false, Doing::Mission) => "MISSION",
            (false, Doing::Return) => "RTL",
            (false, Doing::Land) => "LAND",
            (false, _) => "HOLD",
            (true, Doing::Ground) if family == Some(Family::Copter) => "STABILIZE",
            (true, Doing::Ground) => "MANUAL",
            (true, Doing::Takeoff) if family == Some(Family::Plane) => "TAKEOFF",
            (true, Doing::Takeoff | Doing::Goto) => "GUIDED",
            (true, Doing::Hold) if family == Some(Family::Rover) => "HOLD",
            (true, Doing::Hold) => "LOITER",
            (true, Doing::Mission) => "AUTO",
            (true, Doing::Return) => "RTL",
            (true, Doing::Land) if family == Some(Family::Plane) => "AUTOLAND",
            (true, Doing::Land) if family == Some(Family::Rover) => "HOLD",
            (true, Doing::Land) => "LAND",
        };
        modes::lookup(self.autopilot, self.kind, name).map_or(0, |m| m.custom_mode)
    }

    fn set(&mut self, doing: Doing, target: Option<Point>) {
        self.doing = doing;
        self.target = target;
        self.custom_mode = self.mode_of(doing);
    }

    fn in_air(&self) -> bool {
        self.doing != Doing::Ground
    }

    fn note(&mut self, note: Note) {
        self.noted += 1;
        self.notes.push_back((self.noted, note));
        if self.notes.len() > NOTES {
            self.notes.pop_front();
        }
    }

    fn say(&mut self, severity: MavSeverity, text: impl Into<String>) {
        self.note(Note::Text(severity, text.into()));
    }

    /// The notes after number `after`, each with its number.
    pub fn notes_after(&self, after: u64) -> impl Iterator<Item = &(u64, Note)> {
        self.notes.iter().filter(move |(n, _)| *n > after)
    }

    /// Where it is.
    pub fn position(&self) -> Point {
        self.at
    }

    /// Whether it is armed.
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// Its mode, as its HEARTBEAT's `custom_mode`.
    pub fn custom_mode(&self) -> u32 {
        self.custom_mode
    }

    /// The mission item it flies (or will fly first).
    pub fn current(&self) -> u16 {
        self.current
    }

    /// How high a take-off without an altitude climbs (PX4's MIS_TAKEOFF_ALT; 2.5 m unless set).
    pub fn set_takeoff_default(&mut self, metres: f64) {
        if metres.is_finite() && metres > 0.0 {
            self.takeoff_default = metres;
        }
    }

    /// Makes `seq` the mission item to fly.
    pub fn set_current(&mut self, seq: u16) {
        self.current = seq;
        if self.doing == Doing::Mission {
            self.target = None;
        }
    }

    /// Moves it on to `now`, flying `mission` if it flies the mission.
    pub fn advance(&mut self, now: Instant, mission: &[Item]) {
        let dt = now.saturating_duration_since(self.last).as_secs_f64();
        self.last = now;
        if self.armed {
            let drain = if self.in_air() { 0.2 } else { 0.05 };
            self.battery = (self.battery - drain * dt).max(0.0);
        }
        if self.doing == Doing::Mission && self.target.is_none() {
            self.next_item(mission);
        }
        let Some(target) = self.target else {
            self.velocity = [0.0; 3];
            return;
        };
        let north = (target.lat - self.at.lat) * M_PER_DEG;
        let east = (target.lon - self.at.lon) * M_PER_DEG * self.at.lat.to_radians().cos();
        let up = target.alt - self.at.alt;
        let dist = north.hypot(east);
        let step = (SPEED * dt).min(dist);
        let vstep = if up > 0.0 {
            (CLIMB * dt).min(up)
        } else {
            (DESCENT * dt).min(-up)
        };
        let (dn, de) = if dist > 0.0 {
            (north / dist * step, east / dist * step)
        } else {
            (0.0, 0.0)
        };
        let dz = vstep.copysign(up);
        if dt > 0.0 {
            self.velocity = [dn / dt, de / dt, -dz / dt];
        }
        if dist > 0.5 {
            self.yaw = east.atan2(north).to_degrees().rem_euclid(360.0);
        }
        self.at.lat += dn / M_PER_DEG;
        self.at.lon += de / (M_PER_DEG * self.at.lat.to_radians().cos());
        self.at.alt += dz;
        if (dist - step) < 0.5 && (up - dz).abs() < 0.2 {
            self.at = target;
            self.velocity = [0.0; 3];
            self.arrived(mission);
        }
    }

    /// The target is reached.
    fn arrived(&mut self, mission: &[Item]) {
        match self.doing {
            Doing::Takeoff | Doing::Goto => {
                let hold = if self.ardupilot() {
                    Doing::Goto
                } else {
                    Doing::Hold
                };
                // ArduPilot stays in GUIDED where it is; PX4 goes to HOLD.
                let mode = self.mode_of(hold);
                self.target = None;
                self.doing = Doing::Hold;
                self.custom_mode = mode;
            }
            Doing::Return => self.set(Doing::Land, Some(self.ground_below())),
            Doing::Land => {
                self.set(Doing::Ground, None);
                self.armed = false;
                self.say(MavSeverity::Info, "Landed, disarmed");
            }
            Doing::Mission => {
                self.note(Note::Reached(self.current));
                let item = mission.get(usize::from(self.current)).copied();
                match item.map(|i| i.command) {
                    Some(MavCmd::NavLand) => self.set(Doing::Land, Some(self.ground_below())),
                    Some(MavCmd::NavReturnToLaunch) => self.go_home(),
                    _ => {
                        self.current += 1;
                        self.target = None;
                    }
                }
            }
            Doing::Ground | Doing::Hold => self.target = None,
        }
    }

    fn ground_below(&self) -> Point {
        Point {
            alt: self.home.alt,
            ..self.at
        }
    }

    fn go_home(&mut self) {
        let alt = self.at.alt.max(self.home.alt + 10.0);
        self.set(Doing::Return, Some(Point { alt, ..self.home }));
    }

    /// Picks the next mission item's target; at the end, holds.
    fn next_item(&mut self, mission: &[Item]) {
        loop {
            let Some(item) = mission.get(usize::from(self.current)).copied() else {
                self.say(MavSeverity::Info, "Mission finished");
                self.set(Doing::Hold, None);
                return;
            };
            let alt = if amsl(item.frame) {
                f64::from(item.z)
            } else {
                self.home.alt + f64::from(item.z)
            };
            let at = |item: &Item| Point {
                lat: if item.x == 0 {
                    self.at.lat
                } else {
                    f64::from(item.x) / 1e7
                },
                lon: if item.y == 0 {
                    self.at.lon
                } else {
                    f64::from(item.y) / 1e7
                },
                alt,
            };
            let target = match item.command {
                MavCmd::NavTakeoff => Some(Point { alt, ..self.at }),
                MavCmd::NavWaypoint
                | MavCmd::NavLoiterUnlim
                | MavCmd::NavLoiterTurns
                | MavCmd::NavLoiterTime
                | MavCmd::NavLoiterToAlt => Some(at(&item)),
                MavCmd::NavLand => Some(Point {
                    alt: self.home.alt,
                    ..at(&item)
                }),
                MavCmd::NavReturnToLaunch => Some(Point {
                    alt: self.at.alt.max(self.home.alt + 10.0),
                    ..self.home
                }),
                // DO_ and CONDITION_ items take no time here.
                _ => None,
            };
            match target {
                Some(target) => {
                    self.target = Some(target);
                    return;
                }
                None => {
                    self.note(Note::Reached(self.current));
                    self.current += 1;
                }
            }
        }
    }

    /// Runs a command; `None` for one it does not know. `mission_len` is the mission's length.
    pub fn command(&mut self, command: &Command, mission_len: u16) -> Option<MavResult> {
        let p = command.params;
        Some(match command.command {
            MavCmd::ComponentArmDisarm if p[0] >= 0.5 => {
                if self.in_air() {
                    MavResult::Accepted
                } else if self.battery < 5.0 {
                    MavResult::Denied
                } else {
                    self.armed = true;
                    self.say(MavSeverity::Info, "Armed");
                    MavResult::Accepted
                }
            }
            MavCmd::ComponentArmDisarm => {
                if self.in_air() && p[1] != 21196.0 {
                    return Some(MavResult::Denied);
                }
                self.armed = false;
                self.set(Doing::Ground, None);
                self.at.alt = self.home.alt;
                MavResult::Accepted
            }
            MavCmd::NavTakeoff => self.takeoff(f64::from(command.z)),
            MavCmd::NavLand if self.in_air() => {
                self.set(Doing::Land, Some(self.ground_below()));
                MavResult::Accepted
            }
            MavCmd::NavLand => MavResult::Denied,
            MavCmd::NavReturnToLaunch if self.in_air() => {
                self.go_home();
                MavResult::Accepted
            }
            MavCmd::NavReturnToLaunch => MavResult::Denied,
            MavCmd::DoSetMode => self.set_mode(p[0], p[1], p[2], mission_len),
            MavCmd::DoReposition => self.reposition(command),
            MavCmd::MissionStart => self.start_mission(mission_len),
            MavCmd::PreflightRebootShutdown if p[0] == 1.0 && !self.in_air() => {
                let takeoff = self.takeoff_default;
                *self = Flight::new(self.autopilot, self.kind, self.home);
                self.takeoff_default = takeoff;
                MavResult::Accepted
            }
            MavCmd::PreflightRebootShutdown => MavResult::Denied,
            _ => return None,
        })
    }

    fn takeoff(&mut self, z: f64) -> MavResult {
        if !self.armed || self.in_air() {
            return MavResult::TemporarilyRejected;
        }
        let family = Family::of(self.kind);
        if family == Some(Family::Rover) || family == Some(Family::Sub) {
            return MavResult::Unsupported;
        }
        let guided = self.mode_of(Doing::Goto);
        if self.ardupilot() && family == Some(Family::Copter) && self.custom_mode != guided {
            // ArduCopter takes off in GUIDED only.
            return MavResult::Failed;
        }
        // PX4 takes the altitude above sea level (NaN: MIS_TAKEOFF_ALT up), ArduPilot above home.
        let alt = match (self.ardupilot(), z.is_finite()) {
            (true, _) => self.home.alt + z.max(1.0),
            (false, true) => z.max(self.home.alt + 1.0),
            (false, false) => self.home.alt + self.takeoff_default,
        };
        self.set(Doing::Takeoff, Some(Point { alt, ..self.at }));
        if self.ardupilot() {
            self.custom_mode = guided;
        }
        MavResult::Accepted
    }

    fn set_mode(&mut self, base: f32, main: f32, sub: f32, mission_len: u16) -> MavResult {
        let custom = if self.ardupilot() {
            main as u32
        } else {
            ((main as u32) << 16) | ((sub as u32) << 24)
        };
        self.set_custom_mode(base as u8, custom, mission_len)
    }

    /// SET_MODE (what pymavlink and MAVProxy send), or DO_SET_MODE's mode as `custom_mode`.
    pub fn set_custom_mode(&mut self, base: u8, custom: u32, mission_len: u16) -> MavResult {
        if base & MavModeFlag::CUSTOM_MODE_ENABLED.0 == 0 {
            return MavResult::Unsupported;
        }
        let Some(name) = modes::name(self.autopilot, self.kind, custom) else {
            return MavResult::Denied;
        };
        let doing = match name {
            "TAKEOFF" if !self.ardupilot() => {
                return self.takeoff(f64::NAN);
            }
            "MISSION" | "AUTO" => return self.start_mission(mission_len),
            "RTL" | "SMART_RTL" | "QRTL" if self.in_air() => {
                self.go_home();
                return MavResult::Accepted;
            }
            "LAND" | "QLAND" | "AUTOLAND" if self.in_air() => {
                self.set(Doing::Land, Some(self.ground_below()));
                return MavResult::Accepted;
            }
            _ if self.in_air() => Doing::Hold,
            _ => Doing::Ground,
        };
        self.doing = doing;
        self.target = None;
        self.custom_mode = custom;
        MavResult::Accepted
    }

    fn reposition(&mut self, command: &Command) -> MavResult {
        if !self.armed || !self.in_air() {
            return MavResult::TemporarilyRejected;
        }
        let alt = if !command.z.is_finite() {
            self.at.alt
        } else if amsl(command.frame) {
            f64::from(command.z)
        } else {
            self.home.alt + f64::from(command.z)
        };
        let target = Point {
            lat: if command.x.is_finite() {
                command.x
            } else {
                self.at.lat
            },
            lon: if command.y.is_finite() {
                command.y
            } else {
                self.at.lon
            },
            alt,
        };
        self.set(Doing::Goto, Some(target));
        MavResult::Accepted
    }

    fn start_mission(&mut self, mission_len: u16) -> MavResult {
        if mission_len == 0 || !self.armed {
            return MavResult::Denied;
        }
        // ArduPilot's item 0 is home.
        if self.ardupilot() && self.current == 0 && mission_len > 1 {
            self.current = 1;
        }
        self.set(Doing::Mission, None);
        MavResult::Accepted
    }

    /// Its HEARTBEAT.
    pub fn heartbeat(&self) -> Heartbeat {
        let mut mode = MavModeFlag::CUSTOM_MODE_ENABLED;
        if self.armed {
            mode |= MavModeFlag::SAFETY_ARMED;
        }
        Heartbeat {
            r#type: self.kind,
            autopilot: self.autopilot,
            base_mode: mode,
            custom_mode: self.custom_mode,
            system_status: if self.armed {
                MavState::Active
            } else {
                MavState::Standby
            },
            mavlink_version: 3,
        }
    }

    /// Milliseconds since boot, as telemetry stamps them.
    fn boot_ms(&self, boot: Instant) -> u32 {
        self.last.saturating_duration_since(boot).as_millis() as u32
    }

    /// GLOBAL_POSITION_INT.
    pub fn global_position(&self, boot: Instant) -> GlobalPositionInt {
        let cm = |v: f64| (v * 100.0).round() as i16;
        GlobalPositionInt {
            time_boot_ms: self.boot_ms(boot),
            lat: (self.at.lat * 1e7).round() as i32,
            lon: (self.at.lon * 1e7).round() as i32,
            alt: (self.at.alt * 1000.0).round() as i32,
            relative_alt: ((self.at.alt - self.home.alt) * 1000.0).round() as i32,
            vx: cm(self.velocity[0]),
            vy: cm(self.velocity[1]),
            vz: cm(self.velocity[2]),
            hdg: (self.yaw * 100.0).round() as u16 % 36000,
        }
    }

    /// ATTITUDE.
    pub fn attitude(&self, boot: Instant) -> Attitude {
        let yaw = self.yaw.to_radians();
        Attitude {
            time_boot_ms: self.boot_ms(boot),
            yaw: (if yaw > std::f64::consts::PI {
                yaw - std::f64::consts::TAU
            } else {
                yaw
            }) as f32,
            ..Default::default()
        }
    }

    /// GPS_RAW_INT: a 3D fix with 12 satellites.
    pub fn gps(&self, boot: Instant) -> GpsRawInt {
        GpsRawInt {
            time_usec: u64::from(self.boot_ms(boot)) * 1000,
            fix_type: GpsFixType::Type3dFix,
            lat: (self.at.lat * 1e7).round() as i32,
            lon: (self.at.lon * 1e7).round() as i32,
            alt: (self.at.alt * 1000.0).round() as i32,
            eph: 80,
            epv: 120,
            vel: (self.velocity[0].hypot(self.velocity[1]) * 100.0) as u16,
            cog: (self.yaw * 100.0).round() as u16 % 36000,
            satellites_visible: 12,
            ..Default::default()
        }
    }

    fn voltage_mv(&self) -> u16 {
        (14_000.0 + 2_800.0 * self.battery / 100.0) as u16
    }

    /// BATTERY_STATUS: one 4S pack.
    pub fn battery_status(&self) -> BatteryStatus {
        let mut voltages = [u16::MAX; 10];
        voltages[0] = self.voltage_mv();
        BatteryStatus {
            id: 0,
            battery_function: MavBatteryFunction::All,
            r#type: MavBatteryType::Lipo,
            temperature: i16::MAX,
            voltages,
            current_battery: if self.armed { 1500 } else { 50 },
            current_consumed: -1,
            energy_consumed: -1,
            battery_remaining: self.battery.round() as i8,
            ..Default::default()
        }
    }

    /// SYS_STATUS: every sensor present and healthy.
    pub fn sys_status(&self) -> SysStatus {
        let sensors = MavSysStatusSensor(
            [
                MavSysStatusSensor::SENSOR_3D_GYRO,
                MavSysStatusSensor::SENSOR_3D_ACCEL,
                MavSysStatusSensor::SENSOR_3D_MAG,
                MavSysStatusSensor::ABSOLUTE_PRESSURE,
                MavSysStatusSensor::GPS,
                MavSysStatusSensor::BATTERY,
            ]
            .iter()
            .fold(0, |m, s| m | s.0),
        );
        SysStatus {
            onboard_control_sensors_present: sensors,
            onboard_control_sensors_enabled: sensors,
            onboard_control_sensors_health: sensors,
            load: 200,
            voltage_battery: self.voltage_mv(),
            current_battery: if self.armed { 150 } else { 5 },
            battery_remaining: self.battery.round() as i8,
            ..Default::default()
        }
    }

    /// HOME_POSITION.
    pub fn home_position(&self) -> HomePosition {
        HomePosition {
            latitude: (self.home.lat * 1e7).round() as i32,
            longitude: (self.home.lon * 1e7).round() as i32,
            altitude: (self.home.alt * 1000.0).round() as i32,
            q: [1.0, 0.0, 0.0, 0.0],
            ..Default::default()
        }
    }

    /// EXTENDED_SYS_STATE.
    pub fn extended_sys_state(&self) -> ExtendedSysState {
        ExtendedSysState {
            landed_state: match self.doing {
                Doing::Ground => MavLandedState::OnGround,
                Doing::Takeoff => MavLandedState::Takeoff,
                Doing::Land => MavLandedState::Landing,
                _ => MavLandedState::InAir,
            },
            ..Default::default()
        }
    }

    /// MISSION_CURRENT of a mission of `total` items.
    pub fn mission_current(&self, total: u16) -> MissionCurrent {
        MissionCurrent {
            seq: self.current,
            total,
            mission_state: match (total, self.doing) {
                (0, _) => MissionState::NoMission,
                (_, Doing::Mission) => MissionState::Active,
                _ if self.current >= total => MissionState::Complete,
                _ => MissionState::NotStarted,
            },
            ..Default::default()
        }
    }
}

impl Note {
    /// Its MISSION_ITEM_REACHED or STATUSTEXT.
    pub fn send(&self, link: &super::SharedConnection) -> std::io::Result<()> {
        match self {
            Note::Reached(seq) => link.send(&MissionItemReached { seq: *seq }),
            Note::Text(severity, text) => link.send(&Statustext {
                severity: *severity,
                text: text.as_str().into(),
                ..Default::default()
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    const HOME: Point = Point {
        lat: 47.397742,
        lon: 8.545594,
        alt: 488.0,
    };

    fn long(cmd: MavCmd, p: [f32; 7]) -> Command {
        Command::long(cmd, p)
    }

    /// Advances `flight` by `secs` in 50 ms steps from `t`; returns the new time.
    fn fly(flight: &mut Flight, t: &mut Instant, secs: f64, mission: &[Item]) {
        let steps = (secs / 0.05).round() as u32;
        for _ in 0..steps {
            *t += Duration::from_millis(50);
            flight.advance(*t, mission);
        }
    }

    /// Metres between two points, horizontally and vertically.
    fn off(a: Point, b: Point) -> (f64, f64) {
        let n = (a.lat - b.lat) * M_PER_DEG;
        let e = (a.lon - b.lon) * M_PER_DEG * a.lat.to_radians().cos();
        (n.hypot(e), (a.alt - b.alt).abs())
    }

    fn px4() -> (Flight, Instant) {
        let flight = Flight::new(MavAutopilot::Px4, MavType::Quadrotor, HOME);
        let t = flight.last;
        (flight, t)
    }

    #[test]
    fn takes_off_goes_to_a_point_and_lands_disarmed() {
        let (mut f, mut t) = px4();
        let takeoff = long(
            MavCmd::NavTakeoff,
            [0.0, 0.0, 0.0, f32::NAN, f32::NAN, f32::NAN, 498.0],
        );
        assert_eq!(f.command(&takeoff, 0), Some(MavResult::TemporarilyRejected));
        let arm = long(
            MavCmd::ComponentArmDisarm,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(f.command(&arm, 0), Some(MavResult::Accepted));
        assert_eq!(f.command(&takeoff, 0), Some(MavResult::Accepted));
        assert_eq!(
            modes::name(f.autopilot, f.kind, f.custom_mode()),
            Some("TAKEOFF")
        );
        fly(&mut f, &mut t, 2.0, &[]);
        let climbed = f.position().alt - HOME.alt;
        assert!((5.5..=6.5).contains(&climbed), "3 m/s for 2 s: {climbed}");
        fly(&mut f, &mut t, 2.0, &[]);
        assert_eq!(f.position().alt, 498.0);
        assert_eq!(
            modes::name(f.autopilot, f.kind, f.custom_mode()),
            Some("HOLD")
        );
        // 200 m north-east, 20 m up: 20 s at 10 m/s.
        let to = Point {
            lat: HOME.lat + 0.0013,
            lon: HOME.lon + 0.0019,
            alt: 518.0,
        };
        let mut go = Command::int(
            MavCmd::DoReposition,
            MavFrame::Global,
            [-1.0, 1.0, 0.0, f32::NAN],
            to.lat,
            to.lon,
            518.0,
        );
        go.frame = MavFrame::Global;
        assert_eq!(f.command(&go, 0), Some(MavResult::Accepted));
        let (dist, _) = off(f.position(), to);
        fly(&mut f, &mut t, dist / SPEED + 1.0, &[]);
        let (h, v) = off(f.position(), to);
        assert!(h < 1.0 && v < 1.0, "a go-to ends within 1 m: {h} m, {v} m");
        assert!(f.global_position(t).hdg > 0, "it faced where it went");
        // Disarming in the air is refused; landing ends on the ground, disarmed.
        let disarm = long(MavCmd::ComponentArmDisarm, [0.0; 7]);
        assert_eq!(f.command(&disarm, 0), Some(MavResult::Denied));
        assert_eq!(
            f.command(&long(MavCmd::NavLand, [0.0; 7]), 0),
            Some(MavResult::Accepted)
        );
        fly(&mut f, &mut t, 16.0, &[]);
        assert_eq!((f.position().alt, f.armed()), (HOME.alt, false));
        assert_eq!(
            f.extended_sys_state().landed_state,
            MavLandedState::OnGround
        );
    }

    #[test]
    fn returns_home_and_lands() {
        let (mut f, mut t) = px4();
        f.command(
            &long(
                MavCmd::ComponentArmDisarm,
                [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ),
            0,
        );
        f.command(
            &long(MavCmd::NavTakeoff, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 508.0]),
            0,
        );
        fly(&mut f, &mut t, 8.0, &[]);
        let away = Command::int(
            MavCmd::DoReposition,
            MavFrame::Global,
            [-1.0, 1.0, 0.0, 0.0],
            HOME.lat + 0.001,
            HOME.lon,
            508.0,
        );
        f.command(&away, 0);
        fly(&mut f, &mut t, 15.0, &[]);
        assert!(off(f.position(), HOME).0 > 100.0);
        assert_eq!(
            f.command(&long(MavCmd::NavReturnToLaunch, [0.0; 7]), 0),
            Some(MavResult::Accepted)
        );
        assert_eq!(
            modes::name(f.autopilot, f.kind, f.custom_mode()),
            Some("RTL")
        );
        fly(&mut f, &mut t, 30.0, &[]);
        let (h, v) = off(f.position(), HOME);
        assert!(h < 1.0 && v < 0.01 && !f.armed(), "{h} {v}");
    }

    fn item(command: MavCmd, lat: f64, lon: f64, alt: f32) -> Item {
        Item {
            frame: MavFrame::GlobalRelativeAlt,
            command,
            autocontinue: 1,
            x: (lat * 1e7) as i32,
            y: (lon * 1e7) as i32,
            z: alt,
            ..Default::default()
        }
    }

    #[test]
    fn flies_a_mission_reporting_each_item() {
        for autopilot in [MavAutopilot::Px4, MavAutopilot::Ardupilotmega] {
            let mut f = Flight::new(autopilot, MavType::Quadrotor, HOME);
            let mut t = f.last;
            let ardupilot = autopilot == MavAutopilot::Ardupilotmega;
            let mut mission = Vec::new();
            if ardupilot {
                mission.push(item(MavCmd::NavWaypoint, HOME.lat, HOME.lon, 0.0));
                // home
            }
            mission.push(item(MavCmd::NavTakeoff, 0.0, 0.0, 15.0));
            mission.push(item(MavCmd::NavWaypoint, HOME.lat + 0.0005, HOME.lon, 15.0));
            mission.push(item(
                MavCmd::NavWaypoint,
                HOME.lat + 0.0005,
                HOME.lon + 0.0007,
                20.0,
            ));
            mission.push(item(MavCmd::NavReturnToLaunch, 0.0, 0.0, 0.0));
            let len = mission.len() as u16;
            assert_eq!(
                f.command(&long(MavCmd::MissionStart, [0.0; 7]), len),
                Some(MavResult::Denied)
            );
            f.command(
                &long(
                    MavCmd::ComponentArmDisarm,
                    [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                ),
                len,
            );
            let mode = if ardupilot { "AUTO" } else { "MISSION" };
            let m = modes::lookup(autopilot, MavType::Quadrotor, mode).unwrap();
            let set = long(
                MavCmd::DoSetMode,
                [1.0, m.main() as f32, m.sub() as f32, 0.0, 0.0, 0.0, 0.0],
            );
            assert_eq!(f.command(&set, len), Some(MavResult::Accepted));
            assert_eq!(f.mission_current(len).mission_state, MissionState::Active);
            fly(&mut f, &mut t, 60.0, &mission);
            let reached: Vec<u16> = f
                .notes_after(0)
                .filter_map(|(_, n)| match n {
                    Note::Reached(seq) => Some(*seq),
                    Note::Text(..) => None,
                })
                .collect();
            let first = u16::from(ardupilot);
            assert_eq!(reached, (first..len).collect::<Vec<_>>(), "{autopilot:?}");
            let (h, v) = off(f.position(), HOME);
            assert!(h < 1.0 && v < 0.01 && !f.armed(), "home, landed: {h} {v}");
        }
    }

    #[test]
    fn ardupilot_copter_takes_off_in_guided_only_and_the_battery_drains() {
        let mut f = Flight::new(MavAutopilot::Ardupilotmega, MavType::Quadrotor, HOME);
        let mut t = f.last;
        assert_eq!(
            modes::name(f.autopilot, f.kind, f.custom_mode()),
            Some("STABILIZE")
        );
        f.command(
            &long(
                MavCmd::ComponentArmDisarm,
                [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ),
            0,
        );
        let takeoff = long(MavCmd::NavTakeoff, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0]);
        assert_eq!(f.command(&takeoff, 0), Some(MavResult::Failed));
        let guided = modes::lookup(f.autopilot, f.kind, "GUIDED").unwrap();
        let set = long(
            MavCmd::DoSetMode,
            [1.0, guided.main() as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(f.command(&set, 0), Some(MavResult::Accepted));
        assert_eq!(f.command(&takeoff, 0), Some(MavResult::Accepted));
        let before = f.battery_status().battery_remaining;
        fly(&mut f, &mut t, 30.0, &[]);
        assert_eq!(f.position().alt, HOME.alt + 10.0);
        assert_eq!(
            modes::name(f.autopilot, f.kind, f.custom_mode()),
            Some("GUIDED")
        );
        let after = f.battery_status().battery_remaining;
        assert_eq!(before - after, 6, "0.2 % a second in the air for 30 s");
        assert!(f.sys_status().voltage_battery < 16_800);
        // A mode it has not got is refused.
        let bogus = long(MavCmd::DoSetMode, [1.0, 12.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(f.command(&bogus, 0), Some(MavResult::Denied));
    }
}
