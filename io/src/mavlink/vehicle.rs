//! A software vehicle: it flies ([`super::flight`]), publishes its telemetry, and serves
//! parameters, missions (with geofence and rally points), commands and files on MAVLink
//! endpoints, for testing ground software the way people use a simulator.
//!
//! Each endpoint has a thread of its own with its own parameter and command servers and its
//! own telemetry rates (answers go back where the request came from); the parameters, the
//! missions and the flight are shared. Nothing is written to disk: what is set stays in memory.
//!
//! Telemetry, at these rates until MAV_CMD_SET_MESSAGE_INTERVAL says otherwise on that
//! endpoint: HEARTBEAT, SYS_STATUS, BATTERY_STATUS, EXTENDED_SYS_STATE and MISSION_CURRENT at
//! 1 Hz, GPS_RAW_INT at 2 Hz, GLOBAL_POSITION_INT at 5 Hz, ATTITUDE at 10 Hz, HOME_POSITION every
//! 5 s; MISSION_ITEM_REACHED and STATUSTEXT as they happen.
//!
//! Commands it knows:
//!
//! | command | answer |
//! |---------|--------|
//! | `MAV_CMD_COMPONENT_ARM_DISARM` (400) | arms (param1 1) or disarms (0; in the air only with param2 21196): ACCEPTED, else DENIED |
//! | `MAV_CMD_NAV_TAKEOFF` (22) | climbs: ACCEPTED when armed on the ground (ArduCopter: in GUIDED), else TEMPORARILY_REJECTED (FAILED); PX4 without an altitude climbs its parameter MIS_TAKEOFF_ALT, if it has one, else 2.5 m |
//! | `MAV_CMD_NAV_LAND` (21), `MAV_CMD_NAV_RETURN_TO_LAUNCH` (20) | in the air: ACCEPTED; on the ground: DENIED |
//! | `MAV_CMD_DO_SET_MODE` (176) | a mode of the autopilot's table: ACCEPTED; another: DENIED (SET_MODE, pymavlink's and MAVProxy's way, does the same, unanswered) |
//! | `MAV_CMD_DO_REPOSITION` (192) | in the air: goes there, ACCEPTED |
//! | `MAV_CMD_MISSION_START` (300) | armed with a mission: flies it, ACCEPTED |
//! | `MAV_CMD_SET_MESSAGE_INTERVAL` (511), `MAV_CMD_REQUEST_MESSAGE` (512) | a message it publishes: ACCEPTED; another: UNSUPPORTED |
//! | `MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN` (246) | 1 on the ground: starts afresh, ACCEPTED |
//! | `MAV_CMD_PREFLIGHT_CALIBRATION` (241) | takes 2 s: IN_PROGRESS at 0 % and 50 %, then ACCEPTED; COMMAND_CANCEL stops it (CANCELLED) |
//! | anything else | UNSUPPORTED |

use std::io;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use ferrolink_runtime::mavlink::service::command::{self, Ack, Command, Request};
use ferrolink_runtime::mavlink::service::ftp;
use ferrolink_runtime::mavlink::service::messages::{
    MavAutopilot, MavCmd, MavMissionType, MavResult, MavType, Message,
};
use ferrolink_runtime::mavlink::service::mission::{self, Item};
use ferrolink_runtime::mavlink::service::param::{self, Encoding, Param};
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_runtime::mavlink::MessageMeta;

use super::flight::{Flight, Point};
use super::ftp::DirFs;
use super::{Connection, SharedConnection};

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
    /// Where it stands at first, and comes home to.
    pub home: Point,
}

/// PX4's SITL home, the default: Zurich, 488 m above sea level.
pub const HOME: Point = Point {
    lat: 47.397742,
    lon: 8.545594,
    alt: 488.0,
};

