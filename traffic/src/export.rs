//! CSV export: one file per message type, one row per message, one column per value.

use std::collections::{btree_map, BTreeMap};
use std::fmt::Write as _;
use std::fs::{self, File};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

use crate::{columns, DecodedMessage, PayloadDecoder};

/// Where a logged frame came from, written in front of every CSV row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RowMeta {
    /// Receive time in microseconds.
    pub t_us: u64,
    /// NDLCom sender address.
    pub sender: u8,
    /// NDLCom receiver address.
    pub receiver: u8,
    /// NDLCom frame counter.
    pub counter: u8,
}

/// The columns in front of every row: NDLCom's addresses, or MAVLink's sender and sequence
/// (which [`RowMeta`]'s `sender`, `receiver` and `counter` then carry as `sysid`, `compid` and
/// `seq`).
const NDLCOM_COLUMNS: [&str; 4] = ["t_us", "sender", "receiver", "counter"];
const MAVLINK_COLUMNS: [&str; 4] = ["t_us", "sysid", "compid", "seq"];

impl RowMeta {
    fn fields(&self) -> [String; 4] {
        [
            self.t_us.to_string(),
            self.sender.to_string(),
            self.receiver.to_string(),
            self.counter.to_string(),
        ]
    }
}

/// The file name that collects what could not be decoded.
pub const UNKNOWN_FILE: &str = "unknown.csv";

#[derive(Debug)]
struct Sink {
    path: PathBuf,
    writer: csv::Writer<BufWriter<File>>,
    rows: u64,
}

impl Sink {
    fn create(
        path: PathBuf,
        columns: [&str; 4],
        header: impl IntoIterator<Item = String>,
    ) -> io::Result<Self> {
        let file = File::create(&path)?;
        let mut writer = csv::Writer::from_writer(BufWriter::new(file));
        writer.write_record(columns.iter().map(|c| (*c).to_owned()).chain(header))?;
        Ok(Sink {
            path,
            writer,
            rows: 0,
        })
    }

    fn row(&mut self, meta: &RowMeta, rest: impl IntoIterator<Item = String>) -> io::Result<()> {
        self.writer
            .write_record(meta.fields().into_iter().chain(rest))?;
        self.rows += 1;
        Ok(())
    }
}

/// Writes decoded traffic to one CSV file per message type, `<WIRE_NAME>.csv`, plus
/// [`UNKNOWN_FILE`] for frames that could not be decoded.
///
/// Every file starts with the header `t_us,sender,receiver,counter,<columns...>` and is created
/// (truncating an older one) when its first row comes in. Values are written as by
/// [`Value`]'s `Display`; enum fields stay numeric.
#[derive(Debug)]
pub struct CsvExport {
    dir: PathBuf,
    columns: [&'static str; 4],
    messages: BTreeMap<String, Sink>,
    unknown: Option<Sink>,
}

impl CsvExport {
    /// Exports into `dir`, creating it (and its parents) if need be.
    pub fn new(dir: &Path) -> io::Result<Self> {
        Self::with_columns(dir, NDLCOM_COLUMNS)
    }

    /// Exports MAVLink traffic into `dir`: the rows start with `t_us,sysid,compid,seq`, which
    /// [`RowMeta`]'s `sender`, `receiver` and `counter` carry.
    pub fn new_mavlink(dir: &Path) -> io::Result<Self> {
        Self::with_columns(dir, MAVLINK_COLUMNS)
    }

    fn with_columns(dir: &Path, columns: [&'static str; 4]) -> io::Result<Self> {
        fs::create_dir_all(dir)?;
        Ok(CsvExport {
            dir: dir.to_owned(),
            columns,
            messages: BTreeMap::new(),
            unknown: None,
        })
    }

    /// Appends a row to the file of `decoded`'s message.
    ///
    /// Messages are told apart by wire name; a different layout under a name already written
    /// (e.g. from a second dictionary) is an error, as the CSV header would not fit.
    pub fn write(&mut self, meta: &RowMeta, decoded: &DecodedMessage<'_>) -> io::Result<()> {
        let name = &decoded.message.name.wire;
        let sink = match self.messages.entry(name.clone()) {
            btree_map::Entry::Occupied(sink) => sink.into_mut(),
            btree_map::Entry::Vacant(slot) => {
                let path = self.dir.join(format!("{name}.csv"));
                slot.insert(Sink::create(path, self.columns, columns(decoded.message))?)
            }
        };
        sink.row(meta, decoded.values.iter().map(|(_, v)| v.to_string()))
    }

    /// Appends a frame payload that could not be decoded to [`UNKNOWN_FILE`], with the columns
    /// `id` (its first byte, empty for an empty payload) and `payload_hex` (the bytes after the id,
    /// lowercase hex).
    pub fn write_unknown(&mut self, meta: &RowMeta, frame_payload: &[u8]) -> io::Result<()> {
        match frame_payload.split_first() {
            Some((&id, payload)) => self.write_unknown_id(meta, Some(id.into()), payload),
            None => self.write_unknown_id(meta, None, frame_payload),
        }
    }

    /// Appends a payload of message `id` (empty column for `None`) that could not be decoded to
    /// [`UNKNOWN_FILE`].
    pub fn write_unknown_id(
        &mut self,
        meta: &RowMeta,
        id: Option<u32>,
        payload: &[u8],
    ) -> io::Result<()> {
        let sink = match self.unknown {
            Some(ref mut sink) => sink,
            ref mut slot @ None => {
                let path = self.dir.join(UNKNOWN_FILE);
                let header = ["id".to_owned(), "payload_hex".to_owned()];
                slot.insert(Sink::create(path, self.columns, header)?)
            }
        };
        let id = id.map(|id| id.to_string()).unwrap_or_default();
        let mut hex = String::with_capacity(2 * payload.len());
        for byte in payload {
            // Writing to a String cannot fail.
            let _ = write!(hex, "{byte:02x}");
        }
        sink.row(meta, [id, hex])
    }

    /// Decodes an NDLCom frame payload (id byte first) and writes it to its message's file, or to
    /// [`UNKNOWN_FILE`] if it is empty or its id is not in the dictionary. Returns whether it was
    /// decoded.
    pub fn record(
        &mut self,
        decoder: &PayloadDecoder,
        meta: &RowMeta,
        frame_payload: &[u8],
    ) -> io::Result<bool> {
        match decoder.decode_frame(frame_payload) {
            Some(decoded) => self.write(meta, &decoded).map(|()| true),
            None => self.write_unknown(meta, frame_payload).map(|()| false),
        }
    }

    /// Flushes every file and reports each one written with its number of rows (header not
    /// counted): message files by name, then [`UNKNOWN_FILE`] if anything went there.
    pub fn finish(self) -> io::Result<Vec<(PathBuf, u64)>> {
        let mut out = Vec::with_capacity(self.messages.len() + 1);
        for mut sink in self.messages.into_values().chain(self.unknown) {
            // Flushes the CSV buffer and the file buffer under it.
            sink.writer.flush()?;
            out.push((sink.path, sink.rows));
        }
        Ok(out)
    }
}
