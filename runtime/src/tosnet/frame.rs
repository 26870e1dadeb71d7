//! The ring's frame format (ours: the original's is a Toslink line code inside an FPGA).
//!
//! ```text
//! byte 0      command (bits 7..4) | argument (bits 3..0)
//! bytes 1..   body, by command (below)
//! last byte   CRC-8, polynomial 0x65, over every byte before it
//! ```
//!
//! | code | command    | argument       | body |
//! |------|------------|----------------|------|
//! | 0x0  | IDLE       | sender id      | none |
//! | 0x2  | MASTER_DSC | lowest candidate seen | hops (1 byte) |
//! | 0x3  | MASTER_SET | master id      | none |
//! | 0x4  | NET_DSC    | master id      | count, then `count` node ids in ring order |
//! | 0x5  | NET_SET    | master id      | as NET_DSC, complete |
//! | 0x6  | REG_DSC    | master id      | count, then per position: in mask, out mask |
//! | 0x7  | REG_SET    | master id      | as REG_DSC, complete |
//! | 0x8  | SYNC_DSC   | master id      | zeros, as many as a DATA frame's body has |
//! | 0x9  | SYNC_SET   | master id      | node-to-node delay in ns (u32, little-endian) |
//! | 0xA  | DATA       | master id      | cycle (u16 LE), then per position in ring order, per enabled register ascending: out area (16 bytes), in area (16 bytes) |
//! | 0xC  | ASYNC      | destination (0 = everyone) | source id, then 0..=64 data bytes |
//! | 0xF  | HALT       | master id      | none |
//!
//! A DATA frame is `4 + 32 * r` bytes for `r` enabled registers: the 32 bits of overhead are
//! the model's. Codes 0x1, 0xB, 0xD and 0xE are not used; a frame with one is an error.

use crate::tosnet::crc8;

/// The most nodes in a ring.
pub const MAX_NODES: usize = 15;
/// The most data bytes in an ASYNC frame.
pub const MAX_ASYNC: usize = 64;
/// The longest DATA frame: 15 nodes with 8 registers each.
pub const MAX_FRAME_LEN: usize = data_len(MAX_NODES * 8);

/// A DATA frame's length for `registers` enabled registers.
pub const fn data_len(registers: usize) -> usize {
    4 + registers * super::block::REGISTER_LEN
}

/// The 4-bit command codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Command {
    /// Nothing to say (a keep-alive).
    Idle = 0x0,
    /// Master election: the lowest candidate id goes round.
    MasterDsc = 0x2,
    /// The elected master announces itself.
    MasterSet = 0x3,
    /// Ring discovery: every node appends its id.
    NetDsc = 0x4,
    /// The ring order, for everyone.
    NetSet = 0x5,
    /// Register discovery: every node fills its enable masks.
    RegDsc = 0x6,
    /// Every node's enable masks, for everyone.
    RegSet = 0x7,
    /// The master measures the ring's delay.
    SyncDsc = 0x8,
    /// The node-to-node delay, for everyone's sync strobe.
    SyncSet = 0x9,
    /// One cycle's data.
    Data = 0xA,
    /// A side-channel message outside the cycle.
    Async = 0xC,
    /// Stop the ring.
    Halt = 0xF,
}

impl Command {
    /// The command for a 4-bit code.
    pub const fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            0x0 => Command::Idle,
            0x2 => Command::MasterDsc,
            0x3 => Command::MasterSet,
            0x4 => Command::NetDsc,
            0x5 => Command::NetSet,
            0x6 => Command::RegDsc,
            0x7 => Command::RegSet,
            0x8 => Command::SyncDsc,
            0x9 => Command::SyncSet,
            0xA => Command::Data,
            0xC => Command::Async,
            0xF => Command::Halt,
            _ => return None,
        })
    }
}

