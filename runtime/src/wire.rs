//! Little-endian field access at fixed offsets, the only primitive generated encoders and
//! decoders use.
//!
//! Generated code calls [`get`] and [`put`] with constant offsets on fixed-size arrays, so after
//! inlining the compiler drops every bounds check and the code is straight-line loads and stores.

/// A value with a fixed little-endian wire representation of `SIZE` bytes.
pub trait Wire: Sized + Copy {
    /// Bytes on the wire.
    const SIZE: usize;
    /// Reads the value from the first `SIZE` bytes of `bytes`.
    fn read(bytes: &[u8]) -> Self;
    /// Writes the value into the first `SIZE` bytes of `bytes`.
    fn write(self, bytes: &mut [u8]);
}

macro_rules! wire_primitive {
    ($($t:ty),*) => {$(
        impl Wire for $t {
            const SIZE: usize = ::core::mem::size_of::<$t>();
            #[inline(always)]
            fn read(bytes: &[u8]) -> Self {
                let mut raw = [0u8; ::core::mem::size_of::<$t>()];
                raw.copy_from_slice(&bytes[..Self::SIZE]);
                <$t>::from_le_bytes(raw)
            }
            #[inline(always)]
            fn write(self, bytes: &mut [u8]) {
                bytes[..Self::SIZE].copy_from_slice(&self.to_le_bytes());
            }
        }
    )*};
}
wire_primitive!(u8, i8, u16, i16, u32, i32, u64, i64, f32, f64);

impl<T: Wire + Default, const N: usize> Wire for [T; N] {
    const SIZE: usize = T::SIZE * N;
    #[inline(always)]
    fn read(bytes: &[u8]) -> Self {
        let mut out = [T::default(); N];
        for (i, slot) in out.iter_mut().enumerate() {
            *slot = T::read(&bytes[i * T::SIZE..]);
        }
        out
    }
    #[inline(always)]
    fn write(self, bytes: &mut [u8]) {
        for (i, v) in self.into_iter().enumerate() {
            v.write(&mut bytes[i * T::SIZE..]);
        }
    }
}

/// Reads a `T` at byte offset `at`.
#[inline(always)]
pub fn get<T: Wire>(buf: &[u8], at: usize) -> T {
    T::read(&buf[at..at + T::SIZE])
}

/// Writes `value` at byte offset `at`.
#[inline(always)]
pub fn put<T: Wire>(buf: &mut [u8], at: usize, value: T) {
    value.write(&mut buf[at..at + T::SIZE]);
}

/// Copies `payload` into a zeroed `[u8; N]`: a short payload is zero-filled, a long one is cut.
///
/// This is how a receiver treats a truncated (MAVLink 2) or newer, longer payload.
#[inline(always)]
pub fn zero_extend<const N: usize>(payload: &[u8]) -> [u8; N] {
    // A whole payload is a copy of known size, which compiles to a few moves, where a copy of
    // run-time length is a call to memcpy whose byte stores the field loads then wait on.
    if let Some(whole) = payload.first_chunk::<N>() {
        return *whole;
    }
    let mut out = [0u8; N];
    let n = payload.len().min(N);
    copy_short(&mut out[..n], &payload[..n]);
    out
}

/// Copies `src` into `dst` (of the same length) with copies of fixed size, some overlapping:
/// a payload cut short by MAVLink 2's trailing-zero truncation is at most 255 bytes, where a
/// call to `memcpy` costs more than the copy.
#[inline(always)]
fn copy_short(dst: &mut [u8], src: &[u8]) {
    /// The first and the last `K` bytes, which together cover `K..=2K` bytes.
    #[inline(always)]
    fn ends<const K: usize>(dst: &mut [u8], src: &[u8]) {
        if let (Some(d), Some(s)) = (dst.first_chunk_mut::<K>(), src.first_chunk::<K>()) {
            *d = *s;
        }
        if let (Some(d), Some(s)) = (dst.last_chunk_mut::<K>(), src.last_chunk::<K>()) {
            *d = *s;
        }
    }
    let n = src.len().min(dst.len());
    match n {
        0 => {}
        1..=3 => {
            for (d, s) in dst.iter_mut().zip(src) {
                *d = *s;
            }
        }
        4..=7 => ends::<4>(dst, src),
        8..=15 => ends::<8>(dst, src),
        16..=32 => ends::<16>(dst, src),
        _ => {
            for (d, s) in dst.chunks_exact_mut(32).zip(src.chunks_exact(32)) {
                if let (Some(d), Some(s)) = (d.first_chunk_mut::<32>(), s.first_chunk::<32>()) {
                    *d = *s;
                }
            }
            ends::<32>(dst, src);
        }
    }
}

