//! The microservices on a [`Connection`]: a blocking client for commands, parameters,
//! missions and (in [`super::ftp`]) files ([`Remote`]), on the runtime's state machines
//! ([`ferrolink_runtime::mavlink::service`]).
//!
//! ```no_run
//! use std::time::Duration;
//! use ferrolink_io::mavlink::services::{self, Remote};
//! use ferrolink_io::mavlink::Connection;
//!
//! let mut link = Connection::open("udpin://0.0.0.0:14550", services::TABLE)?;
//! let vehicle = services::wait_for_vehicle(&mut link, Duration::from_secs(5))?
//!     .expect("no vehicle");
//! let mut remote = Remote::new(&mut link, vehicle);
//! let list = remote.fetch_params(Duration::from_secs(30), |_| {})?;
//! println!("{} of {} parameters", list.values.len(), list.count);
//! # Ok::<(), std::io::Error>(())
//! ```

use std::io;
use std::time::{Duration, Instant};

use ferrolink_runtime::mavlink::service::command::{self, Ack, Command};
use ferrolink_runtime::mavlink::service::ftp;
use ferrolink_runtime::mavlink::service::messages::{
    Heartbeat, MavAutopilot, MavModeFlag, MavState, MavType, Message,
};
use ferrolink_runtime::mavlink::service::messages::{MavMissionResult, MavMissionType};
use ferrolink_runtime::mavlink::service::mission::{self, Item};
use ferrolink_runtime::mavlink::service::param::{self, Encoding, Name, Received, Value};
pub use ferrolink_runtime::mavlink::service::peers::Peer;
use ferrolink_runtime::mavlink::service::peers::Peers;
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_runtime::mavlink::{Dialect, MessageMeta};

use super::wait::{block_on, Blocking, Wait};

#[cfg(feature = "tokio")]
mod asynchronous;
use super::{Connection, Filter, OwnHeartbeat, SharedConnection, Subscription};
#[cfg(feature = "tokio")]
pub use asynchronous::AsyncRemote;

/// The messages the services use: a table to open a [`Connection`] with when nothing else is
/// needed.
pub const TABLE: &[MessageMeta] = Message::META;

/// Waits up to `timeout` for the first vehicle (a HEARTBEAT whose autopilot is not
/// `MAV_AUTOPILOT_INVALID`, not a ground station or a camera), answering with our own
/// heartbeats meanwhile. The target is that system's component 1, as ground stations take it.
pub fn wait_for_vehicle(link: &mut Connection, timeout: Duration) -> io::Result<Option<Peer>> {
    let shared = link.shared().clone();
    wait_for(
        &shared,
        |t| link.recv(t),
        timeout,
        |peers| peers.first_vehicle(),
    )
}

/// [`wait_for_vehicle`] on a shared connection, through a subscription of its own to the
/// frames that come from now on.
pub fn wait_for_vehicle_on(link: &SharedConnection, timeout: Duration) -> io::Result<Option<Peer>> {
    let heartbeats = link.subscribe(Filter::all().ids(&[Heartbeat::ID]));
    wait_for(
        link,
        |t| heartbeats.recv(t),
        timeout,
        |peers| peers.first_vehicle(),
    )
}

/// Waits up to `timeout` for a HEARTBEAT from `system` (any component), answering with our
/// own heartbeats meanwhile.
pub fn wait_for_system(
    link: &mut Connection,
    system: u8,
    timeout: Duration,
) -> io::Result<Option<Peer>> {
    let shared = link.shared().clone();
    wait_for(
        &shared,
        |t| link.recv(t),
        timeout,
        |peers| peers.iter().find(|p| p.address.system == system).copied(),
    )
}

/// Reads frames with `recv` until `pick` finds a peer among those heard, answering with our
/// heartbeat on `link` meanwhile.
fn wait_for(
    link: &SharedConnection,
    mut recv: impl FnMut(Duration) -> io::Result<Option<super::Frame>>,
    timeout: Duration,
    pick: impl Fn(&Peers<16>) -> Option<Peer>,
) -> io::Result<Option<Peer>> {
    let start = Instant::now();
    let deadline = start + timeout;
    let mut beat = start;
    let mut peers: Peers<16> = Peers::new();
    loop {
        let now = Instant::now();
        if now >= beat {
            send_heartbeat(link);
            beat = now + Duration::from_secs(1);
        }
        if now >= deadline {
            return Ok(None);
        }
        let left = deadline.saturating_duration_since(now).min(beat - now);
        let Some(frame) = recv(left)? else {
            continue;
        };
        if let Ok(msg) = frame.decode::<Message>() {
            let h = frame.header();
            let now_us = start.elapsed().as_micros() as u64;
            peers.handle(now_us, Address::new(h.sysid, h.compid), &msg);
            if let Some(peer) = pick(&peers) {
                return Ok(Some(peer));
            }
        }
    }
}

