//! The parameter protocol: PARAM_REQUEST_LIST, PARAM_REQUEST_READ, PARAM_SET, PARAM_VALUE.
//!
//! PARAM_VALUE carries every value in one `f32`. Integers get there in one of two ways
//! ([`Encoding`]): PX4 and most autopilots copy the integer's bytes into the float
//! ("bytewise"), ArduPilot converts the number (a C cast). A client picks the target's way from
//! its HEARTBEAT (`autopilot`), unless told otherwise.
//!
//! [`Client`] fetches the whole list and re-requests by index what the stream left out, until
//! it holds `param_count` values; it reads and sets single parameters with retries. A stream
//! that starts again mid-list, or a count that changes, does not confuse it: it keeps a bitmap
//! of the indices it holds, `32 × W` of them.
//!
//! [`Server`] answers from a [`Store`] the caller implements (a slice of [`Param`] is one).

mod client;
pub mod hash;
mod server;

pub use client::{Client, ClientConfig, Event};
pub use server::{Server, ServerConfig};

use super::messages::{MavAutopilot, MavParamType};
use crate::mavlink::CharArray;

/// A parameter name: up to 16 bytes, NUL-padded.
pub type Name = CharArray<16>;

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

/// A parameter value of one of the types PARAM_VALUE carries.
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
            Value::F32(_) => MavParamType::Real32,
        }
    }

    /// The value in PARAM_VALUE's `f32`.
    pub fn encode(self, encoding: Encoding) -> f32 {
        match encoding {
            Encoding::Bytewise => f32::from_bits(match self {
                Value::U8(v) => u32::from(v),
                Value::I8(v) => u32::from(v as u8),
                Value::U16(v) => u32::from(v),
                Value::I16(v) => u32::from(v as u16),
                Value::U32(v) => v,
                Value::I32(v) => v as u32,
                Value::F32(v) => return v,
            }),
            Encoding::CCast => match self {
                Value::U8(v) => f32::from(v),
                Value::I8(v) => f32::from(v),
                Value::U16(v) => f32::from(v),
                Value::I16(v) => f32::from(v),
                Value::U32(v) => v as f32,
                Value::I32(v) => v as f32,
                Value::F32(v) => v,
            },
        }
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

    /// The value as a number.
    pub fn as_f64(self) -> f64 {
        match self {
            Value::U8(v) => f64::from(v),
            Value::I8(v) => f64::from(v),
            Value::U16(v) => f64::from(v),
            Value::I16(v) => f64::from(v),
            Value::U32(v) => f64::from(v),
            Value::I32(v) => f64::from(v),
            Value::F32(v) => f64::from(v),
        }
    }

    /// `v` as type `ty`, if it is exactly representable there (an integer in range for the
    /// integer types; any number for REAL32, rounded to the nearest `f32`).
    pub fn from_f64(ty: MavParamType, v: f64) -> Option<Self> {
        fn int<T: TryFrom<i64>>(v: f64) -> Option<T> {
            // Integral and well inside i64: the cast is exact.
            if v.is_finite() && v == (v as i64) as f64 && v.abs() < 9.0e15 {
                T::try_from(v as i64).ok()
            } else {
                None
            }
        }
        Some(match ty {
            MavParamType::Uint8 => Value::U8(int(v)?),
            MavParamType::Int8 => Value::I8(int(v)?),
            MavParamType::Uint16 => Value::U16(int(v)?),
            MavParamType::Int16 => Value::I16(int(v)?),
            MavParamType::Uint32 => Value::U32(int(v)?),
            MavParamType::Int32 => Value::I32(int(v)?),
            MavParamType::Real32 => Value::F32(v as f32),
            _ => return None,
        })
    }

    /// This value as type `ty`, if the number is exactly representable there (an integer in
    /// range for the integer types; any number for REAL32, rounded to the nearest `f32`): what
    /// `Value::from_f64(ty, self.as_f64())` gives.
    ///
    /// Done in `i64` and `f32`, without `f64`: a single-precision FPU (a Cortex-M4's) does
    /// `f64` in software, kilobytes of it in a firmware that serves parameters.
    pub fn convert(self, ty: MavParamType) -> Option<Self> {
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
            Value::F32(v) => f32_integer(v)?,
        };
        Some(match ty {
            MavParamType::Uint8 => Value::U8(n.try_into().ok()?),
            MavParamType::Int8 => Value::I8(n.try_into().ok()?),
            MavParamType::Uint16 => Value::U16(n.try_into().ok()?),
            MavParamType::Int16 => Value::I16(n.try_into().ok()?),
            MavParamType::Uint32 => Value::U32(n.try_into().ok()?),
            MavParamType::Int32 => Value::I32(n.try_into().ok()?),
            // An integer of 32 bits or fewer (a REAL32 came back above): rounded to nearest,
            // as through `f64` (which holds it exactly).
            MavParamType::Real32 => Value::F32(match i32::try_from(n) {
                Ok(i) => i as f32,
                Err(_) => n as u32 as f32,
            }),
            _ => return None,
        })
    }

    /// Equal type and bits (a NaN equals itself, 0.0 differs from -0.0).
    pub fn same(self, other: Self) -> bool {
        match (self, other) {
            (Value::F32(a), Value::F32(b)) => a.to_bits() == b.to_bits(),
            (a, b) => a == b,
        }
    }
}