/// Why bytes are not a valid frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FrameError {
    /// Fewer than two bytes, or shorter than the command's body.
    Truncated,
    /// A code that is not a command.
    UnknownCommand(u8),
    /// The body's length does not match what the command says.
    BadLength,
    /// The CRC does not match (or was inverted by an upstream node).
    Crc,
    /// SYNC_DSC padding that is not zero.
    Padding,
    /// The output buffer is too small.
    BufferTooSmall,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::Truncated => f.write_str("frame too short"),
            FrameError::UnknownCommand(c) => write!(f, "unknown command code {c:#x}"),
            FrameError::BadLength => f.write_str("body length does not match the command"),
            FrameError::Crc => f.write_str("CRC mismatch"),
            FrameError::Padding => f.write_str("SYNC_DSC padding is not zero"),
            FrameError::BufferTooSmall => f.write_str("output buffer too small"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FrameError {}

/// Whether `frame` (body and CRC) leaves a CRC residue of 0.
pub fn crc_ok(frame: &[u8]) -> bool {
    frame.len() >= 2 && crc8(frame) == 0
}

/// A frame's contents, borrowed from the bytes it was parsed from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Repr<'a> {
    /// IDLE from `sender`.
    Idle {
        /// The sender.
        sender: u8,
    },
    /// MASTER_DSC.
    MasterDsc {
        /// The lowest master candidate the frame has passed.
        candidate: u8,
        /// Nodes passed so far; the frame dies after 2 x 16.
        hops: u8,
    },
    /// MASTER_SET.
    MasterSet {
        /// The master.
        master: u8,
    },
    /// NET_DSC (`complete == false`) or NET_SET.
    Net {
        /// The master.
        master: u8,
        /// NET_SET rather than NET_DSC.
        complete: bool,
        /// Node ids in ring order, the master first.
        ids: &'a [u8],
    },
    /// REG_DSC (`complete == false`) or REG_SET.
    Reg {
        /// The master.
        master: u8,
        /// REG_SET rather than REG_DSC.
        complete: bool,
        /// Per position: in mask, out mask.
        masks: &'a [u8],
    },
    /// SYNC_DSC, padded to `len` body bytes.
    SyncDsc {
        /// The master.
        master: u8,
        /// Padding bytes.
        len: usize,
    },
    /// SYNC_SET.
    SyncSet {
        /// The master.
        master: u8,
        /// The measured node-to-node delay.
        delay_ns: u32,
    },
    /// DATA.
    Data {
        /// The master.
        master: u8,
        /// The master's cycle counter.
        cycle: u16,
        /// The registers, in ring order.
        areas: &'a [u8],
    },
    /// ASYNC.
    Async {
        /// The destination; 0 is everyone.
        dest: u8,
        /// The sender.
        source: u8,
        /// The data.
        data: &'a [u8],
    },
    /// HALT.
    Halt {
        /// The master.
        master: u8,
    },
}

impl<'a> Repr<'a> {
    /// Parses a whole frame, CRC included.
    pub fn parse(frame: &'a [u8]) -> Result<Self, FrameError> {
        if frame.len() < 2 {
            return Err(FrameError::Truncated);
        }
        if !crc_ok(frame) {
            return Err(FrameError::Crc);
        }
        Self::parse_unchecked(frame)
    }

