//! ModRob.Ethernet-1: UART.B-1 messages batched into one UDP datagram.
//!
//! ```text
//! message id: ULID (16) | module id: UUID (16) | count: u16 little-endian | count messages
//! ```
//!
//! The ids are raw 16-byte arrays here; the `ulid` and `uuid` crates give them meaning on a PC.
//! [`PacketBuilder`] batches as many messages as fit the datagram size (by default
//! [`MAX_DATAGRAM_LEN`], a UDP payload that is not fragmented on Ethernet) into a caller
//! buffer; [`Packet`] reads one back without panicking on any input.
//!
//! ```
//! use ferrolink_runtime::modrob::{ethernet::{Packet, PacketBuilder}, Message};
//!
//! let mut buf = [0u8; 1472];
//! let mut builder = PacketBuilder::new(&mut buf, [1; 16], [2; 16]).unwrap();
//! let message = Message::Publication { module: 1, variable: 2, value: 0.5 };
//! while builder.push(&message).is_ok() {}
//! assert_eq!(builder.count(), 119); // (1472 - 34) / 12
//! let bytes = builder.finish();
//! let packet = Packet::new_checked(bytes).unwrap();
//! assert_eq!(packet.count(), 119);
//! assert!(packet.messages().all(|m| m == Ok(message)));
//! ```

use core::fmt;

use super::message::Message;
use super::uart::{self, Crc8, FrameError};

/// The header: message id, module id and count.
pub const HEADER_LEN: usize = 34;
/// The default largest datagram: a 1500-byte Ethernet MTU less the IPv4 and UDP headers.
pub const MAX_DATAGRAM_LEN: usize = 1472;

mod field {
    use core::ops::Range;
    pub const MESSAGE_ID: Range<usize> = 0..16;
    pub const MODULE_ID: Range<usize> = 16..32;
    pub const COUNT: Range<usize> = 32..34;
}

/// The fixed part of a packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Header {
    /// The packet's message id: a ULID, monotonic per sender.
    pub message_id: [u8; 16],
    /// The sending module's UUID.
    pub module_id: [u8; 16],
    /// How many messages follow.
    pub count: u16,
}

impl Header {
    /// Reads the header from the first 34 bytes; `None` if there are fewer.
    pub fn parse(bytes: &[u8]) -> Option<Header> {
        let mut header = Header::default();
        header
            .message_id
            .copy_from_slice(bytes.get(field::MESSAGE_ID)?);
        header
            .module_id
            .copy_from_slice(bytes.get(field::MODULE_ID)?);
        let count = bytes.get(field::COUNT)?;
        header.count = u16::from_le_bytes([*count.first()?, *count.get(1)?]);
        Some(header)
    }

    /// The 34 header bytes.
    pub fn emit(&self) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        out[field::MESSAGE_ID].copy_from_slice(&self.message_id);
        out[field::MODULE_ID].copy_from_slice(&self.module_id);
        out[field::COUNT].copy_from_slice(&self.count.to_le_bytes());
        out
    }
}

/// Why bytes are not an Ethernet-1 packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum PacketError {
    /// Fewer than the 34 header bytes.
    TooShort {
        /// Bytes there are.
        len: usize,
    },
    /// The packet ends inside message `index` (counting from 0), or before it.
    Truncated {
        /// The message's index.
        index: u16,
    },
    /// Message `index` does not start with 0x5A or has a length nibble other than 6 or 8.
    BadMessage {
        /// The message's index.
        index: u16,
        /// What is wrong with it.
        error: FrameError,
    },
    /// Bytes after the counted messages.
    TrailingBytes {
        /// How many.
        len: usize,
    },
    /// The output buffer cannot hold even the header.
    BufferTooSmall {
        /// Bytes the buffer has.
        available: usize,
    },
}

impl fmt::Display for PacketError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PacketError::TooShort { len } => {
                write!(f, "{len} bytes, shorter than the 34-byte header")
            }
            PacketError::Truncated { index } => write!(f, "packet ends inside message {index}"),
            PacketError::BadMessage { index, error } => write!(f, "message {index}: {error}"),
            PacketError::TrailingBytes { len } => {
                write!(f, "{len} bytes after the counted messages")
            }
            PacketError::BufferTooSmall { available } => write!(
                f,
                "a buffer of {available} bytes cannot hold the 34-byte header"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for PacketError {}

/// Builds one packet in a caller buffer, as many messages as fit.
#[derive(Debug)]
pub struct PacketBuilder<'b> {
    buf: &'b mut [u8],
    len: usize,
    max_len: usize,
    count: u16,
    crc: &'static Crc8,
}

