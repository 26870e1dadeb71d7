//! MAVLink 2 message signing: a [`Signer`] for outgoing frames and a [`Verifier`] with replay
//! protection for incoming ones.
//!
//! A signed frame has the incompat flag [`v2::INCOMPAT_SIGNED`] set (the checksum covers it, so
//! the flag is set before the checksum is computed) and ends with a 13-byte trailer:
//!
//! ```text
//! link_id(1) timestamp(6, LE) signature(6)
//! signature = SHA-256(secret_key(32) | frame from the magic byte to the timestamp)[0..6]
//! ```
//!
//! Timestamps count units of 10 us since 2015-01-01 00:00 UTC ([`timestamp_from_unix_micros`]).
//! There is no clock in `no_std`: every call takes the caller's current time (`now`), and a
//! system without a clock may pass 0 and let the verifier follow the timestamps it accepts.
//!
//! ```
//! use ferrolink_runtime::mavlink::{signing::{SecretKey, Signer, Verifier}, v2, Header};
//!
//! let key = SecretKey::new([7; 32]);
//! let mut signer = Signer::new(key.clone(), 1);
//! let mut verifier = Verifier::<8>::new(key);
//!
//! let mut out = [0u8; v2::MAX_FRAME_LEN];
//! let now = 1_000_000;
//! let n = signer.encode_raw(now, Header::new(0, 1, 1), 0, 50, &[4, 0, 0, 0, 2], &mut out).unwrap();
//! let frame = v2::Frame::new_checked(&out[..n]).unwrap();
//! assert!(frame.check_crc(50));
//! assert_eq!(verifier.verify(&frame, now), Ok(()));
//! // The same frame again is a replay.
//! assert!(verifier.verify(&frame, now).is_err());
//! ```

use core::fmt;

use sha2::{Digest, Sha256};

use super::error::EncodeError;
use super::{v2, Dialect, Header, Message};

/// Timestamp units per second (one unit is 10 us).
pub const UNITS_PER_SECOND: u64 = 100_000;
/// The largest timestamp (48 bits).
pub const MAX_TIMESTAMP: u64 = (1 << 48) - 1;
/// How far behind the local timestamp a new stream may start: 60 s.
pub const NEW_STREAM_WINDOW: u64 = 60 * UNITS_PER_SECOND;
/// The signing epoch, 2015-01-01 00:00 UTC, in Unix seconds.
pub const EPOCH_UNIX_SECONDS: u64 = 1_420_070_400;
/// Length of a signature.
pub const SIGNATURE_LEN: usize = 6;

/// Converts microseconds since the Unix epoch to a signing timestamp (0 before 2015).
#[inline]
pub const fn timestamp_from_unix_micros(unix_us: u64) -> u64 {
    let t = div10(unix_us.saturating_sub(EPOCH_UNIX_SECONDS * 1_000_000));
    if t > MAX_TIMESTAMP {
        MAX_TIMESTAMP
    } else {
        t
    }
}

/// `x / 10` with shifts and one multiplication. On a 32-bit microcontroller a `u64` division is
/// a call into compiler_builtins (about 0.9 kB of flash on a Cortex-M), even by a constant.
/// Shift-and-add makes `q` within 1 of `x / 10` from below; the remainder corrects it.
const fn div10(x: u64) -> u64 {
    let mut q = (x >> 1) + (x >> 2);
    q += q >> 4;
    q += q >> 8;
    q += q >> 16;
    q += q >> 32;
    q >>= 3;
    let r = x - q * 10;
    q + (r > 9) as u64
}

/// A 32-byte signing key. Its `Debug` output does not show the key.
#[derive(Clone, PartialEq, Eq)]
pub struct SecretKey([u8; 32]);

impl SecretKey {
    /// Wraps the key bytes.
    #[inline]
    pub const fn new(bytes: [u8; 32]) -> Self {
        Self(bytes)
    }

    /// The key bytes.
    #[inline]
    pub const fn as_bytes(&self) -> &[u8; 32] {
        &self.0
    }
}

impl From<[u8; 32]> for SecretKey {
    fn from(bytes: [u8; 32]) -> Self {
        Self(bytes)
    }
}

impl fmt::Debug for SecretKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("SecretKey(..)")
    }
}

