//! A software vehicle: HEARTBEAT, parameters, missions (with geofence and rally points) and
//! commands served on MAVLink endpoints, for testing ground software the way people use a
//! simulator.
//!
//! Each endpoint has a thread of its own with its own parameter and command servers (answers
//! go back where the request came from); the parameters and the vehicle's state are shared.
//! Nothing is written to disk: what is set stays in memory.
//!
//! Commands it knows:
//!
//! | command | answer |
//! |---------|--------|
//! | `MAV_CMD_COMPONENT_ARM_DISARM` (400) | arms (param1 1) or disarms (0): ACCEPTED |
//! | `MAV_CMD_NAV_TAKEOFF` (22) | ACCEPTED when armed, else TEMPORARILY_REJECTED |
//! | `MAV_CMD_PREFLIGHT_CALIBRATION` (241) | takes 2 s: IN_PROGRESS at 0 % and 50 %, then ACCEPTED; COMMAND_CANCEL stops it (CANCELLED) |
//! | anything else | UNSUPPORTED |

use std::io;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use ferrolink_runtime::mavlink::service::command::{self, Ack, Request};
use ferrolink_runtime::mavlink::service::ftp;
use ferrolink_runtime::mavlink::service::messages::{
    Heartbeat, MavAutopilot, MavCmd, MavMissionType, MavModeFlag, MavResult, MavState, MavType,
    Message,
};
use ferrolink_runtime::mavlink::service::mission::{self, Item};
use ferrolink_runtime::mavlink::service::param::{self, Encoding, Param};
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_runtime::mavlink::MessageMeta;

use super::ftp::DirFs;
use super::Connection;

/// What the vehicle is.
#[derive(Debug, Clone)]
pub struct Config {
    /// Its system and component.
    pub address: Address,
    /// The autopilot it claims in its HEARTBEAT, which also sets how it encodes integer
    /// parameters (C cast for ArduPilot, bytewise otherwise).
    pub autopilot: MavAutopilot,
    /// Its type.
    pub kind: MavType,
    /// Its parameters, in index order.
    pub params: Vec<Param>,
    /// The messages its connections check frames against (the services' at least).
    pub table: Arc<[MessageMeta]>,
    /// The directory it serves over MAVLink FTP; none: FTP requests go unanswered.
    pub ftp_root: Option<PathBuf>,
}

struct Shared {
    params: Vec<Param>,
    missions: Missions,
    armed: bool,
}

/// The mission, the geofence and the rally points, and the current mission item.
#[derive(Debug, Default)]
struct Missions {
    held: [Vec<Item>; 3],
    current: u16,
}

fn slot(kind: MavMissionType) -> usize {
    match kind {
        MavMissionType::Fence => 1,
        MavMissionType::Rally => 2,
        _ => 0,
    }
}

/// The shared missions with one endpoint's upload beside them: a failed upload leaves them
/// as they were.
struct MissionStore<'a> {
    held: &'a mut Missions,
    staged: &'a mut [Vec<Item>; 3],
}

impl mission::Store for MissionStore<'_> {
    fn count(&self, kind: MavMissionType) -> u16 {
        self.held.held[slot(kind)].len() as u16
    }
    fn get(&self, kind: MavMissionType, seq: u16) -> Option<Item> {
        self.held.held[slot(kind)].get(usize::from(seq)).copied()
    }
    fn begin(&mut self, kind: MavMissionType, count: u16) -> bool {
        self.staged[slot(kind)] = vec![Item::default(); usize::from(count)];
        true
    }
    fn put(&mut self, kind: MavMissionType, seq: u16, item: Item) {
        if let Some(s) = self.staged[slot(kind)].get_mut(usize::from(seq)) {
            *s = item;
        }
    }
    fn commit(&mut self, kind: MavMissionType) {
        self.held.held[slot(kind)] = std::mem::take(&mut self.staged[slot(kind)]);
        if kind == MavMissionType::Mission {
            self.held.current = 0;
        }
    }
    fn clear(&mut self, kind: MavMissionType) {
        if kind == MavMissionType::All {
            self.held.held = Default::default();
        } else {
            self.held.held[slot(kind)].clear();
        }
        self.held.current = 0;
    }
    fn current(&self) -> u16 {
        self.held.current
    }
    fn set_current(&mut self, seq: u16) -> bool {
        let ok = usize::from(seq) < self.held.held[0].len();
        if ok {
            self.held.current = seq;
        }
        ok
    }
}

