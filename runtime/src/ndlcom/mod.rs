//! NDLCom: the point-to-point frame format, stream parser, routing and bridge of the DFKI's
//! Node-level Data Link Communication.
//!
//! ```text
//! 0x7E | escape( receiver | sender | counter | length | payload(0..=255) | fcs16 ) | 0x7E
//! ```
//!
//! One module per piece, all `no_std`, allocation-free and sized by const generics:
//!
//! - [`Header`] and [`encode`](mod@encode): the header repr and the encoder (one payload or
//!   scatter-gather parts, into a buffer or straight into a sink);
//! - [`parser`]: the push stream parser over caller- or const-sized storage;
//! - [`counters`]: outgoing counters per receiver and missed-packet tracking per pair;
//! - [`router`]: the routing table and the paper's Algorithm 1, with mirrors, pinned (internal)
//!   ids and invalidation;
//! - [`bridge`]: a router with per-interface parsers and output queues, forwarding store &
//!   forward or cut-through per interface pair;
//! - [`payload`] (with the `mavlink` feature): generated messages as NDLCom payloads.

pub mod bridge;
pub mod counters;
pub mod encode;
mod header;
pub mod parser;
#[cfg(feature = "mavlink")]
pub mod payload;
pub mod router;

pub use encode::{encode, encode_parts, encode_with, encoded_len, EncodeError};
pub use header::Header;
pub use parser::{Frame, Parser};

pub use crate::hdlc::{ESCAPE, FLAG};
/// The receiver address of a frame for everyone.
pub const BROADCAST: u8 = 0xFF;
/// The largest payload.
pub const MAX_PAYLOAD_LEN: usize = 255;
/// FCS length.
pub const FCS_LEN: usize = 2;
/// The largest encoded frame: every byte between the flags escaped.
pub const MAX_FRAME_LEN: usize = max_encoded_len(MAX_PAYLOAD_LEN);

/// The worst-case encoded length of a frame with `payload_len` payload bytes, flags included.
pub const fn max_encoded_len(payload_len: usize) -> usize {
    2 + 2 * (Header::LEN + payload_len + FCS_LEN)
}

/// Parser storage needed for payloads up to `max_payload` bytes: one unescaped frame.
pub const fn storage_len(max_payload: usize) -> usize {
    Header::LEN + max_payload + FCS_LEN
}
