//! The parameter protocols: PARAM_REQUEST_LIST, PARAM_REQUEST_READ, PARAM_SET, PARAM_VALUE,
//! and their extended forms PARAM_EXT_* ([`ext`]).
//!
//! PARAM_VALUE carries every value in one `f32`. Integers get there in one of two ways
//! ([`Encoding`]): PX4 and most autopilots copy the integer's bytes into the float
//! ("bytewise"), ArduPilot converts the number (a C cast). A client picks the target's way from
//! its HEARTBEAT (`autopilot`), unless told otherwise. PARAM_EXT_VALUE carries a value's own
//! bytes, the 64-bit types included.
//!
//! [`Client`] fetches the whole list and re-requests by index what the stream left out, until
//! it holds `param_count` values; it reads and sets single parameters with retries. A stream
//! that starts again mid-list, or a count that changes, does not confuse it: it keeps a bitmap
//! of the indices it holds, `32 × W` of them. It speaks one protocol, [`Protocol::V1`] unless
//! its [`ClientConfig`] says [`Protocol::Ext`]; the operations and events are the same.
//!
//! [`Server`] answers from a [`Store`] the caller implements (a slice of [`Param`] is one),
//! each request in the protocol it came in.

mod client;
pub mod ext;
pub mod hash;
mod server;

pub use client::{Client, ClientConfig, Event};
pub use ext::Bytes;
pub use server::{Server, ServerConfig, LIST_BURST};

use super::messages::{MavAutopilot, MavParamType};
use crate::mavlink::CharArray;

/// A parameter name: up to 16 bytes, NUL-padded.
pub type Name = CharArray<16>;

/// Which messages a client speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Protocol {
    /// PARAM_REQUEST_LIST, PARAM_REQUEST_READ, PARAM_SET and PARAM_VALUE: every autopilot's.
    #[default]
    V1,
    /// PARAM_EXT_REQUEST_LIST, PARAM_EXT_REQUEST_READ, PARAM_EXT_SET, PARAM_EXT_VALUE and
    /// PARAM_EXT_ACK: cameras', gimbals', and whatever has 64-bit parameters.
    Ext,
}

/// How integers travel in PARAM_VALUE's and PARAM_SET's `f32`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// The integer's bytes in the float's (little-endian) bytes, the rest zero: PX4, MAVSDK
    /// and the protocol's own rule.
    Bytewise,
    /// The number converted to `f32`, as a C cast: ArduPilot.
    CCast,
}

impl Encoding {
    /// The encoding an autopilot uses: C cast for ArduPilot, bytewise for every other.
    pub fn for_autopilot(autopilot: MavAutopilot) -> Self {
        match autopilot {
            MavAutopilot::Ardupilotmega => Encoding::CCast,
            _ => Encoding::Bytewise,
        }
    }
}

/// A parameter value: one of the numeric types of MAV_PARAM_TYPE and MAV_PARAM_EXT_TYPE.
///
/// PARAM_VALUE's `f32` carries the seven types up to 32 bits; the 64-bit ones travel whole
/// only in PARAM_EXT_VALUE ([`Protocol::Ext`]). A server's PARAM_VALUE for a 64-bit parameter
/// gives its number rounded to `f32`, which a client does not take as the value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// MAV_PARAM_TYPE_UINT8.
    U8(u8),
    /// MAV_PARAM_TYPE_INT8.
    I8(i8),
    /// MAV_PARAM_TYPE_UINT16.
    U16(u16),
    /// MAV_PARAM_TYPE_INT16.
    I16(i16),
    /// MAV_PARAM_TYPE_UINT32.
    U32(u32),
    /// MAV_PARAM_TYPE_INT32.
    I32(i32),
    /// MAV_PARAM_TYPE_REAL32.
    F32(f32),
    // The 64-bit types last: `is_wide` is one comparison.
    /// MAV_PARAM_TYPE_UINT64.
    U64(u64),
    /// MAV_PARAM_TYPE_INT64.
    I64(i64),
    /// MAV_PARAM_TYPE_REAL64.
    F64(f64),
}

