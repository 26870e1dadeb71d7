//! The vehicle: its HEARTBEAT, the runtime's parameter, mission and command servers over this
//! firmware's stores, the ground stations heard, and what its commands do.
//!
//! Wired as `ferrolink mavlink vehicle` (`io/src/mavlink/vehicle.rs`) wires the same servers:
//! every message goes to each server's `handle`, and what they have to send comes out of
//! their `poll_transmit`, here one message at a time.
//!
//! | command | answer |
//! |---|---|
//! | `MAV_CMD_COMPONENT_ARM_DISARM` (400) | arms (param1 1) or disarms (0): ACCEPTED |
//! | `MAV_CMD_PREFLIGHT_CALIBRATION` (241) | takes 2 s: IN_PROGRESS at 0, 25, 50 and 75 %, then ACCEPTED; COMMAND_CANCEL ends it with CANCELLED |
//! | anything else | UNSUPPORTED |
//!
//! FTP: the read-only file table of [`crate::files`] (the parameters as `@PARAM/param.pck`),
//! served by the runtime's FTP server; its replies go after every other service's.
//!
//! Data link loss: when the last ground station stays silent for 3 s (its HEARTBEATs, as the
//! runtime's [`Peers`] keeps them) while the vehicle is armed and `NAV_DLL_ACT` is not 0, the
//! vehicle disarms: it never leaves the ground, so PX4's actions (hold, return, land) all come
//! to that. `NAV_DLL_ACT` is 0 by default, as in PX4.

use ferrolink_runtime::mavlink::service::command::{self, Ack, Request};
use ferrolink_runtime::mavlink::service::ftp;
use ferrolink_runtime::mavlink::service::messages::{
    Heartbeat, MavAutopilot, MavCmd, MavModeFlag, MavResult, MavState, MavType, Message,
};
use ferrolink_runtime::mavlink::service::param::{self, Encoding, Value};
use ferrolink_runtime::mavlink::service::peers::{Event, Peers};
use ferrolink_runtime::mavlink::service::{mission, Address};

use crate::files::Files;
use crate::hw;
use crate::missions::Missions;
use crate::params::{self, Params};

/// This vehicle: system 1, its autopilot (component 1).
pub const OWN: Address = Address::new(1, 1);

/// HEARTBEAT period: 1 Hz.
const HEARTBEAT_US: u64 = 1_000_000;
/// How long the calibration runs.
const CALIBRATION_US: u64 = 2_000_000;
/// How often it reports progress: 0, 25, 50 and 75 %.
const CALIBRATION_STEP_US: u64 = CALIBRATION_US / 4;

/// Single parameter answers that can wait at once (more are dropped, to be asked for again).
pub type ParamServer = param::Server<16>;
/// Commands remembered, so that a retry gets the same answer and nothing runs twice.
pub type CommandServer = command::Server<4>;
/// Components heard in HEARTBEATs.
pub type GroundStations = Peers<4>;
/// Files open at once over FTP (a ground station reading param.pck, and one more).
pub type FtpServer = ftp::Server<2>;

/// The FTP server's settings: the runtime's defaults. No `burst_gap_us`: a burst's replies go
/// one per pass of the main loop, and `Link::send` waits for the UART at every byte, so the
/// UART paces them whatever its rate; the HEARTBEAT and the other services' answers go before
/// them, and the loop takes a received byte between two of them. (param.pck is some 1 kB: a
/// burst of five replies.)
pub fn ftp_config() -> ftp::ServerConfig {
    ftp::ServerConfig::new(OWN)
}

/// The calibration under way: who asked, when it started, the progress reported.
#[derive(Debug, Clone, Copy)]
struct Calibration {
    from: Address,
    started_us: u64,
    reported: u8,
}