/// The 6-byte signature of `signed`: a frame from its magic byte through the timestamp of its
/// trailer (everything but the signature itself).
pub fn compute_signature(key: &SecretKey, signed: &[u8]) -> [u8; SIGNATURE_LEN] {
    let mut hash = Sha256::new();
    hash.update(key.0);
    hash.update(signed);
    let digest = hash.finalize();
    let mut sig = [0u8; SIGNATURE_LEN];
    for (s, d) in sig.iter_mut().zip(digest.iter()) {
        *s = *d;
    }
    sig
}

/// Whether `frame` is signed and its signature matches `key`. No replay check: see
/// [`Verifier`].
pub fn signature_matches<T: AsRef<[u8]>>(key: &SecretKey, frame: &v2::Frame<T>) -> bool {
    let Some(sent) = frame.signature() else {
        return false;
    };
    let bytes = frame.as_bytes();
    let Some(signed) = bytes.get(..bytes.len().saturating_sub(SIGNATURE_LEN)) else {
        return false;
    };
    let computed = compute_signature(key, signed);
    // Compare without an early exit.
    sent.iter()
        .zip(computed.iter())
        .fold(0u8, |acc, (a, b)| acc | (a ^ b))
        == 0
}

/// Signs outgoing MAVLink 2 frames on one link.
///
/// Each frame gets a timestamp greater than the previous one: the caller's `now`, or the last
/// timestamp plus one if time has not advanced (several frames within 10 us, or a clock that
/// went back). At [`MAX_TIMESTAMP`] (year 2104) the timestamp stops increasing.
#[derive(Debug, Clone)]
pub struct Signer {
    key: SecretKey,
    link_id: u8,
    timestamp: u64,
}

impl Signer {
    /// A signer for link `link_id` that has not sent anything yet.
    pub const fn new(key: SecretKey, link_id: u8) -> Self {
        Self {
            key,
            link_id,
            timestamp: 0,
        }
    }

    /// The link id written into every signature.
    pub fn link_id(&self) -> u8 {
        self.link_id
    }

    /// The timestamp of the last signed frame (0 before the first).
    pub fn timestamp(&self) -> u64 {
        self.timestamp
    }

    /// Makes the next timestamp at least `timestamp` (e.g. restored from storage after a reboot).
    pub fn advance_to(&mut self, timestamp: u64) {
        self.timestamp = self.timestamp.max(timestamp.min(MAX_TIMESTAMP));
    }

    fn next_timestamp(&self, now: u64) -> u64 {
        now.min(MAX_TIMESTAMP)
            .max(self.timestamp.saturating_add(1).min(MAX_TIMESTAMP))
    }

    /// Writes the trailer behind the unsigned part (`len` bytes) of a frame in `out`.
    fn finish(&mut self, now: u64, len: usize, out: &mut [u8]) -> Result<usize, EncodeError> {
        let total = len + v2::SIGNATURE_LEN;
        let Some(frame) = out.get_mut(..total) else {
            return Err(EncodeError::BufferTooSmall { needed: total });
        };
        let timestamp = self.next_timestamp(now);
        let signed_len = total - SIGNATURE_LEN;
        if let Some(trailer) = frame.get_mut(len..signed_len) {
            let ts = timestamp.to_le_bytes();
            trailer[0] = self.link_id;
            trailer[1..].copy_from_slice(&ts[..6]);
        }
        let (signed, sig) = frame.split_at_mut(signed_len);
        sig.copy_from_slice(&compute_signature(&self.key, signed));
        self.timestamp = timestamp;
        Ok(total)
    }

    /// Encodes and signs a frame from a whole payload, as [`v2::encode_raw`] does, and returns
    /// the frame length. Nothing is written (and no timestamp used) on error.
    pub fn encode_raw(
        &mut self,
        now: u64,
        header: Header,
        msg_id: u32,
        crc_extra: u8,
        payload: &[u8],
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let len = v2::encode_raw_with(
            header,
            v2::INCOMPAT_SIGNED,
            msg_id,
            crc_extra,
            payload,
            out,
            v2::SIGNATURE_LEN,
        )?;
        self.finish(now, len, out)
    }

