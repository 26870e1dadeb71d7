//! Ferrolink over Zenoh: fleets of routers joined by a Zenoh network.
//!
//! A crate of its own, so that nothing else compiles Zenoh. It gives the MAVLink router daemon
//! of `ferrolink-io` a `zenoh://` endpoint ([`mavlink`]), the NDLCom bridge a `zenoh://`
//! interface ([`ndlcom`]), a ModRob-1 leader an upstream port ([`modrob`]), and lists the
//! routers on a network ([`fleet`]).
//!
//! Key expressions, under a prefix (`ferrolink` by default):
//!
//! | key | what |
//! |-----|------|
//! | `<prefix>/mavlink/<sysid>/<compid>/<MESSAGE_NAME>` | every frame a router sends to Zenoh, by source system and component |
//! | `<prefix>/mavlink/<sysid>/<compid>/UNKNOWN_<id>` | the same, for an id the router does not know |
//! | `<prefix>/mavlink/<sysid>/<compid>/tx` | commands into the fleet, for system `<sysid>` |
//! | `<prefix>/fleet/<zenoh id>` | each router's links and the systems behind them (a queryable) |
//! | `<prefix>/ndlcom/<sender>/<receiver>/<MESSAGE_NAME>` | every frame an NDLCom bridge sends to Zenoh ([`ndlcom`]) |
//! | `<prefix>/modrob/<robot>/<instance>/<variable>` | what a ModRob-1 leader sends up ([`modrob`]); `.../set` takes values down |
//!
//! So `ferrolink/mavlink/3/**` is one vehicle, and `ferrolink/*/*/*/HEARTBEAT` every heartbeat.

#![warn(missing_docs)]

pub mod fleet;
pub mod mavlink;
pub mod modrob;
pub mod ndlcom;
mod session;
pub mod uri;

pub use session::{one_worker_thread, Running, ONE_WORKER_THREAD};

pub use uri::{Encoding, Mode, ZenohUri, SCHEME};