/// Our HEARTBEAT as a ground station. A peer that is not there yet is no error.
fn send_heartbeat(link: &SharedConnection) {
    let hb = Message::Heartbeat(Heartbeat {
        r#type: MavType::Gcs,
        autopilot: MavAutopilot::Invalid,
        base_mode: MavModeFlag::default(),
        custom_mode: 0,
        system_status: MavState::Active,
        mavlink_version: 3,
    });
    let _ = link.send_dialect(&hb);
}

/// The parameters a fetch got.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamList {
    /// The target's count.
    pub count: u16,
    /// The values by index; `None` where one never came.
    pub values: Vec<Option<Received>>,
    /// The target's `_HASH_CHECK` (PX4's; [`param::hash`]), if it sent one: the key for
    /// [`Remote::refresh_params`].
    pub hash: Option<u32>,
}

impl ParamList {
    /// Takes a value of a list into its place; `false` for one outside the count (PX4's
    /// `_HASH_CHECK`). A new count starts the table again.
    fn take(&mut self, r: &Received) -> bool {
        if r.index >= r.count {
            return false;
        }
        if r.count != self.count || self.values.is_empty() {
            self.count = r.count;
            self.values = vec![None; usize::from(r.count)];
        }
        self.values[usize::from(r.index)] = Some(*r);
        true
    }

    /// How many values never came.
    pub fn missing(&self) -> usize {
        self.values.iter().filter(|v| v.is_none()).count()
    }

    /// The parameter called `name` (exactly as the target spells it), as pymavlink's
    /// `master.params[name]` finds it.
    ///
    /// ```
    /// use ferrolink_io::mavlink::services::ParamList;
    /// use ferrolink_runtime::mavlink::service::param::{Received, Value};
    ///
    /// let rate = Received {
    ///     name: "SR0_POSITION".into(),
    ///     index: 0,
    ///     count: 1,
    ///     value: Some(Value::F32(4.0)),
    ///     custom: None,
    /// };
    /// let list = ParamList { count: 1, values: vec![Some(rate)], hash: None };
    /// assert_eq!(list.get("SR0_POSITION").and_then(|p| p.value), Some(Value::F32(4.0)));
    /// assert!(list.get("SR0_ATTITUDE").is_none());
    /// ```
    pub fn get(&self, name: &str) -> Option<&Received> {
        self.iter().find(|r| r.name.as_str() == name)
    }

    /// Every value that came, in index order.
    pub fn iter(&self) -> impl Iterator<Item = &Received> {
        self.values.iter().flatten()
    }
}

/// A target system seen through a connection: commands, parameters, missions and files,
/// blocking.
///
/// It reads through a subscription of its own to the services' messages from the target's
/// system, so on a [`SharedConnection`] everything else keeps flowing to the other
/// subscribers while an operation runs: a parameter fetch costs no telemetry frame.
#[derive(Debug)]
pub struct Remote<'c> {
    link: &'c SharedConnection,
    replies: Subscription,
    target: Peer,
    start: Instant,
    /// Overrides the target's parameter encoding (which otherwise follows its autopilot).
    pub encoding: Option<Encoding>,
    /// The command client's settings.
    pub command_config: command::ClientConfig,
    /// The parameter client's settings.
    pub param_config: param::ClientConfig,
    /// The mission client's settings.
    pub mission_config: mission::ClientConfig,
    /// How many times a mission transfer is tried from the start when the target stops
    /// answering midway (3): a server that gives up after a few lost frames (MAVSDK's does)
    /// starts afresh.
    pub mission_attempts: u8,
    /// The FTP client's settings.
    pub ftp_config: ftp::ClientConfig,
    /// The next FTP request's sequence number: from the clock at first, so that two runs of a
    /// program do not start alike.
    pub(super) ftp_seq: u16,
}

impl<'c> Remote<'c> {
    /// `target` through `link`, which sends as 255/190 unless set otherwise.
    pub fn new(link: &'c mut Connection, target: Peer) -> Self {
        Self::on(link.shared(), target)
    }

