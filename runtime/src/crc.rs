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
    MCRF4XX.checksum(data)
}

/// Continues a CRC-16/MCRF4XX over one more byte, through the same table. The algorithm has no
/// final xor and reflects input and output alike, so a finished checksum is also the running
/// value: `mcrf4xx_step(mcrf4xx(data), b) == mcrf4xx(data ++ [b])`. MAVLink appends CRC_EXTRA
/// this way, without a second pass through the table code.
#[inline]
pub fn mcrf4xx_step(crc: u16, byte: u8) -> u16 {
    MCRF4XX.table()[0][usize::from(crc.to_le_bytes()[0] ^ byte)] ^ (crc >> 8)
}

/// A fresh running CRC-16/MCRF4XX.
#[inline]
pub fn mcrf4xx_digest() -> Mcrf4xxDigest {
    MCRF4XX.digest()
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn check_value() {
        assert_eq!(mcrf4xx(b"123456789"), 0x6F91);
        let mut d = mcrf4xx_digest();
        d.update(b"1234");
        d.update(b"56789");
        assert_eq!(d.finalize(), 0x6F91);
    }
}
