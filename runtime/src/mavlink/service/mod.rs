//! The MAVLink microservices as sans-I/O state machines: commands and parameters, on the client
//! side and on the server (vehicle) side.
//!
//! Each state machine owns no socket, clock or thread. It is fed messages and the time, and
//! says what to send and when it wants to be woken:
//!
//! - `handle(now_us, from, &msg)`: a message from system and component `from`;
//! - `poll_transmit(now_us)`: the next message to send, until `None`;
//! - `poll_timeout()`: when to call `poll_transmit` again if nothing arrives;
//! - `poll_event()` (clients): what finished or progressed.
//!
//! Time is microseconds on any monotonic clock. Storage is the caller's: capacities are const
//! generics, and values live in traits the caller implements ([`param::Store`]). The same code
//! runs in a microcontroller's main loop, in a blocking thread on a PC and in a test that drives
//! both sides through a lossy link with a fake clock.
//!
//! Messages are those of [`messages`], generated from `definitions/runtime/microservices.xml`,
//! which holds common.xml's definitions of them: ids, layouts and CRC_EXTRA are common.xml's, so
//! frames from any dialect that includes common decode with
//! `messages::Message::decode(id, payload)`, and what a state machine sends goes out through the
//! caller's encoder like any other message.

#[rustfmt::skip]
#[allow(missing_docs, clippy::all)]
pub mod generated;

pub mod command;
pub mod param;

pub use generated::microservices as messages;

/// A system and component: where a request goes, or where a message came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Address {
    /// System id (1..=255; 0 is broadcast).
    pub system: u8,
    /// Component id (0 is every component of the system).
    pub component: u8,
}

impl Address {
    /// System `system`, component `component`.
    pub const fn new(system: u8, component: u8) -> Self {
        Self { system, component }
    }

    /// Whether a message with target fields `(system, component)` is for this address:
    /// exactly, or by broadcast (0) in either field.
    pub const fn is_addressed_by(self, system: u8, component: u8) -> bool {
        (system == 0 || system == self.system) && (component == 0 || component == self.component)
    }
}

/// How long a client waits for an answer, and how often it asks again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Retry {
    /// Wait for an answer this long (µs) before sending again.
    pub timeout_us: u64,
    /// Send again at most this many times after the first.
    pub retries: u8,
}

/// The earlier of two optional deadlines.
pub(crate) fn earliest(a: Option<u64>, b: Option<u64>) -> Option<u64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, None) => a,
        (None, b) => b,
    }
}

/// `v` rounded half away from zero and saturated to `i32` (no `f64::round` without std).
pub(crate) fn round_i32(v: f64) -> i32 {
    if v.is_nan() {
        return 0;
    }
    let r = if v >= 0.0 { v + 0.5 } else { v - 0.5 };
    // `as` saturates.
    r as i32
}
