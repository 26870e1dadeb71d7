//! ModRob-1 messages and their CAN-1 form: a 29-bit extended identifier and 6 or 8 data bytes.
//!
//! ```text
//! identifier: 000 | type(2) | MI(16) | VI or chunk number(8)
//! command:     value or (x, MI lo, MI hi, VI) | command type | reserved       (6 bytes)
//! publication: value f32 LE | reserved(2)                                      (6 bytes)
//! piecewise:   chunk(7, the last one zero-padded) | number of chunks           (8 bytes)
//! ```
//!
//! Types: 0 command, 1 publication, 2 piecewise, 3 reserved. Command types: 0 set value,
//! 1 set publication frequency, 2 set subscription address, 3..=255 reserved.
//!
//! The encoder writes every reserved byte as zero; the decoder ignores reserved bytes and byte 0
//! of a "set subscription address" command, and rejects what the specification reserves: the
//! identifier's three top bits set, message type 3, command types 3..=255 and a data length
//! other than the type's. Every decode error is a value, never a panic.
//!
//! ```
//! use ferrolink_runtime::modrob::{CommandKind, Message};
//!
//! let message = Message::Publication { module: 0x0102, variable: 3, value: 1.5 };
//! let can = message.to_can();
//! assert_eq!(can.id, 0x0101_0203);
//! assert_eq!(can.data(), &[0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00]);
//! assert_eq!(Message::from_can(can.id, can.data()), Ok(message));
//!
//! let set = Message::Command { module: 7, variable: 0, command: CommandKind::SetFrequency(100.0) };
//! assert_eq!(Message::from_can(set.can_id(), set.to_can().data()), Ok(set));
//! ```

use core::fmt;

/// The largest 29-bit extended identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;
/// Data bytes of a command or a publication.
pub const SHORT_DATA_LEN: usize = 6;
/// Data bytes of a piecewise transmission chunk.
pub const PIECEWISE_DATA_LEN: usize = 8;
/// Payload bytes in one piecewise chunk.
pub const CHUNK_LEN: usize = 7;

/// The message type in identifier bits 25..24.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MessageType {
    /// 0b00: a command to a variable.
    Command = 0,
    /// 0b01: a variable's current value.
    Publication = 1,
    /// 0b10: one chunk of a byte array.
    Piecewise = 2,
}

impl MessageType {
    /// The data length this type has on CAN-1 (and in UART.B-1's length nibble).
    pub const fn data_len(self) -> usize {
        match self {
            MessageType::Command | MessageType::Publication => SHORT_DATA_LEN,
            MessageType::Piecewise => PIECEWISE_DATA_LEN,
        }
    }
}

/// What a command asks of its variable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CommandKind {
    /// Command type 0: set the variable to this value.
    SetValue(f32),
    /// Command type 1: publish the variable at this frequency, in Hz.
    SetFrequency(f32),
    /// Command type 2: when a publication from this address arrives, set the commanded
    /// variable to the published value.
    SetSubscription {
        /// The publishing module.
        module: u16,
        /// The published variable.
        variable: u8,
    },
}

impl CommandKind {
    /// The command type byte (data byte 4).
    pub const fn code(&self) -> u8 {
        match self {
            CommandKind::SetValue(_) => 0,
            CommandKind::SetFrequency(_) => 1,
            CommandKind::SetSubscription { .. } => 2,
        }
    }
}

/// One ModRob-1 message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Message {
    /// A command to the variable `variable` of module `module`.
    Command {
        /// The commanded module (MI).
        module: u16,
        /// The commanded variable (VI).
        variable: u8,
        /// What is asked.
        command: CommandKind,
    },
    /// The current value of a variable.
    Publication {
        /// The publishing module (MI).
        module: u16,
        /// The published variable (VI).
        variable: u8,
        /// Its value.
        value: f32,
    },
    /// One chunk of a byte array a module sends about itself.
    Piecewise {
        /// The sending module (MI).
        module: u16,
        /// The chunk's sequence number (the identifier's VI field).
        chunk: u8,
        /// How many chunks the array has.
        chunks: u8,
        /// The chunk; the last one of an array is padded with zeros.
        data: [u8; CHUNK_LEN],
    },
}

