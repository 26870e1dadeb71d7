//! Non-volatile images of a module's settings: the values of its persistent variables and every
//! variable's publication rate and subscription, in a caller's byte buffer (a flash page, an
//! EEPROM), protected by a CRC-32.
//!
//! Layout, every multi-byte field little-endian like the rest of ModRob-1:
//!
//! ```text
//! offset  len  field
//! 0       4    magic "MR1P"
//! 4       1    format version, 1
//! 5       4    the dictionary's fingerprint (Dictionary::fingerprint)
//! 9       2    record count R
//! 11      13R  records, one per variable, in strictly increasing VI order:
//!                +0   1  VI
//!                +1   1  flags: bit 0 value present, bit 1 subscription present, bits 2..7 zero
//!                +2   4  value, f32 (zero when absent)
//!                +6   4  publication rate, u32 millihertz (0: not published)
//!                +10  2  subscription source MI (zero when absent)
//!                +12  1  subscription source VI (zero when absent)
//! 11+13R  4    CRC-32/ISO-HDLC (the zlib / Ethernet CRC) of every byte before it
//! ```
//!
//! [`save`] writes one record per variable of the table, so an image is
//! [`image_len`]`(N)` = `15 + 13 N` bytes (at most 3343 for 256 variables). The value flag is
//! set exactly for the variables the table marks `persist`; non-persistent values are not kept,
//! but every variable's rate and subscription are.
//!
//! [`load`] (and [`check`]) validate the whole image before anything is applied: the length,
//! magic, version, checksum, fingerprint, then every record (a known VI, VIs strictly
//! increasing, no reserved flag bits, the value flag matching the variable's `persist`, a value
//! within its limits, a rate of at most [`MAX_RATE_MHZ`], zero bytes for an absent value or
//! subscription). The checksum is checked before the fingerprint, so a corrupted image is
//! reported as corrupted. Any error leaves the settings untouched. An image may list fewer
//! records than the table has variables: the variables it does not list keep their current
//! settings. Bytes after the CRC are ignored, so an image can be read from a whole flash page.
//! No input makes these functions panic.

use core::fmt;

use crc::{Crc, CRC_32_ISO_HDLC};

use super::dictionary::Dictionary;

/// The highest publication rate accepted, in Hz (a 100 µs period).
pub const MAX_RATE_HZ: f32 = 10_000.0;

/// [`MAX_RATE_HZ`] in millihertz.
pub const MAX_RATE_MHZ: u32 = 10_000_000;

/// A rate in Hz as the engine holds it, in millihertz: rounded to the nearest mHz, at least
/// 1 mHz when positive. `None` for a negative, NaN or infinite rate or one above
/// [`MAX_RATE_HZ`].
///
/// ```
/// use ferrolink_runtime::modrob::engine::rate_to_mhz;
///
/// assert_eq!(rate_to_mhz(100.0), Some(100_000));
/// assert_eq!(rate_to_mhz(1.0 / 3.0), Some(333));
/// assert_eq!(rate_to_mhz(0.0), Some(0));
/// assert_eq!(rate_to_mhz(1e-6), Some(1));
/// assert_eq!(rate_to_mhz(-1.0), None);
/// assert_eq!(rate_to_mhz(f32::NAN), None);
/// ```
pub fn rate_to_mhz(hz: f32) -> Option<u32> {
    if !(0.0..=MAX_RATE_HZ).contains(&hz) {
        return None;
    }
    if hz == 0.0 {
        return Some(0);
    }
    // Non-negative, so adding one half and truncating rounds to nearest.
    let mhz = (f64::from(hz) * 1000.0 + 0.5) as u32;
    Some(mhz.clamp(1, MAX_RATE_MHZ))
}

/// The first four bytes of an image.
pub const MAGIC: [u8; 4] = *b"MR1P";
/// The format version this runtime writes and reads.
pub const VERSION: u8 = 1;
/// Bytes before the first record.
pub const HEADER_LEN: usize = 11;
/// Bytes of one record.
pub const RECORD_LEN: usize = 13;
/// Bytes of the trailing CRC-32.
pub const CRC_LEN: usize = 4;

/// Record flag: the record carries a value.
const FLAG_VALUE: u8 = 0x01;
/// Record flag: the record carries a subscription.
const FLAG_SUBSCRIPTION: u8 = 0x02;

