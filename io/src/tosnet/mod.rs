//! TosNet rings outside an FPGA: an in-process ring on a virtual clock ([`sim`]) and nodes in
//! real processes joined by UDP ([`udp`]).

pub mod sim;
pub mod udp;
