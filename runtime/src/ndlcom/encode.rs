//! The NDLCom encoder: header, payload and FCS, byte-stuffed between two flags.
//!
//! ```text
//! 0x7E | escape( header(4) | payload(0..=255) | fcs16 little-endian ) | 0x7E
//! ```
//!
//! Escaping is HDLC-like: 0x7E and 0x7D anywhere between the flags, FCS included, are sent as
//! 0x7D followed by the byte XOR 0x20. The FCS is CRC-16/MCRF4XX over the unescaped header and
//! payload.
//!
//! The encoder writes into a caller buffer ([`encode`], [`encode_parts`]) or hands out runs of
//! bytes to a sink such as a UART ([`encode_with`]), so a node needs no frame buffer of its own.
//! Into a buffer it either writes a whole frame or returns an error having written nothing.
//!
//! ```
//! use ferrolink_runtime::ndlcom::{encode, Header};
//!
//! let mut buf = [0u8; 16];
//! let n = encode(&Header::new(126, 1, 0, 1), &[126], &mut buf).unwrap();
//! assert_eq!(&buf[..n], &[126, 125, 94, 1, 0, 1, 125, 94, 89, 219, 126]);
//! ```

use core::fmt;

use super::{Header, FLAG};
use crate::crc::mcrf4xx_digest;
use crate::hdlc::{escaped_len, stuff};

/// Why a frame could not be encoded. Nothing was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum EncodeError {
    /// The payload is longer than 255 bytes.
    PayloadTooLong {
        /// The payload length given.
        len: usize,
    },
    /// The header's length field does not match the payload.
    LengthMismatch {
        /// The header's length field.
        header: u8,
        /// The payload length given.
        payload: usize,
    },
    /// The output buffer cannot hold the encoded frame.
    BufferTooSmall {
        /// Bytes the encoded frame needs.
        needed: usize,
        /// Bytes the buffer has.
        available: usize,
    },
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EncodeError::PayloadTooLong { len } => {
                write!(f, "payload of {len} bytes exceeds the 255-byte maximum")
            }
            EncodeError::LengthMismatch { header, payload } => write!(
                f,
                "header says {header} payload bytes but {payload} were given"
            ),
            EncodeError::BufferTooSmall { needed, available } => write!(
                f,
                "encoded frame needs {needed} bytes but the buffer has {available}"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EncodeError {}

/// Checks the header against the payload parts and returns the payload length.
fn check(header: &Header, parts: &[&[u8]]) -> Result<usize, EncodeError> {
    let len: usize = parts.iter().map(|p| p.len()).sum();
    if len > super::MAX_PAYLOAD_LEN {
        return Err(EncodeError::PayloadTooLong { len });
    }
    if usize::from(header.length) != len {
        return Err(EncodeError::LengthMismatch {
            header: header.length,
            payload: len,
        });
    }
    Ok(len)
}

/// The FCS (CRC-16/MCRF4XX) of a header and payload parts, in wire order.
fn fcs(header: &[u8; 4], parts: &[&[u8]]) -> [u8; 2] {
    let mut digest = mcrf4xx_digest();
    digest.update(header);
    for part in parts {
        digest.update(part);
    }
    digest.finalize().to_le_bytes()
}

/// A frame before escaping: header bytes, payload parts and FCS, computed once.
struct Assembled<'p> {
    head: [u8; 4],
    parts: &'p [&'p [u8]],
    fcs: [u8; 2],
}

impl<'p> Assembled<'p> {
    #[inline]
    fn new(header: &Header, parts: &'p [&'p [u8]]) -> Self {
        let head = header.emit();
        let fcs = fcs(&head, parts);
        Assembled { head, parts, fcs }
    }

    /// Encoded length, flags included.
    fn encoded_len(&self) -> usize {
        2 + escaped_len(&self.head)
            + self.parts.iter().map(|p| escaped_len(p)).sum::<usize>()
            + escaped_len(&self.fcs)
    }

    #[inline]
    fn emit(&self, emit: &mut impl FnMut(&[u8])) {
        emit(&[FLAG]);
        stuff(&self.head, emit);
        for part in self.parts {
            stuff(part, emit);
        }
        stuff(&self.fcs, emit);
        emit(&[FLAG]);
    }
}

