//! MAVLink 1 frames.
//!
//! ```text
//! FE len seq sysid compid msgid(1) payload(len) crc(2, LE)
//! ```
//!
//! MAVLink 1 carries ids up to 255 and only the base fields of a message (its `MIN_LEN` bytes),
//! never truncated and never signed.
//!
//! ```
//! use ferrolink_runtime::mavlink::{v1, Header};
//!
//! let payload = [4, 0, 0, 0, 2, 3, 0x51, 4, 3];
//! let mut out = [0u8; v1::MAX_FRAME_LEN];
//! let n = v1::encode_raw(Header::new(0, 1, 1), 0, 50, &payload, &mut out).unwrap();
//! assert_eq!(out[..n][n - 2..], [0xE1, 0x6D]);
//!
//! let frame = v1::Frame::new_checked(&out[..n]).unwrap();
//! assert!(frame.check_crc(50));
//! ```

use super::error::EncodeError;
use super::layout::{emit, emit_with, Layout, View};
use super::Dialect;
use super::{Header, Message, MAX_PAYLOAD_LEN};

/// The first byte of every MAVLink 1 frame.
pub const MAGIC: u8 = 0xFE;
/// Header length, magic byte included.
pub const HEADER_LEN: usize = 6;
pub use super::layout::CHECKSUM_LEN;
/// The longest frame.
pub const MAX_FRAME_LEN: usize = HEADER_LEN + MAX_PAYLOAD_LEN + CHECKSUM_LEN;
/// The shortest frame: an empty payload.
pub const MIN_FRAME_LEN: usize = HEADER_LEN + CHECKSUM_LEN;
/// The largest message id MAVLink 1 can carry.
pub const MAX_MSG_ID: u32 = 0xFF;

/// MAVLink 1's header layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct V1;

impl Layout for V1 {
    const MAGIC: u8 = MAGIC;
    const HEADER_LEN: usize = HEADER_LEN;
    const SEQ: usize = 2;
    const SYSID: usize = 3;
    const COMPID: usize = 4;

    #[inline(always)]
    fn msg_id(bytes: &[u8]) -> u32 {
        bytes.get(5).map_or(0, |&id| u32::from(id))
    }

    #[inline(always)]
    fn trailer_len(_: &[u8]) -> usize {
        0
    }
}

/// A zero-copy view of a MAVLink 1 frame in a byte buffer (see [`View`] for its accessors).
pub type Frame<T> = View<T, V1>;

#[inline]
fn make_head(header: Header, msg_id: u8, len: u8) -> [u8; HEADER_LEN] {
    [MAGIC, len, header.seq, header.sysid, header.compid, msg_id]
}

/// Encodes a frame carrying exactly `payload` into `out` and returns the frame length.
///
/// MAVLink 1 sends a message's base fields only: pass its first `MIN_LEN` payload bytes.
/// Fails with [`EncodeError::IdOutOfRange`] for ids above 255. Nothing is written on error.
pub fn encode_raw(
    header: Header,
    msg_id: u32,
    crc_extra: u8,
    payload: &[u8],
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let Ok(id) = u8::try_from(msg_id) else {
        return Err(EncodeError::IdOutOfRange);
    };
    if payload.len() > MAX_PAYLOAD_LEN {
        return Err(EncodeError::PayloadTooLong);
    }
    emit(
        out,
        make_head(header, id, payload.len() as u8),
        payload,
        crc_extra,
        0,
    )
}

/// Encodes the base fields of message `msg` into `out` and returns the frame length.
///
/// Fails with [`EncodeError::IdOutOfRange`] for ids above 255. If `out` can hold the largest
/// frame ([`MAX_FRAME_LEN`]), the payload is encoded in place and bytes of `out` past the
/// returned length may be overwritten. Nothing is written on error.
#[inline]
pub fn encode<M: Message>(header: Header, msg: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
    encode_with(
        header,
        M::ID,
        M::CRC_EXTRA,
        M::MIN_LEN,
        |p| msg.encode(p),
        out,
    )
}

/// Encodes the base fields of any message of dialect `D` into `out`, as [`encode`] does, and
/// returns the frame length.
#[inline]
pub fn encode_dialect<D: Dialect>(
    header: Header,
    msg: &D,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let meta = msg.meta();
    let min_len = usize::from(meta.min_len);
    encode_with(
        header,
        meta.id,
        meta.crc_extra,
        min_len,
        |p| msg.encode(p),
        out,
    )
}