/// CRC-32/ISO-HDLC: poly 0x04C11DB7 reflected, init and final xor 0xFFFFFFFF;
/// `check("123456789") == 0xCBF43926`.
static CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// The length of an image with one record per variable of a table of `variables` variables.
pub const fn image_len(variables: usize) -> usize {
    HEADER_LEN + RECORD_LEN * variables + CRC_LEN
}

/// What an image keeps of a module: values, publication rates and subscriptions, in table
/// order. [`Engine`](super::engine::Engine) holds its state in one.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings<const N: usize> {
    /// Every variable's value.
    pub values: [f32; N],
    /// Every variable's publication rate, in millihertz (0: not published).
    pub rates: [u32; N],
    /// The (MI, VI) each variable follows, if any.
    pub subscriptions: [Option<(u16, u8)>; N],
}

impl<const N: usize> Settings<N> {
    /// The table's defaults: default values and rates (an invalid default rate counts as 0),
    /// no subscriptions.
    pub fn defaults(dictionary: &Dictionary<N>) -> Self {
        let variables = &dictionary.variables;
        Self {
            values: core::array::from_fn(|i| variables[i].default),
            rates: core::array::from_fn(|i| rate_to_mhz(variables[i].rate).unwrap_or(0)),
            subscriptions: [None; N],
        }
    }
}

/// What is wrong with one record of an image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum RecordError {
    /// The table has no variable with the record's VI.
    UnknownVariable,
    /// The VI is not above the previous record's (a duplicate, or out of order).
    OutOfOrder,
    /// Flag bits 2..7 are set.
    ReservedFlags,
    /// The value flag differs from the variable's `persist` flag.
    PersistMismatch,
    /// The value is outside the variable's limits, or NaN.
    OutOfLimits,
    /// The rate is above [`MAX_RATE_MHZ`].
    InvalidRate,
    /// An absent value or subscription has non-zero bytes.
    NonZeroUnused,
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RecordError::UnknownVariable => "unknown variable",
            RecordError::OutOfOrder => "variables not in increasing order",
            RecordError::ReservedFlags => "reserved flag bits set",
            RecordError::PersistMismatch => "value flag differs from the variable's persist flag",
            RecordError::OutOfLimits => "value outside the variable's limits",
            RecordError::InvalidRate => "rate above 10 kHz",
            RecordError::NonZeroUnused => "unused bytes are not zero",
        })
    }
}

/// Why an image could not be written or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum PersistError {
    /// The buffer given to [`save`] is shorter than the image.
    BufferTooSmall {
        /// The image's length.
        needed: usize,
        /// The buffer's length.
        got: usize,
    },
    /// The image ends before its header, records or CRC do.
    Truncated {
        /// The length the header calls for (or the header's length).
        needed: usize,
        /// The bytes given.
        got: usize,
    },
    /// The image does not start with [`MAGIC`].
    BadMagic,
    /// A format version this runtime does not read.
    UnsupportedVersion(u8),
    /// The CRC-32 does not match: the image is corrupted.
    BadChecksum {
        /// The CRC of the bytes.
        computed: u32,
        /// The CRC stored in the image.
        stored: u32,
    },
    /// The image was made for another variable table.
    WrongDictionary {
        /// This table's fingerprint.
        expected: u32,
        /// The image's.
        found: u32,
    },
    /// The image has more records than the table has variables (or [`save`] was given a table
    /// of more than 65535 variables).
    TooManyRecords {
        /// The record count.
        records: usize,
        /// The table's variables.
        variables: usize,
    },
    /// A record is invalid.
    Invalid {
        /// Its position in the image, from 0.
        record: u16,
        /// Its VI byte.
        vi: u8,
        /// What is wrong.
        error: RecordError,
    },
}

