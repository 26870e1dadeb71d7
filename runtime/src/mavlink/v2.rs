//! MAVLink 2 frames.
//!
//! ```text
//! FD len incompat compat seq sysid compid msgid(3, LE) payload(len) crc(2, LE) [signature(13)]
//! ```
//!
//! Senders drop trailing zero bytes of the payload (keeping at least one), receivers zero-fill a
//! short payload before decoding. Only one incompat flag is defined, [`INCOMPAT_SIGNED`]: the
//! frame carries the 13-byte signature trailer of [`signing`](super::signing).
//!
//! ```
//! use ferrolink_runtime::mavlink::{v2, Header};
//!
//! // HEARTBEAT (id 0, CRC_EXTRA 50) with an already encoded payload.
//! let payload = [4, 0, 0, 0, 2, 3, 0x51, 4, 3];
//! let mut out = [0u8; v2::MAX_FRAME_LEN];
//! let n = v2::encode_raw(Header::new(0, 1, 1), 0, 50, &payload, &mut out).unwrap();
//!
//! let frame = v2::Frame::new_checked(&out[..n]).unwrap();
//! assert_eq!((frame.sysid(), frame.msg_id()), (1, 0));
//! assert!(frame.check_crc(50));
//! assert_eq!(frame.payload(), &payload);
//! ```

use super::error::EncodeError;
use super::layout::{emit, emit_with, Layout, View};
use super::{Dialect, Header, Message, MAX_PAYLOAD_LEN};

/// The first byte of every MAVLink 2 frame.
pub const MAGIC: u8 = 0xFD;
/// Header length, magic byte included.
pub const HEADER_LEN: usize = 10;
pub use super::layout::CHECKSUM_LEN;
/// Length of the signature trailer: link id (1), timestamp (6), signature (6).
pub const SIGNATURE_LEN: usize = 13;
/// The longest unsigned frame.
pub const MAX_UNSIGNED_FRAME_LEN: usize = HEADER_LEN + MAX_PAYLOAD_LEN + CHECKSUM_LEN;
/// The longest frame: a signed frame with a 255-byte payload.
pub const MAX_FRAME_LEN: usize = MAX_UNSIGNED_FRAME_LEN + SIGNATURE_LEN;
/// The shortest frame: an empty payload, no signature.
pub const MIN_FRAME_LEN: usize = HEADER_LEN + CHECKSUM_LEN;
/// The largest message id (24 bits).
pub const MAX_MSG_ID: u32 = 0x00FF_FFFF;
/// incompat flag: the frame is signed.
pub const INCOMPAT_SIGNED: u8 = 0x01;
/// Every incompat flag this implementation understands. A frame with any other bit set must be
/// dropped.
pub const KNOWN_INCOMPAT_FLAGS: u8 = INCOMPAT_SIGNED;

/// MAVLink 2's header layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct V2;

/// Byte positions of the header fields only MAVLink 2 has.
const INCOMPAT: usize = 2;
const COMPAT: usize = 3;

impl Layout for V2 {
    const MAGIC: u8 = MAGIC;
    const HEADER_LEN: usize = HEADER_LEN;
    const SEQ: usize = 4;
    const SYSID: usize = 5;
    const COMPID: usize = 6;

    #[inline(always)]
    fn msg_id(bytes: &[u8]) -> u32 {
        match bytes.get(7..10) {
            Some(&[a, b, c]) => u32::from_le_bytes([a, b, c, 0]),
            _ => 0,
        }
    }

    #[inline(always)]
    fn trailer_len(bytes: &[u8]) -> usize {
        match bytes.get(INCOMPAT) {
            Some(&flags) if flags & INCOMPAT_SIGNED != 0 => SIGNATURE_LEN,
            _ => 0,
        }
    }
}

/// A zero-copy view of a MAVLink 2 frame in a byte buffer (see [`View`] for its accessors; the
/// payload may be truncated, see [`View::decode`]).
pub type Frame<T> = View<T, V2>;

/// What only MAVLink 2 frames carry: flags and the signature.
impl<T: AsRef<[u8]>> View<T, V2> {
    /// The incompat flags.
    #[inline]
    pub fn incompat_flags(&self) -> u8 {
        self.byte(INCOMPAT)
    }

    /// The compat flags (ignored by receivers).
    #[inline]
    pub fn compat_flags(&self) -> u8 {
        self.byte(COMPAT)
    }

    /// Whether any incompat flag other than the known ones is set; such a frame must be dropped.
    #[inline]
    pub fn has_unknown_flags(&self) -> bool {
        self.incompat_flags() & !KNOWN_INCOMPAT_FLAGS != 0
    }