    /// `target` through a shared connection, beside its other subscribers and senders.
    pub fn on(link: &'c SharedConnection, target: Peer) -> Self {
        let (sysid, compid) = link.ids();
        let own = Address::new(sysid, compid);
        let ids: Vec<u32> = TABLE.iter().map(|m| m.id).collect();
        let replies = link.subscribe(Filter::all().ids(&ids).system(target.address.system));
        // A ground station's heartbeat, once a second, unless the program sends its own.
        if !link.is_beating() {
            link.start_heartbeat(OwnHeartbeat::default());
        }
        Self {
            link,
            replies,
            target,
            start: Instant::now(),
            encoding: None,
            command_config: command::ClientConfig::new(own),
            param_config: param::ClientConfig::new(own),
            mission_config: mission::ClientConfig::new(own),
            mission_attempts: 3,
            ftp_config: ftp::ClientConfig::new(own),
            ftp_seq: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.subsec_micros() as u16),
        }
    }

    /// The target.
    pub fn target(&self) -> Peer {
        self.target
    }

    pub(super) fn now_us(&self) -> u64 {
        self.start.elapsed().as_micros() as u64
    }

    /// The next service message from the target's system, or `None` at `until_us`.
    pub(super) async fn next(
        &mut self,
        wait: &impl Wait,
        until_us: u64,
    ) -> io::Result<Option<(Address, Message)>> {
        let exchange = Exchange {
            link: self.link,
            replies: &self.replies,
            start: self.start,
        };
        exchange.next(wait, until_us).await
    }

    pub(super) fn send(&mut self, msg: &Message) -> io::Result<()> {
        self.link.send_dialect(msg)
    }

    /// How many replies this client lost to a full queue (it reads them as fast as they come,
    /// so none, unless the program stalls it).
    pub fn dropped(&self) -> u64 {
        self.replies.dropped()
    }

    /// Sends `command` and waits for its final answer; `progress` sees each `IN_PROGRESS`.
    /// `None` when nothing answered after the retries.
    pub fn command(
        &mut self,
        command: Command,
        progress: impl FnMut(u8),
    ) -> io::Result<Option<Ack>> {
        block_on(self.command_with(&Blocking, command, progress))
    }

    /// [`Remote::command`], waiting with `wait`.
    pub async fn command_with(
        &mut self,
        wait: &impl Wait,
        command: Command,
        progress: impl FnMut(u8),
    ) -> io::Result<Option<Ack>> {
        let exchange = Exchange {
            link: self.link,
            replies: &self.replies,
            start: self.start,
        };
        let config = self.command_config;
        let target = self.target.address;
        run_command(&exchange, wait, config, target, command, progress).await
    }

    fn param_client(&self) -> param::Client<2048> {
        self.param_client_in(self.param_config.protocol)
    }

    fn param_client_in(&self, protocol: param::Protocol) -> param::Client<2048> {
        let mut config = self.param_config;
        config.protocol = protocol;
        config.encoding = self
            .encoding
            .or(Some(Encoding::for_autopilot(self.target.autopilot)));
        param::Client::new(config, self.target.address)
    }

    /// Runs a parameter operation until its event, or until `timeout` passes (`None`).
    async fn run_param(
        &mut self,
        wait: &impl Wait,
        client: &mut param::Client<2048>,
        timeout: Option<Duration>,
        mut on_value: impl FnMut(&Received),
    ) -> io::Result<Option<param::Event>> {
        let end = timeout.map(|t| self.now_us() + t.as_micros() as u64);
        loop {
            let now = self.now_us();
            while let Some(m) = client.poll_transmit(now) {
                self.send(&m)?;
            }
            if let Some(e) = client.poll_event() {
                return Ok(Some(e));
            }
            if end.is_some_and(|end| now >= end) {
                return Ok(None);
            }
            let until = client.poll_timeout().unwrap_or(now + 1_000_000).max(now);
            let until = end.map_or(until, |end| until.min(end));
            if let Some((from, msg)) = self.next(wait, until.max(now + 1)).await? {
                if let Some(r) = client.handle(self.now_us(), from, &msg) {
                    on_value(&r);
                }
            }
        }
    }

    /// Fetches every parameter, re-requesting what the stream left out, for at most `timeout`.
    /// `on_value` sees each value as it arrives (repeats too).
    pub fn fetch_params(
        &mut self,
        timeout: Duration,
        on_value: impl FnMut(&Received),
    ) -> io::Result<ParamList> {
        block_on(self.fetch_params_with(&Blocking, timeout, on_value))
    }

    /// [`Remote::fetch_params`], waiting with `wait`.
    pub async fn fetch_params_with(
        &mut self,
        wait: &impl Wait,
        timeout: Duration,
        mut on_value: impl FnMut(&Received),
    ) -> io::Result<ParamList> {
        let mut client = self.param_client();
        let _ = client.list();
        let mut list = ParamList::default();
        self.run_param(wait, &mut client, Some(timeout), |r| {
            if list.take(r) {
                on_value(r);
            }
        })
        .await?;
        list.hash = client.announced_hash();
        Ok(list)
    }

    /// Brings `cache` up to date: when the target's `_HASH_CHECK` is `cache.hash`, it stops
    /// the target's list and leaves `cache` as it is (`false`); otherwise it fetches every
    /// parameter into `cache` (`true`), as [`Remote::fetch_params`] does. A target without
    /// `_HASH_CHECK` is always fetched.
    pub fn refresh_params(&mut self, cache: &mut ParamList, timeout: Duration) -> io::Result<bool> {
        block_on(self.refresh_params_with(&Blocking, cache, timeout))
    }

    /// [`Remote::refresh_params`], waiting with `wait`.
    pub async fn refresh_params_with(
        &mut self,
        wait: &impl Wait,
        cache: &mut ParamList,
        timeout: Duration,
    ) -> io::Result<bool> {
        let Some(hash) = cache.hash.filter(|_| cache.missing() == 0) else {
            *cache = self.fetch_params_with(wait, timeout, |_| {}).await?;
            return Ok(true);
        };
        let mut client = self.param_client();
        let _ = client.list_unless(hash);
        let mut list = ParamList::default();
        let event = self
            .run_param(wait, &mut client, Some(timeout), |r| {
                list.take(r);
            })
            .await?;
        // The stop goes out before this returns.
        while let Some(m) = client.poll_transmit(self.now_us()) {
            self.send(&m)?;
        }
        if let Some(param::Event::Unchanged { .. }) = event {
            return Ok(false);
        }
        list.hash = client.announced_hash();
        *cache = list;
        Ok(true)
    }

    /// Reads the parameter called `name`; `None` if nothing answered.
    pub fn read_param(&mut self, name: &str) -> io::Result<Option<Received>> {
        block_on(self.read_param_with(&Blocking, name))
    }

    /// [`Remote::read_param`], waiting with `wait`.
    pub async fn read_param_with(
        &mut self,
        wait: &impl Wait,
        name: &str,
    ) -> io::Result<Option<Received>> {
        let mut client = self.param_client();
        let _ = client.read(Name::from(name));
        match self.run_param(wait, &mut client, None, |_| {}).await? {
            Some(param::Event::Read(r)) => Ok(r),
            _ => Ok(None),
        }
    }

    /// Sets the parameter called `name` to `value` and returns what the target reports it holds
    /// then (the set took if that is `value`); `None` if nothing answered.
    pub fn set_param(&mut self, name: &str, value: Value) -> io::Result<Option<Received>> {
        block_on(self.set_param_with(&Blocking, name, value))
    }

    /// [`Remote::set_param`], waiting with `wait`.
    pub async fn set_param_with(
        &mut self,
        wait: &impl Wait,
        name: &str,
        value: Value,
    ) -> io::Result<Option<Received>> {
        let mut client = self.param_client();
        let _ = client.set(Name::from(name), value);
        self.run_set(wait, &mut client).await
    }

    /// Sets the PARAM_EXT CUSTOM parameter called `name` to `bytes` (at most 128, NUL-padded),
    /// in PARAM_EXT_* whatever `param_config.protocol` says; what the target acknowledged is in
    /// [`Received::custom`] (`None` in it: refused). `None` if nothing answered.
    pub fn set_param_custom(&mut self, name: &str, bytes: &[u8]) -> io::Result<Option<Received>> {
        block_on(self.set_param_custom_with(&Blocking, name, bytes))
    }

    /// [`Remote::set_param_custom`], waiting with `wait`.
    pub async fn set_param_custom_with(
        &mut self,
        wait: &impl Wait,
        name: &str,
        bytes: &[u8],
    ) -> io::Result<Option<Received>> {
        let mut client = self.param_client_in(param::Protocol::Ext);
        let _ = client.set_custom(Name::from(name), param::Bytes::from_bytes(bytes));
        self.run_set(wait, &mut client).await
    }

    async fn run_set(
        &mut self,
        wait: &impl Wait,
        client: &mut param::Client<2048>,
    ) -> io::Result<Option<Received>> {
        match self.run_param(wait, client, None, |_| {}).await? {
            Some(param::Event::Set(r)) => Ok(r),
            _ => Ok(None),
        }
    }

    /// Runs a mission operation to its end; `progress` sees (items done, items in all).
    async fn run_mission(
        &mut self,
        wait: &impl Wait,
        client: &mut mission::Client,
        items: &mut Items,
        mut progress: impl FnMut(u16, u16),
    ) -> io::Result<mission::Event> {
        let mut done = 0;
        loop {
            let now = self.now_us();
            while let Some(m) = client.poll_transmit(items, now) {
                if let Message::MissionItemInt(i) = &m {
                    if i.seq >= done {
                        done = i.seq + 1;
                        progress(done, items.0.len() as u16);
                    }
                }
                self.send(&m)?;
            }
            if let Some(e) = client.poll_event() {
                // The download's final ACK goes out before this returns.
                while let Some(m) = client.poll_transmit(items, now) {
                    self.send(&m)?;
                }
                return Ok(e);
            }
            let until = client
                .poll_timeout()
                .unwrap_or(now + 1_000_000)
                .max(now + 1);
            if let Some((from, msg)) = self.next(wait, until).await? {
                client.handle(items, self.now_us(), from, &msg);
                if let Message::MissionItemInt(i) = &msg {
                    progress(i.seq + 1, items.0.len() as u16);
                }
            }
        }
    }

    /// Uploads `items` as the target's `kind` (mission, fence or rally points); the target's
    /// answer, `None` when it stopped answering (or stopped moving on) every attempt. `progress` sees (items sent,
    /// items in all).
    pub fn upload_mission(
        &mut self,
        kind: MavMissionType,
        items: &[Item],
        progress: impl FnMut(u16, u16),
    ) -> io::Result<Option<MavMissionResult>> {
        block_on(self.upload_mission_with(&Blocking, kind, items, progress))
    }

    /// [`Remote::upload_mission`], waiting with `wait`.
    pub async fn upload_mission_with(
        &mut self,
        wait: &impl Wait,
        kind: MavMissionType,
        items: &[Item],
        mut progress: impl FnMut(u16, u16),
    ) -> io::Result<Option<MavMissionResult>> {
        let count = u16::try_from(items.len()).map_err(|_| {
            io::Error::other(format!(
                "{} items: a mission holds at most 65535",
                items.len()
            ))
        })?;
        let mut items = Items(items.to_vec());
        let mut result = None;
        for _ in 0..self.mission_attempts.max(1) {
            let mut client = mission::Client::new(self.mission_config, self.target.address);
            let _ = client.upload(kind, count);
            result = match self
                .run_mission(wait, &mut client, &mut items, &mut progress)
                .await?
            {
                mission::Event::Uploaded(result) => result,
                _ => None,
            };
            if !matches!(
                result,
                None | Some(MavMissionResult::MavMissionOperationCancelled)
            ) {
                break;
            }
        }
        Ok(result)
    }

    /// Clears every item of `kind` on the target (`All`: every kind); the target's answer,
    /// `None` when it did not answer.
    pub fn clear_mission(&mut self, kind: MavMissionType) -> io::Result<Option<MavMissionResult>> {
        block_on(self.clear_mission_with(&Blocking, kind))
    }

    /// [`Remote::clear_mission`], waiting with `wait`.
    pub async fn clear_mission_with(
        &mut self,
        wait: &impl Wait,
        kind: MavMissionType,
    ) -> io::Result<Option<MavMissionResult>> {
        let mut client = mission::Client::new(self.mission_config, self.target.address);
        let _ = client.clear(kind);
        match self
            .run_mission(wait, &mut client, &mut Items::default(), |_, _| {})
            .await?
        {
            mission::Event::Cleared(result) => Ok(result),
            _ => Ok(None),
        }
    }

    /// Makes `seq` the target's current mission item; the current item it then reports,
    /// `None` when it did not answer.
    pub fn set_current_mission_item(&mut self, seq: u16) -> io::Result<Option<u16>> {
        block_on(self.set_current_mission_item_with(&Blocking, seq))
    }

    /// [`Remote::set_current_mission_item`], waiting with `wait`.
    pub async fn set_current_mission_item_with(
        &mut self,
        wait: &impl Wait,
        seq: u16,
    ) -> io::Result<Option<u16>> {
        let mut client = mission::Client::new(self.mission_config, self.target.address);
        let _ = client.set_current(seq);
        match self
            .run_mission(wait, &mut client, &mut Items::default(), |_, _| {})
            .await?
        {
            mission::Event::CurrentSet(current) => Ok(current),
            _ => Ok(None),
        }
    }

    /// Downloads the target's `kind`; `None` when it stopped answering every attempt.
    /// `progress` sees (items received, items in all).
    pub fn download_mission(
        &mut self,
        kind: MavMissionType,
        progress: impl FnMut(u16, u16),
    ) -> io::Result<Option<Vec<Item>>> {
        block_on(self.download_mission_with(&Blocking, kind, progress))
    }

    /// [`Remote::download_mission`], waiting with `wait`.
    pub async fn download_mission_with(
        &mut self,
        wait: &impl Wait,
        kind: MavMissionType,
        mut progress: impl FnMut(u16, u16),
    ) -> io::Result<Option<Vec<Item>>> {
        for _ in 0..self.mission_attempts.max(1) {
            let mut client = mission::Client::new(self.mission_config, self.target.address);
            let _ = client.download(kind);
            let mut items = Items(Vec::new());
            if let mission::Event::Downloaded(Some(_)) = self
                .run_mission(wait, &mut client, &mut items, &mut progress)
                .await?
            {
                return Ok(Some(items.0));
            }
        }
        Ok(None)
    }
}

