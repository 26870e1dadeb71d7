//! The microservices' client from async code: [`AsyncRemote`], on the same drive loops as
//! [`Remote`]'s.

use std::io;
use std::time::Duration;

use ferrolink_runtime::mavlink::service::command::{Ack, Command};
use ferrolink_runtime::mavlink::service::messages::{MavMissionResult, MavMissionType};
use ferrolink_runtime::mavlink::service::mission::Item;
use ferrolink_runtime::mavlink::service::param::{Received, Value};

use super::{ParamList, Peer, Remote};
use crate::mavlink::ftp::ListEntry;
use crate::mavlink::wait::Tokio;
use crate::mavlink::{Connection, SharedConnection};

/// The client from async code (feature `tokio`): the same drive loops as [`Remote`]'s, waiting
/// on tokio's timer (run them inside a tokio runtime with time enabled), so no thread runs for
/// any operation. It shares the connection: everything else on it keeps flowing. Operations on
/// one `AsyncRemote` take turns, as the protocols want one transfer of a kind at a time.
///
/// ```no_run
/// # async fn example() -> std::io::Result<()> {
/// use std::time::Duration;
/// use ferrolink_io::mavlink::services::{self, AsyncRemote};
/// use ferrolink_io::mavlink::SharedConnection;
///
/// let link = SharedConnection::open("udpin://0.0.0.0:14550", services::TABLE)?;
/// let vehicle = services::wait_for_vehicle_on(&link, Duration::from_secs(5))?
///     .expect("no vehicle");
/// let remote = AsyncRemote::on(link, vehicle);
/// let params = remote.fetch_params(Duration::from_secs(30), |_| {}).await?;
/// let log = remote.ftp_get("/logs/flight.bin", |done, size| eprint!("\r{done}/{size}")).await?;
/// # Ok(()) }
/// ```
#[derive(Debug, Clone)]
pub struct AsyncRemote {
    link: SharedConnection,
    target: Peer,
    turn: std::sync::Arc<tokio::sync::Mutex<()>>,
}

impl AsyncRemote {
    /// `target` through `link`'s shared connection.
    pub fn new(link: Connection, target: Peer) -> Self {
        Self::on(link.shared().clone(), target)
    }

    /// `target` through a shared connection.
    pub fn on(link: SharedConnection, target: Peer) -> Self {
        Self {
            link,
            target,
            turn: std::sync::Arc::new(tokio::sync::Mutex::new(())),
        }
    }

    /// The target.
    pub fn target(&self) -> Peer {
        self.target
    }

    /// [`Remote::fetch_params`].
    pub async fn fetch_params(
        &self,
        timeout: Duration,
        on_value: impl FnMut(&Received),
    ) -> io::Result<ParamList> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.fetch_params_with(&Tokio, timeout, on_value).await
    }

    /// [`Remote::read_param`].
    pub async fn read_param(&self, name: &str) -> io::Result<Option<Received>> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.read_param_with(&Tokio, name).await
    }

    /// [`Remote::set_param`].
    pub async fn set_param(&self, name: &str, value: Value) -> io::Result<Option<Received>> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.set_param_with(&Tokio, name, value).await
    }

    /// [`Remote::command`].
    pub async fn command(
        &self,
        command: Command,
        progress: impl FnMut(u8),
    ) -> io::Result<Option<Ack>> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.command_with(&Tokio, command, progress).await
    }

    /// [`Remote::upload_mission`].
    pub async fn upload_mission(
        &self,
        kind: MavMissionType,
        items: &[Item],
        progress: impl FnMut(u16, u16),
    ) -> io::Result<Option<MavMissionResult>> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.upload_mission_with(&Tokio, kind, items, progress).await
    }

    /// [`Remote::download_mission`].
    pub async fn download_mission(
        &self,
        kind: MavMissionType,
        progress: impl FnMut(u16, u16),
    ) -> io::Result<Option<Vec<Item>>> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.download_mission_with(&Tokio, kind, progress).await
    }

    /// [`Remote::clear_mission`].
    pub async fn clear_mission(
        &self,
        kind: MavMissionType,
    ) -> io::Result<Option<MavMissionResult>> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.clear_mission_with(&Tokio, kind).await
    }

    /// [`Remote::ftp_list`].
    pub async fn ftp_list(&self, path: &str) -> io::Result<Vec<ListEntry>> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.ftp_list_with(&Tokio, path).await
    }

    /// [`Remote::ftp_get`].
    pub async fn ftp_get(&self, path: &str, progress: impl FnMut(u32, u32)) -> io::Result<Vec<u8>> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.ftp_get_with(&Tokio, path, progress).await
    }

    /// [`Remote::ftp_put`].
    pub async fn ftp_put(
        &self,
        path: &str,
        data: &[u8],
        progress: impl FnMut(u32, u32),
    ) -> io::Result<()> {
        let _turn = self.turn.lock().await;
        let mut r = Remote::on(&self.link, self.target);
        r.ftp_put_with(&Tokio, path, data, progress).await
    }
}
