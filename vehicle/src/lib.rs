//! The layer MAVLink applications are written on: a [`Node`] (our identity and heartbeat on
//! one shared connection), the [`System`]s it discovers, and per system its typed
//! [telemetry](telemetry), [actions](action) and flight modes by name, commands, and the
//! microservices (parameters, missions, files). Blocking and async: [`System`] and
//! [`AsyncSystem`] are two faces of one implementation, and everything runs beside
//! everything else on the one connection.
//!
//! ```no_run
//! use std::time::Duration;
//! use ferrolink_vehicle::Node;
//!
//! let node = Node::connect("udpin://0.0.0.0:14550")?;
//! let vehicle = node.wait_for_system(Duration::from_secs(10))?.expect("no vehicle");
//! let position = vehicle.telemetry().wait_position(Duration::from_secs(5));
//! println!("{position:?}");
//! vehicle.arm()?;
//! vehicle.takeoff(10.0)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The same, async, on tokio:
//!
//! ```no_run
//! # async fn fly() -> Result<(), Box<dyn std::error::Error>> {
//! use std::time::Duration;
//! use ferrolink_vehicle::Node;
//!
//! let node = Node::connect("udpin://0.0.0.0:14550")?;
//! let vehicle = node.wait_for_system_async(Duration::from_secs(10)).await?.expect("no vehicle");
//! println!("{:?}", vehicle.telemetry().wait_position_async(Duration::from_secs(5)).await);
//! vehicle.arm().await?;
//! vehicle.takeoff(10.0).await?;
//! # Ok(()) }
//! ```
//!
//! The standard dialects come with it, a cargo feature each (`ardupilotmega` by default), as
//! [`dialects`].

pub mod action;
pub mod telemetry;

pub use ferrolink_io::mavlink::modes;

use std::io;
use std::sync::Arc;
use std::time::{Duration, Instant};

pub use ferrolink_dialects as dialects;
use ferrolink_dialects::common::{MavAutopilot, MavType, Message as Common};
use ferrolink_io::mavlink::services::{self, AsyncRemote, Exchange, Peer, Remote};
use ferrolink_io::mavlink::wait::{block_on, Blocking, Tokio, Wait};
use ferrolink_io::mavlink::{Filter, OwnHeartbeat, SharedConnection, Tap};
use ferrolink_runtime::mavlink::service::command::{self, Command};
use ferrolink_runtime::mavlink::service::messages as services_enum;
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_runtime::mavlink::{Dialect, MessageMeta};

pub use action::{Action, ActionError, ActionResult, Outcome};
use telemetry::{Identity, Systems, Telemetry};

/// How long a system may go without a HEARTBEAT before it is taken for gone.
pub const SYSTEM_TIMEOUT: Duration = Duration::from_secs(5);

struct NodeInner {
    link: SharedConnection,
    systems: Systems,
    _tap: Tap,
    start: Instant,
}

/// Our node on a MAVLink network: the connection, our heartbeat, and the systems heard.
/// Cloning it shares it.
#[derive(Clone)]
pub struct Node {
    inner: Arc<NodeInner>,
}

impl std::fmt::Debug for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Node")
            .field("link", &self.inner.link)
            .finish_non_exhaustive()
    }
}

impl Node {
    /// Connects to `uri` (`udpin://0.0.0.0:14550`, pymavlink's spellings too) as a ground
    /// station, 255/190, its heartbeat going out once a second. Frames are checked against
    /// `common`'s messages and those of the enabled dialects.
    pub fn connect(uri: &str) -> io::Result<Node> {
        let link = SharedConnection::open(uri, table())?;
        link.start_heartbeat(OwnHeartbeat::default());
        Ok(Node::on(link))
    }

    /// A node on a connection of the program's own (its ids and heartbeat as they are set),
    /// beside its other users.
    pub fn on(link: SharedConnection) -> Node {
        let systems = Systems::default();
        let seen = systems.clone();
        let tap = link.tap(Filter::all().ids(telemetry::IDS), move |frame| {
            let sysid = frame.header().sysid;
            let mut systems = seen
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            systems.entry(sysid).or_default().take(frame);
        });
        Node {
            inner: Arc::new(NodeInner {
                link,
                systems,
                _tap: tap,
                start: Instant::now(),
            }),
        }
    }

    /// The connection, for senders and subscribers of the program's own.
    pub fn connection(&self) -> &SharedConnection {
        &self.inner.link
    }