    /// Encodes and signs message `msg`, as [`v2::encode`] does, and returns the frame length.
    pub fn encode<M: Message>(
        &mut self,
        now: u64,
        header: Header,
        msg: &M,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let len = v2::encode_with(
            header,
            v2::INCOMPAT_SIGNED,
            M::ID,
            M::CRC_EXTRA,
            |p| msg.encode(p),
            out,
            v2::SIGNATURE_LEN,
        )?;
        self.finish(now, len, out)
    }

    /// Encodes and signs any message of dialect `D`, as [`v2::encode_dialect`] does, and returns
    /// the frame length.
    pub fn encode_dialect<D: Dialect>(
        &mut self,
        now: u64,
        header: Header,
        msg: &D,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let meta = msg.meta();
        let len = v2::encode_with(
            header,
            v2::INCOMPAT_SIGNED,
            meta.id,
            meta.crc_extra,
            |p| msg.encode(p),
            out,
            v2::SIGNATURE_LEN,
        )?;
        self.finish(now, len, out)
    }
}

/// Why a frame failed verification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum VerifyError {
    /// The frame is not signed.
    Unsigned,
    /// The signature does not match the key (or the trailer is cut off).
    BadSignature,
    /// The timestamp is not newer than the last one accepted on this stream.
    Replayed,
    /// A new stream's timestamp is more than 60 s behind the local timestamp.
    TooOld,
}

impl fmt::Display for VerifyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Unsigned => "frame is not signed",
            Self::BadSignature => "signature does not match",
            Self::Replayed => "timestamp not newer than the stream's last one (replay)",
            Self::TooOld => "new stream's timestamp is more than 60 s old",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for VerifyError {}

/// What a [`Verifier`] accepted and rejected so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct VerifyStats {
    /// Frames accepted.
    pub accepted: u64,
    /// Frames rejected as unsigned.
    pub unsigned: u64,
    /// Frames rejected for a bad signature.
    pub bad_signature: u64,
    /// Frames rejected as replays.
    pub replayed: u64,
    /// New streams rejected as too old.
    pub too_old: u64,
    /// Streams forgotten to make room for a new one.
    pub evicted: u64,
}

/// The replay state of one (link id, system id, component id) stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StreamState {
    /// Link id.
    pub link_id: u8,
    /// System id.
    pub sysid: u8,
    /// Component id.
    pub compid: u8,
    /// Timestamp of the last frame accepted on the stream.
    pub timestamp: u64,
    /// When the stream was last updated, in accepted frames (for eviction).
    last_use: u64,
}

/// Verifies signed MAVLink 2 frames and rejects replays, remembering up to `S` streams.
///
/// Streams are keyed by (link id, system id, component id). A known stream's timestamp must
/// strictly increase. A new stream is accepted only if its timestamp is at most 60 s
/// ([`NEW_STREAM_WINDOW`]) behind the local timestamp, which is the largest of every `now`
/// passed in and every timestamp accepted (so a system without a clock can pass 0).
///
/// When the table is full, a new stream replaces the stream updated longest ago, and
/// [`VerifyStats::evicted`] counts it. A forgotten stream is then protected only by the new
/// stream rule: its frames from the last 60 s could be replayed once. Size `S` for the number
/// of signing peers you expect.
#[derive(Debug, Clone)]
pub struct Verifier<const S: usize = 16> {
    key: SecretKey,
    timestamp: u64,
    uses: u64,
    streams: [Option<StreamState>; S],
    stats: VerifyStats,
}

impl<const S: usize> Verifier<S> {
    const HAS_ROOM: () = assert!(S > 0, "Verifier<S> needs room for at least one stream");

