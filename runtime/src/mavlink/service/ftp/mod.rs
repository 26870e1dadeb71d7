//! MAVLink FTP (FILE_TRANSFER_PROTOCOL): the request and reply payload, the opcodes and errors,
//! directory listings, and the file system a [`Server`] serves.
//!
//! Every request and reply travels in the 251-byte `payload` of a FILE_TRANSFER_PROTOCOL
//! message: a 12-byte header (sequence number, session, opcode, size, the opcode answered,
//! burst complete, offset) and up to [`MAX_DATA`] bytes of data. A reply's sequence number is
//! the request's plus one; the replies of a burst read count on from there.
//!
//! What implementations disagree on, and what is chosen here:
//! - The `size` of a burst read is the data per reply (ArduPilot's and pymavlink's reading; the
//!   spec's text is unclear, PX4 ignores it and sends full replies). 0 asks for full replies.
//!   [`Server`] honours it; [`Client`] asks for full replies and takes replies of any size.
//! - A burst ends, `burst_complete` set, at the end of the file or after
//!   [`ServerConfig::burst_replies`] replies, whichever comes first; a client asks for the next
//!   burst from where it is. A read past the end is answered `EOF`.
//! - A read may ask for more than is left: the reply holds what there is (MAVSDK's server
//!   fails such a read, so [`Client`] never asks for more than is left).
//! - `CalcFileCRC32` is [`crate::crc::FTP_CRC32`]: zlib's table from 0, no final xor.

mod buffers;
mod client;
mod server;

pub use buffers::{Chunk, Source};
pub use client::{Client, ClientConfig, Error, Event};
pub use server::{Server, ServerConfig};

use super::messages::{FileTransferProtocol, Message};

/// Data bytes in one payload: 251 less the 12-byte header.
pub const MAX_DATA: usize = 239;

/// The opcodes of requests and replies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
#[allow(missing_docs)]
pub enum Opcode {
    None = 0,
    TerminateSession = 1,
    ResetSessions = 2,
    ListDirectory = 3,
    OpenFileRO = 4,
    ReadFile = 5,
    CreateFile = 6,
    WriteFile = 7,
    RemoveFile = 8,
    CreateDirectory = 9,
    RemoveDirectory = 10,
    OpenFileWO = 11,
    TruncateFile = 12,
    Rename = 13,
    CalcFileCRC32 = 14,
    BurstReadFile = 15,
    Ack = 128,
    Nak = 129,
}

impl Opcode {
    /// The opcode numbered `v`, if any.
    pub fn from_u8(v: u8) -> Option<Self> {
        use Opcode::*;
        Some(match v {
            0 => None,
            1 => TerminateSession,
            2 => ResetSessions,
            3 => ListDirectory,
            4 => OpenFileRO,
            5 => ReadFile,
            6 => CreateFile,
            7 => WriteFile,
            8 => RemoveFile,
            9 => CreateDirectory,
            10 => RemoveDirectory,
            11 => OpenFileWO,
            12 => TruncateFile,
            13 => Rename,
            14 => CalcFileCRC32,
            15 => BurstReadFile,
            128 => Ack,
            129 => Nak,
            _ => return Option::None,
        })
    }
}

/// Why a request failed: the first data byte of a NAK (the second holds `errno` for
/// [`Nak::FailErrno`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Nak {
    /// Failed, no reason given.
    Fail,
    /// Failed with this `errno`.
    FailErrno(u8),
    /// A size out of range.
    InvalidDataSize,
    /// No such open session.
    InvalidSession,
    /// Every session is taken.
    NoSessionsAvailable,
    /// A read at or past the end of the file, or a listing past its last entry.
    Eof,
    /// An opcode the server does not know.
    UnknownCommand,
    /// Already there.
    FileExists,
    /// Not to be written or removed.
    FileProtected,
    /// No such file or directory.
    FileNotFound,
}

impl Nak {
    /// The code byte.
    pub fn code(self) -> u8 {
        match self {
            Nak::Fail => 1,
            Nak::FailErrno(_) => 2,
            Nak::InvalidDataSize => 3,
            Nak::InvalidSession => 4,
            Nak::NoSessionsAvailable => 5,
            Nak::Eof => 6,
            Nak::UnknownCommand => 7,
            Nak::FileExists => 8,
            Nak::FileProtected => 9,
            Nak::FileNotFound => 10,
        }
    }

    /// The error in a NAK's data. PX4 reports a missing file as `FailErrno` with `ENOENT` (2).
    pub fn from_data(data: &[u8]) -> Self {
        match data {
            [2, 2, ..] => Nak::FileNotFound,
            [2, errno, ..] => Nak::FailErrno(*errno),
            [3, ..] => Nak::InvalidDataSize,
            [4, ..] => Nak::InvalidSession,
            [5, ..] => Nak::NoSessionsAvailable,
            [6, ..] => Nak::Eof,
            [7, ..] => Nak::UnknownCommand,
            [8, ..] => Nak::FileExists,
            [9, ..] => Nak::FileProtected,
            [10, ..] => Nak::FileNotFound,
            _ => Nak::Fail,
        }
    }
}

