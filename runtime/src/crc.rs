//! The checksums the protocols share, taken from the `crc` crate's catalogue (table driven).

use ::crc::{Crc, Digest, Table, CRC_16_MCRF4XX};

/// Bytes the CRC table consumes per step: 16 with the `fast-crc` feature (an 8 KiB table,
/// several times faster on long frames), else 1 (a 512-byte table, for small flash).
#[cfg(feature = "fast-crc")]
const SLICES: usize = 16;
#[cfg(not(feature = "fast-crc"))]
const SLICES: usize = 1;

/// CRC-16/MCRF4XX: poly 0x1021 reflected, init 0xFFFF, no final xor. MAVLink's checksum and
/// NDLCom's FCS. `check("123456789") == 0x6F91`.
pub const MCRF4XX: Crc<u16, Table<SLICES>> = Crc::<u16, Table<SLICES>>::new(&CRC_16_MCRF4XX);

/// A running CRC-16/MCRF4XX.
pub type Mcrf4xxDigest = Digest<'static, u16, Table<SLICES>>;

/// CRC-16/MCRF4XX of `data`.
#[inline]
pub fn mcrf4xx(data: &[u8]) -> u16 {
    mcrf4xx_with(data, None)
}

/// CRC-16/MCRF4XX of `data` followed by `extra`, if any: MAVLink's checksum of a frame body
/// and its CRC_EXTRA.
///
/// With `fast-crc`, every 16-byte block goes through the crate's slicing-by-16 tables, and so
/// does the rest, `extra` included, as one more step of its length. The crate itself takes the
/// rest one byte after another, a chain of dependent lookups that cost more than the whole
/// blocks on frames of 20 to 40 bytes: this halves the checksum of a 35-byte frame.
#[inline]
pub fn mcrf4xx_with(data: &[u8], extra: Option<u8>) -> u16 {
    #[cfg(feature = "fast-crc")]
    {
        let tables = MCRF4XX.table();
        let mut blocks = data.chunks_exact(SLICES);
        let mut crc = MCRF4XX.algorithm.init;
        for block in blocks.by_ref().filter_map(<[u8]>::first_chunk::<SLICES>) {
            crc = fold(tables, crc, block, None);
        }
        let rest = blocks.remainder();
        // The rest (0 to 15 bytes) and `extra` as one step of their length, through a kernel
        // specialised for it.
        macro_rules! by_len {
            ($($k:literal)*) => {
                match rest.len() {
                    $($k => rest.first_chunk::<$k>().map_or(crc, |r| fold(tables, crc, r, extra)),)*
                    _ => crc,
                }
            };
        }
        by_len!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15)
    }
    #[cfg(not(feature = "fast-crc"))]
    {
        let crc = MCRF4XX.checksum(data);
        match extra {
            Some(byte) => mcrf4xx_step(crc, byte),
            None => crc,
        }
    }
}

/// One slicing step over `bytes` and then `extra` (at most [`SLICES`] bytes in all) from the
/// running value `crc`. The tables are linear in their index, so each byte's share and the
/// running value's share (its two bytes, `m - 1` and `m - 2` steps from the end) are looked
/// up apart and XORed: the running value's lookups are the only ones a step waits for from the
/// step before. With `K` and the presence of `extra` known, every index is a constant.
#[cfg(feature = "fast-crc")]
#[inline(always)]
fn fold<const K: usize>(
    tables: &[[u16; 256]; SLICES],
    crc: u16,
    bytes: &[u8; K],
    extra: Option<u8>,
) -> u16 {
    let m = K + usize::from(extra.is_some());
    let mut out = 0;
    for (j, &byte) in bytes.iter().enumerate() {
        if let Some(table) = tables.get(m - 1 - j) {
            out ^= table[usize::from(byte)];
        }
    }
    if let Some(byte) = extra {
        out ^= tables[0][usize::from(byte)];
    }
    let [lo, hi] = crc.to_le_bytes();
    out ^ match m {
        0 => crc,
        1 => tables[0][usize::from(lo)] ^ u16::from(hi),
        _ => match tables.get(m - 2..m) {
            Some([second, first]) => first[usize::from(lo)] ^ second[usize::from(hi)],
            // Cannot happen: a step takes at most `SLICES` bytes.
            _ => crc,
        },
    }
}

/// Continues a CRC-16/MCRF4XX over one more byte, through the same table. The algorithm has no
/// final xor and reflects input and output alike, so a finished checksum is also the running
/// value: `mcrf4xx_step(mcrf4xx(data), b) == mcrf4xx(data ++ [b])`.
#[inline]
pub fn mcrf4xx_step(crc: u16, byte: u8) -> u16 {
    MCRF4XX.table()[0][usize::from(crc.to_le_bytes()[0] ^ byte)] ^ (crc >> 8)
}

/// The CRC-32 of MAVLink FTP's `CalcFileCRC32`, as PX4, ArduPilot and MAVSDK compute it: the
/// IEEE polynomial reflected (zlib's table), but from 0 and with no final xor (zlib's CRC-32
/// starts from and ends with `0xFFFFFFFF`). Byte at a time, through a 1 KiB table.
pub const FTP_CRC32: Crc<u32, Table<1>> = Crc::<u32, Table<1>>::new(&::crc::Algorithm {
    width: 32,
    poly: 0x04c1_1db7,
    init: 0,
    refin: true,
    refout: true,
    xorout: 0,
    check: 0x2dfd_2d88,
    residue: 0,
});

/// A fresh running CRC-16/MCRF4XX.
#[inline]
pub fn mcrf4xx_digest() -> Mcrf4xxDigest {
    MCRF4XX.digest()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ftp_crc32_is_zlibs_without_the_inversions() {
        // zlib's CRC-32 of "123456789" is 0xCBF43926; with neither the initial nor the final
        // inversion it is this.
        assert_eq!(FTP_CRC32.checksum(b"123456789"), 0x2dfd_2d88);
        assert_eq!(FTP_CRC32.checksum(b""), 0);
    }

    #[test]
    fn a_checksum_continues_byte_by_byte() {
        let data = b"123456789 and then some more bytes than one table step takes";
        for n in 0..data.len() {
            assert_eq!(
                mcrf4xx_step(mcrf4xx(&data[..n]), data[n]),
                mcrf4xx(&data[..=n])
            );
        }
    }

    #[test]
    fn every_length_matches_the_crate_bytewise() {
        // The crate's byte-at-a-time path is the reference for every step length and
        // remainder, with and without a trailing extra byte.
        const BYTEWISE: Crc<u16, Table<1>> = Crc::<u16, Table<1>>::new(&CRC_16_MCRF4XX);
        let data: std::vec::Vec<u8> = (0..300u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        for n in 0..data.len() {
            let body = &data[..n];
            assert_eq!(mcrf4xx(body), BYTEWISE.checksum(body), "length {n}");
            for extra in [0u8, 0x32, 0xff] {
                let mut digest = BYTEWISE.digest();
                digest.update(body);
                digest.update(&[extra]);
                assert_eq!(
                    mcrf4xx_with(body, Some(extra)),
                    digest.finalize(),
                    "length {n}"
                );
            }
        }
    }

    #[test]
    fn check_value() {
        assert_eq!(mcrf4xx(b"123456789"), 0x6F91);
        let mut d = mcrf4xx_digest();
        d.update(b"1234");
        d.update(b"56789");
        assert_eq!(d.finalize(), 0x6F91);
    }
}