    /// A verifier with `key`, no streams and a local timestamp of 0.
    pub const fn new(key: SecretKey) -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::HAS_ROOM;
        Self {
            key,
            timestamp: 0,
            uses: 0,
            streams: [None; S],
            stats: VerifyStats {
                accepted: 0,
                unsigned: 0,
                bad_signature: 0,
                replayed: 0,
                too_old: 0,
                evicted: 0,
            },
        }
    }

    /// The local timestamp: the largest `now` passed in or timestamp accepted.
    pub fn timestamp(&self) -> u64 {
        self.timestamp
    }

    /// The key it checks signatures with.
    pub fn key(&self) -> &SecretKey {
        &self.key
    }

    /// The counters.
    pub fn stats(&self) -> &VerifyStats {
        &self.stats
    }

    /// The streams remembered, in no particular order.
    pub fn streams(&self) -> impl Iterator<Item = &StreamState> + '_ {
        self.streams.iter().flatten()
    }

    /// Forgets every stream (the local timestamp is kept).
    pub fn forget_streams(&mut self) {
        self.streams = [None; S];
    }

    /// Checks the signature of `frame` and that it is not a replay, then records its timestamp.
    ///
    /// `now` is the caller's current time in signing units (pass 0 without a clock). The checksum
    /// is not checked here; the stream parser does that.
    pub fn verify<T: AsRef<[u8]>>(
        &mut self,
        frame: &v2::Frame<T>,
        now: u64,
    ) -> Result<(), VerifyError> {
        self.timestamp = self.timestamp.max(now.min(MAX_TIMESTAMP));
        let result = self.check(frame);
        match result {
            Ok(()) => self.stats.accepted += 1,
            Err(VerifyError::Unsigned) => self.stats.unsigned += 1,
            Err(VerifyError::BadSignature) => self.stats.bad_signature += 1,
            Err(VerifyError::Replayed) => self.stats.replayed += 1,
            Err(VerifyError::TooOld) => self.stats.too_old += 1,
        }
        result
    }

    fn check<T: AsRef<[u8]>>(&mut self, frame: &v2::Frame<T>) -> Result<(), VerifyError> {
        if !frame.is_signed() {
            return Err(VerifyError::Unsigned);
        }
        let (Some(link_id), Some(ts)) = (frame.link_id(), frame.timestamp()) else {
            return Err(VerifyError::BadSignature);
        };
        if !signature_matches(&self.key, frame) {
            return Err(VerifyError::BadSignature);
        }
        let (sysid, compid) = (frame.sysid(), frame.compid());
        self.uses += 1;
        let last_use = self.uses;
        let known = self
            .streams
            .iter_mut()
            .flatten()
            .find(|s| (s.link_id, s.sysid, s.compid) == (link_id, sysid, compid));
        match known {
            Some(stream) if ts <= stream.timestamp => return Err(VerifyError::Replayed),
            Some(stream) => {
                stream.timestamp = ts;
                stream.last_use = last_use;
            }
            None => {
                if ts.saturating_add(NEW_STREAM_WINDOW) < self.timestamp {
                    return Err(VerifyError::TooOld);
                }
                let state = StreamState {
                    link_id,
                    sysid,
                    compid,
                    timestamp: ts,
                    last_use,
                };
                self.insert(state);
            }
        }
        self.timestamp = self.timestamp.max(ts);
        Ok(())
    }

    fn insert(&mut self, state: StreamState) {
        if let Some(free) = self.streams.iter_mut().find(|s| s.is_none()) {
            *free = Some(state);
            return;
        }
        let oldest = self
            .streams
            .iter_mut()
            .min_by_key(|s| s.as_ref().map_or(0, |s| s.last_use));
        if let Some(slot) = oldest {
            *slot = Some(state);
            self.stats.evicted += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mavlink::testing::{golden_heartbeat, hex, GOLDEN_KEY, GOLDEN_SIGNED, GOLDEN_V2};

    const TS: u64 = 0x12_3456_789A;

    fn key() -> SecretKey {
        SecretKey::new(GOLDEN_KEY)
    }

    #[test]
    fn div10_is_division_by_ten() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let edges = (0..2000u64).chain((0..64).flat_map(|b| {
            let p = 1u64 << b;
            [
                p - 1,
                p,
                p + 1,
                p.wrapping_mul(10),
                p.wrapping_mul(10).wrapping_sub(1),
            ]
        }));
        for v in edges.chain([u64::MAX, u64::MAX - 1, u64::MAX - 9, u64::MAX / 10 * 10]) {
            assert_eq!(div10(v), v / 10, "{v}");
        }
        for _ in 0..1_000_000 {
            // xorshift64*
            x ^= x >> 12;
            x ^= x << 25;
            x ^= x >> 27;
            let v = x.wrapping_mul(0x2545_F491_4F6C_DD1D);
            assert_eq!(div10(v), v / 10, "{v}");
            assert_eq!(div10(v >> 13), (v >> 13) / 10);
        }
    }

    #[test]
    fn golden_signed_frame_is_reproduced() {
        let golden = hex(GOLDEN_SIGNED);
        let mut signer = Signer::new(key(), 7);
        let mut out = [0xA5u8; 34];
        let n = signer
            .encode(TS, Header::new(0, 1, 1), &golden_heartbeat(), &mut out)
            .unwrap();
        assert_eq!(out[..n], golden[..]);
        assert_eq!(signer.timestamp(), TS);

        // The in-place path and the raw encoder agree.
        let mut signer = Signer::new(key(), 7);
        let mut big = [0xA5u8; v2::MAX_FRAME_LEN];
        let n = signer
            .encode(TS, Header::new(0, 1, 1), &golden_heartbeat(), &mut big)
            .unwrap();
        assert_eq!(big[..n], golden[..]);
        let mut signer = Signer::new(key(), 7);
        let unsigned = hex(GOLDEN_V2);
        let n = signer
            .encode_raw(TS, Header::new(0, 1, 1), 0, 50, &unsigned[10..19], &mut out)
            .unwrap();
        assert_eq!(out[..n], golden[..]);
    }

    #[test]
    fn golden_signed_frame_verifies() {
        let golden = hex(GOLDEN_SIGNED);
        let frame = v2::Frame::new_checked(&golden[..]).unwrap();
        assert!(frame.check_crc(50));
        assert_eq!(frame.link_id(), Some(7));
        assert_eq!(frame.timestamp(), Some(TS));
        assert_eq!(
            frame.signature(),
            Some([0xfa, 0xb2, 0x66, 0xb9, 0x49, 0xd9])
        );
        assert!(signature_matches(&key(), &frame));
        let mut v = Verifier::<4>::new(key());
        assert_eq!(v.verify(&frame, TS), Ok(()));
        assert_eq!(v.verify(&frame, TS), Err(VerifyError::Replayed));
        assert_eq!(v.stats().accepted, 1);
        assert_eq!(v.stats().replayed, 1);
    }

    #[test]
    fn errors_write_nothing_and_keep_the_timestamp() {
        let mut signer = Signer::new(key(), 7);
        let mut out = [0xA5u8; 33];
        assert_eq!(
            signer.encode(TS, Header::default(), &golden_heartbeat(), &mut out),
            Err(EncodeError::BufferTooSmall { needed: 34 })
        );
        assert!(out.iter().all(|&b| b == 0xA5));
        assert_eq!(signer.timestamp(), 0);
        assert_eq!(
            signer.encode_raw(TS, Header::default(), 1 << 24, 0, &[1], &mut out),
            Err(EncodeError::IdOutOfRange)
        );
    }

    #[test]
    fn timestamps_strictly_increase() {
        let mut signer = Signer::new(key(), 0);
        let mut out = [0u8; 64];
        let mut last = 0;
        for now in [5, 5, 5, 3, 100, 100] {
            let n = signer
                .encode_raw(now, Header::default(), 0, 50, &[1], &mut out)
                .unwrap();
            let ts = v2::Frame::new_checked(&out[..n])
                .unwrap()
                .timestamp()
                .unwrap();
            assert!(ts > last);
            last = ts;
        }
        assert_eq!(last, 101);
        signer.advance_to(1000);
        assert_eq!(signer.timestamp(), 1000);
        signer.advance_to(MAX_TIMESTAMP + 5);
        assert_eq!(signer.timestamp(), MAX_TIMESTAMP);
    }

    #[test]
    fn unix_time_conversion() {
        assert_eq!(timestamp_from_unix_micros(0), 0);
        assert_eq!(
            timestamp_from_unix_micros(EPOCH_UNIX_SECONDS * 1_000_000),
            0
        );
        assert_eq!(
            timestamp_from_unix_micros((EPOCH_UNIX_SECONDS + 1) * 1_000_000 + 25),
            UNITS_PER_SECOND + 2
        );
        assert_eq!(timestamp_from_unix_micros(u64::MAX), MAX_TIMESTAMP);
    }

    #[test]
    fn key_is_not_printed() {
        let s = std::format!("{:?}", Signer::new(key(), 3));
        assert!(s.contains("SecretKey(..)"), "{s}");
        assert!(!s.contains("31"), "{s}");
    }
}