impl fmt::Display for PersistError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            PersistError::BufferTooSmall { needed, got } => {
                write!(f, "buffer of {got} bytes for an image of {needed}")
            }
            PersistError::Truncated { needed, got } => {
                write!(f, "image of {got} bytes where {needed} are needed")
            }
            PersistError::BadMagic => f.write_str("not a ModRob-1 settings image (bad magic)"),
            PersistError::UnsupportedVersion(v) => write!(f, "image format version {v}"),
            PersistError::BadChecksum { computed, stored } => write!(
                f,
                "image CRC {stored:#010x} where the bytes give {computed:#010x}"
            ),
            PersistError::WrongDictionary { expected, found } => write!(
                f,
                "image made for dictionary {found:#010x}, this one is {expected:#010x}"
            ),
            PersistError::TooManyRecords { records, variables } => {
                write!(f, "{records} records for {variables} variables")
            }
            PersistError::Invalid { record, vi, error } => {
                write!(f, "record {record} (VI {vi}): {error}")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for PersistError {}

#[cfg(feature = "std")]
impl std::error::Error for RecordError {}

/// One record, checked against the table.
struct Record {
    index: usize,
    value: Option<f32>,
    rate: u32,
    subscription: Option<(u16, u8)>,
}

fn le_u32(bytes: [u8; 4]) -> u32 {
    u32::from_le_bytes(bytes)
}

/// Parses and checks one record; `previous` is the VI of the record before, if any.
fn parse_record<const N: usize>(
    dictionary: &Dictionary<N>,
    bytes: &[u8],
    previous: Option<u8>,
) -> Result<Record, RecordError> {
    let mut b = [0u8; RECORD_LEN];
    if let Some(src) = bytes.get(..RECORD_LEN) {
        b.copy_from_slice(src);
    }
    let [vi, flags, v0, v1, v2, v3, r0, r1, r2, r3, m0, m1, sv] = b;
    let index = dictionary
        .index_of(vi)
        .ok_or(RecordError::UnknownVariable)?;
    if previous.is_some_and(|p| vi <= p) {
        return Err(RecordError::OutOfOrder);
    }
    if flags & !(FLAG_VALUE | FLAG_SUBSCRIPTION) != 0 {
        return Err(RecordError::ReservedFlags);
    }
    let variable = &dictionary.variables[index];
    if (flags & FLAG_VALUE != 0) != variable.persist {
        return Err(RecordError::PersistMismatch);
    }
    let value = if flags & FLAG_VALUE != 0 {
        let value = f32::from_le_bytes([v0, v1, v2, v3]);
        if !variable.accepts(value) {
            return Err(RecordError::OutOfLimits);
        }
        Some(value)
    } else if [v0, v1, v2, v3] != [0; 4] {
        return Err(RecordError::NonZeroUnused);
    } else {
        None
    };
    let rate = le_u32([r0, r1, r2, r3]);
    if rate > MAX_RATE_MHZ {
        return Err(RecordError::InvalidRate);
    }
    let subscription = if flags & FLAG_SUBSCRIPTION != 0 {
        Some((u16::from_le_bytes([m0, m1]), sv))
    } else if [m0, m1, sv] != [0; 3] {
        return Err(RecordError::NonZeroUnused);
    } else {
        None
    };
    Ok(Record {
        index,
        value,
        rate,
        subscription,
    })
}

/// Writes the image of `settings` for `dictionary` into the start of `buf`; returns its length,
/// [`image_len`]`(N)`.
pub fn save<const N: usize>(
    dictionary: &Dictionary<N>,
    settings: &Settings<N>,
    buf: &mut [u8],
) -> Result<usize, PersistError> {
    let count = u16::try_from(N).map_err(|_| PersistError::TooManyRecords {
        records: N,
        variables: N,
    })?;
    let len = image_len(N);
    let got = buf.len();
    let image = buf
        .get_mut(..len)
        .ok_or(PersistError::BufferTooSmall { needed: len, got })?;
    let (body, crc) = image.split_at_mut(len - CRC_LEN);
    let (header, records) = body.split_at_mut(HEADER_LEN);
    let [m0, m1, m2, m3] = MAGIC;
    let [f0, f1, f2, f3] = dictionary.fingerprint.to_le_bytes();
    let [c0, c1] = count.to_le_bytes();
    header.copy_from_slice(&[m0, m1, m2, m3, VERSION, f0, f1, f2, f3, c0, c1]);
    for (i, (record, variable)) in records
        .chunks_exact_mut(RECORD_LEN)
        .zip(&dictionary.variables)
        .enumerate()
    {
        let mut flags = 0;
        let [v0, v1, v2, v3] = if variable.persist {
            flags |= FLAG_VALUE;
            settings.values[i].to_le_bytes()
        } else {
            [0; 4]
        };
        let ([m0, m1], sv) = match settings.subscriptions[i] {
            Some((module, vi)) => {
                flags |= FLAG_SUBSCRIPTION;
                (module.to_le_bytes(), vi)
            }
            None => ([0; 2], 0),
        };
        let [r0, r1, r2, r3] = settings.rates[i].to_le_bytes();
        record.copy_from_slice(&[
            variable.vi,
            flags,
            v0,
            v1,
            v2,
            v3,
            r0,
            r1,
            r2,
            r3,
            m0,
            m1,
            sv,
        ]);
    }
    let sum = CRC32.checksum(body);
    crc.copy_from_slice(&sum.to_le_bytes());
    Ok(len)
}

/// Checks a whole image against `dictionary` without applying it; returns the image's length
/// (the bytes after it are not part of it).
pub fn check<const N: usize>(
    dictionary: &Dictionary<N>,
    image: &[u8],
) -> Result<usize, PersistError> {
    records(dictionary, image).map(|(_, len)| len)
}

/// Checks everything; returns the record bytes and the image's length.
fn records<'i, const N: usize>(
    dictionary: &Dictionary<N>,
    image: &'i [u8],
) -> Result<(&'i [u8], usize), PersistError> {
    let got = image.len();
    let Some(&[m0, m1, m2, m3, version, f0, f1, f2, f3, c0, c1]) = image.get(..HEADER_LEN) else {
        return Err(PersistError::Truncated {
            needed: HEADER_LEN,
            got,
        });
    };
    if [m0, m1, m2, m3] != MAGIC {
        return Err(PersistError::BadMagic);
    }
    if version != VERSION {
        return Err(PersistError::UnsupportedVersion(version));
    }
    let count = usize::from(u16::from_le_bytes([c0, c1]));
    let len = image_len(count);
    let (Some(body), Some(stored)) = (image.get(..len - CRC_LEN), image.get(len - CRC_LEN..len))
    else {
        return Err(PersistError::Truncated { needed: len, got });
    };
    let stored = u32::from_le_bytes([stored[0], stored[1], stored[2], stored[3]]);
    let computed = CRC32.checksum(body);
    if computed != stored {
        return Err(PersistError::BadChecksum { computed, stored });
    }
    let found = le_u32([f0, f1, f2, f3]);
    if found != dictionary.fingerprint {
        return Err(PersistError::WrongDictionary {
            expected: dictionary.fingerprint,
            found,
        });
    }
    if count > N {
        return Err(PersistError::TooManyRecords {
            records: count,
            variables: N,
        });
    }
    let records = &body[HEADER_LEN..];
    let mut previous = None;
    for (position, bytes) in records.chunks_exact(RECORD_LEN).enumerate() {
        let vi = bytes[0];
        parse_record(dictionary, bytes, previous).map_err(|error| PersistError::Invalid {
            record: position as u16,
            vi,
            error,
        })?;
        previous = Some(vi);
    }
    Ok((records, len))
}