/// The vehicle's state and its services. The stores and the FTP server (its replies are
/// 1.6 kB) are the caller's `static`s; the other servers are small.
#[derive(Debug)]
pub struct Vehicle {
    params: ParamServer,
    param_store: &'static mut Params,
    missions: mission::Server,
    mission_store: &'static mut Missions,
    commands: CommandServer,
    peers: GroundStations,
    ftp: &'static mut FtpServer,
    /// The FTP sessions reading param.pck with its defaults, a bit each.
    ftp_with_defaults: u8,
    armed: bool,
    calibration: Option<Calibration>,
    next_heartbeat_us: u64,
}

impl Vehicle {
    /// A disarmed vehicle over these stores, with `ftp` as its FTP server; its first
    /// HEARTBEAT goes at once. The servers use bytewise parameters (a generic autopilot) and
    /// the runtime's defaults otherwise.
    pub fn new(
        param_store: &'static mut Params,
        mission_store: &'static mut Missions,
        ftp: &'static mut FtpServer,
    ) -> Self {
        Self {
            params: param::Server::new(param::ServerConfig {
                own: OWN,
                encoding: Encoding::for_autopilot(MavAutopilot::Generic),
                list_interval_us: 0,
                hash_check: false,
            }),
            param_store,
            missions: mission::Server::new(mission::ServerConfig::new(OWN)),
            mission_store,
            commands: command::Server::new(command::ServerConfig::new(OWN)),
            peers: Peers::new(),
            ftp,
            ftp_with_defaults: 0,
            armed: false,
            calibration: None,
            next_heartbeat_us: 0,
        }
    }

