//! What the vehicle serves over MAVLink FTP: a small read-only file table, the runtime's
//! [`FileSystem`] for its FTP server.
//!
//! | path | what |
//! |---|---|
//! | `/` | the directory `@PARAM` |
//! | `/@PARAM` | the file `param.pck` |
//! | `/@PARAM/param.pck` | the parameters in ArduPilot's packed format |
//! | `/@PARAM/param.pck?withdefaults=1` | the same, each with its default |
//!
//! Paths are taken with or without their leading and trailing `/`. Nothing can be written,
//! created, removed or renamed: every such request is refused with `FileProtected`.
//!
//! `param.pck` is not kept anywhere: [`param_pck`] computes the bytes a read asks for from the
//! parameter table and the values as they are at that moment. Its layout depends on the
//! names and types only, so its size is fixed and a file read in several requests keeps its
//! shape even when a value changes in between (`SYS_STACK_USED` may; the client then gets the
//! value of the moment its block was read).
//!
//! # param.pck
//!
//! ArduPilot's format (`libraries/AP_Filesystem/README.md`; pymavlink's `mavftp` and MAVProxy
//! decode it), little-endian:
//!
//! - a 6-byte header: the magic `0x671b` (`0x671c` with defaults), the number of parameters in
//!   the file and the number the vehicle has (both 64);
//! - one record per parameter, in index order: a byte with the type in its low 4 bits and the
//!   flags in its high 4 (bit 0: a default follows the value), a byte with the number of name
//!   bytes shared with the previous parameter's name (low 4 bits, at most 15) and the number
//!   of the others less one (high 4 bits), those other name bytes, the value, and with
//!   defaults the default;
//! - zero bytes before a record wherever its value and default would otherwise cross a
//!   239-byte boundary (a full FTP read), so that a block read again never holds half of a
//!   value. Decoders skip zero bytes between records (a record never starts with one).
//!
//! The format has ArduPilot's four types only: INT8 (1), INT16 (2), INT32 (3) and FLOAT (4).
//! The others go to the smallest one that holds every value: UINT8 as INT16, UINT16 as INT32;
//! UINT32 as INT32 too (its bits: exact up to 2³¹ − 1, which every UINT32 here stays below).
//! With defaults, every record carries its default (flag bit 0 always set), not only those
//! that differ as ArduPilot does: the layout then stays the same whatever the values.

use ferrolink_runtime::mavlink::service::ftp::{Entry, EntryKind, FileSystem, Nak, MAX_DATA};
use ferrolink_runtime::mavlink::service::param::{Encoding, Value};

use crate::params::{self, Params, TABLE};

/// The one directory.
const DIR: &str = "@PARAM";
/// Its one file.
const FILE: &str = "param.pck";
/// The file's path, without the leading `/`.
const PATH: &str = "@PARAM/param.pck";
/// The query that asks for the defaults too.
const WITH_DEFAULTS: &str = "?withdefaults=1";

/// param.pck's magic: without defaults, with.
const MAGIC: u16 = 0x671b;
const MAGIC_DEFAULTS: u16 = 0x671c;

/// A record's value may not cross a multiple of this.
const BLOCK: u32 = MAX_DATA as u32;

/// ArduPilot's type for `v` and its size in bytes.
fn packed_type(v: Value) -> (u8, u32) {
    match v {
        Value::I8(_) => (1, 1),
        Value::U8(_) | Value::I16(_) => (2, 2),
        Value::U16(_) | Value::U32(_) | Value::I32(_) => (3, 4),
        // The format has no 64-bit type: such a value would go as FLOAT, its number rounded,
        // as PARAM_VALUE carries it (the table has none).
        Value::F32(_) | Value::U64(_) | Value::I64(_) | Value::F64(_) => (4, 4),
    }
}

