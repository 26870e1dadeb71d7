//! A system's telemetry, typed, in SI units and degrees: the latest of each kind, and
//! subscriptions to their updates.
//!
//! | kind | from |
//! |---|---|
//! | [`Position`] | GLOBAL_POSITION_INT |
//! | home ([`Position`]) | HOME_POSITION |
//! | [`Attitude`] (Euler angles) | ATTITUDE |
//! | [`Quaternion`] | ATTITUDE_QUATERNION |
//! | [`Velocity`] (north, east, down) | GLOBAL_POSITION_INT |
//! | [`Gps`] | GPS_RAW_INT |
//! | [`Battery`] | BATTERY_STATUS, or SYS_STATUS for a system that sends no BATTERY_STATUS |
//! | [`Health`] | SYS_STATUS |
//! | [`State`]: armed, flight mode, landed state | HEARTBEAT, EXTENDED_SYS_STATE |
//! | [`Text`] | STATUSTEXT, chunked texts joined |
//!
//! Frames are decoded on the connection's own thread as they arrive (a tap), so the latest
//! values are always current and no thread or task runs for them. Each subscription
//! ([`Updates`]) has a bounded queue of its own: one that stops reading loses its own updates,
//! counted, and nothing else.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use ferrolink_dialects::common::{
    GpsFixType, MavAutopilot, MavLandedState, MavModeFlag, MavSeverity, MavState,
    MavSysStatusSensor, MavType, Message,
};
use ferrolink_io::mavlink::Frame;

use crate::modes;

/// A position on the globe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Position {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude above mean sea level, metres.
    pub alt_amsl: f32,
    /// Altitude above home, metres (0 for home itself).
    pub alt_rel: f32,
}

/// Attitude as Euler angles, degrees.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Attitude {
    /// Roll, right wing down positive.
    pub roll: f32,
    /// Pitch, nose up positive.
    pub pitch: f32,
    /// Yaw, clockwise from north.
    pub yaw: f32,
}

/// Attitude as a quaternion (w, x, y, z).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Quaternion {
    /// w.
    pub w: f32,
    /// x.
    pub x: f32,
    /// y.
    pub y: f32,
    /// z.
    pub z: f32,
}

/// Ground velocity, metres a second.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Velocity {
    /// North.
    pub north: f32,
    /// East.
    pub east: f32,
    /// Down.
    pub down: f32,
}

/// A GPS fix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fix {
    /// No fix (or no GPS).
    #[default]
    None,
    /// 2D.
    Fix2d,
    /// 3D.
    Fix3d,
    /// 3D with differential corrections.
    Dgps,
    /// RTK, float.
    RtkFloat,
    /// RTK, fixed.
    RtkFixed,
}

impl Fix {
    /// The name the CLI prints: `NO_FIX`, `2D`, `3D`, `DGPS`, `RTK_FLOAT`, `RTK_FIXED`.
    pub fn name(self) -> &'static str {
        match self {
            Fix::None => "NO_FIX",
            Fix::Fix2d => "2D",
            Fix::Fix3d => "3D",
            Fix::Dgps => "DGPS",
            Fix::RtkFloat => "RTK_FLOAT",
            Fix::RtkFixed => "RTK_FIXED",
        }
    }
}

/// The GPS receiver's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Gps {
    /// Its fix.
    pub fix: Fix,
    /// Satellites in view (`None`: unknown).
    pub satellites: Option<u8>,
}

/// The battery.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Battery {
    /// Voltage, volts.
    pub voltage: f32,
    /// Charge left, percent (`None`: unknown).
    pub remaining: Option<f32>,
}

/// Whether the sensors and systems the vehicle reports on are healthy (SYS_STATUS): `None`
/// for those it has not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Health {
    /// Gyroscopes.
    pub gyro: Option<bool>,
    /// Accelerometers.
    pub accel: Option<bool>,
    /// Magnetometers.
    pub mag: Option<bool>,
    /// Barometer.
    pub baro: Option<bool>,
    /// GPS.
    pub gps: Option<bool>,
    /// RC receiver.
    pub rc: Option<bool>,
    /// Battery.
    pub battery: Option<bool>,
}

