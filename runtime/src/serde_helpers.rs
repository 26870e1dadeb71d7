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