impl Value {
    /// The MAV_PARAM_TYPE.
    pub fn param_type(self) -> MavParamType {
        match self {
            Value::U8(_) => MavParamType::Uint8,
            Value::I8(_) => MavParamType::Int8,
            Value::U16(_) => MavParamType::Uint16,
            Value::I16(_) => MavParamType::Int16,
            Value::U32(_) => MavParamType::Uint32,
            Value::I32(_) => MavParamType::Int32,
            Value::U64(_) => MavParamType::Uint64,
            Value::I64(_) => MavParamType::Int64,
            Value::F32(_) => MavParamType::Real32,
            Value::F64(_) => MavParamType::Real64,
        }
    }

    /// The value in PARAM_VALUE's `f32`. A 64-bit value, which the float cannot carry, is its
    /// number rounded to `f32` in either encoding.
    pub fn encode(self, encoding: Encoding) -> f32 {
        match self {
            Value::U64(v) => v as f32,
            Value::I64(v) => v as f32,
            Value::F64(v) => v as f32,
            narrow => narrow.encode_narrow(encoding).unwrap_or_default(),
        }
    }

    /// [`Value::encode`] for the types of 32 bits or fewer; `None` for the wider ones (whose
    /// conversions a single-precision FPU does in software).
    pub fn encode_narrow(self, encoding: Encoding) -> Option<f32> {
        Some(match (encoding, self) {
            (_, Value::F32(v)) => v,
            (Encoding::Bytewise, Value::U8(v)) => f32::from_bits(u32::from(v)),
            (Encoding::Bytewise, Value::I8(v)) => f32::from_bits(u32::from(v as u8)),
            (Encoding::Bytewise, Value::U16(v)) => f32::from_bits(u32::from(v)),
            (Encoding::Bytewise, Value::I16(v)) => f32::from_bits(u32::from(v as u16)),
            (Encoding::Bytewise, Value::U32(v)) => f32::from_bits(v),
            (Encoding::Bytewise, Value::I32(v)) => f32::from_bits(v as u32),
            (Encoding::CCast, Value::U8(v)) => f32::from(v),
            (Encoding::CCast, Value::I8(v)) => f32::from(v),
            (Encoding::CCast, Value::U16(v)) => f32::from(v),
            (Encoding::CCast, Value::I16(v)) => f32::from(v),
            (Encoding::CCast, Value::U32(v)) => v as f32,
            (Encoding::CCast, Value::I32(v)) => v as f32,
            (_, Value::U64(_) | Value::I64(_) | Value::F64(_)) => return None,
        })
    }

    /// The value of type `ty` in PARAM_VALUE's `raw`; `None` for the 64-bit types and unknown
    /// ones, which a 4-byte float cannot carry.
    pub fn decode(raw: f32, ty: MavParamType, encoding: Encoding) -> Option<Self> {
        let bits = raw.to_bits();
        Some(match (encoding, ty) {
            (_, MavParamType::Real32) => Value::F32(raw),
            (Encoding::Bytewise, MavParamType::Uint8) => Value::U8(bits as u8),
            (Encoding::Bytewise, MavParamType::Int8) => Value::I8(bits as u8 as i8),
            (Encoding::Bytewise, MavParamType::Uint16) => Value::U16(bits as u16),
            (Encoding::Bytewise, MavParamType::Int16) => Value::I16(bits as u16 as i16),
            (Encoding::Bytewise, MavParamType::Uint32) => Value::U32(bits),
            (Encoding::Bytewise, MavParamType::Int32) => Value::I32(bits as i32),
            // `as` from a float truncates toward zero and saturates, as the C cast's defined cases.
            (Encoding::CCast, MavParamType::Uint8) => Value::U8(raw as u8),
            (Encoding::CCast, MavParamType::Int8) => Value::I8(raw as i8),
            (Encoding::CCast, MavParamType::Uint16) => Value::U16(raw as u16),
            (Encoding::CCast, MavParamType::Int16) => Value::I16(raw as i16),
            (Encoding::CCast, MavParamType::Uint32) => Value::U32(raw as u32),
            (Encoding::CCast, MavParamType::Int32) => Value::I32(raw as i32),
            _ => return None,
        })
    }

