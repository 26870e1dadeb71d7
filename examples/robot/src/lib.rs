//! The ModRob-1 example robot (`definitions/modrob/robot.toml`): fourteen module engines on the
//! generated dictionaries and the leader, over a simulated CAN bus ([`can`]) or over Ethernet-1
//! on UDP loopback ([`ethernet`]).

pub mod can;
pub mod ethernet;
pub mod modules;