/// Reads an enum-typed field stored on the wire as `W`.
#[inline(always)]
pub fn get_enum<W: Wire + Into<RawBits>, E: Enum>(buf: &[u8], at: usize) -> E {
    E::from_bits(get::<W>(buf, at).into().0)
}

/// Writes an enum-typed field stored on the wire as `W` (the value is cut to `W`'s width).
#[inline(always)]
pub fn put_enum<W: Wire + FromBits, E: Enum>(buf: &mut [u8], at: usize, value: E) {
    put(buf, at, W::from_bits(value.bits()));
}

/// A protocol enum or flag set with a raw integer value; unknown values are kept, never rejected.
pub trait Enum: Copy {
    /// Builds the value from raw bits (any bits are accepted).
    fn from_bits(bits: u64) -> Self;
    /// The raw bits.
    fn bits(self) -> u64;
}

/// The raw bits of an integer wire value, sign-extended for signed types.
#[derive(Debug, Clone, Copy)]
pub struct RawBits(pub u64);

/// Builds an integer wire value from raw bits, cutting them to its width.
pub trait FromBits {
    /// Keeps the low bits that fit.
    fn from_bits(bits: u64) -> Self;
}

macro_rules! raw_bits {
    ($($t:ty),*) => {$(
        impl From<$t> for RawBits {
            #[inline(always)]
            fn from(v: $t) -> Self {
                RawBits(v as u64)
            }
        }
        impl FromBits for $t {
            #[inline(always)]
            fn from_bits(bits: u64) -> Self {
                bits as $t
            }
        }
    )*};
}
raw_bits!(u8, i8, u16, i16, u32, i32, u64, i64);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_extend_copies_every_length() {
        let payload: [u8; 255] = core::array::from_fn(|i| i as u8 ^ 0x5A);
        for n in 0..=255 {
            let out: [u8; 255] = zero_extend(&payload[..n]);
            assert_eq!(out[..n], payload[..n], "length {n}");
            assert!(out[n..].iter().all(|&b| b == 0), "length {n}");
            let short: [u8; 20] = zero_extend(&payload[..n]);
            assert_eq!(
                short[..n.min(20)],
                payload[..n.min(20)],
                "cut at 20, length {n}"
            );
        }
    }

    #[test]
    fn primitives_are_little_endian() {
        let mut buf = [0xA5u8; 16];
        put(&mut buf, 1, 0x0102_0304u32);
        put(&mut buf, 5, -2i16);
        put(&mut buf, 7, [1u16, 2]);
        assert_eq!(buf[..11], [0xA5, 4, 3, 2, 1, 0xFE, 0xFF, 1, 0, 2, 0]);
        assert_eq!(get::<u32>(&buf, 1), 0x0102_0304);
        assert_eq!(get::<i16>(&buf, 5), -2);
        assert_eq!(get::<[u16; 2]>(&buf, 7), [1, 2]);
    }

    #[test]
    fn floats_round_trip_bit_exact() {
        let mut buf = [0u8; 12];
        put(&mut buf, 0, f32::from_bits(0x7FC0_0001));
        put(&mut buf, 4, -0.0f64);
        assert_eq!(get::<f32>(&buf, 0).to_bits(), 0x7FC0_0001);
        assert_eq!(get::<f64>(&buf, 4).to_bits(), (-0.0f64).to_bits());
    }

    #[test]
    fn zero_extend_fills_and_cuts() {
        assert_eq!(zero_extend::<4>(&[1, 2]), [1, 2, 0, 0]);
        assert_eq!(zero_extend::<2>(&[1, 2, 3]), [1, 2]);
    }
}