/// Whether the vehicle is on the ground or flying (EXTENDED_SYS_STATE).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Landed {
    /// Unknown.
    #[default]
    Undefined,
    /// On the ground.
    OnGround,
    /// Flying.
    InAir,
    /// Taking off.
    Takeoff,
    /// Landing.
    Landing,
}

impl Landed {
    /// The name the CLI prints: `ON_GROUND`, `IN_AIR`, `TAKEOFF`, `LANDING`, `UNDEFINED`.
    pub fn name(self) -> &'static str {
        match self {
            Landed::Undefined => "UNDEFINED",
            Landed::OnGround => "ON_GROUND",
            Landed::InAir => "IN_AIR",
            Landed::Takeoff => "TAKEOFF",
            Landed::Landing => "LANDING",
        }
    }
}

/// The vehicle's state, from its HEARTBEAT (and EXTENDED_SYS_STATE).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct State {
    /// Armed.
    pub armed: bool,
    /// Its flight mode, by the autopilot's own name (`CUSTOM(N)` for one without a name).
    pub mode: String,
    /// Its `custom_mode`.
    pub custom_mode: u32,
    /// On the ground or flying.
    pub landed: Landed,
}

/// A status text (STATUSTEXT; texts sent in chunks come joined).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Text {
    /// Its severity.
    pub severity: MavSeverity,
    /// The text.
    pub text: String,
}

/// One update.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Update {
    /// The position.
    Position(Position),
    /// Home.
    Home(Position),
    /// Attitude, Euler angles.
    Attitude(Attitude),
    /// Attitude, quaternion.
    Quaternion(Quaternion),
    /// Velocity.
    Velocity(Velocity),
    /// GPS.
    Gps(Gps),
    /// Battery.
    Battery(Battery),
    /// Health.
    Health(Health),
    /// Armed, mode, landed state.
    State(State),
    /// A status text.
    Text(Text),
}

/// The kinds of [`Update`], to subscribe to some.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Kind {
    /// [`Update::Position`].
    Position,
    /// [`Update::Home`].
    Home,
    /// [`Update::Attitude`].
    Attitude,
    /// [`Update::Quaternion`].
    Quaternion,
    /// [`Update::Velocity`].
    Velocity,
    /// [`Update::Gps`].
    Gps,
    /// [`Update::Battery`].
    Battery,
    /// [`Update::Health`].
    Health,
    /// [`Update::State`].
    State,
    /// [`Update::Text`].
    Text,
}

impl Update {
    /// Its kind.
    pub fn kind(&self) -> Kind {
        match self {
            Update::Position(_) => Kind::Position,
            Update::Home(_) => Kind::Home,
            Update::Attitude(_) => Kind::Attitude,
            Update::Quaternion(_) => Kind::Quaternion,
            Update::Velocity(_) => Kind::Velocity,
            Update::Gps(_) => Kind::Gps,
            Update::Battery(_) => Kind::Battery,
            Update::Health(_) => Kind::Health,
            Update::State(_) => Kind::State,
            Update::Text(_) => Kind::Text,
        }
    }
}

/// The message ids telemetry is made from.
pub(crate) const IDS: &[u32] = &[0, 1, 24, 30, 31, 33, 147, 242, 245, 253];

/// How many updates a subscription holds for its reader.
const QUEUE: usize = 1024;

/// What a system's HEARTBEAT says it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Identity {
    pub autopilot: MavAutopilot,
    pub kind: MavType,
    pub base_mode: MavModeFlag,
    pub custom_mode: u32,
    pub status: MavState,
}

/// One subscriber's end.
struct Subscriber {
    kinds: Vec<Kind>,
    tx: flume::Sender<Update>,
    dropped: Arc<AtomicU64>,
}

/// A chunked STATUSTEXT being joined.
struct Chunks {
    id: u16,
    severity: MavSeverity,
    text: String,
}

/// Everything known of one system.
#[derive(Default)]
pub(crate) struct Latest {
    pub identity: Option<Identity>,
    pub heard: Option<Instant>,
    pub components: Vec<u8>,
    position: Option<Position>,
    home: Option<Position>,
    attitude: Option<Attitude>,
    quaternion: Option<Quaternion>,
    velocity: Option<Velocity>,
    gps: Option<Gps>,
    battery: Option<Battery>,
    battery_status_seen: bool,
    health: Option<Health>,
    state: Option<State>,
    landed: Landed,
    text: Option<Text>,
    chunks: Option<Chunks>,
    subscribers: Vec<Subscriber>,
}