    /// The vehicles heard in the last [`SYSTEM_TIMEOUT`] (systems whose HEARTBEAT names an
    /// autopilot), by system id.
    pub fn systems(&self) -> Vec<System> {
        let systems = self
            .inner
            .systems
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let mut ids: Vec<u8> = systems
            .iter()
            .filter(|(_, l)| l.heard.is_some_and(|t| t.elapsed() < SYSTEM_TIMEOUT))
            .map(|(&id, _)| id)
            .collect();
        ids.sort_unstable();
        ids.into_iter().map(|id| self.handle(id)).collect()
    }

    /// System `id`, if it was heard.
    pub fn system(&self, id: u8) -> Option<System> {
        self.systems().into_iter().find(|s| s.id == id)
    }

    fn handle(&self, id: u8) -> System {
        System {
            node: self.clone(),
            id,
            component: 1,
        }
    }

    /// The first vehicle heard, waiting up to `timeout` for one (`None` then).
    pub fn wait_for_system(&self, timeout: Duration) -> io::Result<Option<System>> {
        block_on(self.discover(&Blocking, timeout))
    }

    /// [`Node::wait_for_system`], async.
    pub async fn wait_for_system_async(
        &self,
        timeout: Duration,
    ) -> io::Result<Option<AsyncSystem>> {
        Ok(self.discover(&Tokio, timeout).await?.map(AsyncSystem))
    }

    async fn discover(&self, wait: &impl Wait, timeout: Duration) -> io::Result<Option<System>> {
        let heartbeats = self.inner.link.subscribe(Filter::all().ids(&[0]));
        let until = Instant::now() + timeout;
        loop {
            if let Some(first) = self.systems().into_iter().next() {
                return Ok(Some(first));
            }
            if wait.next(&heartbeats, until).await?.is_none() {
                return Ok(self.systems().into_iter().next());
            }
        }
    }
}

/// `common`'s messages and those of every enabled dialect.
fn table() -> Arc<[MessageMeta]> {
    #[allow(unused_mut)]
    let mut table: Vec<MessageMeta> = Common::META.to_vec();
    #[cfg(feature = "all")]
    table.extend_from_slice(<dialects::all::Message as Dialect>::META);
    #[cfg(feature = "ardupilotmega")]
    table.extend_from_slice(<dialects::ardupilotmega::Message as Dialect>::META);
    table.sort_by_key(|m| m.id);
    table.dedup_by_key(|m| m.id);
    table.into()
}

/// A system the node heard: its telemetry, actions, commands and services, blocking. Cloning
/// it is cheap; [`System::asynchronous`] is the async face of the same system.
#[derive(Clone)]
pub struct System {
    node: Node,
    id: u8,
    component: u8,
}

impl std::fmt::Debug for System {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("System").field("id", &self.id).finish()
    }
}

impl System {
    /// Its system id.
    pub fn id(&self) -> u8 {
        self.id
    }

    /// The same system, its commands going to component `component` (1, the autopilot, by
    /// default).
    pub fn with_component(mut self, component: u8) -> System {
        self.component = component;
        self
    }

    /// Its autopilot, from its last HEARTBEAT.
    pub fn autopilot(&self) -> MavAutopilot {
        self.identity()
            .map_or(MavAutopilot::Generic, |i| i.autopilot)
    }

    /// Its type, from its last HEARTBEAT.
    pub fn kind(&self) -> MavType {
        self.identity().map_or(MavType::Generic, |i| i.kind)
    }

    /// The component ids heard from it.
    pub fn components(&self) -> Vec<u8> {
        self.with(|l| l.components.clone()).unwrap_or_default()
    }