/// How long the calibration command runs.
const CALIBRATION: Duration = Duration::from_secs(2);

/// Opens every endpoint, prints nothing, calls `ready` once all are open, and serves until
/// `stop` is set or `run_for` passes. An endpoint that fails at run time (a device unplugged)
/// ends only its own thread.
pub fn run(
    config: &Config,
    endpoints: &[String],
    run_for: Option<Duration>,
    stop: &Arc<AtomicBool>,
    ready: impl FnOnce(),
) -> io::Result<()> {
    if let Some(root) = &config.ftp_root {
        DirFs::new(root)?;
    }
    let mut links = Vec::new();
    for uri in endpoints {
        let mut link = Connection::open(uri, config.table.clone())
            .map_err(|e| io::Error::new(e.kind(), format!("{uri}: {e}")))?;
        link.set_ids(config.address.system, config.address.component);
        links.push(link);
    }
    let shared = Arc::new(Mutex::new(Shared {
        params: config.params.clone(),
        missions: Missions::default(),
        armed: false,
    }));
    ready();
    let end = run_for.map(|d| Instant::now() + d);
    std::thread::scope(|scope| {
        for link in links {
            let shared = shared.clone();
            scope.spawn(move || serve(config, link, &shared, end, stop));
        }
    });
    Ok(())
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    shared.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A command that takes time: who asked, when it ends, the progress reported so far.
struct Running {
    from: Address,
    command: MavCmd,
    started: Instant,
    reported: u8,
}

fn serve(
    config: &Config,
    mut link: Connection,
    shared: &Mutex<Shared>,
    end: Option<Instant>,
    stop: &AtomicBool,
) {
    let own = config.address;
    let mut params: param::Server<64> = param::Server::new(param::ServerConfig {
        own,
        encoding: Encoding::for_autopilot(config.autopilot),
        // 40,000 values a second: a 1,000-value list in 25 ms. All at once, it overran the
        // receiving socket's buffer on loopback, and the client asked again for what was lost.
        list_interval_us: 25,
        // As PX4 does, for clients that cache the parameters.
        hash_check: config.autopilot == MavAutopilot::Px4,
    });
    let mut commands: command::Server<8> = command::Server::new(command::ServerConfig::new(own));
    let mut missions = mission::Server::new(mission::ServerConfig::new(own));
    // Each endpoint has its own sessions; the files are the directory's, shared.
    let mut files = config
        .ftp_root
        .as_deref()
        .and_then(|root| DirFs::new(root).ok());
    let mut ftp: ftp::Server<4> = ftp::Server::new(ftp::ServerConfig::new(own));
    let mut staged: [Vec<Item>; 3] = Default::default();
    let mut running: Vec<Running> = Vec::new();
    let start = Instant::now();
    let now_us = || start.elapsed().as_micros() as u64;
    let mut beat = Instant::now();
    loop {
        let now = Instant::now();
        if stop.load(Ordering::Relaxed) || end.is_some_and(|e| now >= e) {
            return;
        }
        if now >= beat {
            let armed = lock(shared).armed;
            let _ = link.send_dialect(&heartbeat(config, armed));
            beat = now + Duration::from_secs(1);
        }
        // Long commands: progress at half time, the result at the end.
        running.retain_mut(|r| {
            let elapsed = now.duration_since(r.started);
            if elapsed >= CALIBRATION {
                commands.respond(now_us(), r.from, r.command, Ack::new(MavResult::Accepted));
                return false;
            }
            if elapsed >= CALIBRATION / 2 && r.reported < 50 {
                r.reported = 50;
                commands.respond(now_us(), r.from, r.command, in_progress(50));
            }
            true
        });
        let t = now_us();
        {
            let mut state = lock(shared);
            while let Some(m) = params.poll_transmit(&state.params[..], t) {
                if link.send_dialect(&m).is_err() {
                    break;
                }
            }
            let store = MissionStore {
                held: &mut state.missions,
                staged: &mut staged,
            };
            while let Some(m) = missions.poll_transmit(&store, t) {
                let _ = link.send_dialect(&m);
            }
        }
        while let Some(m) = commands.poll_transmit(t) {
            let _ = link.send_dialect(&m);
        }
        if let Some(files) = files.as_mut() {
            while let Some(m) = ftp.poll_transmit(files, t) {
                let _ = link.send_dialect(&m);
            }
        }
        // Sleep until a frame, the next heartbeat, a long command's next step, or 100 ms
        // (to look at `stop`).
        let mut wake = beat.min(now + Duration::from_millis(100));
        for r in &running {
            wake = wake
                .min(r.started + CALIBRATION / 2)
                .min(r.started + CALIBRATION);
        }
        for deadline in [
            params.poll_timeout(),
            missions.poll_timeout(),
            ftp.poll_timeout(),
        ]
        .into_iter()
        .flatten()
        {
            let at = start + Duration::from_micros(deadline);
            wake = wake.min(at.max(now));
        }
        let frame = match link.recv(wake.saturating_duration_since(Instant::now())) {
            Ok(Some(frame)) => frame,
            Ok(None) => continue,
            Err(_) => return,
        };
        let Ok(msg) = frame.decode::<Message>() else {
            continue;
        };
        let h = frame.header();
        let from = Address::new(h.sysid, h.compid);
        let t = now_us();
        {
            let mut state = lock(shared);
            params.handle(&mut state.params[..], t, from, &msg);
            let mut store = MissionStore {
                held: &mut state.missions,
                staged: &mut staged,
            };
            missions.handle(&mut store, t, from, &msg);
        }
        if let Some(files) = files.as_mut() {
            ftp.handle(files, t, from, &msg);
        }
        match commands.handle(t, from, &msg) {
            Some(Request::Run { from, command }) => {
                let answer = run_command(shared, command.command, command.params[0]);
                match answer {
                    Some(ack) => {
                        commands.respond(t, from, command.command, ack);
                    }
                    None => {
                        commands.respond(t, from, command.command, in_progress(0));
                        running.push(Running {
                            from,
                            command: command.command,
                            started: Instant::now(),
                            reported: 0,
                        });
                    }
                }
            }
            Some(Request::Cancel { from, command }) => {
                let before = running.len();
                running.retain(|r| !(r.from == from && r.command == command));
                if running.len() < before {
                    commands.respond(t, from, command, Ack::new(MavResult::Cancelled));
                }
            }
            None => {}
        }
    }
}

fn in_progress(progress: u8) -> Ack {
    Ack {
        result: MavResult::InProgress,
        progress,
        result_param2: 0,
    }
}

/// Runs a command: its answer, or `None` for one that takes time.
fn run_command(shared: &Mutex<Shared>, command: MavCmd, param1: f32) -> Option<Ack> {
    let mut state = lock(shared);
    Some(Ack::new(match command {
        MavCmd::ComponentArmDisarm => {
            state.armed = param1 >= 0.5;
            MavResult::Accepted
        }
        MavCmd::NavTakeoff if state.armed => MavResult::Accepted,
        MavCmd::NavTakeoff => MavResult::TemporarilyRejected,
        MavCmd::PreflightCalibration => return None,
        _ => MavResult::Unsupported,
    }))
}

fn heartbeat(config: &Config, armed: bool) -> Message {
    let mut mode = MavModeFlag::CUSTOM_MODE_ENABLED;
    if armed {
        mode |= MavModeFlag::SAFETY_ARMED;
    }
    Message::Heartbeat(Heartbeat {
        r#type: config.kind,
        autopilot: config.autopilot,
        base_mode: mode,
        custom_mode: 0,
        system_status: if armed {
            MavState::Active
        } else {
            MavState::Standby
        },
        mavlink_version: 3,
    })
}