/// Checks a whole image made for `dictionary`, then applies it to `settings`: values of the
/// listed persistent variables, rates and subscriptions of the listed variables. On any error
/// `settings` is untouched.
pub fn load<const N: usize>(
    dictionary: &Dictionary<N>,
    image: &[u8],
    settings: &mut Settings<N>,
) -> Result<(), PersistError> {
    let (records, _) = records(dictionary, image)?;
    let mut previous = None;
    for bytes in records.chunks_exact(RECORD_LEN) {
        // Every record passed the same check above.
        let Ok(record) = parse_record(dictionary, bytes, previous) else {
            continue;
        };
        previous = Some(bytes[0]);
        if let Some(value) = record.value {
            settings.values[record.index] = value;
        }
        settings.rates[record.index] = record.rate;
        settings.subscriptions[record.index] = record.subscription;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modrob::dictionary::{Direction, Variable};

    const TABLE: Dictionary<2> = Dictionary {
        name: "t",
        kind: "t",
        module: 1,
        uuid: None,
        info: "",
        fingerprint: 0xA1B2_C3D4,
        variables: [
            Variable {
                vi: 3,
                name: "gain",
                unit: "1",
                direction: Direction::Input,
                min: 0.0,
                max: 10.0,
                default: 1.0,
                persist: true,
                rate: 0.0,
                description: "",
            },
            Variable {
                vi: 9,
                name: "speed",
                unit: "m/s",
                direction: Direction::Output,
                min: -5.0,
                max: 5.0,
                default: 0.0,
                persist: false,
                rate: 100.0,
                description: "",
            },
        ],
    };

    #[test]
    fn crc_check_value() {
        assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn layout() {
        let mut settings = Settings::defaults(&TABLE);
        settings.values = [1.5, 2.0];
        settings.subscriptions[1] = Some((0x0102, 7));
        // Pre-filled so that an unwritten byte shows.
        let mut buf = [0xa5u8; 50];
        assert_eq!(save(&TABLE, &settings, &mut buf), Ok(image_len(2)));
        let body: [u8; 37] = [
            b'M', b'R', b'1', b'P', 1, // magic, version
            0xD4, 0xC3, 0xB2, 0xA1, // fingerprint
            2, 0, // records
            3, 0x01, 0x00, 0x00, 0xc0, 0x3f, 0, 0, 0, 0, 0, 0, 0, // gain = 1.5, rate 0
            9, 0x02, 0, 0, 0, 0, 0xa0, 0x86, 0x01, 0x00, 0x02, 0x01, 7, // 100 Hz, <- 0x0102.7
        ];
        assert_eq!(buf[..37], body);
        assert_eq!(buf[37..41], CRC32.checksum(&body).to_le_bytes());
        assert_eq!(buf[41..], [0xa5; 9]);
        assert_eq!(check(&TABLE, &buf), Ok(41));
        assert_eq!(
            save(&TABLE, &settings, &mut buf[..40]),
            Err(PersistError::BufferTooSmall {
                needed: 41,
                got: 40
            })
        );
    }

    /// Rewrites the CRC of an image after its bytes were edited.
    fn reseal(image: &mut [u8]) {
        let len = image.len();
        let sum = CRC32.checksum(&image[..len - CRC_LEN]);
        image[len - CRC_LEN..].copy_from_slice(&sum.to_le_bytes());
    }

    #[test]
    fn record_errors() {
        let settings = Settings::defaults(&TABLE);
        let mut good = [0u8; image_len(2)];
        save(&TABLE, &settings, &mut good).unwrap();
        let cases: [(usize, u8, u16, RecordError); 7] = [
            (11, 4, 0, RecordError::UnknownVariable),
            (24, 3, 1, RecordError::OutOfOrder),
            (12, 0x05, 0, RecordError::ReservedFlags),
            (12, 0x00, 0, RecordError::PersistMismatch),
            (16, 0x7f, 0, RecordError::OutOfLimits), // 1.0 becomes +inf
            (33, 0xff, 1, RecordError::InvalidRate),
            (35, 1, 1, RecordError::NonZeroUnused),
        ];
        for (offset, byte, record, error) in cases {
            let mut image = good;
            image[offset] = byte;
            reseal(&mut image);
            let mut s = settings.clone();
            s.values[0] = 4.0;
            let before = s.clone();
            let err = load(&TABLE, &image, &mut s).unwrap_err();
            assert!(
                matches!(err, PersistError::Invalid { record: r, error: e, .. } if r == record && e == error),
                "offset {offset}: {err:?}"
            );
            assert_eq!(s, before);
        }
        // Too many records: a 3-record image for a 2-variable table.
        let mut long = [0u8; image_len(3)];
        long[..image_len(2) - CRC_LEN].copy_from_slice(&good[..image_len(2) - CRC_LEN]);
        long[9] = 3;
        reseal(&mut long);
        assert_eq!(
            check(&TABLE, &long),
            Err(PersistError::TooManyRecords {
                records: 3,
                variables: 2
            })
        );
    }

    #[test]
    fn subset_keeps_the_rest() {
        let mut image = [0u8; image_len(1)];
        image[..11].copy_from_slice(&[b'M', b'R', b'1', b'P', 1, 0xD4, 0xC3, 0xB2, 0xA1, 1, 0]);
        // Only VI 9: rate 5 Hz.
        image[11..24].copy_from_slice(&[9, 0, 0, 0, 0, 0, 0x88, 0x13, 0, 0, 0, 0, 0]);
        reseal(&mut image);
        let mut s = Settings::defaults(&TABLE);
        s.values[0] = 7.0;
        load(&TABLE, &image, &mut s).unwrap();
        assert_eq!(s.values, [7.0, 0.0]);
        assert_eq!(s.rates, [0, 5000]);
    }
}