/// Why bytes are not a ModRob-1 message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum DecodeError {
    /// Identifier bits above bit 25 are set: bits 28..26 are reserved, and a CAN-1 identifier
    /// has 29 bits.
    ReservedIdBits {
        /// The identifier as received.
        id: u32,
    },
    /// Message type 3 (0b11), which is reserved.
    ReservedType,
    /// A command type from the reserved range 3..=255.
    ReservedCommand {
        /// The command type byte.
        command: u8,
    },
    /// The data length is not the one of the message type (6 for commands and publications,
    /// 8 for piecewise chunks).
    DataLength {
        /// The length the type has.
        expected: u8,
        /// The length received.
        got: usize,
    },
    /// An 11-bit (standard) CAN identifier: CAN-1 uses extended identifiers only.
    StandardId,
    /// A remote (RTR) CAN frame, which carries no data.
    RemoteFrame,
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecodeError::ReservedIdBits { id } => {
                write!(
                    f,
                    "identifier {id:#010x} has reserved bits (28..26 or above) set"
                )
            }
            DecodeError::ReservedType => f.write_str("message type 3 is reserved"),
            DecodeError::ReservedCommand { command } => {
                write!(f, "command type {command} is reserved")
            }
            DecodeError::DataLength { expected, got } => {
                write!(f, "{got} data bytes where the message type has {expected}")
            }
            DecodeError::StandardId => {
                f.write_str("standard (11-bit) identifier; CAN-1 uses extended identifiers")
            }
            DecodeError::RemoteFrame => f.write_str("remote frame; ModRob-1 messages carry data"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for DecodeError {}

/// A message in CAN-1 form: the extended identifier and the data bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    /// The 29-bit extended identifier.
    pub id: u32,
    /// The data bytes; only the first `len` are sent.
    pub bytes: [u8; 8],
    /// Data length: 6 or 8.
    pub len: u8,
}

impl CanFrame {
    /// The data bytes that are sent.
    #[inline]
    pub fn data(&self) -> &[u8] {
        self.bytes
            .get(..usize::from(self.len))
            .unwrap_or(&self.bytes)
    }
}

impl Message {
    /// The message type.
    #[inline]
    pub const fn message_type(&self) -> MessageType {
        match self {
            Message::Command { .. } => MessageType::Command,
            Message::Publication { .. } => MessageType::Publication,
            Message::Piecewise { .. } => MessageType::Piecewise,
        }
    }

    /// The module identifier (MI): the commanded, publishing or sending module.
    #[inline]
    pub const fn module(&self) -> u16 {
        match *self {
            Message::Command { module, .. }
            | Message::Publication { module, .. }
            | Message::Piecewise { module, .. } => module,
        }
    }

    /// The identifier's low byte: the VI, or a piecewise chunk's number.
    #[inline]
    pub const fn low_byte(&self) -> u8 {
        match *self {
            Message::Command { variable, .. } | Message::Publication { variable, .. } => variable,
            Message::Piecewise { chunk, .. } => chunk,
        }
    }

    /// Data length on CAN-1: 6, or 8 for a piecewise chunk.
    #[inline]
    pub const fn data_len(&self) -> usize {
        self.message_type().data_len()
    }

    /// The 29-bit CAN-1 identifier: type in bits 25..24, MI in 23..8, VI (chunk) in 7..0.
    #[inline]
    pub const fn can_id(&self) -> u32 {
        (self.message_type() as u32) << 24 | (self.module() as u32) << 8 | self.low_byte() as u32
    }

