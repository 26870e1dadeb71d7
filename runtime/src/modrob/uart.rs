//! ModRob.UART.B-1 (and SPI-1, which sends the same bytes): one CAN-1 message as a byte array.
//!
//! ```text
//! 0x5A | id_and_len: u32 little-endian | data (6 or 8 bytes) | crc8
//! id_and_len = (29-bit CAN-1 identifier << 4) | data length
//! ```
//!
//! The CRC-8 covers every byte before it, 0x5A included. The specification leaves the
//! polynomial open; the default here is CRC-8/SMBUS ([`Crc8::SMBUS`]) and any other 8-bit
//! algorithm of the `crc` crate can be used instead ([`encode_with`], [`decode_with`],
//! [`Parser::with_crc`](super::Parser::with_crc)).
//!
//! ```
//! use ferrolink_runtime::modrob::{uart, Message};
//!
//! let message = Message::Publication { module: 0x0102, variable: 3, value: 1.5 };
//! let mut buf = [0u8; uart::MAX_FRAME_LEN];
//! let n = uart::encode(&message, &mut buf).unwrap();
//! assert_eq!(n, 12);
//! assert_eq!(&buf[..5], &[0x5a, 0x36, 0x20, 0x10, 0x10]);
//! assert_eq!(uart::decode(&buf[..n]), Ok(message));
//! ```

use core::fmt;

use super::message::{DecodeError, Message, PIECEWISE_DATA_LEN, SHORT_DATA_LEN};

/// The first byte of every message.
pub const SYNC: u8 = 0x5A;
/// Sync byte and `id_and_len`.
pub const HEAD_LEN: usize = 5;
/// A command or publication on the wire.
pub const SHORT_FRAME_LEN: usize = HEAD_LEN + SHORT_DATA_LEN + 1;
/// A piecewise chunk on the wire, the longest message.
pub const MAX_FRAME_LEN: usize = HEAD_LEN + PIECEWISE_DATA_LEN + 1;

/// An 8-bit CRC algorithm with its lookup table (256 bytes; keep it in a `static` or a
/// `const`).
///
/// ```
/// use ferrolink_runtime::modrob::uart::Crc8;
///
/// assert_eq!(Crc8::SMBUS.checksum(b"123456789"), 0xF4);
/// static MAXIM: Crc8 = Crc8::new(&crc::CRC_8_MAXIM_DOW);
/// assert_eq!(MAXIM.checksum(b"123456789"), 0xA1);
/// ```
#[derive(Clone)]
pub struct Crc8 {
    crc: crc::Crc<u8>,
}

impl Crc8 {
    /// CRC-8/SMBUS: poly 0x07, init 0, not reflected, no final xor; check 0xF4. The project's
    /// choice for ModRob-1.
    pub const SMBUS: Crc8 = Crc8::new(&crc::CRC_8_SMBUS);

    /// A CRC from the `crc` crate's catalogue, or an algorithm of your own.
    pub const fn new(algorithm: &'static crc::Algorithm<u8>) -> Self {
        Crc8 {
            crc: crc::Crc::<u8>::new(algorithm),
        }
    }

    /// The CRC of `bytes`.
    #[inline]
    pub const fn checksum(&self, bytes: &[u8]) -> u8 {
        self.crc.checksum(bytes)
    }

    /// The algorithm's parameters.
    #[inline]
    pub fn algorithm(&self) -> &'static crc::Algorithm<u8> {
        self.crc.algorithm
    }
}

impl Default for Crc8 {
    fn default() -> Self {
        Crc8::SMBUS
    }
}

impl fmt::Debug for Crc8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Crc8")
            .field("algorithm", self.crc.algorithm)
            .finish()
    }
}

/// The default CRC, as a `'static` reference.
pub(crate) static SMBUS: Crc8 = Crc8::SMBUS;

/// The encoded output does not fit. Nothing was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is too small.
    BufferTooSmall {
        /// Bytes needed.
        needed: usize,
        /// Bytes the buffer has.
        available: usize,
    },
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EncodeError::BufferTooSmall { needed, available } => write!(
                f,
                "the message needs {needed} bytes but the buffer has {available}"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EncodeError {}

/// Why bytes are not one UART.B-1 message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FrameError {
    /// Fewer bytes than the message needs (5 to read its length, then 12 or 14).
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Bytes there are.
        available: usize,
    },
    /// The first byte is not 0x5A.
    BadSync {
        /// The first byte.
        byte: u8,
    },
    /// The length nibble is neither 6 nor 8.
    BadLength {
        /// The length nibble.
        len: u8,
    },
    /// The CRC does not match.
    Crc {
        /// The CRC of the received bytes.
        computed: u8,
        /// The CRC byte received.
        received: u8,
    },
    /// The CRC matches but the message is not valid ModRob-1 (a reserved value, or a length
    /// that does not match the message type).
    Decode(DecodeError),
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::Truncated { needed, available } => {
                write!(f, "truncated: {available} of {needed} bytes")
            }
            FrameError::BadSync { byte } => write!(f, "starts with {byte:#04x}, not 0x5a"),
            FrameError::BadLength { len } => write!(f, "length nibble {len} is neither 6 nor 8"),
            FrameError::Crc { computed, received } => write!(
                f,
                "CRC mismatch: received {received:#04x}, computed {computed:#04x}"
            ),
            FrameError::Decode(e) => fmt::Display::fmt(e, f),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FrameError {}

