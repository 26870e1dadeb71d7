//! MAVLink: the contract generated dialects implement, plus frames, parsing and signing.
//!
//! A generated dialect provides one struct per message implementing [`Message`], and one enum of
//! all messages implementing [`Dialect`], whose [`Dialect::META`] table (sorted by id) is all a
//! parser or router needs to check and forward frames without decoding them.

//!
//! The frame layer, one module per wire format:
//!
//! - [`v1`] and [`v2`]: zero-copy frame views and encoders into caller buffers;
//! - [`parser`]: the backtracking stream parser, which recovers every intact frame from a noisy
//!   byte stream at any chunking;
//! - [`signing`]: MAVLink 2 signatures and replay protection, and [`router`], which checks
//!   them at its edges (both with the `signing` feature);
//! - [`service`]: the microservices (commands, parameters) as state machines (`services`).

mod chars;
mod enums;
mod error;
mod frame;
pub mod layout;
pub mod parser;
#[cfg(feature = "signing")]
pub mod router;
#[cfg(feature = "services")]
pub mod service;
#[cfg(feature = "signing")]
pub mod signing;
#[cfg(test)]
pub(crate) mod testing;
pub mod v1;
pub mod v2;

pub use chars::CharArray;
#[doc(hidden)]
pub use enums::fmt_flags;
pub use error::{EncodeError, FrameError};
pub use frame::{AnyFrame, Version};
pub use layout::Header;
pub use parser::Parser;

/// The largest MAVLink payload.
pub const MAX_PAYLOAD_LEN: usize = 255;

/// A payload buffer large enough for any message.
pub type PayloadBuf = [u8; MAX_PAYLOAD_LEN];

/// One message type of a dialect, with its wire layout fixed at generation time.
pub trait Message: Sized {
    /// The message id (24 bits).
    const ID: u32;
    /// The wire name, e.g. `"HEARTBEAT"`.
    const NAME: &'static str;
    /// The seed mixed into the frame checksum; it changes when the base layout changes.
    const CRC_EXTRA: u8;
    /// Payload length of the base fields (what MAVLink 1 sends).
    const MIN_LEN: usize;
    /// Payload length including extension fields.
    const MAX_LEN: usize;

    /// Writes the whole payload (`MAX_LEN` bytes, not truncated) to the start of `buf` and
    /// returns `MAX_LEN`.
    fn encode(&self, buf: &mut PayloadBuf) -> usize;

    /// Decodes a payload of any length: a short one is zero-filled, a long one is cut.
    /// Decoding never fails; unknown enum values are kept as `Unknown(raw)`.
    fn decode(payload: &[u8]) -> Self;
}

/// What a parser or router knows about a message id without decoding it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageMeta {
    /// Message id.
    pub id: u32,
    /// CRC_EXTRA seed.
    pub crc_extra: u8,
    /// Base payload length.
    pub min_len: u8,
    /// Payload length with extensions.
    pub max_len: u8,
    /// Payload offset of `target_system`, if the message is addressed.
    pub target_system: Option<u8>,
    /// Payload offset of `target_component`, if present.
    pub target_component: Option<u8>,
}

/// Looks `id` up in a table sorted by id.
#[inline]
pub fn find_meta(table: &[MessageMeta], id: u32) -> Option<&MessageMeta> {
    find_index(table, id).and_then(|i| table.get(i))
}

/// Where `id` is in a table sorted by id.
#[inline]
pub(crate) fn find_index(table: &[MessageMeta], id: u32) -> Option<usize> {
    table.binary_search_by_key(&id, |m| m.id).ok()
}

/// An id that the dialect does not define.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnknownMessageId(pub u32);

impl core::fmt::Display for UnknownMessageId {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "message id {} is not in this dialect", self.0)
    }
}

#[cfg(feature = "std")]
impl std::error::Error for UnknownMessageId {}

/// Decodes message `M` into `out`, wrapped by `wrap` (a dialect enum's variant): the arm a
/// generated [`Dialect::decode_into`] calls for each message.
///
/// One out-of-line function per message: `M::decode` is inlined into it and stores the fields
/// straight into `out`, with no temporary to copy, while the dialect's dispatch stays a jump
/// table of calls. Inlining all of a large dialect's decoders into the dispatch instead
/// measured no faster and made rustc take a third longer on MAVLink's common.xml.
#[inline(never)]
pub fn decode_variant<M: Message, D>(payload: &[u8], out: &mut D, wrap: impl FnOnce(M) -> D) {
    *out = wrap(M::decode(payload));
}

/// All messages of one dialect, as one enum.
pub trait Dialect: Sized {
    /// Metadata of every message, sorted by id.
    const META: &'static [MessageMeta];

    /// Decodes the payload of message `id` (zero-filling or cutting it as [`Message::decode`]).
    fn decode(id: u32, payload: &[u8]) -> Result<Self, UnknownMessageId>;

    /// Decodes like [`Dialect::decode`], into `out`: only the message's own bytes are written,
    /// where returning the enum by value moves all of it (as large as the largest message).
    /// On an unknown id `out` is left as it was.
    fn decode_into(id: u32, payload: &[u8], out: &mut Self) -> Result<(), UnknownMessageId> {
        *out = Self::decode(id, payload)?;
        Ok(())
    }

    /// The message id.
    fn id(&self) -> u32;

    /// The message's wire name, e.g. `"HEARTBEAT"`.
    fn name(&self) -> &'static str;

    /// Writes the whole payload and returns its length (`MAX_LEN`).
    fn encode(&self, buf: &mut PayloadBuf) -> usize;

    /// Metadata of this message.
    fn meta(&self) -> &'static MessageMeta {
        match find_meta(Self::META, self.id()) {
            Some(m) => m,
            // Every variant's id is in META by construction of the generated code.
            None => &UNKNOWN_META,
        }
    }

    /// Metadata of message `id`, if the dialect has it.
    fn meta_of(id: u32) -> Option<&'static MessageMeta> {
        find_meta(Self::META, id)
    }
}

static UNKNOWN_META: MessageMeta = MessageMeta {
    id: u32::MAX,
    crc_extra: 0,
    min_len: 0,
    max_len: 0,
    target_system: None,
    target_component: None,
};