/// Writes the unescaped `header | payload | fcs` frame into `out` and returns its length.
pub(crate) fn assemble(
    header: &Header,
    parts: &[&[u8]],
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let len = check(header, parts)?;
    let needed = super::storage_len(len);
    if out.len() < needed {
        return Err(EncodeError::BufferTooSmall {
            needed,
            available: out.len(),
        });
    }
    let head = header.emit();
    let fcs = fcs(&head, parts);
    let mut pos = 0;
    for part in [&head[..]]
        .into_iter()
        .chain(parts.iter().copied())
        .chain([&fcs[..]])
    {
        if let Some(dst) = out.get_mut(pos..pos + part.len()) {
            dst.copy_from_slice(part);
        }
        pos += part.len();
    }
    Ok(pos)
}

/// Exact encoded length of a frame with this header and payload parts, flags included.
pub fn encoded_len(header: &Header, parts: &[&[u8]]) -> usize {
    Assembled::new(header, parts).encoded_len()
}

/// Encodes a frame and hands its bytes to `emit`, in runs, flags included.
///
/// This is the form for a UART or a queue: no frame buffer is needed. `emit` is not called at
/// all if the header does not match the payload.
pub fn encode_with(
    header: &Header,
    parts: &[&[u8]],
    mut emit: impl FnMut(&[u8]),
) -> Result<(), EncodeError> {
    check(header, parts)?;
    Assembled::new(header, parts).emit(&mut emit);
    Ok(())
}

/// Encodes a frame whose payload is the concatenation of `parts` (scatter-gather) into `out`
/// and returns its length. On error nothing is written.
pub fn encode_parts(
    header: &Header,
    parts: &[&[u8]],
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let len = check(header, parts)?;
    let frame = Assembled::new(header, parts);
    // The worst case needs no counting; a tighter buffer is checked exactly.
    if out.len() < super::max_encoded_len(len) {
        let needed = frame.encoded_len();
        if out.len() < needed {
            return Err(EncodeError::BufferTooSmall {
                needed,
                available: out.len(),
            });
        }
    }
    let mut pos = 0;
    frame.emit(&mut |run: &[u8]| {
        if let Some(dst) = out.get_mut(pos..pos + run.len()) {
            dst.copy_from_slice(run);
        }
        pos += run.len();
    });
    Ok(pos)
}

/// Encodes one frame into `out` and returns its length. On error nothing is written.
#[inline]
pub fn encode(header: &Header, payload: &[u8], out: &mut [u8]) -> Result<usize, EncodeError> {
    encode_parts(header, &[payload], out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_write_nothing() {
        let mut buf = [0xa5u8; 8];
        let err = encode(&Header::new(1, 2, 3, 4), &[0x7e; 4], &mut buf).unwrap_err();
        assert_eq!(
            err,
            EncodeError::BufferTooSmall {
                needed: 2 + 4 + 8 + 2,
                available: 8
            }
        );
        assert_eq!(buf, [0xa5; 8]);
        let err = encode(&Header::new(1, 2, 3, 5), &[0; 4], &mut buf).unwrap_err();
        assert!(matches!(
            err,
            EncodeError::LengthMismatch {
                header: 5,
                payload: 4
            }
        ));
        let err = encode_parts(&Header::new(1, 2, 3, 0), &[&[0; 200], &[0; 56]], &mut buf);
        assert_eq!(err, Err(EncodeError::PayloadTooLong { len: 256 }));
    }

    #[test]
    fn exact_buffer_is_enough() {
        let header = Header::new(0x7d, 0x7e, 0, 3);
        let payload = [0x7e, 1, 0x7d];
        let needed = encoded_len(&header, &[&payload]);
        let mut buf = [0xa5u8; 64];
        let n = encode(&header, &payload, &mut buf[..needed]).unwrap();
        assert_eq!(n, needed);
        let mut whole = [0u8; 64];
        assert_eq!(encode(&header, &payload, &mut whole), Ok(n));
        assert_eq!(buf[..n], whole[..n]);
    }

    #[test]
    fn parts_equal_one_payload() {
        let header = Header::new(9, 8, 7, 6);
        let mut a = [0u8; 32];
        let mut b = [0u8; 32];
        let n = encode(&header, &[1, 0x7e, 3, 4, 0x7d, 6], &mut a).unwrap();
        let m = encode_parts(&header, &[&[1], &[], &[0x7e, 3, 4], &[0x7d, 6]], &mut b).unwrap();
        assert_eq!(a[..n], b[..m]);
    }
}
