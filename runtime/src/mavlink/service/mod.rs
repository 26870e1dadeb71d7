//! The MAVLink microservices as sans-I/O state machines: commands, parameters, missions and FTP, on the client
//! side and on the server (vehicle) side, and the heartbeat table clients pick targets from.
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

// Formatted by the generator; the descriptions are common.xml's text, not rustdoc.
#[rustfmt::skip]
#[allow(missing_docs, clippy::all, rustdoc::broken_intra_doc_links, rustdoc::bare_urls, rustdoc::invalid_html_tags)]
pub mod generated;

pub mod command;
pub mod ftp;
pub mod mission;
pub mod param;
pub mod peers;

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

impl Retry {
    /// Whether a peer silent for `silent_us`, through `tries` sendings, is given up: only after
    /// as long as `retries + 1` of the longest waits, and at least twice as many sendings. A
    /// client whose waits follow a short round trip asks many times in that time; one that has
    /// not measured a round trip yet still asks `2 × (retries + 1)` times before it gives up.
    pub fn exhausted(&self, silent_us: u64, tries: u8) -> bool {
        let rounds = u64::from(self.retries) + 1;
        silent_us >= self.timeout_us.saturating_mul(rounds) && u64::from(tries) >= 2 * rounds
    }
}

/// Why a client's operation could not start: another is under way, and one runs at a time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Busy;

impl core::fmt::Display for Busy {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("another operation is under way")
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Busy {}

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

/// A round-trip time estimate, smoothed as TCP does (RFC 6298), so that a client's timeouts
/// follow the link: short on a cable, long on a radio at range.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Rtt {
    srtt_us: u64,
    rttvar_us: u64,
    sampled: bool,
}

impl Rtt {
    /// The shortest timeout the estimate gives, whatever the link: 20 ms.
    pub const MIN_TIMEOUT_US: u64 = 20_000;

    /// A measured round trip: a request answered at its first sending (Karn's rule: never a
    /// retried one).
    pub fn sample(&mut self, rtt_us: u64) {
        if self.sampled {
            let diff = self.srtt_us.abs_diff(rtt_us);
            self.rttvar_us = (3 * self.rttvar_us + diff) / 4;
            self.srtt_us = (7 * self.srtt_us + rtt_us) / 8;
        } else {
            self.srtt_us = rtt_us;
            self.rttvar_us = rtt_us / 2;
            self.sampled = true;
        }
    }

    /// When to time a sending at `now_us` from: at a request's first sending (Karn's rule), or
    /// at any while nothing was measured yet (the answer may be to an earlier sending, which
    /// only makes the first estimate short; a link that loses the first answers would
    /// otherwise keep the longest timeout).
    pub fn time_sending(&self, now_us: u64, first_try: bool) -> Option<u64> {
        (first_try || !self.sampled).then_some(now_us)
    }

    /// The smoothed round trip, once measured.
    pub fn smoothed_us(&self) -> Option<u64> {
        self.sampled.then_some(self.srtt_us)
    }

    /// How long to wait for an answer: `srtt + 4 × rttvar`, between [`Rtt::MIN_TIMEOUT_US`]
    /// and `max_us`; `max_us` until a round trip was measured.
    pub fn timeout_us(&self, max_us: u64) -> u64 {
        if !self.sampled {
            return max_us;
        }
        (self.srtt_us + 4 * self.rttvar_us).clamp(Self::MIN_TIMEOUT_US.min(max_us), max_us)
    }

    /// The wait after `tries` unanswered sendings: [`Rtt::timeout_us`] doubled for each of
    /// the first two, so that a slow answer is not asked for again and again, and at most
    /// `max_us`. No further: on a lossy link the waits stay short, and many tries fit in the
    /// time a client with fixed timeouts gives an answer.
    pub fn backoff_us(&self, max_us: u64, tries: u8) -> u64 {
        self.timeout_us(max_us)
            .saturating_mul(1 << tries.min(2))
            .min(max_us)
    }
}
