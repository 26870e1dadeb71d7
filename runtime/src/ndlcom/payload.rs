//! Generated messages as NDLCom payloads.
//!
//! By NDLCom convention the first payload byte names the payload's type. Here it is the
//! dictionary's message id (so only ids below 256 can ride NDLCom, which `ferrolink check
//! --carrier ndlcom` enforces), followed by the message's whole fixed wire layout (`MAX_LEN`
//! bytes, little-endian, in MAVLink wire order). A shorter payload decodes zero-filled, as a
//! truncated MAVLink 2 payload does, so old and new nodes interoperate when fields are added.
//!
//! ```
//! use ferrolink_runtime::mavlink::{Message, PayloadBuf};
//! use ferrolink_runtime::ndlcom::{counters::TxCounters, parser::{Feed, Parser}, payload};
//! # #[derive(Debug, PartialEq)] struct Ping { seq: u32 }
//! # impl Message for Ping {
//! #     const ID: u32 = 4; const NAME: &'static str = "PING"; const CRC_EXTRA: u8 = 0;
//! #     const MIN_LEN: usize = 4; const MAX_LEN: usize = 4;
//! #     fn encode(&self, buf: &mut PayloadBuf) -> usize { buf[..4].copy_from_slice(&self.seq.to_le_bytes()); 4 }
//! #     fn decode(p: &[u8]) -> Self { let mut b = [0; 4]; b[..p.len().min(4)].copy_from_slice(&p[..p.len().min(4)]); Ping { seq: u32::from_le_bytes(b) } }
//! # }
//!
//! let mut counters = TxCounters::<256>::new();
//! let mut wire = [0u8; 64];
//! let n = payload::send(&mut counters, 1, 2, &Ping { seq: 7 }, &mut wire).unwrap();
//!
//! let mut parser = Parser::new([0u8; 64]);
//! let Feed::Frame { frame, .. } = parser.feed(&wire[..n]) else { panic!() };
//! assert_eq!((frame.header().sender, frame.header().receiver), (1, 2));
//! assert_eq!(payload::message_id(frame.payload()), Some(4));
//! assert_eq!(payload::decode_message::<Ping>(frame.payload()), Ok(Ping { seq: 7 }));
//! ```

use core::fmt;

use super::counters::TxCounters;
use super::{encode_parts, encode_with, EncodeError, Header, MAX_PAYLOAD_LEN};
use crate::mavlink::{Dialect, Message, PayloadBuf};

/// Why a message could not become, or come from, a payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum PayloadError {
    /// The message id does not fit the one-byte type field.
    IdTooLarge(u32),
    /// The message's wire layout plus its id byte exceeds 255 bytes.
    TooLong(usize),
    /// An empty payload names no message.
    Empty,
    /// The id is not one of the expected message(s).
    UnknownId(u32),
    /// The frame could not be encoded.
    Encode(EncodeError),
}

impl fmt::Display for PayloadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PayloadError::IdTooLarge(id) => {
                write!(
                    f,
                    "message id {id} does not fit NDLCom's one-byte type field"
                )
            }
            PayloadError::TooLong(len) => {
                write!(f, "a {len}-byte payload exceeds NDLCom's 255-byte maximum")
            }
            PayloadError::Empty => f.write_str("an empty payload names no message"),
            PayloadError::UnknownId(id) => write!(f, "message id {id} is not expected here"),
            PayloadError::Encode(e) => e.fmt(f),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for PayloadError {}

impl From<EncodeError> for PayloadError {
    fn from(e: EncodeError) -> Self {
        PayloadError::Encode(e)
    }
}

/// The message id and wire layout of `msg`: `(id byte, body buffer, body length)`.
fn split<M: Message>(msg: &M, body: &mut PayloadBuf) -> Result<(u8, usize), PayloadError> {
    let id = u8::try_from(M::ID).map_err(|_| PayloadError::IdTooLarge(M::ID))?;
    if M::MAX_LEN + 1 > MAX_PAYLOAD_LEN {
        return Err(PayloadError::TooLong(M::MAX_LEN + 1));
    }
    Ok((id, msg.encode(body)))
}

/// Writes `msg` as a payload (id byte, then its wire layout) into `out`; returns the length.
pub fn encode_message<M: Message>(msg: &M, out: &mut [u8]) -> Result<usize, PayloadError> {
    let mut body = [0u8; MAX_PAYLOAD_LEN];
    let (id, n) = split(msg, &mut body)?;
    let available = out.len();
    let dst = out
        .get_mut(..n + 1)
        .ok_or(PayloadError::Encode(EncodeError::BufferTooSmall {
            needed: n + 1,
            available,
        }))?;
    if let Some((first, rest)) = dst.split_first_mut() {
        *first = id;
        rest.copy_from_slice(body.get(..n).unwrap_or_default());
    }
    Ok(n + 1)
}

/// The message id a payload names.
#[inline]
pub fn message_id(payload: &[u8]) -> Option<u8> {
    payload.first().copied()
}

/// Decodes a payload as one message type.
pub fn decode_message<M: Message>(payload: &[u8]) -> Result<M, PayloadError> {
    match payload.split_first() {
        Some((&id, body)) if u32::from(id) == M::ID => Ok(M::decode(body)),
        Some((&id, _)) => Err(PayloadError::UnknownId(id.into())),
        None => Err(PayloadError::Empty),
    }
}

/// Decodes a payload into the dialect's message enum.
pub fn decode<D: Dialect>(payload: &[u8]) -> Result<D, PayloadError> {
    let (&id, body) = payload.split_first().ok_or(PayloadError::Empty)?;
    D::decode(id.into(), body).map_err(|e| PayloadError::UnknownId(e.0))
}

/// Encodes `msg` as a whole frame from `sender` to `receiver` into `out`, taking the
/// receiver's next counter; returns the frame length. On error nothing is written and no
/// counter is taken.
pub fn send<M: Message, const A: usize>(
    counters: &mut TxCounters<A>,
    sender: u8,
    receiver: u8,
    msg: &M,
    out: &mut [u8],
) -> Result<usize, PayloadError> {
    let mut body = [0u8; MAX_PAYLOAD_LEN];
    let (id, n) = split(msg, &mut body)?;
    let header = Header::new(receiver, sender, counters.peek(receiver), (n + 1) as u8);
    let len = encode_parts(&header, &[&[id], body.get(..n).unwrap_or_default()], out)?;
    counters.next(receiver);
    Ok(len)
}

/// Like [`send`], handing the frame's bytes to `emit` (a UART, a queue) instead of a buffer.
pub fn send_with<M: Message, const A: usize>(
    counters: &mut TxCounters<A>,
    sender: u8,
    receiver: u8,
    msg: &M,
    emit: impl FnMut(&[u8]),
) -> Result<(), PayloadError> {
    let mut body = [0u8; MAX_PAYLOAD_LEN];
    let (id, n) = split(msg, &mut body)?;
    let header = counters.header(receiver, sender, (n + 1) as u8);
    Ok(encode_with(
        &header,
        &[&[id], body.get(..n).unwrap_or_default()],
        emit,
    )?)
}
