//! Lowering: parsed files to one [`Ir`](crate::ir::Ir), with everything computed that the
//! backends need, one submodule per protocol:
//!
//! - MAVLink dialects in [`mavlink`]: wire order, offsets, lengths, CRC_EXTRA, merged enums;
//! - TosNet register maps in [`tosnet`]: area names resolved, offsets and lengths;
//! - ModRob-1 dictionaries and robots in [`modrob`]: fingerprints, names resolved.

pub mod mavlink;
#[cfg(feature = "toml")]
pub mod modrob;
#[cfg(feature = "toml")]
pub mod tosnet;

pub use mavlink::{crc_extra, layout};
