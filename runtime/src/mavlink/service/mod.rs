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
        self.outlasted(silent_us) && u64::from(tries) >= 2 * rounds
    }

    /// Whether a peer that drives an exchange and has gone silent for `silent_us` has given
    /// it up: as long as `retries + 1` of the longest waits, the time silence takes to give up
    /// when this side sends nothing to count.
    pub fn outlasted(&self, silent_us: u64) -> bool {
        let rounds = u64::from(self.retries) + 1;
        silent_us >= self.timeout_us.saturating_mul(rounds)
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

// The servers' conversions between integers scaled by a frame (degrees × 10⁷, metres × 10⁴)
// and floats, done with integers: a single-precision FPU such as the Cortex-M4's does `f64` in
// software, some 4 kB of it in a firmware. Each gives exactly what the `f64` expression in its
// description gives (the tests compare them).

/// `round_i32(f64::from(v) * f64::from(s))`, for `s` below 2²⁴: the product of `v`'s 24-bit
/// significand and `s` is exact in 48 bits, so it is rounded (half away from zero) and
/// saturated as an integer. A NaN gives 0.
pub(crate) fn mul_round(v: f32, s: u32) -> i32 {
    let bits = v.to_bits();
    let biased = (bits >> 23) & 0xff;
    let frac = bits & 0x7f_ffff;
    if biased == 0xff && frac != 0 {
        return 0;
    }
    // |v| = m · 2^e
    let (m, e) = match biased {
        0 => (frac, -149),
        _ => (frac | 0x80_0000, biased as i32 - 150),
    };
    let p = u64::from(m) * u64::from(s);
    let magnitude = if biased == 0xff || e > 16 {
        // Infinite, or at least 2⁴⁰.
        u64::MAX
    } else if e >= 0 {
        p << e
    } else if e < -62 {
        0
    } else {
        (p + (1 << (-e - 1))) >> -e
    };
    if bits >> 31 == 0 {
        magnitude.min(i32::MAX as u64) as i32
    } else if magnitude > 1 << 31 {
        i32::MIN
    } else {
        (magnitude as i64).wrapping_neg() as i32
    }
}

/// `f64::from(v)`, by moving the bits: exact, a NaN made quiet as an FPU makes it.
pub(crate) fn widen(v: f32) -> f64 {
    let bits = v.to_bits();
    let sign = u64::from(bits >> 31) << 63;
    let biased = (bits >> 23) & 0xff;
    let frac = u64::from(bits & 0x7f_ffff);
    let magnitude = match biased {
        0 if frac == 0 => 0,
        // Subnormal: normal in f64. The leading 1 moves up to the implicit bit's place.
        0 => {
            let shift = frac.leading_zeros() - 40;
            (u64::from(897 - shift) << 52) | (frac << shift & 0x7f_ffff) << 29
        }
        0xff if frac != 0 => 0x7ff8_u64 << 48 | frac << 29,
        0xff => 0x7ff << 52,
        _ => (u64::from(biased) + 896) << 52 | frac << 29,
    };
    f64::from_bits(sign | magnitude)
}

/// `f64::from(n) / f64::from(d)` (to nearest, ties to even) for `d` from 1 to 2²⁴ − 1.
pub(crate) fn div_f64(n: i32, d: u32) -> f64 {
    if n == 0 {
        return 0.0;
    }
    let (q, e, sticky) = quotient(n.unsigned_abs(), d);
    let (m, carry) = round_bits(q, sticky, 53);
    let biased = (e + i32::from(carry) + 1023) as u64;
    let sign = u64::from(n < 0) << 63;
    f64::from_bits(sign | biased << 52 | (m & ((1 << 52) - 1)))
}

/// `(f64::from(n) / f64::from(d)) as f32` for `d` from 1 to 2²⁴ − 1: [`div_f64`]'s quotient
/// rounded once more, from 53 bits to 24 (to nearest, ties to even).
pub(crate) fn div_f32(n: i32, d: u32) -> f32 {
    // 0 is 0.0 in both; any other quotient is a normal number within f32's range.
    let bits = div_f64(n, d).to_bits();
    if n == 0 {
        return 0.0;
    }
    // The quotient is between 2⁻²⁴ and 2³¹.
    let m = bits & ((1 << 52) - 1) | 1 << 52;
    let (m, carry) = round_bits(m << 11, false, 24);
    let biased = (((bits >> 52) & 0x7ff) as i32 - 1023 + i32::from(carry) + 127) as u32;
    let sign = ((bits >> 63) as u32) << 31;
    f32::from_bits(sign | biased << 23 | (m as u32 & 0x7f_ffff))
}

/// `n / d` for `n` and `d` not 0 and `d` below 2²⁴, by long division a byte at a time: its
/// leading 64 bits `q` (bit 63 set), the exponent `e` (the quotient is `q · 2^(e - 63)` and
/// what is left over), and whether anything is left over.
fn quotient(n: u32, d: u32) -> (u64, i32, bool) {
    let mut q = u64::from(n / d);
    let mut r = n % d;
    let mut shift = 0;
    // At least 56 bits: 53 and a rounding bit, whatever the leading zeros.
    while q < 1 << 55 {
        // r < d < 2²⁴: shifted by a byte, it still fits.
        r <<= 8;
        q = q << 8 | u64::from(r / d);
        r %= d;
        shift += 8;
    }
    let lz = q.leading_zeros();
    (q << lz, 63 - lz as i32 - shift, r != 0)
}

/// `q` (bit 63 set) rounded to its `bits` leading bits, to nearest, ties to even (`sticky`:
/// something below `q` is not zero): the significand (bit `bits - 1` set), and whether the
/// rounding carried into the next power of two (the exponent goes up by one).
fn round_bits(q: u64, sticky: bool, bits: u32) -> (u64, bool) {
    const HALF: u64 = 1 << 63;
    let m = q >> (64 - bits);
    let rest = q << bits;
    let up = rest > HALF || (rest == HALF && (sticky || m & 1 == 1));
    let m = m + u64::from(up);
    if m >> bits == 0 {
        (m, false)
    } else {
        (m >> 1, true)
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Integers over the whole `i32` range: every power of two and its neighbours, the scales'
    /// multiples and halves (ties), and a pseudo-random spread.
    fn integers() -> impl Iterator<Item = i32> {
        let edges = (0..32).flat_map(|k| {
            let p = 1i64 << k;
            [p - 1, p, p + 1, -p - 1, -p, -p + 1]
        });
        let scaled = [1i64, 10_000, 10_000_000]
            .into_iter()
            .flat_map(|s| (-300..=300).flat_map(move |k| [k * s, k * s + s / 2, k * s - 1]));
        let mut x = 0x1234_5678u32;
        let random = (0..200_000).map(move |_| {
            // xorshift32
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            i64::from(x as i32)
        });
        edges
            .chain(scaled)
            .chain(random)
            .chain([i64::from(i32::MIN), i64::from(i32::MAX), 0])
            .filter_map(|v| i32::try_from(v).ok())
    }

    /// Floats: the integers' values as floats and scaled down, halves, specials, and a
    /// pseudo-random spread of bit patterns.
    fn floats() -> impl Iterator<Item = f32> {
        let mut x = 0x9e37_79b9u32;
        let random = (0..300_000).map(move |_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            f32::from_bits(x)
        });
        let from_ints = integers().take(20_000).flat_map(|i| {
            [
                i as f32,
                i as f32 / 1e7,
                i as f32 / 1e4,
                i as f32 + 0.5,
                (i as f32 + 0.5) / 1e7,
            ]
        });
        let special = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -2.5,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            214.748_36,
            -214.748_36,
            214.748_37,
            -214.748_37,
            180.0,
            -180.0,
        ];
        special.into_iter().chain(from_ints).chain(random)
    }

    const SCALES: [u32; 3] = [1, 10_000, 10_000_000];

    #[test]
    fn widen_is_the_conversion() {
        let subnormals = (0..23).flat_map(|k| [1u32 << k, (1 << k) | 1, (2 << k) - 1]);
        let nans = [
            0x7fc0_0000u32,
            0x7f80_0001,
            0x7fbf_ffff,
            0xffc0_1234,
            0xff80_0001,
        ];
        let bits = subnormals.chain(nans).chain(floats().map(f32::to_bits));
        for b in bits.flat_map(|b| [b, b ^ 1 << 31]) {
            let v = f32::from_bits(b);
            assert_eq!(widen(v).to_bits(), f64::from(v).to_bits(), "{v:e} ({b:#x})");
        }
    }

    #[test]
    fn mul_round_is_the_f64_product_rounded() {
        for s in SCALES {
            for v in floats() {
                assert_eq!(
                    mul_round(v, s),
                    round_i32(f64::from(v) * f64::from(s)),
                    "{v:e} ({:#x}) × {s}",
                    v.to_bits()
                );
            }
        }
    }

    #[test]
    fn div_f64_is_the_f64_quotient() {
        for s in SCALES {
            for n in integers() {
                let want = f64::from(n) / f64::from(s);
                assert_eq!(div_f64(n, s).to_bits(), want.to_bits(), "{n} / {s}");
            }
        }
    }

    #[test]
    fn div_f32_is_the_f64_quotient_as_f32() {
        for s in SCALES {
            for n in integers() {
                let want = (f64::from(n) / f64::from(s)) as f32;
                assert_eq!(div_f32(n, s).to_bits(), want.to_bits(), "{n} / {s}");
            }
        }
    }
}
