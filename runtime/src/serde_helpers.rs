//! serde adapters for the pymavlink `to_dict()` JSON form, used by generated code through
//! `#[serde(with = ...)]`.

/// Fixed-size arrays of any length as JSON lists (serde's own impls stop at 32).
pub mod array {
    use core::fmt;
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Serializes as a list.
    pub fn serialize<S: Serializer, T: Serialize, const N: usize>(
        v: &[T; N],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(N)?;
        for item in v {
            t.serialize_element(item)?;
        }
        t.end()
    }

    /// Deserializes a list of exactly `N` items.
    pub fn deserialize<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de> + Default + Copy,
    {
        struct V<T, const N: usize>(core::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de> + Default + Copy, const N: usize> Visitor<'de> for V<T, N> {
            type Value = [T; N];
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "a list of {N} items")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut out = [T::default(); N];
                for (i, slot) in out.iter_mut().enumerate() {
                    *slot = seq
                        .next_element()?
                        .ok_or_else(|| A::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<T>()?.is_some() {
                    return Err(A::Error::invalid_length(N + 1, &self));
                }
                Ok(out)
            }
        }
        d.deserialize_tuple(N, V::<T, N>(core::marker::PhantomData))
    }
}

/// A single `char` field (one byte) as a one-character string, `""` for 0.
pub mod char {
    use serde::{Deserializer, Serializer};

    /// Serializes the byte as a one-character string.
    pub fn serialize<S: Serializer>(v: &u8, s: S) -> Result<S::Ok, S::Error> {
        let buf = [*v];
        let text = if *v == 0 {
            ""
        } else {
            core::str::from_utf8(&buf).unwrap_or("\u{fffd}")
        };
        s.serialize_str(text)
    }

    /// Deserializes a string of at most one byte.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<u8, D::Error> {
        let c = <crate::mavlink::CharArray<1> as serde::Deserialize>::deserialize(d)?;
        Ok(c.0[0])
    }
}

/// A `float` field shown as pymavlink shows it: the exact value as a double.
pub mod f32 {
    use serde::{Deserialize, Deserializer, Serializer};

    /// Serializes the exact value as an `f64`.
    pub fn serialize<S: Serializer>(v: &f32, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(f64::from(*v))
    }

    /// Deserializes a number, rounding to the nearest `f32`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
        f64::deserialize(d).map(|v| v as f32)
    }
}

/// `float[N]` fields as lists of exact doubles.
pub mod f32_array {
    use serde::ser::SerializeTuple;
    use serde::{Deserializer, Serializer};

    /// Serializes as a list of `f64`.
    pub fn serialize<S: Serializer, const N: usize>(v: &[f32; N], s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(N)?;
        for item in v {
            t.serialize_element(&f64::from(*item))?;
        }
        t.end()
    }

    /// Deserializes a list of exactly `N` numbers.
    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<[f32; N], D::Error> {
        let wide: [f64; N] = super::array::deserialize(d)?;
        Ok(wide.map(|v| v as f32))
    }
}

/// An enum or bitmask carried in a signed integer field, as pymavlink shows it: the field's
/// signed value (`-19` for the byte 0xED in an `int8_t`). Deserializing takes the signed value,
/// or the unsigned one of the same width, so JSON written either way reads back to the same
/// bits; anything outside both ranges is an error.
macro_rules! signed_enum {
    ($(#[$doc:meta])* $module:ident, $bits:literal) => {
        $(#[$doc])*
        pub mod $module {
            use serde::{Deserializer, Serializer};

            use crate::wire::Enum;

            /// Serializes the field's signed value.
            pub fn serialize<S: Serializer, E: Enum>(v: &E, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_i64(super::signed_value(v.bits(), $bits))
            }

            /// Deserializes a signed (or same-width unsigned) integer into the enum's bits.
            pub fn deserialize<'de, D: Deserializer<'de>, E: Enum>(d: D) -> Result<E, D::Error> {
                super::signed_enum_bits(d, $bits).map(E::from_bits)
            }
        }
    };
}

signed_enum!(
    /// An enum on an `int8_t` field.
    signed_enum_8,
    8
);
signed_enum!(
    /// An enum on an `int16_t` field.
    signed_enum_16,
    16
);
signed_enum!(
    /// An enum on an `int32_t` field.
    signed_enum_32,
    32
);
signed_enum!(
    /// An enum on an `int64_t` field.
    signed_enum_64,
    64
);

/// The low `width` bits of `bits` as a signed number.
fn signed_value(bits: u64, width: u32) -> i64 {
    let shift = 64 - width;
    ((bits << shift) as i64) >> shift
}

/// Reads an integer that fits `width` bits signed or unsigned, as raw bits sign-extended the way
/// the wire decoder hands them to enums.
fn signed_enum_bits<'de, D: serde::Deserializer<'de>>(d: D, width: u32) -> Result<u64, D::Error> {
    use core::fmt;
    use serde::de::{Error, Unexpected, Visitor};

    struct V(u32);
    impl Visitor<'_> for V {
        type Value = u64;
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            write!(f, "an integer of {} bits, signed or unsigned", self.0)
        }
        fn visit_i64<E: Error>(self, v: i64) -> Result<u64, E> {
            let min = i64::MIN >> (64 - self.0);
            if v < min {
                return Err(E::invalid_value(Unexpected::Signed(v), &self));
            }
            if v < 0 {
                return Ok(v as u64);
            }
            self.visit_u64(v as u64)
        }
        fn visit_u64<E: Error>(self, v: u64) -> Result<u64, E> {
            let max = u64::MAX >> (64 - self.0);
            if v > max {
                return Err(E::invalid_value(Unexpected::Unsigned(v), &self));
            }
            Ok(signed_value(v, self.0) as u64)
        }
    }
    d.deserialize_i64(V(width))
}

#[cfg(test)]
mod tests {
    use super::{signed_enum_bits, signed_value};
    use serde::de::value::{Error, I64Deserializer, U64Deserializer};

    #[test]
    fn signed_values_and_bits_agree() {
        assert_eq!(signed_value(0xED, 8), -19);
        assert_eq!(signed_value(0x7F, 8), 127);
        assert_eq!(signed_value(0xFFFF_FFFF_FFFF_FFED, 8), -19);
        assert_eq!(signed_value(u64::MAX, 64), -1);
        let bits = |v: i64, w| signed_enum_bits(I64Deserializer::<Error>::new(v), w);
        assert_eq!(bits(-19, 8).unwrap(), (-19i64) as u64);
        assert_eq!(bits(-128, 8).unwrap(), (-128i64) as u64);
        assert!(bits(-129, 8).is_err());
        assert_eq!(bits(5, 8).unwrap(), 5);
        let ubits = |v: u64, w| signed_enum_bits(U64Deserializer::<Error>::new(v), w);
        assert_eq!(ubits(0xED, 8).unwrap(), (-19i64) as u64);
        assert!(ubits(256, 8).is_err());
        assert_eq!(ubits(u64::MAX, 64).unwrap(), u64::MAX);
    }
}
