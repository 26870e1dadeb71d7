//! PARAM_EXT_*: the extended parameter protocol, as cameras and gimbals speak it.
//!
//! A value travels as its own little-endian bytes at the start of a 128-byte field (the rest
//! zero), typed by MAV_PARAM_EXT_TYPE, so the 64-bit types keep every bit and no encoding has
//! to be agreed. A set is answered by PARAM_EXT_ACK: ACCEPTED with the new value, or another
//! result with the value held; IN_PROGRESS says the answer will follow.
//!
//! MAV_PARAM_EXT_TYPE_CUSTOM (128 bytes of the server's own meaning) is not a [`Value`]: a
//! client gets such a value's bytes in [`super::Received::custom`] and sets them with
//! [`super::Client::set_custom`]. The [`super::Server`] serves [`Value`]s only, and refuses a
//! set of CUSTOM bytes (VALUE_UNSUPPORTED).

use super::super::messages::{MavParamExtType, MavParamType};
use super::Value;
use crate::mavlink::CharArray;

/// PARAM_EXT_VALUE's, PARAM_EXT_SET's and PARAM_EXT_ACK's `param_value`.
pub type Bytes = CharArray<128>;

impl Value {
    /// The MAV_PARAM_EXT_TYPE (the same number as the MAV_PARAM_TYPE).
    pub fn ext_type(self) -> MavParamExtType {
        MavParamExtType::from_raw(self.param_type().raw())
    }

    /// The value as PARAM_EXT_* carry it.
    pub fn to_ext(self) -> Bytes {
        // The value's bits, zero-extended: its little-endian bytes, then zeros.
        let bits = match self {
            Value::U8(v) => u64::from(v),
            Value::I8(v) => u64::from(v as u8),
            Value::U16(v) => u64::from(v),
            Value::I16(v) => u64::from(v as u16),
            Value::U32(v) => u64::from(v),
            Value::I32(v) => u64::from(v as u32),
            Value::U64(v) => v,
            Value::I64(v) => v as u64,
            Value::F32(v) => u64::from(v.to_bits()),
            Value::F64(v) => v.to_bits(),
        };
        CharArray::from_bytes(&bits.to_le_bytes())
    }

    /// The value of type `ty` in `bytes`; `None` for CUSTOM and unknown types.
    pub fn from_ext(bytes: &Bytes, ty: MavParamExtType) -> Option<Self> {
        let mut le = [0u8; 8];
        le.copy_from_slice(&bytes.0[..8]);
        // Each type's bytes are the low bytes of these.
        let bits = u64::from_le_bytes(le);
        Some(match MavParamType::from_raw(ty.raw()) {
            MavParamType::Uint8 => Value::U8(bits as u8),
            MavParamType::Int8 => Value::I8(bits as i8),
            MavParamType::Uint16 => Value::U16(bits as u16),
            MavParamType::Int16 => Value::I16(bits as i16),
            MavParamType::Uint32 => Value::U32(bits as u32),
            MavParamType::Int32 => Value::I32(bits as i32),
            MavParamType::Uint64 => Value::U64(bits),
            MavParamType::Int64 => Value::I64(bits as i64),
            MavParamType::Real32 => Value::F32(f32::from_bits(bits as u32)),
            MavParamType::Real64 => Value::F64(f64::from_bits(bits)),
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_round_trips_bit_for_bit() {
        let values = [
            Value::U8(0xfe),
            Value::I8(-2),
            Value::U16(0xbeef),
            Value::I16(-32768),
            Value::U32(0xdead_beef),
            Value::I32(i32::MIN),
            Value::U64(u64::MAX - 1),
            Value::I64(i64::MIN + 3),
            Value::F32(-0.0),
            Value::F32(f32::from_bits(0x7fc0_1234)),
            Value::F64(core::f64::consts::PI),
            Value::F64(f64::from_bits(0xfff8_0000_0000_0001)),
        ];
        for v in values {
            let bytes = v.to_ext();
            let back = Value::from_ext(&bytes, v.ext_type()).unwrap();
            assert!(back.same(v), "{v:?} came back as {back:?}");
            assert_eq!(v.ext_type().raw(), v.param_type().raw());
        }
        // Little-endian, at the start, the rest zero.
        let b = Value::U64(0x0102_0304_0506_0708).to_ext();
        assert_eq!(b.0[..9], [8, 7, 6, 5, 4, 3, 2, 1, 0]);
        assert!(b.0[8..].iter().all(|&x| x == 0));
        assert_eq!(Value::from_ext(&b, MavParamExtType::Custom), None);
    }
}
