//! ModRob-1 links for PCs: a simulated CAN bus carrying CAN-1 frames ([`can_sim`]) and
//! Ethernet-1 over UDP sockets ([`udp`]); messages as JSON ([`json`]).

pub mod can_sim;
pub mod json;
pub mod udp;