/// `v` as an integer, if it is one and within `i32::MIN..=u32::MAX` (beyond, no integer type
/// of PARAM_VALUE holds it). `as` saturates, so the round trip is exact only in range.
fn f32_integer(v: f32) -> Option<i64> {
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
    /// The index (`u16::MAX` for values outside the list, such as PX4's `_HASH_CHECK`).
    pub index: u16,
    /// How many parameters the sender has.
    pub count: u16,
    /// The value, decoded with the sender's encoding; `None` for a type a float cannot carry.
    pub value: Option<Value>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    const TYPES: [MavParamType; 9] = [
        MavParamType::Uint8,
        MavParamType::Int8,
        MavParamType::Uint16,
        MavParamType::Int16,
        MavParamType::Uint32,
        MavParamType::Int32,
        MavParamType::Real32,
        MavParamType::Uint64,
        MavParamType::Real64,
    ];

    /// Values of every type: the integer types' edges and their neighbours, floats around
    /// them, fractions, specials, and a pseudo-random spread of bit patterns.
    fn values() -> Vec<Value> {
        let mut ints: Vec<i64> = vec![0, 1, -1, 2, -2, 100, -100];
        for k in [7, 8, 15, 16, 24, 25, 31, 32] {
            let p = 1i64 << k;
            ints.extend([p - 1, p, p + 1, -p - 1, -p, -p + 1]);
        }
        let mut x = 0x2545_f491u32;
        let mut out = Vec::new();
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            ints.push(i64::from(x as i32));
            ints.push(i64::from(x));
            out.push(Value::F32(f32::from_bits(x)));
        }
        for &i in &ints {
            out.extend(u8::try_from(i).ok().map(Value::U8));
            out.extend(i8::try_from(i).ok().map(Value::I8));
            out.extend(u16::try_from(i).ok().map(Value::U16));
            out.extend(i16::try_from(i).ok().map(Value::I16));
            out.extend(u32::try_from(i).ok().map(Value::U32));
            out.extend(i32::try_from(i).ok().map(Value::I32));
            let f = i as f32;
            out.extend([f, -f, f + 0.5, f - 0.5, f.next_up(), f.next_down()].map(Value::F32));
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
            ]
            .map(Value::F32),
        );
        out
    }

    #[test]
    fn convert_is_the_conversion_through_f64() {
        for v in values() {
            for ty in TYPES {
                let want = if v.param_type() == ty {
                    Some(v)
                } else {
                    Value::from_f64(ty, v.as_f64())
                };
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
}