impl Latest {
    /// Takes in a frame of this system.
    pub(crate) fn take(&mut self, frame: &Frame) {
        let compid = frame.header().compid;
        if !self.components.contains(&compid) {
            self.components.push(compid);
        }
        let Ok(message) = frame.decode::<Message>() else {
            return;
        };
        for update in self.updates(&message) {
            self.publish(update);
        }
    }

    fn updates(&mut self, message: &Message) -> Vec<Update> {
        let deg = |raw: i32| f64::from(raw) / 1e7;
        match message {
            Message::Heartbeat(hb) => {
                // A ground station or a camera beside the autopilot says nothing of the vehicle.
                if hb.autopilot == MavAutopilot::Invalid {
                    return Vec::new();
                }
                self.heard = Some(Instant::now());
                self.identity = Some(Identity {
                    autopilot: hb.autopilot,
                    kind: hb.r#type,
                    base_mode: hb.base_mode,
                    custom_mode: hb.custom_mode,
                    status: hb.system_status,
                });
                self.state_update()
            }
            Message::ExtendedSysState(s) => {
                self.landed = match s.landed_state {
                    MavLandedState::OnGround => Landed::OnGround,
                    MavLandedState::InAir => Landed::InAir,
                    MavLandedState::Takeoff => Landed::Takeoff,
                    MavLandedState::Landing => Landed::Landing,
                    _ => Landed::Undefined,
                };
                self.state_update()
            }
            Message::GlobalPositionInt(p) => {
                let position = Position {
                    lat: deg(p.lat),
                    lon: deg(p.lon),
                    alt_amsl: p.alt as f32 / 1000.0,
                    alt_rel: p.relative_alt as f32 / 1000.0,
                };
                let velocity = Velocity {
                    north: f32::from(p.vx) / 100.0,
                    east: f32::from(p.vy) / 100.0,
                    down: f32::from(p.vz) / 100.0,
                };
                self.position = Some(position);
                self.velocity = Some(velocity);
                vec![Update::Position(position), Update::Velocity(velocity)]
            }
            Message::HomePosition(h) => {
                let home = Position {
                    lat: deg(h.latitude),
                    lon: deg(h.longitude),
                    alt_amsl: h.altitude as f32 / 1000.0,
                    alt_rel: 0.0,
                };
                self.home = Some(home);
                vec![Update::Home(home)]
            }
            Message::Attitude(a) => {
                let attitude = Attitude {
                    roll: a.roll.to_degrees(),
                    pitch: a.pitch.to_degrees(),
                    yaw: a.yaw.to_degrees(),
                };
                self.attitude = Some(attitude);
                vec![Update::Attitude(attitude)]
            }
            Message::AttitudeQuaternion(q) => {
                let quaternion = Quaternion {
                    w: q.q1,
                    x: q.q2,
                    y: q.q3,
                    z: q.q4,
                };
                self.quaternion = Some(quaternion);
                vec![Update::Quaternion(quaternion)]
            }
            Message::GpsRawInt(g) => {
                let fix = match g.fix_type {
                    GpsFixType::Type2dFix => Fix::Fix2d,
                    GpsFixType::Type3dFix => Fix::Fix3d,
                    GpsFixType::Dgps => Fix::Dgps,
                    GpsFixType::RtkFloat => Fix::RtkFloat,
                    GpsFixType::RtkFixed => Fix::RtkFixed,
                    _ => Fix::None,
                };
                let gps = Gps {
                    fix,
                    satellites: (g.satellites_visible != u8::MAX).then_some(g.satellites_visible),
                };
                self.gps = Some(gps);
                vec![Update::Gps(gps)]
            }
            Message::BatteryStatus(b) => {
                self.battery_status_seen = true;
                // Cells in mV, UINT16_MAX where there is none; the first cell may hold the
                // whole pack's voltage when cells are not known.
                let cells = b.voltages.iter().chain(&b.voltages_ext);
                let mv: u32 = cells
                    .take_while(|&&v| v != u16::MAX && v != 0)
                    .map(|&v| u32::from(v))
                    .sum();
                self.battery_update(mv as f32 / 1000.0, b.battery_remaining)
            }
            Message::SysStatus(s) => {
                let health = health(
                    s.onboard_control_sensors_present,
                    s.onboard_control_sensors_health,
                );
                self.health = Some(health);
                let mut updates = vec![Update::Health(health)];
                if !self.battery_status_seen && s.voltage_battery != u16::MAX {
                    updates.extend(self.battery_update(
                        f32::from(s.voltage_battery) / 1000.0,
                        s.battery_remaining,
                    ));
                }
                updates
            }
            Message::Statustext(t) => {
                self.text_update(t.severity, t.text.as_str(), t.id, t.chunk_seq)
            }
            _ => Vec::new(),
        }
    }

