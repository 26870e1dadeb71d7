//! Shared fixtures: the hand-written dialect and golden frames of the unit tests
//! (`src/mavlink/testing.rs`), a tiny deterministic PRNG and frame builders.
#![allow(dead_code)]

use ferrolink_runtime::mavlink::{signing::Signer, v1, v2, Header, MessageMeta};

#[path = "../../src/mavlink/testing.rs"]
mod testing;
pub use testing::*;

/// Ids that are in no table here.
pub const UNKNOWN_IDS: [u32; 4] = [1, 77, 4000, 0x00FF_FFFF];

/// xorshift64: deterministic, seeded, good enough to shuffle a test stream.
#[derive(Debug, Clone)]
pub struct XorShift(u64);

impl XorShift {
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }

    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        x
    }

    /// Uniform enough in `0..n` (n > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }

    pub fn byte(&mut self) -> u8 {
        self.next_u64() as u8
    }

    pub fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.byte()).collect()
    }

    pub fn pick<'t, T>(&mut self, items: &'t [T]) -> &'t T {
        &items[self.below(items.len() as u64) as usize]
    }
}

/// A random payload for `meta`: `max_len` bytes with a random run of trailing zeros, so that
/// MAVLink 2 truncation varies.
pub fn random_payload(rng: &mut XorShift, max_len: usize) -> Vec<u8> {
    let mut p = rng.bytes(max_len);
    let zeros = rng.below(max_len as u64 + 1) as usize;
    for b in &mut p[max_len - zeros..] {
        *b = 0;
    }
    p
}

pub fn random_header(rng: &mut XorShift) -> Header {
    Header::new(rng.byte(), rng.byte(), rng.byte())
}

/// How to send a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    V1,
    V2,
    Signed,
}

/// Encodes a frame of message `meta` with a random payload.
pub fn random_frame(
    rng: &mut XorShift,
    meta: &MessageMeta,
    kind: Kind,
    signer: &mut Signer,
) -> Vec<u8> {
    let header = random_header(rng);
    let payload = random_payload(rng, usize::from(meta.max_len));
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = match kind {
        Kind::V1 => v1::encode_raw(
            header,
            meta.id,
            meta.crc_extra,
            &payload[..usize::from(meta.min_len)],
            &mut out,
        ),
        Kind::V2 => v2::encode_raw(header, meta.id, meta.crc_extra, &payload, &mut out),
        Kind::Signed => {
            let now = rng.below(1 << 40);
            signer.encode_raw(now, header, meta.id, meta.crc_extra, &payload, &mut out)
        }
    }
    .expect("encodes");
    out[..n].to_vec()
}

/// Rewrites the checksum of a complete (unsigned part of a) frame for `crc_extra`.
pub fn fix_crc(frame: &mut [u8], crc_extra: u8) {
    let head = if frame[0] == v1::MAGIC {
        v1::HEADER_LEN
    } else {
        v2::HEADER_LEN
    };
    let body = head + usize::from(frame[1]);
    let mut digest = ferrolink_runtime::crc::mcrf4xx_digest();
    digest.update(&frame[1..body]);
    digest.update(&[crc_extra]);
    let crc = digest.finalize();
    frame[body..body + 2].copy_from_slice(&crc.to_le_bytes());
}
