//! HDLC-like byte stuffing, shared by NDLCom frames and TosNet on byte streams.
//!
//! A frame goes between two flags (0x7E). Between them, 0x7E and 0x7D are sent as 0x7D
//! followed by the byte XOR 0x20, so a flag on the wire always delimits.

/// Starts and ends every frame.
pub const FLAG: u8 = 0x7E;
/// Escapes a 0x7E or 0x7D between the flags; the next byte is XORed with 0x20.
pub const ESCAPE: u8 = 0x7D;
/// What an escaped byte is XORed with.
pub(crate) const XOR: u8 = 0x20;

/// Whether `b` must be escaped (0x7D or 0x7E).
#[inline(always)]
pub(crate) const fn is_special(b: u8) -> bool {
    b.wrapping_sub(ESCAPE) < 2
}

/// Bytes `bytes` take once escaped.
#[inline]
pub(crate) fn escaped_len(bytes: &[u8]) -> usize {
    bytes.len() + bytes.iter().filter(|&&b| is_special(b)).count()
}

/// Calls `emit` with the escaped form of `bytes`, in runs.
#[inline]
pub(crate) fn stuff(mut bytes: &[u8], emit: &mut impl FnMut(&[u8])) {
    while let Some(i) = bytes.iter().position(|&b| is_special(b)) {
        let (run, rest) = bytes.split_at(i);
        if !run.is_empty() {
            emit(run);
        }
        if let Some((&b, rest)) = rest.split_first() {
            emit(&[ESCAPE, b ^ XOR]);
            bytes = rest;
        }
    }
    if !bytes.is_empty() {
        emit(bytes);
    }
}

/// Encoded length of an unescaped frame, flags included.
pub(crate) fn stuffed_len(frame: &[u8]) -> usize {
    2 + escaped_len(frame)
}

/// Escapes an unescaped frame between two flags.
pub(crate) fn stuff_frame(frame: &[u8], mut emit: impl FnMut(&[u8])) {
    emit(&[FLAG]);
    stuff(frame, &mut emit);
    emit(&[FLAG]);
}

#[cfg(feature = "tosnet")]
/// Writes `frame`, escaped between two flags, into `out`; `None` (nothing written that counts)
/// if `out` is too small.
pub(crate) fn stuff_into(frame: &[u8], out: &mut [u8]) -> Option<usize> {
    let len = stuffed_len(frame);
    let out = out.get_mut(..len)?;
    let mut pos = 0;
    stuff_frame(frame, |run| {
        if let Some(dst) = out.get_mut(pos..pos + run.len()) {
            dst.copy_from_slice(run);
        }
        pos += run.len();
    });
    Some(len)
}

#[cfg(all(test, feature = "tosnet"))]
mod tests {
    use super::*;

    #[test]
    fn specials_are_escaped_and_nothing_else() {
        let mut out = [0u8; 16];
        let n = stuff_into(&[1, FLAG, 2, ESCAPE, 3], &mut out).unwrap();
        assert_eq!(&out[..n], [FLAG, 1, ESCAPE, 0x5E, 2, ESCAPE, 0x5D, 3, FLAG]);
        assert_eq!(stuff_into(&[FLAG; 8], &mut out), None);
    }
}
