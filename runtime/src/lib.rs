//! The Ferrolink runtime: everything generated bindings plug into.
//!
//! `no_std`, no allocation, no `unsafe`. Each protocol sits behind its own feature:
//!
//! | feature   | what it brings |
//! |-----------|----------------|
//! | `mavlink` | MAVLink v1/v2 frames, the backtracking stream parser, the dialect traits |
//! | `signing` | MAVLink 2 message signing (SHA-256) and the MAVLink router (implies `mavlink`) |
//! | `services` | the MAVLink microservices (commands, parameters) as sans-I/O state machines (implies `mavlink`) |
//! | `ndlcom`  | NDLCom frames, stream parser, packet counters, router and bridge |
//! | `tosnet`  | TosNet shared-memory block, ring frames and the node engine |
//! | `modrob`  | ModRob-1 messages on CAN-1, UART.B-1/SPI-1 (encoder, stream parser) and Ethernet-1 packets; module and leader engines |
//! | `embedded-can` | `embedded_can::Frame` conversions for ModRob-1 messages (implies `modrob`) |
//! | `fast-crc` | a 16-bytes-per-step CRC table (8 KiB) instead of the 512-byte one; on by default |
//! | `serde`   | serde support for generated types (pymavlink's `to_dict()` JSON form) |
//! | `std`     | `std::error::Error` for the error types |
//!
//! Generated code only calls into this crate through [`wire`] (fixed-offset field access) and the
//! traits of each protocol module, so the generated files stay thin and declarative.
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;
// Generated code names the crate by its absolute path: the microservices' messages
// (`mavlink::service::messages`) live here, and the test dialect (`mavlink::testing`) is
// included by the integration tests too.
extern crate self as ferrolink_runtime;

pub mod crc;
pub mod framing;
#[cfg(any(feature = "ndlcom", feature = "tosnet"))]
mod hdlc;
#[cfg(feature = "mavlink")]
pub mod mavlink;
#[cfg(feature = "modrob")]
pub mod modrob;
#[cfg(feature = "ndlcom")]
pub mod ndlcom;
#[cfg(feature = "serde")]
pub mod serde_helpers;
#[cfg(feature = "tosnet")]
pub mod tosnet;
pub mod wire;

/// Adds `n` to a drop or frame counter, wrapping: parsers count in `usize`, which on a 32-bit
/// microcontroller wraps after 4 Gi events rather than overflowing.
#[inline(always)]
#[allow(dead_code)]
pub(crate) fn bump(counter: &mut usize, n: usize) {
    *counter = counter.wrapping_add(n);
}

#[doc(hidden)]
pub mod __private {
    #[cfg(feature = "serde")]
    pub use serde;
}