    /// The value as a number (the 64-bit integers rounded to `f64` beyond 2⁵³).
    pub fn as_f64(self) -> f64 {
        match self {
            Value::F32(v) => f64::from(v),
            Value::F64(v) => v,
            Value::U64(v) => v as f64,
            Value::I64(v) => v as f64,
            other => other.integer().map_or(0.0, |n| n as f64),
        }
    }

    /// The number of an integer value; `None` for the floats.
    pub fn integer(self) -> Option<i128> {
        Some(match self {
            Value::U8(v) => i128::from(v),
            Value::I8(v) => i128::from(v),
            Value::U16(v) => i128::from(v),
            Value::I16(v) => i128::from(v),
            Value::U32(v) => i128::from(v),
            Value::I32(v) => i128::from(v),
            Value::U64(v) => i128::from(v),
            Value::I64(v) => i128::from(v),
            Value::F32(_) | Value::F64(_) => return None,
        })
    }

    /// `v` as type `ty`, if it is exactly representable there (an integer in range for the
    /// integer types; any number for the floats, REAL32 rounded to the nearest `f32`).
    pub fn from_f64(ty: MavParamType, v: f64) -> Option<Self> {
        match ty {
            MavParamType::Real32 => Some(Value::F32(v as f32)),
            _ => Value::F64(v).convert(ty),
        }
    }

    /// This value as type `ty`, if the number is exactly representable there: an integer in
    /// range for the integer types; any number for the floats, rounded to nearest.
    ///
    /// No `f64` arithmetic between types up to 32 bits: a single-precision FPU (a
    /// Cortex-M4's) does `f64` in software, kilobytes of it in a firmware that serves
    /// parameters.
    pub fn convert(self, ty: MavParamType) -> Option<Self> {
        if self.param_type() == ty {
            return Some(self);
        }
        if !self.is_wide() && !is_wide(ty) {
            return self.convert_narrow(ty);
        }
        let n = match self {
            Value::F32(v) => match ty {
                MavParamType::Real64 => return Some(Value::F64(f64::from(v))),
                _ => f64_integer(f64::from(v))?,
            },
            Value::F64(v) => match ty {
                MavParamType::Real32 => return Some(Value::F32(v as f32)),
                _ => f64_integer(v)?,
            },
            other => other.integer()?,
        };
        Some(match ty {
            MavParamType::Uint8 => Value::U8(n.try_into().ok()?),
            MavParamType::Int8 => Value::I8(n.try_into().ok()?),
            MavParamType::Uint16 => Value::U16(n.try_into().ok()?),
            MavParamType::Int16 => Value::I16(n.try_into().ok()?),
            MavParamType::Uint32 => Value::U32(n.try_into().ok()?),
            MavParamType::Int32 => Value::I32(n.try_into().ok()?),
            MavParamType::Uint64 => Value::U64(n.try_into().ok()?),
            MavParamType::Int64 => Value::I64(n.try_into().ok()?),
            // An integer of 64 bits or fewer (the floats came back above), rounded to nearest
            // once: `i64` and `u64` convert with one rounding.
            MavParamType::Real32 => Value::F32(match i64::try_from(n) {
                Ok(i) => i as f32,
                Err(_) => n as u64 as f32,
            }),
            MavParamType::Real64 => Value::F64(match i64::try_from(n) {
                Ok(i) => i as f64,
                Err(_) => n as u64 as f64,
            }),
            _ => return None,
        })
    }