    /// A message from `from`, for every service.
    #[inline(never)]
    pub fn handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        self.peers_handle(now_us, from, msg);
        self.param_handle(now_us, from, msg);
        self.mission_handle(now_us, from, msg);
        self.command_handle(now_us, from, msg);
        self.ftp_handle(now_us, from, msg);
    }

    /// What time brings: the calibration's progress and end, lost ground stations.
    pub fn tick(&mut self, now_us: u64) {
        self.command_tick(now_us);
        self.peers_tick(now_us);
    }

    /// The next message to send: the HEARTBEAT when due, then the command, parameter,
    /// mission and FTP servers' answers, one per call.
    #[inline(never)]
    pub fn poll_transmit(&mut self, now_us: u64) -> Option<Message> {
        if now_us >= self.next_heartbeat_us {
            return Some(self.heartbeat(now_us));
        }
        self.command_transmit(now_us)
            .or_else(|| self.param_transmit(now_us))
            .or_else(|| self.mission_transmit(now_us))
            .or_else(|| self.ftp_transmit(now_us))
    }

    // Each service is called from functions of its own, kept out of line: one copy of its
    // code serves every caller, and `size.sh` finds each service's share under its name.

    #[inline(never)]
    fn param_handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        self.params.handle(self.param_store, now_us, from, msg);
    }

    #[inline(never)]
    fn param_transmit(&mut self, now_us: u64) -> Option<Message> {
        self.params.poll_transmit(self.param_store, now_us)
    }

    #[inline(never)]
    fn mission_handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        self.missions.handle(self.mission_store, now_us, from, msg);
    }

    #[inline(never)]
    fn mission_transmit(&mut self, now_us: u64) -> Option<Message> {
        self.missions.poll_transmit(self.mission_store, now_us)
    }

    #[inline(never)]
    fn ftp_handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        let mut files = Files {
            params: self.param_store,
            with_defaults: &mut self.ftp_with_defaults,
        };
        self.ftp.handle(&mut files, now_us, from, msg);
    }

    #[inline(never)]
    fn ftp_transmit(&mut self, now_us: u64) -> Option<Message> {
        let mut files = Files {
            params: self.param_store,
            with_defaults: &mut self.ftp_with_defaults,
        };
        self.ftp.poll_transmit(&mut files, now_us)
    }

    #[inline(never)]
    fn command_handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        match self.commands.handle(now_us, from, msg) {
            Some(Request::Run { from, command }) => {
                let ack = self.command_run(now_us, from, command.command, command.params[0]);
                self.commands.respond(now_us, from, command.command, ack);
            }
            Some(Request::Cancel { from, command })
                if self
                    .calibration
                    .is_some_and(|c| c.from == from && command == MavCmd::PreflightCalibration) =>
            {
                self.calibration = None;
                self.commands
                    .respond(now_us, from, command, Ack::new(MavResult::Cancelled));
            }
            _ => {}
        }
    }

    /// Runs a new command from `from`: its first answer.
    fn command_run(&mut self, now_us: u64, from: Address, command: MavCmd, param1: f32) -> Ack {
        Ack::new(match command {
            MavCmd::ComponentArmDisarm => {
                self.armed = param1 >= 0.5;
                MavResult::Accepted
            }
            // One calibration at a time (the command server already refuses a second one from
            // the same sender while the first runs).
            MavCmd::PreflightCalibration if self.calibration.is_some() => {
                MavResult::TemporarilyRejected
            }
            MavCmd::PreflightCalibration => {
                self.calibration = Some(Calibration {
                    from,
                    started_us: now_us,
                    reported: 0,
                });
                return in_progress(0);
            }
            _ => MavResult::Unsupported,
        })
    }

    /// The calibration's progress every quarter of its time, then its end.
    #[inline(never)]
    fn command_tick(&mut self, now_us: u64) {
        let Some(mut c) = self.calibration else {
            return;
        };
        let elapsed = now_us.saturating_sub(c.started_us);
        let ack = if elapsed >= CALIBRATION_US {
            self.calibration = None;
            Ack::new(MavResult::Accepted)
        } else {
            let progress = (elapsed / CALIBRATION_STEP_US * 25) as u8;
            if progress <= c.reported {
                return;
            }
            c.reported = progress;
            self.calibration = Some(c);
            in_progress(progress)
        };
        self.commands
            .respond(now_us, c.from, MavCmd::PreflightCalibration, ack);
    }

    #[inline(never)]
    fn command_transmit(&mut self, now_us: u64) -> Option<Message> {
        self.commands.poll_transmit(now_us)
    }

    #[inline(never)]
    fn peers_handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        self.peers.handle(now_us, from, msg);
    }

    /// Ground stations silent too long are lost; when none is left, the data link loss
    /// action.
    #[inline(never)]
    fn peers_tick(&mut self, now_us: u64) {
        self.peers.expire(now_us);
        let mut lost = false;
        while let Some(event) = self.peers.poll_event() {
            lost |= matches!(event, Event::Lost(_));
        }
        // Ground stations, and any other component that is not an autopilot.
        let gcs_left = self.peers.iter().any(|p| !p.is_vehicle());
        let action = self.param_store.value(params::NAV_DLL_ACT);
        if lost && !gcs_left && self.armed && action.is_some_and(|a| a != Value::U8(0)) {
            self.armed = false;
        }
    }

    /// The HEARTBEAT, due at `now_us`. The stack figure is refreshed with it.
    #[inline(never)]
    fn heartbeat(&mut self, now_us: u64) -> Message {
        // A fixed rate: a late HEARTBEAT does not delay the next, but after a stall the next
        // is a whole period away.
        self.next_heartbeat_us += HEARTBEAT_US;
        if self.next_heartbeat_us <= now_us {
            self.next_heartbeat_us = now_us + HEARTBEAT_US;
        }
        self.param_store
            .update(params::STACK_USED, Value::U32(hw::stack_used()));
        let mut base_mode = MavModeFlag::CUSTOM_MODE_ENABLED;
        if self.armed {
            base_mode |= MavModeFlag::SAFETY_ARMED;
        }
        Message::Heartbeat(Heartbeat {
            r#type: MavType::Quadrotor,
            autopilot: MavAutopilot::Generic,
            base_mode,
            custom_mode: 0,
            system_status: if self.armed {
                MavState::Active
            } else {
                MavState::Standby
            },
            mavlink_version: 3,
        })
    }
}

fn in_progress(progress: u8) -> Ack {
    Ack {
        result: MavResult::InProgress,
        progress,
        result_param2: 0,
    }
}
