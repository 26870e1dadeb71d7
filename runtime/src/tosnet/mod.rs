//! TosNet: a ring of nodes sharing one 4 KiB block of memory, refreshed every cycle.
//!
//! Each cycle the master sends its copy of the block's enabled registers round the ring in one
//! DATA frame; every slave takes what it needs, writes its own out areas into the frame and
//! passes it on; when the frame is back, the master has everyone's out areas and starts the next
//! cycle. The pieces, all `no_std` and allocation-free:
//!
//! - [`block`]: the block, its word addressing and the typed write capabilities generated
//!   register maps use ([`OutWriter`] for a node's own out areas, [`InWriter`] for the master);
//! - [`frame`]: our frame format for software links, byte by byte;
//! - [`stream`]: those frames on a byte stream (serial, pty, TCP), delimited by flags;
//! - [`node`]: the node engine: master election, ring and register discovery, sync delays,
//!   DATA handling, the watchdog, double buffering, the side channel and the counters.
//!
//! CRC-8 with polynomial 0x65 (init 0, not reflected, no final xor) protects every frame.

pub mod block;
pub mod frame;
pub mod node;
pub mod stream;

pub use block::{Area, Block, InWriter, NodeId, OutWriter};
pub use frame::{Command, FrameError, Repr};
pub use node::{Config, Counters, Node, Phase, Role, Status};

use ::crc::{Algorithm, Crc, Table};

/// The paper's bit rate: 10 Mbit/s.
pub const PAPER_BITRATE: f64 = 10e6;

/// The paper's delay through one node: 5.46 µs.
pub const PAPER_NODE_DELAY_NS: f64 = 5460.0;

/// The model's cycle rate, `1 / ((32 + 256 r) / B + i d)` in Hz, for `nodes` nodes (i), `registers`
/// enabled registers in the whole ring (r), a bit rate B in bit/s and a delay d per node.
pub fn model_rate(nodes: usize, registers: usize, bitrate: f64, node_delay_ns: f64) -> f64 {
    let bits = 32.0 + 256.0 * registers as f64;
    1.0 / (bits / bitrate + nodes as f64 * node_delay_ns * 1e-9)
}

/// CRC-8 with polynomial 0x65 (x^8 + x^6 + x^5 + x^2 + 1), init 0, not reflected, no final xor.
pub const CRC_8_TOSNET: Algorithm<u8> = Algorithm {
    width: 8,
    poly: 0x65,
    init: 0x00,
    refin: false,
    refout: false,
    xorout: 0x00,
    check: 0xDF,
    residue: 0x00,
};

/// 16 bytes per step with `fast-crc` (a 4 KiB table), else 1 (256 bytes).
#[cfg(feature = "fast-crc")]
const SLICES: usize = 16;
#[cfg(not(feature = "fast-crc"))]
const SLICES: usize = 1;

const CRC8: Crc<u8, Table<SLICES>> = Crc::<u8, Table<SLICES>>::new(&CRC_8_TOSNET);

/// TosNet's CRC-8 of `data`. `crc8(b"123456789") == 0xDF`; data followed by its CRC gives 0.
pub fn crc8(data: &[u8]) -> u8 {
    CRC8.checksum(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_value_and_residue() {
        assert_eq!(crc8(b"123456789"), 0xDF);
        assert_eq!(crc8(b"123456789\xDF"), 0);
        assert_eq!(crc8(&[]), 0);
    }
}