    /// [`Value::convert`] between the types of 32 bits or fewer, in `i64` and `f32`; `None`
    /// when either type is wider.
    pub fn convert_narrow(self, ty: MavParamType) -> Option<Self> {
        if self.param_type() == ty {
            return Some(self);
        }
        let n = match self {
            Value::U8(v) => i64::from(v),
            Value::I8(v) => i64::from(v),
            Value::U16(v) => i64::from(v),
            Value::I16(v) => i64::from(v),
            Value::U32(v) => i64::from(v),
            Value::I32(v) => i64::from(v),
            Value::F32(v) => f32_integer32(v)?,
            Value::U64(_) | Value::I64(_) | Value::F64(_) => return None,
        };
        Some(match ty {
            MavParamType::Uint8 => Value::U8(n.try_into().ok()?),
            MavParamType::Int8 => Value::I8(n.try_into().ok()?),
            MavParamType::Uint16 => Value::U16(n.try_into().ok()?),
            MavParamType::Int16 => Value::I16(n.try_into().ok()?),
            MavParamType::Uint32 => Value::U32(n.try_into().ok()?),
            MavParamType::Int32 => Value::I32(n.try_into().ok()?),
            // An integer of 32 bits or fewer (a REAL32 came back above): rounded to nearest.
            MavParamType::Real32 => Value::F32(match i32::try_from(n) {
                Ok(i) => i as f32,
                Err(_) => n as u32 as f32,
            }),
            _ => return None,
        })
    }

    /// Whether the value is of a 64-bit type.
    pub fn is_wide(self) -> bool {
        matches!(self, Value::U64(_) | Value::I64(_) | Value::F64(_))
    }

    /// Equal type and bits (a NaN equals itself, 0.0 differs from -0.0).
    pub fn same(self, other: Self) -> bool {
        match (self, other) {
            (Value::F32(a), Value::F32(b)) => a.to_bits() == b.to_bits(),
            (Value::F64(a), Value::F64(b)) => a.to_bits() == b.to_bits(),
            (a, b) => a == b,
        }
    }
}

/// Integers as integers, floats as the shortest text that reads back as the same value.
impl core::fmt::Display for Value {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Value::F32(v) => write!(f, "{v:?}"),
            Value::F64(v) => write!(f, "{v:?}"),
            other => write!(f, "{}", other.integer().unwrap_or_default()),
        }
    }
}

/// Whether `ty` is one of the 64-bit types, which PARAM_VALUE cannot carry (PARAM_EXT_VALUE
/// does).
pub fn is_wide(ty: MavParamType) -> bool {
    matches!(
        ty,
        MavParamType::Uint64 | MavParamType::Int64 | MavParamType::Real64
    )
}

/// `v` as an integer, if it is one and within `i32::MIN..=u32::MAX` (beyond, no integer type
/// of 32 bits or fewer holds it), in the FPU's own conversions.
fn f32_integer32(v: f32) -> Option<i64> {
    if v < 0.0 {
        let i = v as i32;
        (i as f32 == v).then_some(i64::from(i))
    } else if v < 4_294_967_296.0 {
        let u = v as u32;
        (u as f32 == v).then_some(i64::from(u))
    } else {
        // Too large, or NaN.
        None
    }
}

/// `v` as an integer, if it is one and within `i64::MIN..=u64::MAX` (beyond, no integer type
/// holds it). `as` saturates, so the round trip is exact only in range.
fn f64_integer(v: f64) -> Option<i128> {
    if v < 0.0 {
        let i = v as i64;
        (i as f64 == v).then_some(i128::from(i))
    } else if v < 18_446_744_073_709_551_616.0 {
        let u = v as u64;
        (u as f64 == v).then_some(i128::from(u))
    } else {
        None
    }
}

/// One parameter: its name and value. A slice of them is a [`Store`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    /// The name.
    pub name: Name,
    /// The value, whose type is the parameter's.
    pub value: Value,
}

/// Where a [`Server`] keeps its parameters. Indices are `0..count()`.
pub trait Store {
    /// Whether the server answers PARAM_EXT_* for this store, and its parameters may be of the
    /// 64-bit types. `true` unless the store says otherwise: a firmware whose parameters are
    /// all of 32 bits or fewer, and that speaks PARAM_* only, says `false`, and the server's
    /// code for the rest (some kilobytes, with `f64` done in software on a single-precision
    /// FPU) is left out.
    const EXTENDED: bool = true;