/// param.pck (with the defaults when `defaults`) from byte `offset` into `buf`: the bytes
/// written, and the size of the file.
pub fn param_pck(params: &Params, defaults: bool, offset: u32, buf: &mut [u8]) -> (usize, u32) {
    // Each piece of the file (the header, then each record with its padding) is laid out in
    // `piece`, and the part of it that falls in `offset..` goes to `buf`.
    let mut at = 0u32;
    let mut put = |piece: &[u8]| {
        for (i, &b) in piece.iter().enumerate() {
            let pos = (at + i as u32).wrapping_sub(offset) as usize;
            if let Some(slot) = buf.get_mut(pos) {
                *slot = b;
            }
        }
        at += piece.len() as u32;
        at
    };
    let magic = if defaults { MAGIC_DEFAULTS } else { MAGIC };
    let [c0, c1] = (params::COUNT as u16).to_le_bytes();
    let [m0, m1] = magic.to_le_bytes();
    let mut end = put(&[m0, m1, c0, c1, c0, c1]);
    let mut last: &[u8] = &[];
    for (index, param) in TABLE.iter().enumerate() {
        let name = &param.name.0;
        let name = &name[..name.iter().position(|&b| b == 0).unwrap_or(name.len())];
        // At least one byte of the name is sent, even when it is all the previous name's.
        let common = name
            .iter()
            .zip(last)
            .take_while(|(a, b)| a == b)
            .count()
            .min(name.len() - 1)
            .min(15);
        last = name;
        let rest = &name[common..];
        let value = params.value(index as u16).unwrap_or(param.default());
        let (ty, size) = packed_type(value);
        // Zero bytes first if the value and the default would cross a block's end.
        let data = end + 2 + rest.len() as u32;
        let data_len = if defaults { 2 * size } else { size };
        let pad = match BLOCK - data % BLOCK {
            room if room < data_len => room,
            _ => 0,
        } as usize;
        // The bytewise encoding is the integer's bits, as wide as the packed type needs
        // (a UINT8 zero-extended to INT16, a UINT16 to INT32).
        // (None of 64 bits: their code is left out.)
        let bits = |v: Value| {
            let f = v.encode_narrow(Encoding::Bytewise).unwrap_or_default();
            f.to_bits().to_le_bytes()
        };
        let mut piece = [0u8; 8 + 2 + 16 + 8];
        piece[pad] = ty | u8::from(defaults) << 4;
        piece[pad + 1] = common as u8 | ((rest.len() - 1) as u8) << 4;
        let mut n = pad + 2 + rest.len();
        piece[pad + 2..n].copy_from_slice(rest);
        let size = size as usize;
        piece[n..n + size].copy_from_slice(&bits(value)[..size]);
        n += size;
        if defaults {
            piece[n..n + size].copy_from_slice(&bits(param.default())[..size]);
            n += size;
        }
        end = put(&piece[..n]);
    }
    (
        end.saturating_sub(offset).min(buf.len() as u32) as usize,
        end,
    )
}

/// The file table over the parameter store, for the FTP server's calls. Which sessions read
/// param.pck with its defaults is the vehicle's (`with_defaults`, a bit per session), kept
/// from one call to the next.
#[derive(Debug)]
pub struct Files<'a> {
    /// The parameters param.pck holds.
    pub params: &'a Params,
    /// Bit `n` set: session `n` has param.pck open with its defaults.
    pub with_defaults: &'a mut u8,
}

impl Files<'_> {
    /// Whether session `session` reads param.pck with its defaults.
    fn defaults(&self, session: u8) -> bool {
        *self.with_defaults & 1u8.wrapping_shl(u32::from(session)) != 0
    }
}

/// A path without its leading and trailing `/`. (By bytes: `str::trim_matches` decodes
/// UTF-8, ten times the code.)
fn trim(path: &str) -> &str {
    let bytes = path.as_bytes();
    let start = bytes.iter().position(|&b| b != b'/').unwrap_or(bytes.len());
    let end = bytes
        .iter()
        .rposition(|&b| b != b'/')
        .map_or(start, |i| i + 1);
    path.get(start..end).unwrap_or_default()
}

impl FileSystem for Files<'_> {
    fn list(
        &mut self,
        path: &str,
        from: u32,
        out: &mut dyn FnMut(Entry<'_>) -> bool,
    ) -> Result<(), Nak> {
        let entry = match trim(path) {
            "" => Entry {
                kind: EntryKind::Dir,
                name: DIR,
                size: 0,
            },
            DIR => Entry {
                kind: EntryKind::File,
                name: FILE,
                size: param_pck(self.params, false, 0, &mut []).1,
            },
            _ => return Err(Nak::FileNotFound),
        };
        if from == 0 {
            out(entry);
        }
        Ok(())
    }

    fn open_read(&mut self, session: u8, path: &str) -> Result<u32, Nak> {
        let path = trim(path);
        let defaults = match path.strip_prefix(PATH) {
            Some("") => false,
            Some(WITH_DEFAULTS) => true,
            _ => return Err(Nak::FileNotFound),
        };
        let bit = 1u8.wrapping_shl(u32::from(session));
        *self.with_defaults = if defaults {
            *self.with_defaults | bit
        } else {
            *self.with_defaults & !bit
        };
        Ok(param_pck(self.params, defaults, 0, &mut []).1)
    }

    fn open_write(&mut self, _session: u8, _path: &str, _create: bool) -> Result<u32, Nak> {
        Err(Nak::FileProtected)
    }

    fn read(&mut self, session: u8, offset: u32, buf: &mut [u8]) -> Result<usize, Nak> {
        Ok(param_pck(self.params, self.defaults(session), offset, buf).0)
    }

    fn write(&mut self, _session: u8, _offset: u32, _data: &[u8]) -> Result<(), Nak> {
        Err(Nak::FileProtected)
    }

    fn close(&mut self, _session: u8) {}

    fn remove_file(&mut self, _path: &str) -> Result<(), Nak> {
        Err(Nak::FileProtected)
    }

    fn create_dir(&mut self, _path: &str) -> Result<(), Nak> {
        Err(Nak::FileProtected)
    }

    fn remove_dir(&mut self, _path: &str) -> Result<(), Nak> {
        Err(Nak::FileProtected)
    }

    fn rename(&mut self, _from: &str, _to: &str) -> Result<(), Nak> {
        Err(Nak::FileProtected)
    }

    fn truncate(&mut self, _path: &str, _len: u32) -> Result<(), Nak> {
        Err(Nak::FileProtected)
    }
}