impl core::fmt::Display for Nak {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Nak::Fail => f.write_str("failed"),
            Nak::FailErrno(e) => write!(f, "failed (errno {e})"),
            Nak::InvalidDataSize => f.write_str("invalid data size"),
            Nak::InvalidSession => f.write_str("no such session"),
            Nak::NoSessionsAvailable => f.write_str("no session available"),
            Nak::Eof => f.write_str("end of file"),
            Nak::UnknownCommand => f.write_str("unknown command"),
            Nak::FileExists => f.write_str("file exists"),
            Nak::FileProtected => f.write_str("file protected"),
            Nak::FileNotFound => f.write_str("file not found"),
        }
    }
}

/// One request or reply: the payload of a FILE_TRANSFER_PROTOCOL message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Payload {
    /// Sequence number.
    pub seq: u16,
    /// Session.
    pub session: u8,
    /// Opcode (a request's, or ACK/NAK), as on the wire.
    pub opcode: u8,
    /// Data bytes used, or for reads the bytes asked for.
    pub size: u8,
    /// The request's opcode, in a reply.
    pub req_opcode: u8,
    /// Set in the last reply of a burst.
    pub burst_complete: bool,
    /// Offset in the file, or index in a listing.
    pub offset: u32,
    /// Data; `size` of them count.
    pub data: [u8; MAX_DATA],
}

impl Payload {
    /// A request with no data.
    pub fn request(seq: u16, session: u8, opcode: Opcode, offset: u32) -> Self {
        Self {
            seq,
            session,
            opcode: opcode as u8,
            size: 0,
            req_opcode: 0,
            burst_complete: false,
            offset,
            data: [0; MAX_DATA],
        }
    }

    /// An empty reply of `opcode` (ACK or NAK) to `request`.
    pub fn reply(request: &Payload, opcode: Opcode) -> Self {
        let mut p = Self::request(request.seq.wrapping_add(1), request.session, opcode, 0);
        p.req_opcode = request.opcode;
        p
    }

    /// A NAK of `request` for `why`.
    pub fn nak(request: &Payload, why: Nak) -> Self {
        let mut p = Self::reply(request, Opcode::Nak);
        p.data[0] = why.code();
        p.size = 1;
        if let Nak::FailErrno(errno) = why {
            p.data[1] = errno;
            p.size = 2;
        }
        p
    }

    /// The payload of a message's 251 bytes.
    pub fn parse(bytes: &[u8; 251]) -> Self {
        let mut data = [0; MAX_DATA];
        data.copy_from_slice(&bytes[12..]);
        Self {
            seq: u16::from_le_bytes([bytes[0], bytes[1]]),
            session: bytes[2],
            opcode: bytes[3],
            size: bytes[4],
            req_opcode: bytes[5],
            burst_complete: bytes[6] != 0,
            offset: u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]),
            data,
        }
    }

    /// The 251 bytes.
    pub fn to_bytes(&self) -> [u8; 251] {
        let mut b = [0; 251];
        b[..2].copy_from_slice(&self.seq.to_le_bytes());
        b[2] = self.session;
        b[3] = self.opcode;
        b[4] = self.size;
        b[5] = self.req_opcode;
        b[6] = u8::from(self.burst_complete);
        b[8..12].copy_from_slice(&self.offset.to_le_bytes());
        b[12..].copy_from_slice(&self.data);
        b
    }

    /// The data bytes in use (`size`, at most [`MAX_DATA`]).
    pub fn bytes(&self) -> &[u8] {
        &self.data[..usize::from(self.size).min(MAX_DATA)]
    }

    /// Sets the data; `bytes` longer than [`MAX_DATA`] are cut.
    pub fn set_bytes(&mut self, bytes: &[u8]) {
        let n = bytes.len().min(MAX_DATA);
        self.data[..n].copy_from_slice(&bytes[..n]);
        self.size = n as u8;
    }

    /// The `n`th NUL-terminated string in the data (a path; `Rename` has two), if it is UTF-8.
    /// The last one needs no terminator.
    pub fn path(&self, n: usize) -> Option<&str> {
        let s = self.bytes().split(|&b| b == 0).nth(n)?;
        core::str::from_utf8(s).ok()
    }

    /// The message carrying this payload to `target`.
    pub fn to_message(&self, target: super::Address) -> Message {
        Message::FileTransferProtocol(FileTransferProtocol {
            target_network: 0,
            target_system: target.system,
            target_component: target.component,
            payload: self.to_bytes(),
        })
    }
}

/// What a directory entry is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EntryKind {
    /// A file.
    File,
    /// A directory.
    Dir,
    /// An entry the server skipped (`S`): something else, or a name too long to send.
    Skip,
}