impl From<DecodeError> for FrameError {
    fn from(e: DecodeError) -> Self {
        FrameError::Decode(e)
    }
}

/// Encoded length of a message: 12, or 14 for a piecewise chunk.
#[inline]
pub const fn encoded_len(message: &Message) -> usize {
    HEAD_LEN + message.data_len() + 1
}

/// Encodes `message` into `out` with CRC-8/SMBUS and returns its length (12 or 14).
#[inline]
pub fn encode(message: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
    encode_with(message, &SMBUS, out)
}

/// Encodes `message` into `out` with the given CRC and returns its length. On error nothing is
/// written.
pub fn encode_with(message: &Message, crc: &Crc8, out: &mut [u8]) -> Result<usize, EncodeError> {
    let len = encoded_len(message);
    let available = out.len();
    let Some(out) = out.get_mut(..len) else {
        return Err(EncodeError::BufferTooSmall {
            needed: len,
            available,
        });
    };
    let can = message.to_can();
    let id_and_len = can.id << 4 | u32::from(can.len);
    let (head, rest) = out.split_at_mut(HEAD_LEN);
    head[0] = SYNC;
    head[1..].copy_from_slice(&id_and_len.to_le_bytes());
    let (data, tail) = rest.split_at_mut(usize::from(can.len));
    data.copy_from_slice(can.data());
    let sum = {
        let mut digest = crc.crc.digest();
        digest.update(head);
        digest.update(data);
        digest.finalize()
    };
    if let Some(slot) = tail.first_mut() {
        *slot = sum;
    }
    Ok(len)
}

/// The length of the message starting at `bytes[0]`, read from its length nibble, once 5 bytes
/// are there. Checks the sync byte and the nibble, not the CRC.
pub fn frame_len(bytes: &[u8]) -> Result<usize, FrameError> {
    let [sync, a, ..] = *bytes else {
        return Err(FrameError::Truncated {
            needed: HEAD_LEN,
            available: bytes.len(),
        });
    };
    if sync != SYNC {
        return Err(FrameError::BadSync { byte: sync });
    }
    match a & 0x0f {
        6 => Ok(SHORT_FRAME_LEN),
        8 => Ok(MAX_FRAME_LEN),
        len => Err(FrameError::BadLength { len }),
    }
}

/// Decodes the message at the start of `bytes` (CRC-8/SMBUS); bytes after it are ignored.
#[inline]
pub fn decode(bytes: &[u8]) -> Result<Message, FrameError> {
    decode_with(bytes, &SMBUS)
}

/// Decodes the message at the start of `bytes` with the given CRC; bytes after it are ignored.
pub fn decode_with(bytes: &[u8], crc: &Crc8) -> Result<Message, FrameError> {
    let len = frame_len(bytes)?;
    let Some(frame) = bytes.get(..len) else {
        return Err(FrameError::Truncated {
            needed: len,
            available: bytes.len(),
        });
    };
    let (body, received) = frame.split_at(len - 1);
    let computed = crc.checksum(body);
    let received = received.first().copied().unwrap_or(!computed);
    if computed != received {
        return Err(FrameError::Crc { computed, received });
    }
    Ok(decode_checked(body)?)
}

/// Decodes `sync | id_and_len | data` whose CRC was checked.
pub(crate) fn decode_checked(body: &[u8]) -> Result<Message, DecodeError> {
    let mut word = [0u8; 4];
    if let Some(b) = body.get(1..HEAD_LEN) {
        word.copy_from_slice(b);
    }
    let id = u32::from_le_bytes(word) >> 4;
    Message::from_can(id, body.get(HEAD_LEN..).unwrap_or_default())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modrob::CommandKind;

    #[test]
    fn errors_write_nothing_and_decode_never_panics() {
        let m = Message::Command {
            module: 1,
            variable: 2,
            command: CommandKind::SetValue(0.0),
        };
        let mut buf = [0xa5u8; 11];
        assert_eq!(
            encode(&m, &mut buf),
            Err(EncodeError::BufferTooSmall {
                needed: 12,
                available: 11
            })
        );
        assert_eq!(buf, [0xa5; 11]);
        let mut full = [0xa5u8; 16];
        let n = encode(&m, &mut full).unwrap();
        assert_eq!(full[n..], [0xa5; 4]);
        for cut in 0..n {
            assert!(matches!(
                decode(&full[..cut]),
                Err(FrameError::Truncated { .. })
            ));
        }
        full[n - 1] ^= 1;
        assert!(matches!(decode(&full), Err(FrameError::Crc { .. })));
    }
}