/// What a drive loop talks through: the connection it sends on, the subscription it reads the
/// replies from, and the instant its clock counts from.
#[derive(Debug, Clone, Copy)]
pub struct Exchange<'a> {
    /// Where requests go.
    pub link: &'a SharedConnection,
    /// Where replies come from: the services' messages of the target's system, at least.
    pub replies: &'a Subscription,
    /// Time zero of the state machines' clock.
    pub start: Instant,
}

impl Exchange<'_> {
    fn now_us(&self) -> u64 {
        self.start.elapsed().as_micros() as u64
    }

    /// The next service message of the replies, or `None` at `until_us`.
    async fn next(
        &self,
        wait: &impl Wait,
        until_us: u64,
    ) -> io::Result<Option<(Address, Message)>> {
        let until = self.start + Duration::from_micros(until_us);
        loop {
            let Some(frame) = wait.next(self.replies, until).await? else {
                return Ok(None);
            };
            if let Ok(msg) = frame.decode::<Message>() {
                let h = frame.header();
                return Ok(Some((Address::new(h.sysid, h.compid), msg)));
            }
        }
    }
}

/// The command service's drive loop, for both faces ([`super::wait`]): sends `command` to
/// `target` with the client's retries and waits for its final answer; `progress` sees each
/// `IN_PROGRESS`. `None` when nothing answered after the retries.
pub async fn run_command(
    exchange: &Exchange<'_>,
    wait: &impl Wait,
    config: command::ClientConfig,
    target: Address,
    command: Command,
    mut progress: impl FnMut(u8),
) -> io::Result<Option<Ack>> {
    let mut client: command::Client<1> = command::Client::new(config);
    client
        .send(exchange.now_us(), target, command)
        .map_err(|e| io::Error::other(e.to_string()))?;
    loop {
        let now = exchange.now_us();
        while let Some(m) = client.poll_transmit(now) {
            exchange.link.send_dialect(&m)?;
        }
        while let Some(e) = client.poll_event() {
            match e {
                command::Event::Progress { progress: p, .. } => progress(p),
                command::Event::Done { ack, .. } => return Ok(ack),
            }
        }
        let until = client.poll_timeout().unwrap_or(now + 1_000_000);
        if let Some((from, msg)) = exchange.next(wait, until).await? {
            client.handle(exchange.now_us(), from, &msg);
        }
    }
}

/// Mission items in a `Vec`, as the mission client reads and fills them.
#[derive(Debug, Default)]
pub struct Items(pub Vec<Item>);

impl mission::Items for Items {
    fn len(&self) -> u16 {
        u16::try_from(self.0.len()).unwrap_or(u16::MAX)
    }
    fn get(&self, seq: u16) -> Option<Item> {
        self.0.get(usize::from(seq)).copied()
    }
    fn reset(&mut self, count: u16) -> bool {
        self.0 = vec![Item::default(); usize::from(count)];
        true
    }
    fn put(&mut self, seq: u16, item: Item) {
        if let Some(slot) = self.0.get_mut(usize::from(seq)) {
            *slot = item;
        }
    }
}