    /// The CAN-1 data field; reserved bytes are zero.
    pub fn can_data(&self) -> [u8; 8] {
        let mut data = [0u8; 8];
        let (value, code) = match *self {
            Message::Command { command, .. } => match command {
                CommandKind::SetValue(v) | CommandKind::SetFrequency(v) => {
                    (v.to_le_bytes(), command.code())
                }
                CommandKind::SetSubscription { module, variable } => {
                    let [lo, hi] = module.to_le_bytes();
                    ([0, lo, hi, variable], command.code())
                }
            },
            Message::Publication { value, .. } => (value.to_le_bytes(), 0),
            Message::Piecewise {
                chunks,
                data: chunk,
                ..
            } => {
                let [a, b, c, d, e, f, g] = chunk;
                return [a, b, c, d, e, f, g, chunks];
            }
        };
        let [a, b, c, d] = value;
        data[..5].copy_from_slice(&[a, b, c, d, code]);
        data
    }

    /// The message in CAN-1 form.
    #[inline]
    pub fn to_can(&self) -> CanFrame {
        CanFrame {
            id: self.can_id(),
            bytes: self.can_data(),
            len: self.data_len() as u8,
        }
    }

    /// Decodes a CAN-1 message from its 29-bit identifier and data bytes.
    pub fn from_can(id: u32, data: &[u8]) -> Result<Message, DecodeError> {
        if id >> 26 != 0 {
            return Err(DecodeError::ReservedIdBits { id });
        }
        let message_type = match id >> 24 {
            0 => MessageType::Command,
            1 => MessageType::Publication,
            2 => MessageType::Piecewise,
            _ => return Err(DecodeError::ReservedType),
        };
        let module = (id >> 8) as u16;
        let low = id as u8;
        let expected = message_type.data_len();
        if data.len() != expected {
            return Err(DecodeError::DataLength {
                expected: expected as u8,
                got: data.len(),
            });
        }
        let mut bytes = [0u8; 8];
        bytes[..expected].copy_from_slice(data);
        let [a, b, c, d, code, _, g, chunks] = bytes;
        let value = f32::from_le_bytes([a, b, c, d]);
        Ok(match message_type {
            MessageType::Command => Message::Command {
                module,
                variable: low,
                command: match code {
                    0 => CommandKind::SetValue(value),
                    1 => CommandKind::SetFrequency(value),
                    2 => CommandKind::SetSubscription {
                        module: u16::from_le_bytes([b, c]),
                        variable: d,
                    },
                    command => return Err(DecodeError::ReservedCommand { command }),
                },
            },
            MessageType::Publication => Message::Publication {
                module,
                variable: low,
                value,
            },
            MessageType::Piecewise => Message::Piecewise {
                module,
                chunk: low,
                chunks,
                data: [a, b, c, d, code, bytes[5], g],
            },
        })
    }

    /// Whether two messages have the same wire form (floats compared by their bits, so a NaN
    /// equals itself).
    pub fn same_wire(&self, other: &Message) -> bool {
        self.to_can() == other.to_can()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reserved_values_are_errors() {
        assert_eq!(
            Message::from_can(0x0300_0000, &[0; 6]),
            Err(DecodeError::ReservedType)
        );
        assert_eq!(
            Message::from_can(0x0400_0000, &[0; 6]),
            Err(DecodeError::ReservedIdBits { id: 0x0400_0000 })
        );
        assert_eq!(
            Message::from_can(0, &[0, 0, 0, 0, 3, 0]),
            Err(DecodeError::ReservedCommand { command: 3 })
        );
        assert_eq!(
            Message::from_can(0x0200_0000, &[0; 6]),
            Err(DecodeError::DataLength {
                expected: 8,
                got: 6
            })
        );
    }

    #[test]
    fn piecewise_layout() {
        let m = Message::Piecewise {
            module: 0xabcd,
            chunk: 255,
            chunks: 9,
            data: [1, 2, 3, 4, 5, 6, 7],
        };
        let can = m.to_can();
        assert_eq!(can.id, 0x02ab_cdff);
        assert_eq!(can.data(), &[1, 2, 3, 4, 5, 6, 7, 9]);
        assert_eq!(Message::from_can(can.id, can.data()), Ok(m));
    }
}
