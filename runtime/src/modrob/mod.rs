//! ModRob-1: the messages of the modular mobile robot protocol (commands, publications,
//! piecewise transmissions) on its three networks, and the engines of its modules and leaders.
//!
//! - [`message`]: [`Message`] and its CAN-1 form (29-bit extended identifier, 6 or 8 data
//!   bytes), [`Message::to_can`] and [`Message::from_can`];
//! - [`uart`]: the UART.B-1 / SPI-1 byte array `0x5A | id_and_len | data | crc8`, with a
//!   configurable CRC-8 (CRC-8/SMBUS by default);
//! - [`parser`]: a push stream parser for UART.B-1 / SPI-1 that resynchronises on 0x5A;
//! - [`ethernet`]: Ethernet-1 packets (ULID, module UUID, count, UART.B-1 messages), a builder
//!   that batches messages into one datagram and a reader;
//! - `can` (feature `embedded-can`): conversions to and from `embedded_can::Frame`;
//! - [`dictionary`]: the tables the generator emits for module dictionaries and robots;
//! - [`engine`]: a module's variables, commands, subscriptions and publication schedule;
//! - [`persist`]: the stored image of a module's settings, checked before it is loaded;
//! - [`piecewise`]: chunking a module's info text and reassembling it;
//! - [`leader`]: configuring modules as they appear, and routing between networks.
//!
//! All of it is `no_std` and allocation-free. Choices the specification leaves open, made
//! here: CRC-8/SMBUS, `id_and_len` and the Ethernet-1 count little-endian, the last piecewise
//! chunk padded with zeros, reserved bytes written as zero and ignored when read, and reserved
//! values (identifier bits 28..26, message type 3, command types 3..=255, a wrong data length)
//! reported as [`DecodeError`]s.

#[cfg(feature = "embedded-can")]
pub mod can;
pub mod dictionary;
pub mod engine;
pub mod ethernet;
pub mod leader;
pub mod message;
pub mod parser;
pub mod persist;
pub mod piecewise;
pub mod uart;

pub use dictionary::{Dictionary, Direction, Instance, Network, Robot, Transport, Variable};
pub use engine::{Engine, Handled, SetError};
pub use leader::{Forward, Leader, Port};
pub use message::{CanFrame, CommandKind, DecodeError, Message, MessageType};
pub use parser::{Feed, Parser};
pub use persist::{PersistError, Settings};
pub use piecewise::{Progress, Reassembler};
pub use uart::{decode as decode_uart, encode as encode_uart, Crc8};