    fn battery_update(&mut self, voltage: f32, remaining: i8) -> Vec<Update> {
        let battery = Battery {
            voltage,
            remaining: (remaining >= 0).then_some(f32::from(remaining)),
        };
        self.battery = Some(battery);
        vec![Update::Battery(battery)]
    }

    fn state_update(&mut self) -> Vec<Update> {
        let Some(id) = self.identity else {
            return Vec::new();
        };
        let state = State {
            armed: id.base_mode.0 & MavModeFlag::SAFETY_ARMED.0 != 0,
            mode: modes::display(id.autopilot, id.kind, id.custom_mode),
            custom_mode: id.custom_mode,
            landed: self.landed,
        };
        self.state = Some(state.clone());
        vec![Update::State(state)]
    }

    /// A STATUSTEXT: whole (id 0, or a text shorter than 50 bytes), or a chunk of text `id`,
    /// joined until a chunk shorter than 50 bytes ends it.
    fn text_update(&mut self, severity: MavSeverity, part: &str, id: u16, seq: u8) -> Vec<Update> {
        let last = part.len() < 50;
        let (severity, whole) = if id == 0 {
            (severity, part.to_owned())
        } else {
            let chunks = match self.chunks.take() {
                Some(c) if c.id == id && seq > 0 => c,
                _ => Chunks {
                    id,
                    severity,
                    text: String::new(),
                },
            };
            let mut chunks = chunks;
            chunks.text.push_str(part);
            if !last && chunks.text.len() < 50 * 255 {
                self.chunks = Some(chunks);
                return Vec::new();
            }
            (chunks.severity, chunks.text)
        };
        let text = Text {
            severity,
            text: whole,
        };
        self.text = Some(text.clone());
        vec![Update::Text(text)]
    }

    fn publish(&mut self, update: Update) {
        let kind = update.kind();
        self.subscribers.retain(|s| {
            if !s.kinds.is_empty() && !s.kinds.contains(&kind) {
                return !s.tx.is_disconnected();
            }
            match s.tx.try_send(update.clone()) {
                Ok(()) => true,
                Err(flume::TrySendError::Full(_)) => {
                    s.dropped.fetch_add(1, Ordering::Relaxed);
                    true
                }
                Err(flume::TrySendError::Disconnected(_)) => false,
            }
        });
    }
}

fn health(present: MavSysStatusSensor, healthy: MavSysStatusSensor) -> Health {
    let bit = |flags: &[MavSysStatusSensor]| {
        let mask = flags.iter().fold(0, |m, f| m | f.0);
        (present.0 & mask != 0).then_some(healthy.0 & mask == present.0 & mask)
    };
    use MavSysStatusSensor as S;
    Health {
        gyro: bit(&[S::SENSOR_3D_GYRO, S::SENSOR_3D_GYRO2]),
        accel: bit(&[S::SENSOR_3D_ACCEL, S::SENSOR_3D_ACCEL2]),
        mag: bit(&[S::SENSOR_3D_MAG, S::SENSOR_3D_MAG2]),
        baro: bit(&[S::ABSOLUTE_PRESSURE]),
        gps: bit(&[S::GPS]),
        rc: bit(&[S::RC_RECEIVER]),
        battery: bit(&[S::BATTERY]),
    }
}

/// The systems heard on a connection, shared by the node's tap and every handle.
pub(crate) type Systems = Arc<Mutex<HashMap<u8, Latest>>>;

/// One system's telemetry: see the [module documentation](self).
#[derive(Clone)]
pub struct Telemetry {
    pub(crate) systems: Systems,
    pub(crate) system: u8,
}