fn encode_with(
    header: Header,
    msg_id: u32,
    crc_extra: u8,
    min_len: usize,
    fill: impl FnOnce(&mut super::PayloadBuf) -> usize,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let Ok(id) = u8::try_from(msg_id) else {
        return Err(EncodeError::IdOutOfRange);
    };
    emit_with(
        out,
        fill,
        |_| min_len,
        |len| make_head(header, id, len),
        crc_extra,
        0,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mavlink::testing::{golden_heartbeat, hex, Big, ExtMsg, TestDialect, GOLDEN_V1};
    use crate::mavlink::FrameError;

    const HB: Header = Header::new(0, 1, 1);

    #[test]
    fn golden_heartbeat_round_trip() {
        let golden = hex(GOLDEN_V1);
        let mut out = [0xA5u8; 17];
        assert_eq!(encode(HB, &golden_heartbeat(), &mut out), Ok(17));
        assert_eq!(out[..], golden[..]);

        let mut big = [0xA5u8; MAX_FRAME_LEN];
        let msg = TestDialect::Heartbeat(golden_heartbeat());
        assert_eq!(encode_dialect(HB, &msg, &mut big), Ok(17));
        assert_eq!(big[..17], golden[..]);

        let mut out = [0xA5u8; 18];
        assert_eq!(encode_raw(HB, 0, 50, &golden[6..15], &mut out), Ok(17));
        assert_eq!(out[..17], golden[..]);
        assert_eq!(out[17], 0xA5);

        let frame = Frame::new_checked(&golden[..]).unwrap();
        assert_eq!(frame.payload_len(), 9);
        assert_eq!(frame.header(), HB);
        assert_eq!(frame.msg_id(), 0);
        assert_eq!(frame.checksum(), 0x6DE1);
        assert!(frame.check_crc(50));
        assert!(!frame.check_crc(49));
        assert_eq!(frame.as_bytes(), &golden[..]);
        assert_eq!(
            frame.decode::<TestDialect>(),
            Ok(TestDialect::Heartbeat(golden_heartbeat()))
        );
    }

    #[test]
    fn truncated_input_is_rejected() {
        let golden = hex(GOLDEN_V1);
        for cut in 0..golden.len() {
            assert_eq!(
                Frame::new_checked(&golden[..cut]).err(),
                Some(FrameError::Truncated)
            );
            let f = Frame::new_unchecked(&golden[..cut]);
            let _ = (f.header(), f.msg_id(), f.payload(), f.check_crc(50));
            let _ = (f.as_bytes(), f.decode::<TestDialect>());
        }
        assert_eq!(
            Frame::new_checked(&hex(super::super::testing::GOLDEN_V2)[..]).err(),
            Some(FrameError::BadMagic)
        );
    }

    #[test]
    fn sends_base_fields_only_and_zero_fills_extensions() {
        // Re-id the extension message below 256 to send it over MAVLink 1.
        let msg = ExtMsg {
            base_i32: 1,
            base_u16: 0,
            base_u8: 0,
            ext_u8: 9,
            ext_f32: 10.0,
        };
        let mut payload = [0u8; 255];
        let n = msg.encode(&mut payload);
        assert_eq!(n, ExtMsg::MAX_LEN);
        let mut out = [0xA5u8; 32];
        let len = encode_raw(HB, 200, 1, &payload[..ExtMsg::MIN_LEN], &mut out).unwrap();
        assert_eq!(len, HEADER_LEN + ExtMsg::MIN_LEN + CHECKSUM_LEN);
        let frame = Frame::new_checked(&out[..len]).unwrap();
        assert_eq!(frame.payload(), &payload[..7], "no truncation in MAVLink 1");
        let back: ExtMsg = frame.decode_message();
        assert_eq!(
            back,
            ExtMsg {
                ext_u8: 0,
                ext_f32: 0.0,
                ..msg
            }
        );
    }

    #[test]
    fn refuses_ids_above_255() {
        let mut out = [0xA5u8; MAX_FRAME_LEN];
        assert_eq!(
            encode(HB, &Big([1; 255]), &mut out),
            Err(EncodeError::IdOutOfRange)
        );
        assert_eq!(
            encode_dialect(HB, &TestDialect::Big(Big([1; 255])), &mut out),
            Err(EncodeError::IdOutOfRange)
        );
        assert_eq!(
            encode_raw(HB, 256, 0, &[1], &mut out),
            Err(EncodeError::IdOutOfRange)
        );
        assert!(out.iter().all(|&b| b == 0xA5));
        assert_eq!(encode_raw(HB, 255, 0, &[1], &mut out), Ok(9));
    }

    #[test]
    fn small_buffers_are_refused() {
        let mut out = [0xA5u8; 16];
        assert_eq!(
            encode(HB, &golden_heartbeat(), &mut out),
            Err(EncodeError::BufferTooSmall { needed: 17 })
        );
        assert!(out.iter().all(|&b| b == 0xA5));
        assert_eq!(
            encode_raw(HB, 0, 0, &[0; 256], &mut out),
            Err(EncodeError::PayloadTooLong)
        );
    }
}