    /// Parses a whole frame without checking its CRC.
    pub fn parse_unchecked(frame: &'a [u8]) -> Result<Self, FrameError> {
        let Some((&head, rest)) = frame.split_first() else {
            return Err(FrameError::Truncated);
        };
        let body = rest.split_last().map_or(&[][..], |(_, b)| b);
        if rest.is_empty() {
            return Err(FrameError::Truncated);
        }
        let arg = head & 0x0F;
        let command = Command::from_code(head >> 4).ok_or(FrameError::UnknownCommand(head >> 4))?;
        let exact = |n: usize| {
            if body.len() == n {
                Ok(())
            } else if body.len() < n {
                Err(FrameError::Truncated)
            } else {
                Err(FrameError::BadLength)
            }
        };
        let counted = |per: usize| -> Result<&'a [u8], FrameError> {
            let (&count, entries) = body.split_first().ok_or(FrameError::Truncated)?;
            if usize::from(count) > MAX_NODES {
                return Err(FrameError::BadLength);
            }
            exact(1 + usize::from(count) * per)?;
            Ok(entries)
        };
        Ok(match command {
            Command::Idle => {
                exact(0)?;
                Repr::Idle { sender: arg }
            }
            Command::MasterDsc => {
                exact(1)?;
                Repr::MasterDsc {
                    candidate: arg,
                    hops: body[0],
                }
            }
            Command::MasterSet => {
                exact(0)?;
                Repr::MasterSet { master: arg }
            }
            Command::NetDsc | Command::NetSet => Repr::Net {
                master: arg,
                complete: command == Command::NetSet,
                ids: counted(1)?,
            },
            Command::RegDsc | Command::RegSet => Repr::Reg {
                master: arg,
                complete: command == Command::RegSet,
                masks: counted(2)?,
            },
            Command::SyncDsc => {
                if body.iter().any(|&b| b != 0) {
                    return Err(FrameError::Padding);
                }
                Repr::SyncDsc {
                    master: arg,
                    len: body.len(),
                }
            }
            Command::SyncSet => {
                exact(4)?;
                Repr::SyncSet {
                    master: arg,
                    delay_ns: u32::from_le_bytes([body[0], body[1], body[2], body[3]]),
                }
            }
            Command::Data => {
                if body.len() < 2 {
                    return Err(FrameError::Truncated);
                }
                if (body.len() - 2) % super::block::REGISTER_LEN != 0 {
                    return Err(FrameError::BadLength);
                }
                Repr::Data {
                    master: arg,
                    cycle: u16::from_le_bytes([body[0], body[1]]),
                    areas: &body[2..],
                }
            }
            Command::Async => {
                let (&source, data) = body.split_first().ok_or(FrameError::Truncated)?;
                if data.len() > MAX_ASYNC {
                    return Err(FrameError::BadLength);
                }
                Repr::Async {
                    dest: arg,
                    source,
                    data,
                }
            }
            Command::Halt => {
                exact(0)?;
                Repr::Halt { master: arg }
            }
        })
    }

    /// The command.
    pub fn command(&self) -> Command {
        match self {
            Repr::Idle { .. } => Command::Idle,
            Repr::MasterDsc { .. } => Command::MasterDsc,
            Repr::MasterSet { .. } => Command::MasterSet,
            Repr::Net { complete, .. } => {
                if *complete {
                    Command::NetSet
                } else {
                    Command::NetDsc
                }
            }
            Repr::Reg { complete, .. } => {
                if *complete {
                    Command::RegSet
                } else {
                    Command::RegDsc
                }
            }
            Repr::SyncDsc { .. } => Command::SyncDsc,
            Repr::SyncSet { .. } => Command::SyncSet,
            Repr::Data { .. } => Command::Data,
            Repr::Async { .. } => Command::Async,
            Repr::Halt { .. } => Command::Halt,
        }
    }

    fn arg(&self) -> u8 {
        match *self {
            Repr::Idle { sender: a }
            | Repr::MasterDsc { candidate: a, .. }
            | Repr::MasterSet { master: a }
            | Repr::Net { master: a, .. }
            | Repr::Reg { master: a, .. }
            | Repr::SyncDsc { master: a, .. }
            | Repr::SyncSet { master: a, .. }
            | Repr::Data { master: a, .. }
            | Repr::Async { dest: a, .. }
            | Repr::Halt { master: a } => a & 0x0F,
        }
    }

    /// The whole frame's length, CRC included.
    pub fn buffer_len(&self) -> usize {
        2 + match self {
            Repr::Idle { .. } | Repr::MasterSet { .. } | Repr::Halt { .. } => 0,
            Repr::MasterDsc { .. } => 1,
            Repr::Net { ids, .. } => 1 + ids.len(),
            Repr::Reg { masks, .. } => 1 + masks.len(),
            Repr::SyncDsc { len, .. } => *len,
            Repr::SyncSet { .. } => 4,
            Repr::Data { areas, .. } => 2 + areas.len(),
            Repr::Async { data, .. } => 1 + data.len(),
        }
    }

    /// Writes the frame, CRC included, into the front of `buf`; returns its length.
    pub fn emit(&self, buf: &mut [u8]) -> Result<usize, FrameError> {
        let len = self.buffer_len();
        let frame = buf.get_mut(..len).ok_or(FrameError::BufferTooSmall)?;
        frame[0] = (self.command() as u8) << 4 | self.arg();
        let body = &mut frame[1..len - 1];
        match self {
            Repr::Idle { .. } | Repr::MasterSet { .. } | Repr::Halt { .. } => {}
            Repr::MasterDsc { hops, .. } => body[0] = *hops,
            Repr::Net { ids: list, .. } | Repr::Reg { masks: list, .. } => {
                let count = if matches!(self, Repr::Reg { .. }) {
                    list.len() / 2
                } else {
                    list.len()
                };
                body[0] = u8::try_from(count).map_err(|_| FrameError::BadLength)?;
                body[1..].copy_from_slice(list);
            }
            Repr::SyncDsc { .. } => body.fill(0),
            Repr::SyncSet { delay_ns, .. } => body.copy_from_slice(&delay_ns.to_le_bytes()),
            Repr::Data { cycle, areas, .. } => {
                body[..2].copy_from_slice(&cycle.to_le_bytes());
                body[2..].copy_from_slice(areas);
            }
            Repr::Async { source, data, .. } => {
                body[0] = *source;
                body[1..].copy_from_slice(data);
            }
        }
        seal(frame);
        Ok(len)
    }
}