    /// Whether the signed flag is set (the frame ends with a 13-byte signature trailer).
    #[inline]
    pub fn is_signed(&self) -> bool {
        self.incompat_flags() & INCOMPAT_SIGNED != 0
    }

    /// The 13-byte signature trailer (link id, timestamp, signature), if the frame is signed.
    #[inline]
    pub fn signature_trailer(&self) -> Option<&[u8; SIGNATURE_LEN]> {
        if !self.is_signed() {
            return None;
        }
        self.bytes()
            .get(self.body_len() + CHECKSUM_LEN..)?
            .first_chunk()
    }

    /// The signing link id, if the frame is signed.
    #[inline]
    pub fn link_id(&self) -> Option<u8> {
        self.signature_trailer().map(|t| t[0])
    }

    /// The signing timestamp (units of 10 us since 2015-01-01 00:00 UTC), if the frame is
    /// signed.
    #[inline]
    pub fn timestamp(&self) -> Option<u64> {
        self.signature_trailer().map(|t| {
            let mut raw = [0u8; 8];
            raw[..6].copy_from_slice(&t[1..7]);
            u64::from_le_bytes(raw)
        })
    }

    /// The 6-byte signature, if the frame is signed.
    #[inline]
    pub fn signature(&self) -> Option<[u8; 6]> {
        self.signature_trailer().map(|t| {
            let mut sig = [0u8; 6];
            sig.copy_from_slice(&t[7..]);
            sig
        })
    }
}

/// How many payload bytes a MAVLink 2 sender puts on the wire: trailing zeros are dropped, but
/// at least one byte is kept.
#[inline]
pub fn truncated_len(payload: &[u8]) -> usize {
    payload.iter().rposition(|&b| b != 0).map_or(1, |i| i + 1)
}

#[inline]
fn make_head(header: Header, incompat: u8, msg_id: u32, len: u8) -> [u8; HEADER_LEN] {
    let [a, b, c, _] = msg_id.to_le_bytes();
    [
        MAGIC,
        len,
        incompat,
        0,
        header.seq,
        header.sysid,
        header.compid,
        a,
        b,
        c,
    ]
}

/// Encodes a frame from a whole payload into `out` and returns the frame length.
///
/// Trailing zero bytes of `payload` are not sent (at least one byte is, a zero byte if
/// `payload` is empty); compat and incompat flags are 0. Nothing is written on error.
pub fn encode_raw(
    header: Header,
    msg_id: u32,
    crc_extra: u8,
    payload: &[u8],
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    encode_raw_with(header, 0, msg_id, crc_extra, payload, out, 0)
}

/// Encodes message `msg` into `out` and returns the frame length.
///
/// If `out` can hold the largest frame ([`MAX_UNSIGNED_FRAME_LEN`]), the payload is encoded in
/// place and bytes of `out` past the returned length may be overwritten. Nothing is written on
/// error.
#[inline]
pub fn encode<M: Message>(header: Header, msg: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
    encode_with(header, 0, M::ID, M::CRC_EXTRA, |p| msg.encode(p), out, 0)
}

/// Encodes any message of dialect `D` into `out`, as [`encode`] does, and returns the frame
/// length.
#[inline]
pub fn encode_dialect<D: Dialect>(
    header: Header,
    msg: &D,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let meta = msg.meta();
    encode_with(
        header,
        0,
        meta.id,
        meta.crc_extra,
        |p| msg.encode(p),
        out,
        0,
    )
}

/// [`encode_raw`] with incompat flags and `reserve` bytes that must fit after the frame.
pub(crate) fn encode_raw_with(
    header: Header,
    incompat: u8,
    msg_id: u32,
    crc_extra: u8,
    payload: &[u8],
    out: &mut [u8],
    reserve: usize,
) -> Result<usize, EncodeError> {
    if msg_id > MAX_MSG_ID {
        return Err(EncodeError::IdOutOfRange);
    }
    if payload.len() > MAX_PAYLOAD_LEN {
        return Err(EncodeError::PayloadTooLong);
    }
    let payload = match payload.get(..truncated_len(payload)) {
        Some(p) => p,
        None => &[0],
    };
    let head = make_head(header, incompat, msg_id, payload.len() as u8);
    emit(out, head, payload, crc_extra, reserve)
}