    /// Its flight modes' names.
    pub fn mode_names(&self) -> Vec<&'static str> {
        modes::names(self.autopilot(), self.kind())
    }

    /// Its telemetry.
    pub fn telemetry(&self) -> Telemetry {
        Telemetry {
            systems: self.node.inner.systems.clone(),
            system: self.id,
        }
    }

    /// The async face of this system.
    pub fn asynchronous(&self) -> AsyncSystem {
        AsyncSystem(self.clone())
    }

    /// The microservices' client for it (parameters, missions, files, commands), blocking, on
    /// the node's connection beside everything else.
    pub fn remote(&self) -> Remote<'_> {
        Remote::on(&self.node.inner.link, self.peer())
    }

    /// It as the microservices' clients name a target.
    fn peer(&self) -> Peer {
        let identity = self.identity();
        Peer {
            address: Address::new(self.id, self.component),
            autopilot: services_enum::MavAutopilot::from_raw(
                identity.map_or(0, |i| i.autopilot.raw()),
            ),
            kind: services_enum::MavType::from_raw(identity.map_or(0, |i| i.kind.raw())),
            since_us: 0,
            last_us: 0,
        }
    }

    fn with<T>(&self, f: impl FnOnce(&telemetry::Latest) -> T) -> Option<T> {
        let systems = self
            .node
            .inner
            .systems
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        systems.get(&self.id).map(f)
    }

    fn identity(&self) -> Option<Identity> {
        self.with(|l| l.identity).flatten()
    }

    /// Does `action`; `progress` sees each `IN_PROGRESS` percentage.
    pub fn act(&self, action: &Action, progress: impl FnMut(u8)) -> Result<Outcome, ActionError> {
        block_on(self.run_action(&Blocking, action, progress))
    }

    /// Sends `command` to it (component 1 unless [`System::with_component`] says otherwise)
    /// through the command service and waits for the answer.
    pub fn command(&self, command: Command, progress: impl FnMut(u8)) -> io::Result<Outcome> {
        block_on(self.run_commands(&Blocking, vec![command], progress))
    }

    /// Arms.
    pub fn arm(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::Arm, |_| {})
    }
    /// Disarms (`force`: in flight too).
    pub fn disarm(&self, force: bool) -> Result<Outcome, ActionError> {
        let action = if force {
            Action::ForceDisarm
        } else {
            Action::Disarm
        };
        self.act(&action, |_| {})
    }
    /// Takes off to `alt` metres above home.
    pub fn takeoff(&self, alt: f32) -> Result<Outcome, ActionError> {
        self.act(&Action::Takeoff { alt }, |_| {})
    }
    /// Lands.
    pub fn land(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::Land, |_| {})
    }
    /// Returns to launch.
    pub fn return_to_launch(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::ReturnToLaunch, |_| {})
    }
    /// Holds position.
    pub fn hold(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::Hold, |_| {})
    }
    /// Flies to a position (altitude above mean sea level).
    pub fn goto(&self, lat: f64, lon: f64, alt_amsl: f32) -> Result<Outcome, ActionError> {
        self.act(&Action::Goto { lat, lon, alt_amsl }, |_| {})
    }
    /// Switches to flight mode `name` (any case).
    pub fn set_mode(&self, name: &str) -> Result<Outcome, ActionError> {
        self.act(&Action::SetMode(name.to_owned()), |_| {})
    }
    /// Reboots the autopilot.
    pub fn reboot(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::Reboot, |_| {})
    }
    /// Asks for message `id` at `hz` a second (MAV_CMD_SET_MESSAGE_INTERVAL; 0 stops it).
    pub fn set_rate(&self, id: u32, hz: f32) -> io::Result<Outcome> {
        self.command(rate(id, hz), |_| {})
    }
    /// Asks for message `id` once (MAV_CMD_REQUEST_MESSAGE).
    pub fn request_message(&self, id: u32) -> io::Result<Outcome> {
        self.command(request(id), |_| {})
    }

    async fn run_action(
        &self,
        wait: &impl Wait,
        action: &Action,
        progress: impl FnMut(u8),
    ) -> Result<Outcome, ActionError> {
        let identity = self.identity().ok_or_else(|| {
            ActionError::Io(io::Error::new(
                io::ErrorKind::NotConnected,
                format!("system {} sent no HEARTBEAT yet", self.id),
            ))
        })?;
        let home = match action {
            Action::Takeoff { .. } => self.home_amsl(wait).await?,
            _ => None,
        };
        let steps = action::plan(action, &identity, home)?;
        if steps.is_empty() {
            // Already there (in the mode asked for).
            return Ok(Outcome {
                result: ActionResult::Accepted,
                command: 0,
                progress: Vec::new(),
            });
        }
        Ok(self.run_commands(wait, steps, progress).await?)
    }

    /// Home's altitude above sea level: from HOME_POSITION, or from a position (its altitude
    /// less its height above home), waiting up to a second for either.
    async fn home_amsl(&self, wait: &impl Wait) -> io::Result<Option<f32>> {
        let known = || {
            let t = self.telemetry();
            t.home()
                .map(|h| h.alt_amsl)
                .or_else(|| t.position().map(|p| p.alt_amsl - p.alt_rel))
        };
        let frames = self
            .node
            .inner
            .link
            .subscribe(Filter::all().ids(&[33, 242]).system(self.id));
        let until = Instant::now() + Duration::from_secs(1);
        while known().is_none() {
            if wait.next(&frames, until).await?.is_none() {
                break;
            }
        }
        Ok(known())
    }

    /// Sends `steps` one after the other, each once the one before was accepted.
    async fn run_commands(
        &self,
        wait: &impl Wait,
        steps: Vec<Command>,
        mut progress: impl FnMut(u8),
    ) -> io::Result<Outcome> {
        let link = &self.node.inner.link;
        let replies = link.subscribe(Filter::all().ids(&[77]).system(self.id));
        let exchange = Exchange {
            link,
            replies: &replies,
            start: self.node.inner.start,
        };
        let (sysid, compid) = link.ids();
        let config = command::ClientConfig::new(Address::new(sysid, compid));
        let target = Address::new(self.id, self.component);
        let mut outcome = Outcome {
            result: ActionResult::NoAnswer,
            command: 0,
            progress: Vec::new(),
        };
        for step in steps {
            outcome.command = step.command.raw();
            let ack = services::run_command(&exchange, wait, config, target, step, |p| {
                outcome.progress.push(p);
                progress(p);
            })
            .await?;
            outcome.result = ActionResult::of(ack);
            if outcome.result != ActionResult::Accepted {
                break;
            }
        }
        Ok(outcome)
    }
}