/// Writes the CRC of everything before the last byte into the last byte.
pub fn seal(frame: &mut [u8]) {
    if let Some((crc, body)) = frame.split_last_mut() {
        *crc = crc8(body);
    }
}

/// Seals a frame that arrived broken: the CRC of what is forwarded, with its last four bits
/// inverted, so no node downstream accepts the data.
pub fn seal_broken(frame: &mut [u8]) {
    if let Some((crc, body)) = frame.split_last_mut() {
        *crc = crc8(body) ^ 0x0F;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(repr: Repr<'_>) {
        let mut buf = [0xa5u8; 64];
        let len = repr.emit(&mut buf).expect("fits");
        assert_eq!(len, repr.buffer_len());
        assert_eq!(Repr::parse(&buf[..len]), Ok(repr));
        assert_eq!(buf[len], 0xa5, "wrote past the frame");
    }

    #[test]
    fn every_command_round_trips() {
        round_trip(Repr::Idle { sender: 3 });
        round_trip(Repr::MasterDsc {
            candidate: 2,
            hops: 7,
        });
        round_trip(Repr::MasterSet { master: 2 });
        round_trip(Repr::Net {
            master: 2,
            complete: false,
            ids: &[2, 5, 9],
        });
        round_trip(Repr::Reg {
            master: 2,
            complete: true,
            masks: &[0, 0, 3, 7],
        });
        round_trip(Repr::SyncDsc { master: 1, len: 10 });
        round_trip(Repr::SyncSet {
            master: 1,
            delay_ns: 5460,
        });
        round_trip(Repr::Data {
            master: 1,
            cycle: 0xBEEF,
            areas: &[9; 32],
        });
        round_trip(Repr::Async {
            dest: 0,
            source: 4,
            data: b"hello",
        });
        round_trip(Repr::Halt { master: 1 });
    }

    #[test]
    fn bytes_by_hand() {
        let mut buf = [0u8; 8];
        let len = Repr::SyncSet {
            master: 1,
            delay_ns: 5460,
        }
        .emit(&mut buf)
        .expect("fits");
        // 0x91, 5460 = 0x1554 little-endian, then the CRC.
        assert_eq!(&buf[..5], &[0x91, 0x54, 0x15, 0x00, 0x00]);
        assert_eq!(len, 6);
        assert_eq!(buf[5], crc8(&buf[..5]));
    }

    #[test]
    fn errors() {
        assert_eq!(Repr::parse(&[0x30]), Err(FrameError::Truncated));
        let mut f = [0x10, 0];
        seal(&mut f);
        assert_eq!(Repr::parse(&f), Err(FrameError::UnknownCommand(1)));
        let mut f = [0x30, 1, 0];
        seal(&mut f);
        assert_eq!(Repr::parse(&f), Err(FrameError::BadLength));
        let mut f = [0x40, 2, 1, 0];
        seal(&mut f);
        assert_eq!(Repr::parse(&f), Err(FrameError::Truncated));
        let mut f = [0xA0, 0, 0, 1, 0];
        seal(&mut f);
        assert_eq!(Repr::parse(&f), Err(FrameError::BadLength));
        let mut f = [0x30, 0];
        seal_broken(&mut f);
        assert_eq!(Repr::parse(&f), Err(FrameError::Crc));
        assert_eq!(Repr::parse_unchecked(&f), Ok(Repr::MasterSet { master: 0 }));
    }
}
