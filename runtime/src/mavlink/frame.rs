//! A frame of either version ([`AnyFrame`]), and which version a byte starts.

use super::error::FrameError;
use super::layout::Header;
use super::{v1, v2, Dialect, UnknownMessageId};

/// A MAVLink wire-format version.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Version {
    /// MAVLink 1: magic `0xFE`, 8-bit ids, no truncation, no signing.
    V1,
    /// MAVLink 2: magic `0xFD`, 24-bit ids, payload truncation, optional signature.
    V2,
}

impl Version {
    /// The version whose magic byte is `byte`.
    #[inline]
    pub const fn from_magic(byte: u8) -> Option<Self> {
        match byte {
            v1::MAGIC => Some(Self::V1),
            v2::MAGIC => Some(Self::V2),
            _ => None,
        }
    }

    /// The magic byte that starts a frame of this version.
    #[inline]
    pub const fn magic(self) -> u8 {
        match self {
            Self::V1 => v1::MAGIC,
            Self::V2 => v2::MAGIC,
        }
    }
}

/// A zero-copy view of a MAVLink 1 or MAVLink 2 frame, chosen by its magic byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnyFrame<T: AsRef<[u8]>> {
    /// A MAVLink 1 frame.
    V1(v1::Frame<T>),
    /// A MAVLink 2 frame.
    V2(v2::Frame<T>),
}

macro_rules! delegate {
    ($self:ident, $f:ident => $e:expr) => {
        match $self {
            AnyFrame::V1($f) => $e,
            AnyFrame::V2($f) => $e,
        }
    };
}

impl<T: AsRef<[u8]>> AnyFrame<T> {
    /// Wraps `buffer` as the frame version its first byte names, checking its length as the
    /// version's `new_checked` does.
    pub fn new_checked(buffer: T) -> Result<Self, FrameError> {
        match buffer
            .as_ref()
            .first()
            .copied()
            .and_then(Version::from_magic)
        {
            Some(Version::V1) => v1::Frame::new_checked(buffer).map(Self::V1),
            Some(Version::V2) => v2::Frame::new_checked(buffer).map(Self::V2),
            None if buffer.as_ref().is_empty() => Err(FrameError::Truncated),
            None => Err(FrameError::BadMagic),
        }
    }

    /// The wire-format version.
    #[inline]
    pub fn version(&self) -> Version {
        match self {
            Self::V1(_) => Version::V1,
            Self::V2(_) => Version::V2,
        }
    }

    /// The MAVLink 1 view, if this is a MAVLink 1 frame.
    #[inline]
    pub fn as_v1(&self) -> Option<&v1::Frame<T>> {
        match self {
            Self::V1(f) => Some(f),
            Self::V2(_) => None,
        }
    }

    /// The MAVLink 2 view, if this is a MAVLink 2 frame.
    #[inline]
    pub fn as_v2(&self) -> Option<&v2::Frame<T>> {
        match self {
            Self::V1(_) => None,
            Self::V2(f) => Some(f),
        }
    }

    /// The underlying buffer.
    #[inline]
    pub fn into_inner(self) -> T {
        delegate!(self, f => f.into_inner())
    }

    /// The sender fields.
    #[inline]
    pub fn header(&self) -> Header {
        delegate!(self, f => f.header())
    }

    /// The sequence number.
    #[inline]
    pub fn seq(&self) -> u8 {
        delegate!(self, f => f.seq())
    }

    /// The sending system id.
    #[inline]
    pub fn sysid(&self) -> u8 {
        delegate!(self, f => f.sysid())
    }

    /// The sending component id.
    #[inline]
    pub fn compid(&self) -> u8 {
        delegate!(self, f => f.compid())
    }

    /// The message id.
    #[inline]
    pub fn msg_id(&self) -> u32 {
        delegate!(self, f => f.msg_id())
    }

    /// The payload length the header announces.
    #[inline]
    pub fn payload_len(&self) -> u8 {
        delegate!(self, f => f.payload_len())
    }

    /// The payload as sent (MAVLink 2 payloads may be truncated).
    #[inline]
    pub fn payload(&self) -> &[u8] {
        delegate!(self, f => f.payload())
    }

    /// The checksum as sent.
    #[inline]
    pub fn checksum(&self) -> u16 {
        delegate!(self, f => f.checksum())
    }

    /// The checksum the frame should carry for a message with `crc_extra`.
    #[inline]
    pub fn compute_checksum(&self, crc_extra: u8) -> u16 {
        delegate!(self, f => f.compute_checksum(crc_extra))
    }

    /// Whether the checksum matches for a message with `crc_extra`.
    #[inline]
    pub fn check_crc(&self, crc_extra: u8) -> bool {
        delegate!(self, f => f.check_crc(crc_extra))
    }

    /// Whether the frame carries a MAVLink 2 signature.
    #[inline]
    pub fn is_signed(&self) -> bool {
        match self {
            Self::V1(_) => false,
            Self::V2(f) => f.is_signed(),
        }
    }

    /// Length of the whole frame, signature included, as its header announces.
    #[inline]
    pub fn frame_len(&self) -> usize {
        delegate!(self, f => f.frame_len())
    }

    /// The frame's bytes: exactly [`frame_len`](Self::frame_len) bytes, or fewer if the buffer is
    /// short (only possible for unchecked views).
    #[inline]
    pub fn as_bytes(&self) -> &[u8] {
        delegate!(self, f => f.as_bytes())
    }

    /// Decodes the payload as a message of dialect `D`, zero-filling a truncated payload.
    #[inline]
    pub fn decode<D: Dialect>(&self) -> Result<D, UnknownMessageId> {
        D::decode(self.msg_id(), self.payload())
    }

    /// Decodes like `decode`, into `out` (see [`Dialect::decode_into`]).
    #[inline]
    pub fn decode_into<D: Dialect>(&self, out: &mut D) -> Result<(), UnknownMessageId> {
        D::decode_into(self.msg_id(), self.payload(), out)
    }
}

/// Whether `byte` starts a frame of either version.
#[inline(always)]
pub(crate) const fn is_magic(byte: u8) -> bool {
    // 0xFD and 0xFE are adjacent: one compare.
    byte.wrapping_sub(v2::MAGIC) < 2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn magic_bytes() {
        for b in 0..=255u8 {
            assert_eq!(is_magic(b), b == 0xFD || b == 0xFE, "{b:#x}");
        }
        assert_eq!(Version::from_magic(0xFE), Some(Version::V1));
        assert_eq!(Version::from_magic(0xFD), Some(Version::V2));
        assert_eq!(Version::from_magic(0x55), None);
        assert_eq!(Version::V2.magic(), 0xFD);
    }

    #[test]
    fn any_frame_dispatches_on_magic() {
        assert_eq!(AnyFrame::new_checked(&[][..]), Err(FrameError::Truncated));
        assert_eq!(
            AnyFrame::new_checked(&[0x55][..]),
            Err(FrameError::BadMagic)
        );
        assert_eq!(
            AnyFrame::new_checked(&[0xFE][..]),
            Err(FrameError::Truncated)
        );
        assert_eq!(
            AnyFrame::new_checked(&[0xFD, 0][..]),
            Err(FrameError::Truncated)
        );
    }
}