fn rate(id: u32, hz: f32) -> Command {
    let interval = if hz > 0.0 { 1e6 / hz } else { -1.0 };
    Command::long(
        ferrolink_runtime::mavlink::service::messages::MavCmd::from_raw(511),
        [id as f32, interval, 0.0, 0.0, 0.0, 0.0, 0.0],
    )
}

fn request(id: u32) -> Command {
    Command::long(
        ferrolink_runtime::mavlink::service::messages::MavCmd::from_raw(512),
        [id as f32, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )
}

/// The async face of a [`System`]: the same system, its actions and commands as `async fn`s
/// that wait on tokio's timer (run them inside a tokio runtime with time enabled); no thread
/// runs for them.
#[derive(Clone, Debug)]
pub struct AsyncSystem(System);

impl AsyncSystem {
    /// The blocking face.
    pub fn blocking(&self) -> &System {
        &self.0
    }
    /// Its system id.
    pub fn id(&self) -> u8 {
        self.0.id
    }
    /// Its telemetry (the latest values, and subscriptions with `recv_async`).
    pub fn telemetry(&self) -> Telemetry {
        self.0.telemetry()
    }
    /// The microservices' client for it (parameters, missions, files, commands), async, with
    /// progress, on the node's connection beside everything else.
    pub fn remote(&self) -> AsyncRemote {
        AsyncRemote::on(self.0.node.inner.link.clone(), self.0.peer())
    }
    /// Does `action`; `progress` sees each `IN_PROGRESS` percentage.
    pub async fn act(
        &self,
        action: &Action,
        progress: impl FnMut(u8),
    ) -> Result<Outcome, ActionError> {
        self.0.run_action(&Tokio, action, progress).await
    }
    /// [`System::command`].
    pub async fn command(&self, command: Command, progress: impl FnMut(u8)) -> io::Result<Outcome> {
        self.0.run_commands(&Tokio, vec![command], progress).await
    }
    /// Arms.
    pub async fn arm(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::Arm, |_| {}).await
    }
    /// Disarms (`force`: in flight too).
    pub async fn disarm(&self, force: bool) -> Result<Outcome, ActionError> {
        let action = if force {
            Action::ForceDisarm
        } else {
            Action::Disarm
        };
        self.act(&action, |_| {}).await
    }
    /// Takes off to `alt` metres above home.
    pub async fn takeoff(&self, alt: f32) -> Result<Outcome, ActionError> {
        self.act(&Action::Takeoff { alt }, |_| {}).await
    }
    /// Lands.
    pub async fn land(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::Land, |_| {}).await
    }
    /// Returns to launch.
    pub async fn return_to_launch(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::ReturnToLaunch, |_| {}).await
    }
    /// Holds position.
    pub async fn hold(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::Hold, |_| {}).await
    }
    /// Flies to a position (altitude above mean sea level).
    pub async fn goto(&self, lat: f64, lon: f64, alt_amsl: f32) -> Result<Outcome, ActionError> {
        self.act(&Action::Goto { lat, lon, alt_amsl }, |_| {}).await
    }
    /// Switches to flight mode `name` (any case).
    pub async fn set_mode(&self, name: &str) -> Result<Outcome, ActionError> {
        self.act(&Action::SetMode(name.to_owned()), |_| {}).await
    }
    /// Reboots the autopilot.
    pub async fn reboot(&self) -> Result<Outcome, ActionError> {
        self.act(&Action::Reboot, |_| {}).await
    }
    /// [`System::set_rate`].
    pub async fn set_rate(&self, id: u32, hz: f32) -> io::Result<Outcome> {
        self.command(rate(id, hz), |_| {}).await
    }
    /// [`System::request_message`].
    pub async fn request_message(&self, id: u32) -> io::Result<Outcome> {
        self.command(request(id), |_| {}).await
    }
}