impl<'b> PacketBuilder<'b> {
    /// A packet with these ids in `buf`, at most [`MAX_DATAGRAM_LEN`] bytes long (or
    /// `buf.len()` if less).
    pub fn new(
        buf: &'b mut [u8],
        message_id: [u8; 16],
        module_id: [u8; 16],
    ) -> Result<Self, PacketError> {
        let Some(head) = buf.get_mut(..HEADER_LEN) else {
            return Err(PacketError::BufferTooSmall {
                available: buf.len(),
            });
        };
        head.copy_from_slice(
            &Header {
                message_id,
                module_id,
                count: 0,
            }
            .emit(),
        );
        let max_len = buf.len().min(MAX_DATAGRAM_LEN);
        Ok(PacketBuilder {
            buf,
            len: HEADER_LEN,
            max_len,
            count: 0,
            crc: &uart::SMBUS,
        })
    }

    /// Sets the largest datagram (never beyond the buffer, nor below what is already in).
    pub fn set_max_len(&mut self, max_len: usize) -> &mut Self {
        self.max_len = max_len.min(self.buf.len()).max(self.len);
        self
    }

    /// Encodes messages with another CRC (messages already in keep theirs).
    pub fn set_crc(&mut self, crc: &'static Crc8) -> &mut Self {
        self.crc = crc;
        self
    }

    /// Appends a message; when it does not fit (or 65535 are in) it is handed back and the
    /// packet is unchanged.
    pub fn push(&mut self, message: &Message) -> Result<(), Message> {
        let end = self.len + uart::encoded_len(message);
        if end > self.max_len || self.count == u16::MAX {
            return Err(*message);
        }
        let written = self
            .buf
            .get_mut(self.len..end)
            .map(|out| uart::encode_with(message, self.crc, out));
        match written {
            Some(Ok(n)) => {
                self.len += n;
                self.count += 1;
                Ok(())
            }
            _ => Err(*message),
        }
    }

    /// Messages in the packet.
    #[inline]
    pub fn count(&self) -> u16 {
        self.count
    }

    /// Bytes in the packet so far, header included.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no message is in yet.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Bytes still free below the datagram size.
    #[inline]
    pub fn remaining(&self) -> usize {
        self.max_len - self.len
    }

    /// Writes the count and returns the packet's bytes.
    pub fn finish(self) -> &'b [u8] {
        if let Some(count) = self.buf.get_mut(field::COUNT) {
            count.copy_from_slice(&self.count.to_le_bytes());
        }
        let len = self.len;
        let buf: &'b [u8] = self.buf;
        buf.get(..len).unwrap_or_default()
    }
}

/// A received packet whose framing was checked: the header is there and the counted messages
/// fill the rest exactly. Each message's CRC and content are checked as it is read.
#[derive(Debug, Clone, Copy)]
pub struct Packet<'a> {
    header: Header,
    messages: &'a [u8],
    crc: &'static Crc8,
}

impl<'a> Packet<'a> {
    /// Checks the header and that `count` messages (by their sync bytes and length nibbles)
    /// fill the packet exactly.
    pub fn new_checked(bytes: &'a [u8]) -> Result<Self, PacketError> {
        let header = Header::parse(bytes).ok_or(PacketError::TooShort { len: bytes.len() })?;
        let messages = bytes.get(HEADER_LEN..).unwrap_or_default();
        let mut rest = messages;
        for index in 0..header.count {
            let len = match uart::frame_len(rest) {
                Ok(len) => len,
                Err(FrameError::Truncated { .. }) => return Err(PacketError::Truncated { index }),
                Err(error) => return Err(PacketError::BadMessage { index, error }),
            };
            rest = rest.get(len..).ok_or(PacketError::Truncated { index })?;
        }
        if !rest.is_empty() {
            return Err(PacketError::TrailingBytes { len: rest.len() });
        }
        Ok(Packet {
            header,
            messages,
            crc: &uart::SMBUS,
        })
    }

    /// Checks messages with another CRC.
    pub fn with_crc(self, crc: &'static Crc8) -> Self {
        Packet { crc, ..self }
    }

    /// The header.
    #[inline]
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The message id (a ULID).
    #[inline]
    pub fn message_id(&self) -> [u8; 16] {
        self.header.message_id
    }

    /// The sending module's UUID.
    #[inline]
    pub fn module_id(&self) -> [u8; 16] {
        self.header.module_id
    }

    /// How many messages the packet holds.
    #[inline]
    pub fn count(&self) -> u16 {
        self.header.count
    }

    /// The messages, each checked (CRC, reserved values) as it is read.
    pub fn messages(&self) -> Messages<'a> {
        Messages {
            rest: self.messages,
            crc: self.crc,
        }
    }
}

/// The messages of a [`Packet`], in order.
#[derive(Debug, Clone)]
pub struct Messages<'a> {
    rest: &'a [u8],
    crc: &'static Crc8,
}

impl Iterator for Messages<'_> {
    type Item = Result<Message, FrameError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let Ok(len) = uart::frame_len(self.rest) else {
            // Not reached after `new_checked`; stop rather than guess.
            let error = uart::frame_len(self.rest).err();
            self.rest = &[];
            return error.map(Err);
        };
        let (frame, rest) = self.rest.split_at(len.min(self.rest.len()));
        self.rest = rest;
        Some(uart::decode_with(frame, self.crc))
    }
}
