//! `char[N]` fields: a fixed-size, NUL-padded byte string.

use crate::wire::Wire;

/// A MAVLink `char[N]` field: exactly `N` bytes on the wire, NUL-padded, not necessarily
/// NUL-terminated. Round trips are byte-exact, including bytes after the first NUL.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CharArray<const N: usize>(pub [u8; N]);

impl<const N: usize> CharArray<N> {
    /// All bytes, including padding.
    pub const fn as_bytes(&self) -> &[u8; N] {
        &self.0
    }

    /// The text up to the first NUL (all `N` bytes if there is none).
    pub fn text_bytes(&self) -> &[u8] {
        let end = self.0.iter().position(|&b| b == 0).unwrap_or(N);
        &self.0[..end]
    }

    /// The text up to the first NUL, or up to the first byte that is not valid UTF-8.
    pub fn as_str(&self) -> &str {
        let bytes = self.text_bytes();
        match core::str::from_utf8(bytes) {
            Ok(s) => s,
            Err(e) => core::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default(),
        }
    }

    /// Copies `bytes` in, cut at `N` and NUL-padded.
    pub fn from_bytes(bytes: &[u8]) -> Self {
        Self(crate::wire::zero_extend(bytes))
    }
}

impl<const N: usize> Default for CharArray<N> {
    fn default() -> Self {
        Self([0; N])
    }
}

impl<const N: usize> From<&str> for CharArray<N> {
    /// Copies the string in, cut at `N` bytes and NUL-padded.
    fn from(s: &str) -> Self {
        Self::from_bytes(s.as_bytes())
    }
}

impl<const N: usize> core::fmt::Debug for CharArray<N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Debug::fmt(self.as_str(), f)
    }
}

impl<const N: usize> core::fmt::Display for CharArray<N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl<const N: usize> Wire for CharArray<N> {
    const SIZE: usize = N;
    #[inline(always)]
    fn read(bytes: &[u8]) -> Self {
        let mut out = [0u8; N];
        out.copy_from_slice(&bytes[..N]);
        Self(out)
    }
    #[inline(always)]
    fn write(self, bytes: &mut [u8]) {
        bytes[..N].copy_from_slice(&self.0);
    }
}

#[cfg(feature = "serde")]
impl<const N: usize> serde::Serialize for CharArray<N> {
    /// As pymavlink's `to_dict()`: the text cut at the first NUL.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

#[cfg(feature = "serde")]
impl<'de, const N: usize> serde::Deserialize<'de> for CharArray<N> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<const N: usize> serde::de::Visitor<'_> for V<N> {
            type Value = CharArray<N>;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                write!(f, "a string of at most {N} bytes")
            }
            fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<Self::Value, E> {
                if s.len() > N {
                    return Err(E::invalid_length(s.len(), &self));
                }
                Ok(CharArray::from(s))
            }
        }
        d.deserialize_str(V::<N>)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_stops_at_nul_but_bytes_round_trip() {
        let c = CharArray::<6>(*b"ab\0cd\0");
        assert_eq!(c.as_str(), "ab");
        let mut buf = [0u8; 6];
        c.write(&mut buf);
        assert_eq!(CharArray::<6>::read(&buf), c);
    }

    #[test]
    fn full_length_without_nul() {
        let c = CharArray::<3>::from("abcdef");
        assert_eq!(c.as_bytes(), b"abc");
        assert_eq!(c.as_str(), "abc");
    }

    #[test]
    fn invalid_utf8_keeps_valid_prefix() {
        let c = CharArray::<4>([b'o', b'k', 0xFF, b'x']);
        assert_eq!(c.as_str(), "ok");
    }
}
