//! Shared fixtures: a hand-written dialect in the shape generated code has, the golden frames,
//! a tiny deterministic PRNG and frame builders.
#![allow(dead_code)]

use ferrolink_runtime::mavlink::{
    signing::Signer, v1, v2, Dialect, Header, Message, MessageMeta, PayloadBuf, UnknownMessageId,
};
use ferrolink_runtime::wire::{get, put, zero_extend};

pub const GOLDEN_V2: &str = "fd0900000001010000000400000002035104037bae";
pub const GOLDEN_V1: &str = "fe0900010100040000000203510403e16d";
pub const GOLDEN_SIGNED: &str =
    "fd0901000001010000000400000002035104039c56079a7856341200fab266b949d9";
pub const GOLDEN_TIMESTAMP: u64 = 0x12_3456_789A;
pub const GOLDEN_LINK: u8 = 7;

pub fn golden_key() -> [u8; 32] {
    core::array::from_fn(|i| i as u8)
}

pub fn hex(s: &str) -> Vec<u8> {
    hex::decode(s).expect("valid hex")
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Heartbeat {
    pub custom_mode: u32,
    pub r#type: u8,
    pub autopilot: u8,
    pub base_mode: u8,
    pub system_status: u8,
    pub mavlink_version: u8,
}

pub fn golden_heartbeat() -> Heartbeat {
    Heartbeat {
        custom_mode: 4,
        r#type: 2,
        autopilot: 3,
        base_mode: 0x51,
        system_status: 4,
        mavlink_version: 3,
    }
}

impl Message for Heartbeat {
    const ID: u32 = 0;
    const NAME: &'static str = "HEARTBEAT";
    const CRC_EXTRA: u8 = 50;
    const MIN_LEN: usize = 9;
    const MAX_LEN: usize = 9;

    fn encode(&self, buf: &mut PayloadBuf) -> usize {
        put(buf, 0, self.custom_mode);
        put(buf, 4, self.r#type);
        put(buf, 5, self.autopilot);
        put(buf, 6, self.base_mode);
        put(buf, 7, self.system_status);
        put(buf, 8, self.mavlink_version);
        Self::MAX_LEN
    }

    fn decode(payload: &[u8]) -> Self {
        let p = zero_extend::<9>(payload);
        Self {
            custom_mode: get(&p, 0),
            r#type: get(&p, 4),
            autopilot: get(&p, 5),
            base_mode: get(&p, 6),
            system_status: get(&p, 7),
            mavlink_version: get(&p, 8),
        }
    }
}

/// Base fields `i32 @0, u16 @4, u8 @6`; extensions `u8 @7, f32 @8`. Id below 256 so that it can
/// travel over MAVLink 1 as well.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExtMsg {
    pub base_i32: i32,
    pub base_u16: u16,
    pub base_u8: u8,
    pub ext_u8: u8,
    pub ext_f32: f32,
}

impl Message for ExtMsg {
    const ID: u32 = 200;
    const NAME: &'static str = "EXT_TEST";
    const CRC_EXTRA: u8 = 0xC3;
    const MIN_LEN: usize = 7;
    const MAX_LEN: usize = 12;

    fn encode(&self, buf: &mut PayloadBuf) -> usize {
        put(buf, 0, self.base_i32);
        put(buf, 4, self.base_u16);
        put(buf, 6, self.base_u8);
        put(buf, 7, self.ext_u8);
        put(buf, 8, self.ext_f32);
        Self::MAX_LEN
    }

    fn decode(payload: &[u8]) -> Self {
        let p = zero_extend::<12>(payload);
        Self {
            base_i32: get(&p, 0),
            base_u16: get(&p, 4),
            base_u8: get(&p, 6),
            ext_u8: get(&p, 7),
            ext_f32: get(&p, 8),
        }
    }
}

/// The largest payload, with a 24-bit id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Big(pub [u8; 255]);

impl Message for Big {
    const ID: u32 = 0x00AB_CDEF;
    const NAME: &'static str = "BIG_TEST";
    const CRC_EXTRA: u8 = 7;
    const MIN_LEN: usize = 255;
    const MAX_LEN: usize = 255;

    fn encode(&self, buf: &mut PayloadBuf) -> usize {
        put(buf, 0, self.0);
        Self::MAX_LEN
    }

    fn decode(payload: &[u8]) -> Self {
        Self(zero_extend(payload))
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum TestDialect {
    Heartbeat(Heartbeat),
    Ext(ExtMsg),
    Big(Big),
}

pub const fn meta_of<M: Message>() -> MessageMeta {
    MessageMeta {
        id: M::ID,
        name: M::NAME,
        crc_extra: M::CRC_EXTRA,
        min_len: M::MIN_LEN as u8,
        max_len: M::MAX_LEN as u8,
        target_system: None,
        target_component: None,
    }
}

impl Dialect for TestDialect {
    const META: &'static [MessageMeta] = &[
        meta_of::<Heartbeat>(),
        meta_of::<ExtMsg>(),
        meta_of::<Big>(),
    ];

    fn decode(id: u32, payload: &[u8]) -> Result<Self, UnknownMessageId> {
        match id {
            Heartbeat::ID => Ok(Self::Heartbeat(Heartbeat::decode(payload))),
            ExtMsg::ID => Ok(Self::Ext(ExtMsg::decode(payload))),
            Big::ID => Ok(Self::Big(Big::decode(payload))),
            other => Err(UnknownMessageId(other)),
        }
    }

    fn id(&self) -> u32 {
        match self {
            Self::Heartbeat(_) => Heartbeat::ID,
            Self::Ext(_) => ExtMsg::ID,
            Self::Big(_) => Big::ID,
        }
    }

    fn encode(&self, buf: &mut PayloadBuf) -> usize {
        match self {
            Self::Heartbeat(m) => m.encode(buf),
            Self::Ext(m) => m.encode(buf),
            Self::Big(m) => m.encode(buf),
        }
    }
}

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