/// [`encode`] with incompat flags and `reserve` bytes that must fit after the frame.
pub(crate) fn encode_with(
    header: Header,
    incompat: u8,
    msg_id: u32,
    crc_extra: u8,
    fill: impl FnOnce(&mut super::PayloadBuf) -> usize,
    out: &mut [u8],
    reserve: usize,
) -> Result<usize, EncodeError> {
    if msg_id > MAX_MSG_ID {
        return Err(EncodeError::IdOutOfRange);
    }
    emit_with(
        out,
        fill,
        truncated_len,
        |len| make_head(header, incompat, msg_id, len),
        crc_extra,
        reserve,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mavlink::testing::{
        golden_heartbeat, hex, Big, ExtMsg, Heartbeat, TestDialect, GOLDEN_V2,
    };
    use crate::mavlink::FrameError;

    const HB: Header = Header::new(0, 1, 1);

    #[test]
    fn golden_heartbeat_encodes_byte_exact() {
        let golden = hex(GOLDEN_V2);
        // Exactly sized buffer (stack path) and a large one (in-place path).
        let mut out = [0xA5u8; 21];
        assert_eq!(encode(HB, &golden_heartbeat(), &mut out), Ok(21));
        assert_eq!(out[..], golden[..]);

        let mut big = [0xA5u8; MAX_FRAME_LEN];
        assert_eq!(encode(HB, &golden_heartbeat(), &mut big), Ok(21));
        assert_eq!(big[..21], golden[..]);

        let mut out = [0xA5u8; 21];
        let msg = TestDialect::Heartbeat(golden_heartbeat());
        assert_eq!(encode_dialect(HB, &msg, &mut out), Ok(21));
        assert_eq!(out[..], golden[..]);

        let mut out = [0xA5u8; 22];
        assert_eq!(encode_raw(HB, 0, 50, &golden[10..19], &mut out), Ok(21));
        assert_eq!(out[..21], golden[..]);
        assert_eq!(out[21], 0xA5);
    }

    #[test]
    fn golden_heartbeat_parses() {
        let golden = hex(GOLDEN_V2);
        let frame = Frame::new_checked(&golden[..]).unwrap();
        assert_eq!(frame.payload_len(), 9);
        assert_eq!(frame.incompat_flags(), 0);
        assert_eq!(frame.compat_flags(), 0);
        assert_eq!(frame.header(), HB);
        assert_eq!(frame.msg_id(), 0);
        assert_eq!(frame.checksum(), 0xAE7B);
        assert_eq!(frame.frame_len(), 21);
        assert!(frame.check_crc(50));
        assert!(!frame.check_crc(51));
        assert!(!frame.is_signed());
        assert_eq!(frame.signature_trailer(), None);
        assert_eq!(frame.timestamp(), None);
        assert_eq!(frame.as_bytes(), &golden[..]);
        assert_eq!(
            frame.decode::<TestDialect>(),
            Ok(TestDialect::Heartbeat(golden_heartbeat()))
        );
        assert_eq!(frame.decode_message::<Heartbeat>(), golden_heartbeat());
    }

    #[test]
    fn truncated_input_is_rejected() {
        let golden = hex(GOLDEN_V2);
        for cut in 0..golden.len() {
            assert_eq!(
                Frame::new_checked(&golden[..cut]).err(),
                Some(FrameError::Truncated),
                "cut at {cut}"
            );
        }
        let mut bad = golden.clone();
        bad[0] = 0xFE;
        assert_eq!(
            Frame::new_checked(&bad[..]).err(),
            Some(FrameError::BadMagic)
        );
        // A longer buffer is fine: the frame is what the header announces.
        let mut long = golden.clone();
        long.extend_from_slice(&[1, 2, 3]);
        let frame = Frame::new_checked(&long[..]).unwrap();
        assert_eq!(frame.as_bytes(), &golden[..]);
        assert!(frame.check_crc(50));
    }

    #[test]
    fn unchecked_views_never_panic() {
        let golden = hex(GOLDEN_V2);
        for cut in 0..golden.len() {
            let f = Frame::new_unchecked(&golden[..cut]);
            let _ = (f.seq(), f.sysid(), f.compid(), f.msg_id(), f.header());
            let _ = (f.payload(), f.checksum(), f.check_crc(50), f.as_bytes());
            let _ = (f.timestamp(), f.signature(), f.link_id(), f.frame_len());
            let _ = f.decode::<TestDialect>();
        }
        // Signed flag with the trailer missing.
        let mut signed = golden.clone();
        signed[2] = INCOMPAT_SIGNED;
        let f = Frame::new_unchecked(&signed[..]);
        assert_eq!(f.signature_trailer(), None);
        assert_eq!(
            Frame::new_checked(&signed[..]).err(),
            Some(FrameError::Truncated)
        );
    }

    #[test]
    fn truncation_keeps_at_least_one_byte() {
        assert_eq!(truncated_len(&[]), 1);
        assert_eq!(truncated_len(&[0; 9]), 1);
        assert_eq!(truncated_len(&[0, 0, 7, 0, 0]), 3);
        assert_eq!(truncated_len(&[1, 0, 0, 9]), 4);

        let zero = Heartbeat::default();
        let mut out = [0xA5u8; 13];
        assert_eq!(encode(HB, &zero, &mut out), Ok(13));
        assert_eq!(out[1], 1, "length byte");
        assert_eq!(out[10], 0, "the kept payload byte");
        let frame = Frame::new_checked(&out[..]).unwrap();
        assert!(frame.check_crc(50));
        assert_eq!(frame.decode_message::<Heartbeat>(), zero);

        // In place, with stale bytes in the buffer.
        let mut big = [0xA5u8; MAX_FRAME_LEN];
        assert_eq!(encode(HB, &zero, &mut big), Ok(13));
        assert_eq!(big[..13], out[..]);

        let mut raw = [0xA5u8; 13];
        assert_eq!(encode_raw(HB, 0, 50, &[], &mut raw), Ok(13));
        assert_eq!(raw, out);
    }

    #[test]
    fn extensions_truncate_and_zero_fill() {
        let msg = ExtMsg {
            base_i32: 0x0403_0201,
            base_u16: 0,
            base_u8: 0,
            ext_u8: 0,
            ext_f32: 0.0,
        };
        let mut out = [0xA5u8; 64];
        let n = encode(Header::new(9, 2, 3), &msg, &mut out).unwrap();
        assert_eq!(
            n,
            HEADER_LEN + 4 + CHECKSUM_LEN,
            "cut inside the base fields"
        );
        let frame = Frame::new_checked(&out[..n]).unwrap();
        assert_eq!(frame.msg_id(), ExtMsg::ID);
        assert!(frame.check_crc(ExtMsg::CRC_EXTRA));
        assert_eq!(frame.decode::<TestDialect>(), Ok(TestDialect::Ext(msg)));

        let full = ExtMsg {
            ext_f32: f32::from_bits(0xDEAD_BEEF),
            ..msg
        };
        let n = encode(Header::new(9, 2, 3), &full, &mut out).unwrap();
        assert_eq!(n, HEADER_LEN + ExtMsg::MAX_LEN + CHECKSUM_LEN);
        let frame = Frame::new_checked(&out[..n]).unwrap();
        assert_eq!(frame.decode::<TestDialect>(), Ok(TestDialect::Ext(full)));

        // A longer payload than this dialect knows is cut.
        let mut long = [0u8; 20];
        long[..4].copy_from_slice(&[1, 2, 3, 4]);
        long[19] = 0xFF;
        let n = encode_raw(
            Header::default(),
            ExtMsg::ID,
            ExtMsg::CRC_EXTRA,
            &long,
            &mut out,
        )
        .unwrap();
        let frame = Frame::new_checked(&out[..n]).unwrap();
        assert_eq!(frame.payload_len(), 20);
        assert_eq!(frame.decode_message::<ExtMsg>(), msg);
    }

    #[test]
    fn largest_frame_and_id() {
        let big = Big([0xFF; 255]);
        let mut out = [0xA5u8; MAX_UNSIGNED_FRAME_LEN];
        assert_eq!(
            encode(Header::new(1, 2, 3), &big, &mut out),
            Ok(MAX_UNSIGNED_FRAME_LEN)
        );
        let frame = Frame::new_checked(&out[..]).unwrap();
        assert_eq!(frame.msg_id(), 0x00AB_CDEF);
        assert_eq!(frame.payload(), &[0xFF; 255][..]);
        assert!(frame.check_crc(Big::CRC_EXTRA));

        let mut small = [0xA5u8; MAX_UNSIGNED_FRAME_LEN - 1];
        assert_eq!(
            encode(Header::new(1, 2, 3), &big, &mut small),
            Err(EncodeError::BufferTooSmall {
                needed: MAX_UNSIGNED_FRAME_LEN
            })
        );
        assert!(small.iter().all(|&b| b == 0xA5), "nothing written on error");
    }

    #[test]
    fn encode_errors_write_nothing() {
        let mut out = [0xA5u8; 40];
        assert_eq!(
            encode_raw(Header::default(), MAX_MSG_ID + 1, 0, &[1], &mut out),
            Err(EncodeError::IdOutOfRange)
        );
        assert_eq!(
            encode_raw(Header::default(), 0, 0, &[1; 256], &mut out),
            Err(EncodeError::PayloadTooLong)
        );
        assert_eq!(
            encode_raw(Header::default(), 0, 0, &[1; 29], &mut out),
            Err(EncodeError::BufferTooSmall { needed: 41 })
        );
        assert!(out.iter().all(|&b| b == 0xA5));
        assert_eq!(
            encode_raw(Header::default(), MAX_MSG_ID, 0, &[1; 28], &mut out),
            Ok(40)
        );
        assert_eq!(Frame::new_checked(&out[..]).unwrap().msg_id(), MAX_MSG_ID);
    }
}