    /// How many parameters there are.
    fn count(&self) -> u16;
    /// Parameter `index`.
    fn get(&self, index: u16) -> Option<Param>;
    /// The index of the parameter called `name`.
    fn index_of(&self, name: &Name) -> Option<u16>;
    /// Sets parameter `index` to `value` (already of the parameter's type) and returns the
    /// value it now holds; `None` if it refused (read-only, out of limits).
    fn set(&mut self, index: u16, value: Value) -> Option<Value>;
}

impl Store for [Param] {
    fn count(&self) -> u16 {
        self.len().min(usize::from(u16::MAX)) as u16
    }

    fn get(&self, index: u16) -> Option<Param> {
        self.get(usize::from(index)).copied()
    }

    fn index_of(&self, name: &Name) -> Option<u16> {
        self.iter()
            .position(|p| p.name == *name)
            .and_then(|i| u16::try_from(i).ok())
    }

    fn set(&mut self, index: u16, value: Value) -> Option<Value> {
        let p = self.get_mut(usize::from(index))?;
        p.value = value;
        Some(value)
    }
}

/// A PARAM_VALUE as a client understood it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Received {
    /// The name.
    pub name: Name,
    /// The index (`u16::MAX` for values outside the list, such as PX4's `_HASH_CHECK`, and
    /// for PARAM_EXT_ACK, which carries none).
    pub index: u16,
    /// How many parameters the sender has (0 from PARAM_EXT_ACK, which does not say).
    pub count: u16,
    /// The value, decoded with the sender's encoding; `None` for a type a float cannot carry
    /// (PARAM_VALUE of a 64-bit type), for PARAM_EXT's CUSTOM type, and for a set the target
    /// refused by PARAM_EXT_ACK.
    pub value: Option<Value>,
    /// A PARAM_EXT CUSTOM value's 128 bytes (its meaning is the target's own; `value` is
    /// `None`).
    pub custom: Option<Bytes>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;
    use std::vec;
    use std::vec::Vec;

    const TYPES: [MavParamType; 11] = [
        MavParamType::Uint8,
        MavParamType::Int8,
        MavParamType::Uint16,
        MavParamType::Int16,
        MavParamType::Uint32,
        MavParamType::Int32,
        MavParamType::Uint64,
        MavParamType::Int64,
        MavParamType::Real32,
        MavParamType::Real64,
        MavParamType::Unknown(42),
    ];

    /// Values of every type: the integer types' edges and their neighbours, floats around
    /// them, fractions, specials, and a pseudo-random spread of bit patterns.
    fn values() -> Vec<Value> {
        let mut ints: Vec<i64> = vec![0, 1, -1, 2, -2, 100, -100];
        for k in [7, 8, 15, 16, 24, 25, 31, 32, 53, 54, 62] {
            let p = 1i64 << k;
            ints.extend([p - 1, p, p + 1, -p - 1, -p, -p + 1]);
        }
        ints.extend([i64::MAX, i64::MIN, i64::MIN + 1]);
        let mut x = 0x2545_f491u32;
        let mut out = Vec::new();
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            ints.push(i64::from(x as i32));
            ints.push(i64::from(x));
            ints.push(i64::from(x) << 31 | i64::from(x >> 7));
            out.push(Value::F32(f32::from_bits(x)));
            out.push(Value::F64(f64::from_bits(
                u64::from(x) << 32 | u64::from(!x),
            )));
            out.push(Value::U64(u64::from(x) << 33 | 0x1_0000_0001));
        }
        for &i in &ints {
            out.extend(u8::try_from(i).ok().map(Value::U8));
            out.extend(i8::try_from(i).ok().map(Value::I8));
            out.extend(u16::try_from(i).ok().map(Value::U16));
            out.extend(i16::try_from(i).ok().map(Value::I16));
            out.extend(u32::try_from(i).ok().map(Value::U32));
            out.extend(i32::try_from(i).ok().map(Value::I32));
            out.extend(u64::try_from(i).ok().map(Value::U64));
            out.push(Value::I64(i));
            let f = i as f32;
            out.extend([f, -f, f + 0.5, f - 0.5, f.next_up(), f.next_down()].map(Value::F32));
            let d = i as f64;
            out.extend([d, -d, d + 0.5, d.next_up(), d.next_down()].map(Value::F64));
        }
        out.extend(
            [
                -0.0,
                0.25,
                f32::MIN_POSITIVE,
                f32::MAX,
                f32::MIN,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::NAN,
                4_294_967_296.0,
                -2_147_483_648.0,
                -2_147_483_904.0,
                18_446_744_073_709_551_616.0,
                -9_223_372_036_854_775_808.0,
            ]
            .map(Value::F32),
        );
        out.extend([u64::MAX, u64::MAX - 1].map(Value::U64));
        out.extend(
            [
                f64::NAN,
                f64::INFINITY,
                -0.0,
                1e300,
                f64::from(f32::MAX) * 2.0,
                18_446_744_073_709_551_616.0,
                18_446_744_073_709_549_568.0,
            ]
            .map(Value::F64),
        );
        out
    }

    /// The number a value stands for, exactly: an integer, or a float as `f64` (which holds
    /// every `f32`).
    enum Number {
        Int(i128),
        Float(f64),
    }

    /// [`Value::convert`] done the plain way, in `i128` and `f64`.
    fn reference(v: Value, ty: MavParamType) -> Option<Value> {
        if v.param_type() == ty {
            return Some(v);
        }
        let n = match v {
            Value::F32(f) => Number::Float(f64::from(f)),
            Value::F64(f) => Number::Float(f),
            other => Number::Int(other.integer().unwrap()),
        };
        let int = || match n {
            Number::Int(i) => Some(i),
            Number::Float(f) if f.is_finite() && f == f.trunc() && f.abs() < 1e30 => {
                Some(f as i128)
            }
            Number::Float(_) => None,
        };
        Some(match ty {
            MavParamType::Uint8 => Value::U8(int()?.try_into().ok()?),
            MavParamType::Int8 => Value::I8(int()?.try_into().ok()?),
            MavParamType::Uint16 => Value::U16(int()?.try_into().ok()?),
            MavParamType::Int16 => Value::I16(int()?.try_into().ok()?),
            MavParamType::Uint32 => Value::U32(int()?.try_into().ok()?),
            MavParamType::Int32 => Value::I32(int()?.try_into().ok()?),
            MavParamType::Uint64 => Value::U64(int()?.try_into().ok()?),
            MavParamType::Int64 => Value::I64(int()?.try_into().ok()?),
            MavParamType::Real32 => Value::F32(match n {
                Number::Int(i) => i as f32,
                Number::Float(f) => f as f32,
            }),
            MavParamType::Real64 => Value::F64(match n {
                Number::Int(i) => i as f64,
                Number::Float(f) => f,
            }),
            _ => return None,
        })
    }

    #[test]
    fn convert_is_the_plain_conversion() {
        for v in values() {
            for ty in TYPES {
                let want = reference(v, ty);
                let got = v.convert(ty);
                let same = match (got, want) {
                    (Some(a), Some(b)) => a.same(b),
                    (None, None) => true,
                    _ => false,
                };
                assert!(same, "{v:?} as {ty:?}: {got:?}, want {want:?}");
            }
        }
    }

    #[test]
    fn display_is_exact() {
        assert_eq!(Value::U64(u64::MAX).to_string(), "18446744073709551615");
        assert_eq!(Value::I64(i64::MIN).to_string(), "-9223372036854775808");
        assert_eq!(Value::I8(-5).to_string(), "-5");
        assert_eq!(Value::F32(0.1).to_string(), "0.1");
        assert_eq!(Value::F64(0.1).to_string(), "0.1");
        assert_eq!(Value::F32(2.0).to_string(), "2.0");
    }
}
