//! A hand-written test dialect, written the way generated code is: HEARTBEAT, a message with
//! extension fields, and a message with the largest payload and a 24-bit id; and the golden
//! frames. Shared by the unit tests here and the integration tests (`tests/common/mod.rs`
//! includes this file), so paths are absolute.
#![allow(dead_code)]

use std::vec::Vec;

use ferrolink_runtime::mavlink::{Dialect, Message, MessageMeta, PayloadBuf, UnknownMessageId};
use ferrolink_runtime::wire::{get, put, zero_extend};

/// HEARTBEAT type=2 autopilot=3 base_mode=0x51 custom_mode=4 system_status=4
/// mavlink_version=3 from sysid 1, compid 1, seq 0.
pub const GOLDEN_V2: &str = "fd0900000001010000000400000002035104037bae";
/// The same message as a MAVLink 1 frame.
pub const GOLDEN_V1: &str = "fe0900010100040000000203510403e16d";
/// The same message signed with key 00 01 .. 1f on link 7.
pub const GOLDEN_SIGNED: &str =
    "fd0901000001010000000400000002035104039c56079a7856341200fab266b949d9";
/// The signing timestamp of [`GOLDEN_SIGNED`].
pub const GOLDEN_TIMESTAMP: u64 = 0x12_3456_789A;
/// The signing link id of [`GOLDEN_SIGNED`].
pub const GOLDEN_LINK: u8 = 7;
/// The signing key of [`GOLDEN_SIGNED`].
pub const GOLDEN_KEY: [u8; 32] = {
    let mut k = [0u8; 32];
    let mut i = 0;
    while i < 32 {
        k[i] = i as u8;
        i += 1;
    }
    k
};

pub fn hex(s: &str) -> Vec<u8> {
    ::hex::decode(s).expect("valid hex")
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

/// A message with extension fields: base `i32 @0, u16 @4, u8 @6`, extensions `u8 @7, f32 @8`.
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

/// The metadata of `M`, as a generated table has it (no target fields).
pub const fn meta_of<M: Message>() -> MessageMeta {
    MessageMeta {
        id: M::ID,
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

    fn name(&self) -> &'static str {
        match self {
            Self::Heartbeat(_) => Heartbeat::NAME,
            Self::Ext(_) => ExtMsg::NAME,
            Self::Big(_) => Big::NAME,
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