impl std::fmt::Debug for Telemetry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Telemetry")
            .field("system", &self.system)
            .finish_non_exhaustive()
    }
}

impl Telemetry {
    fn with<T>(&self, f: impl FnOnce(&Latest) -> T) -> Option<T> {
        let systems = self
            .systems
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        systems.get(&self.system).map(f)
    }

    /// The latest position.
    pub fn position(&self) -> Option<Position> {
        self.with(|l| l.position).flatten()
    }
    /// Home.
    pub fn home(&self) -> Option<Position> {
        self.with(|l| l.home).flatten()
    }
    /// The latest attitude, Euler angles.
    pub fn attitude(&self) -> Option<Attitude> {
        self.with(|l| l.attitude).flatten()
    }
    /// The latest attitude, quaternion.
    pub fn quaternion(&self) -> Option<Quaternion> {
        self.with(|l| l.quaternion).flatten()
    }
    /// The latest velocity.
    pub fn velocity(&self) -> Option<Velocity> {
        self.with(|l| l.velocity).flatten()
    }
    /// The latest GPS state.
    pub fn gps(&self) -> Option<Gps> {
        self.with(|l| l.gps).flatten()
    }
    /// The latest battery state.
    pub fn battery(&self) -> Option<Battery> {
        self.with(|l| l.battery).flatten()
    }
    /// The latest health.
    pub fn health(&self) -> Option<Health> {
        self.with(|l| l.health).flatten()
    }
    /// Armed, flight mode, landed state.
    pub fn state(&self) -> Option<State> {
        self.with(|l| l.state.clone()).flatten()
    }
    /// The last status text.
    pub fn text(&self) -> Option<Text> {
        self.with(|l| l.text.clone()).flatten()
    }
    /// When its last HEARTBEAT came.
    pub fn last_heard(&self) -> Option<Instant> {
        self.with(|l| l.heard).flatten()
    }

    /// The position, waiting up to `timeout` for the first one.
    pub fn wait_position(&self, timeout: Duration) -> Option<Position> {
        let updates = self.subscribe(&[Kind::Position]);
        if let Some(p) = self.position() {
            return Some(p);
        }
        let until = Instant::now() + timeout;
        while let Some(update) = updates.recv(until.saturating_duration_since(Instant::now())) {
            if let Update::Position(p) = update {
                return Some(p);
            }
        }
        None
    }

    /// [`Telemetry::wait_position`], async (on tokio's timer).
    pub async fn wait_position_async(&self, timeout: Duration) -> Option<Position> {
        let updates = self.subscribe(&[Kind::Position]);
        if let Some(p) = self.position() {
            return Some(p);
        }
        let wait = async {
            while let Some(update) = updates.recv_async().await {
                if let Update::Position(p) = update {
                    return Some(p);
                }
            }
            None
        };
        tokio::time::timeout(timeout, wait).await.ok().flatten()
    }

    /// A subscription to updates of `kinds` (all of them when empty), from now on.
    pub fn subscribe(&self, kinds: &[Kind]) -> Updates {
        let (tx, rx) = flume::bounded(QUEUE);
        let dropped = Arc::new(AtomicU64::new(0));
        let mut systems = self
            .systems
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        systems
            .entry(self.system)
            .or_default()
            .subscribers
            .push(Subscriber {
                kinds: kinds.to_vec(),
                tx,
                dropped: dropped.clone(),
            });
        Updates { rx, dropped }
    }
}

/// A subscription to a system's telemetry updates: blocking ([`Updates::recv`]) or async
/// ([`Updates::recv_async`]), from the same queue.
#[derive(Debug)]
pub struct Updates {
    rx: flume::Receiver<Update>,
    dropped: Arc<AtomicU64>,
}

impl Updates {
    /// Waits up to `timeout` for the next update; `None` when none came in time, or the
    /// connection closed.
    pub fn recv(&self, timeout: Duration) -> Option<Update> {
        self.rx.recv_timeout(timeout).ok()
    }

    /// Waits for the next update; `None` once the connection closed.
    pub async fn recv_async(&self) -> Option<Update> {
        self.rx.recv_async().await.ok()
    }

    /// An update that is already there.
    pub fn try_recv(&self) -> Option<Update> {
        self.rx.try_recv().ok()
    }

    /// How many updates this subscription lost because its queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}
