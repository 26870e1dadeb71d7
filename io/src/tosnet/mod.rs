//! TosNet rings outside an FPGA: an in-process ring on a virtual clock ([`sim`]) and nodes in
//! real processes ([`node`]), joined by UDP (one frame per datagram) or by byte streams such as
//! serial links (frames between flags).

pub mod node;
pub mod sim;

pub use node::{Framing, LinkNode, UdpNode};
