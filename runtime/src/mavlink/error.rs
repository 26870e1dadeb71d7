//! Errors of the frame layer. All are small `Copy` values; none carries a borrowed buffer.

use core::fmt;

/// Why a frame could not be encoded. Nothing is written to the output buffer when this is
/// returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is shorter than the frame; `needed` is the frame's length.
    BufferTooSmall {
        /// Bytes the frame needs.
        needed: usize,
    },
    /// The message id does not fit the wire format (MAVLink 1: 8 bits, MAVLink 2: 24 bits).
    IdOutOfRange,
    /// The payload is longer than 255 bytes.
    PayloadTooLong,
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BufferTooSmall { needed } => {
                write!(f, "output buffer too small, the frame needs {needed} bytes")
            }
            Self::IdOutOfRange => f.write_str("message id does not fit this MAVLink version"),
            Self::PayloadTooLong => f.write_str("payload longer than 255 bytes"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EncodeError {}

/// Why a buffer is not a frame of the expected version.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum FrameError {
    /// The first byte is not the version's magic byte.
    BadMagic,
    /// The buffer ends before the length its header announces (or before the header ends).
    Truncated,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BadMagic => f.write_str("not a MAVLink frame: wrong magic byte"),
            Self::Truncated => f.write_str("frame shorter than its header announces"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FrameError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_texts() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(
            EncodeError::BufferTooSmall { needed: 21 }.to_string(),
            "output buffer too small, the frame needs 21 bytes"
        );
        assert_eq!(
            FrameError::Truncated.to_string(),
            "frame shorter than its header announces"
        );
    }
}