struct Shared {
    params: Vec<Param>,
    missions: Missions,
    flight: Flight,
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
        flight: Flight::new(
            ferrolink_dialects::common::MavAutopilot::from_raw(config.autopilot.raw()),
            ferrolink_dialects::common::MavType::from_raw(config.kind.raw()),
            config.home,
        ),
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
    let mut rates = Rates::new(start);
    let mut noted = 0;
    let sender = link.shared().clone();
    loop {
        let now = Instant::now();
        if stop.load(Ordering::Relaxed) || end.is_some_and(|e| now >= e) {
            return;
        }
        {
            let mut state = lock(shared);
            let Shared {
                missions, flight, ..
            } = &mut *state;
            flight.advance(now, &missions.held[0]);
            missions.current = flight.current();
            let total = missions.held[0].len() as u16;
            for id in rates.due(now) {
                let _ = publish(&sender, flight, id, total, start);
            }
            for (n, note) in flight.notes_after(noted) {
                let _ = note.send(&sender);
                noted = *n;
            }
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
        // Sleep until a frame, the next telemetry, a long command's next step, or 100 ms
        // (to look at `stop`).
        let mut wake = rates.next().min(now + Duration::from_millis(100));
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
            // SET_MODE, which pymavlink's set_mode and MAVProxy's `mode` send (superseded by
            // DO_SET_MODE, and still their way): not a command, so no answer but the next
            // HEARTBEAT.
            #[allow(deprecated)]
            if let Ok(ferrolink_dialects::common::Message::SetMode(m)) =
                frame.decode::<ferrolink_dialects::common::Message>()
            {
                if m.target_system == own.system {
                    let mut state = lock(shared);
                    let len = state.missions.held[0].len() as u16;
                    state
                        .flight
                        .set_custom_mode(m.base_mode.raw(), m.custom_mode, len);
                }
            }
            continue;
        };
        let h = frame.header();
        let from = Address::new(h.sysid, h.compid);
        let t = now_us();
        {
            let mut state = lock(shared);
            params.handle(&mut state.params[..], t, from, &msg);
            let before = state.missions.current;
            let mut store = MissionStore {
                held: &mut state.missions,
                staged: &mut staged,
            };
            missions.handle(&mut store, t, from, &msg);
            if state.missions.current != before {
                let current = state.missions.current;
                state.flight.set_current(current);
            }
        }
        if let Some(files) = files.as_mut() {
            ftp.handle(files, t, from, &msg);
        }
        match commands.handle(t, from, &msg) {
            Some(Request::Run { from, command }) => {
                let answer = run_command(shared, &mut rates, &command);
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
fn run_command(shared: &Mutex<Shared>, rates: &mut Rates, command: &Command) -> Option<Ack> {
    let p = command.params;
    let result = match command.command {
        MavCmd::PreflightCalibration => return None,
        MavCmd::SetMessageInterval => rates.set(p[0] as u32, p[1]),
        MavCmd::RequestMessage => rates.once(p[0] as u32),
        _ => {
            let mut state = lock(shared);
            let len = state.missions.held[0].len() as u16;
            let takeoff = state
                .params
                .iter()
                .find(|p| p.name.as_str() == "MIS_TAKEOFF_ALT")
                .map(|p| p.value.as_f64());
            if let Some(metres) = takeoff {
                state.flight.set_takeoff_default(metres);
            }
            let result = state.flight.command(command, len);
            state.missions.current = state.flight.current();
            result.unwrap_or(MavResult::Unsupported)
        }
    };
    Some(Ack::new(result))
}

/// The messages it publishes, with their default intervals.
const TELEMETRY: &[(u32, Duration)] = &[
    (0, Duration::from_secs(1)),
    (1, Duration::from_secs(1)),
    (24, Duration::from_millis(500)),
    (30, Duration::from_millis(100)),
    (33, Duration::from_millis(200)),
    (42, Duration::from_secs(1)),
    (147, Duration::from_secs(1)),
    (242, Duration::from_secs(5)),
    (245, Duration::from_secs(1)),
];

/// One endpoint's telemetry rates: when each message is due next, and those asked for once.
struct Rates {
    /// Message id, interval (`None`: off), next time due.
    every: Vec<(u32, Option<Duration>, Instant)>,
    once: Vec<u32>,
}

impl Rates {
    fn new(start: Instant) -> Self {
        Rates {
            every: TELEMETRY
                .iter()
                .map(|&(id, interval)| (id, Some(interval), start))
                .collect(),
            once: Vec::new(),
        }
    }

    /// MAV_CMD_SET_MESSAGE_INTERVAL: `interval_us` µs, -1 off, 0 the default.
    fn set(&mut self, id: u32, interval_us: f32) -> MavResult {
        let Some(slot) = self.every.iter_mut().find(|(i, ..)| *i == id) else {
            return MavResult::Unsupported;
        };
        let default = TELEMETRY.iter().find(|(i, _)| *i == id).map(|(_, d)| *d);
        slot.1 = if interval_us < 0.0 {
            None
        } else if interval_us == 0.0 {
            default
        } else {
            // At most 1 kHz.
            Some(Duration::from_micros(interval_us.max(1000.0) as u64))
        };
        slot.2 = Instant::now();
        MavResult::Accepted
    }

    /// MAV_CMD_REQUEST_MESSAGE.
    fn once(&mut self, id: u32) -> MavResult {
        if !TELEMETRY.iter().any(|(i, _)| *i == id) {
            return MavResult::Unsupported;
        }
        self.once.push(id);
        MavResult::Accepted
    }

    /// The messages due at `now`; each is then due again one interval on.
    fn due(&mut self, now: Instant) -> Vec<u32> {
        let mut due = std::mem::take(&mut self.once);
        for (id, interval, next) in &mut self.every {
            if let Some(interval) = interval {
                if now >= *next {
                    due.push(*id);
                    // Keep the rate when a beat was late, without a burst to catch up.
                    *next = (*next + *interval).max(now);
                }
            }
        }
        due
    }

    /// When the next message is due.
    fn next(&self) -> Instant {
        self.every
            .iter()
            .filter(|(_, interval, _)| interval.is_some())
            .map(|(_, _, next)| *next)
            .min()
            .unwrap_or_else(|| Instant::now() + Duration::from_secs(1))
    }
}

/// Sends message `id` of the flight on `link`.
fn publish(
    link: &SharedConnection,
    flight: &Flight,
    id: u32,
    total: u16,
    boot: Instant,
) -> io::Result<()> {
    match id {
        0 => link.send(&flight.heartbeat()),
        1 => link.send(&flight.sys_status()),
        24 => link.send(&flight.gps(boot)),
        30 => link.send(&flight.attitude(boot)),
        33 => link.send(&flight.global_position(boot)),
        42 => link.send(&flight.mission_current(total)),
        147 => link.send(&flight.battery_status()),
        242 => link.send(&flight.home_position()),
        245 => link.send(&flight.extended_sys_state()),
        _ => Ok(()),
    }
}