/// One entry of a directory listing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Entry<'a> {
    /// File, directory or skipped.
    pub kind: EntryKind,
    /// Its name, without the directory.
    pub name: &'a str,
    /// A file's size in bytes (0 for the others).
    pub size: u32,
}

/// A file system the [`Server`] serves. Paths are as the client sent them (UTF-8, `/`
/// separated); confining them to a root is the implementation's job. Files are open per
/// session, a small number the server picks; `read` and `write` name the session.
pub trait FileSystem {
    /// Calls `out` with the entries of directory `path` from the `from`th on, in an order that
    /// stays the same between calls, until it returns `false` or there are no more.
    fn list(
        &mut self,
        path: &str,
        from: u32,
        out: &mut dyn FnMut(Entry<'_>) -> bool,
    ) -> Result<(), Nak>;
    /// Opens `path` for reading in `session`; its size.
    fn open_read(&mut self, session: u8, path: &str) -> Result<u32, Nak>;
    /// Opens `path` for writing in `session`: created empty (or emptied) when `create`, else
    /// it must exist. Its size.
    fn open_write(&mut self, session: u8, path: &str, create: bool) -> Result<u32, Nak>;
    /// Reads at `offset` of the file open in `session`; the bytes read (0 at the end).
    fn read(&mut self, session: u8, offset: u32, buf: &mut [u8]) -> Result<usize, Nak>;
    /// Writes `data` at `offset` of the file open for writing in `session`.
    fn write(&mut self, session: u8, offset: u32, data: &[u8]) -> Result<(), Nak>;
    /// Closes what `session` holds open.
    fn close(&mut self, session: u8);
    /// Removes file `path`.
    fn remove_file(&mut self, path: &str) -> Result<(), Nak>;
    /// Creates directory `path`.
    fn create_dir(&mut self, path: &str) -> Result<(), Nak>;
    /// Removes the empty directory `path`.
    fn remove_dir(&mut self, path: &str) -> Result<(), Nak>;
    /// Renames `from` to `to`.
    fn rename(&mut self, from: &str, to: &str) -> Result<(), Nak>;
    /// Cuts or extends file `path` to `len` bytes.
    fn truncate(&mut self, path: &str, len: u32) -> Result<(), Nak>;
}

/// Appends `entry` to a listing reply's data as the protocol writes it (`F<name>\t<size>\0`,
/// `D<name>\0`, `S\0`); `false` if it does not fit.
pub(crate) fn push_entry(data: &mut [u8; MAX_DATA], used: &mut usize, entry: Entry<'_>) -> bool {
    let mut buf = [0u8; MAX_DATA];
    let mut w = Cursor {
        buf: &mut buf,
        at: 0,
    };
    let ok = match entry.kind {
        EntryKind::File => {
            w.put(b"F") && w.put(entry.name.as_bytes()) && w.put(b"\t") && w.num(entry.size)
        }
        EntryKind::Dir => w.put(b"D") && w.put(entry.name.as_bytes()),
        EntryKind::Skip => w.put(b"S"),
    } && w.put(b"\0");
    let n = w.at;
    if !ok || *used + n > MAX_DATA {
        return false;
    }
    data[*used..*used + n].copy_from_slice(&buf[..n]);
    *used += n;
    true
}

struct Cursor<'a> {
    buf: &'a mut [u8; MAX_DATA],
    at: usize,
}

impl Cursor<'_> {
    fn put(&mut self, b: &[u8]) -> bool {
        match self.buf.get_mut(self.at..self.at + b.len()) {
            Some(dst) => {
                dst.copy_from_slice(b);
                self.at += b.len();
                true
            }
            None => false,
        }
    }

    fn num(&mut self, mut v: u32) -> bool {
        let mut digits = [0u8; 10];
        let mut n = 0;
        loop {
            digits[9 - n] = b'0' + (v % 10) as u8;
            n += 1;
            v /= 10;
            if v == 0 {
                break;
            }
        }
        self.put(&digits[10 - n..])
    }
}

/// The entries of a listing reply's data, in order (`S` entries included as
/// [`EntryKind::Skip`]; malformed ones as a skip too, so the index still counts them).
pub fn entries(data: &[u8]) -> impl Iterator<Item = Entry<'_>> {
    data.split(|&b| b == 0).filter(|e| !e.is_empty()).map(|e| {
        let text = core::str::from_utf8(e).unwrap_or("S");
        let (kind, rest) = match text.as_bytes().first() {
            Some(b'F') => (EntryKind::File, &text[1..]),
            Some(b'D') => (EntryKind::Dir, &text[1..]),
            _ => (EntryKind::Skip, ""),
        };
        let (name, size) = match rest.split_once('\t') {
            Some((name, size)) => (name, size.trim().parse().unwrap_or(0)),
            None => (rest, 0),
        };
        Entry { kind, name, size }
    })
}
