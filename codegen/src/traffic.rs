//! Decoding logged traffic with a dictionary, and exporting it to CSV.
//!
//! Nothing here uses generated code: the layout of every message comes from the [`Ir`] at run
//! time, so a log can be decoded with whatever dictionary the user points at.
//!
//! The payload rules are MAVLink's: values are little-endian at the [`Field::offset`]s of the
//! wire order, and a payload shorter than [`Message::max_len`] is zero-filled before decoding (the
//! MAVLink 2 truncation rule). NDLCom frames carry such a payload behind a one-byte message id;
//! [`PayloadDecoder::decode_frame`] and [`CsvExport::record`] take that frame payload as it is.
//!
//! ```no_run
//! use std::path::{Path, PathBuf};
//! use ferrolink_codegen::traffic::{CsvExport, PayloadDecoder, RowMeta};
//!
//! let checked = ferrolink_codegen::load(&[PathBuf::from("minimal.xml")]).unwrap();
//! let decoder = PayloadDecoder::new(&checked.ir);
//! let mut export = CsvExport::new(Path::new("export"))?;
//! let meta = RowMeta { t_us: 0, sender: 1, receiver: 2, counter: 0 };
//! export.record(&decoder, &meta, &[30, 0x10, 0x27])?; // ATTITUDE, time_boot_ms = 10000
//! for (path, rows) in export.finish()? {
//!     println!("{}: {rows} rows", path.display());
//! }
//! # Ok::<(), std::io::Error>(())
//! ```

use std::collections::{btree_map, BTreeMap, HashMap};
use std::fmt::{self, Write as _};
use std::fs::{self, File};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

use ferrolink_runtime::mavlink::MessageMeta;

use crate::ir::{Enum, Field, Ir, Message, Primitive};

/// One decoded value.
///
/// Enum fields stay numbers; [`PayloadDecoder::enum_label`] gives the entry names for display.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// `uint8_t` .. `uint64_t`.
    Unsigned(u64),
    /// `int8_t` .. `int64_t`.
    Signed(i64),
    /// `float` and `double`.
    ///
    /// A `float` is widened through its shortest decimal representation, so that `0.1f32` is held
    /// (and printed) as `0.1` rather than `0.10000000149011612`; `value as f32` always gives the
    /// wire value back.
    Float(f64),
    /// A `char[N]` array: the bytes up to the first NUL, decoded as lossy UTF-8.
    Text(String),
}

impl Value {
    /// Widens an `f32` to the `f64` closest to its shortest round-tripping decimal.
    pub fn from_f32(value: f32) -> Self {
        let widened = value
            .to_string()
            .parse::<f64>()
            .ok()
            // Keep the exact widening whenever the decimal route would not lead back to the
            // same bits (NaN payloads, and as a guard against double rounding).
            .filter(|&w| (w as f32).to_bits() == value.to_bits())
            .unwrap_or(f64::from(value));
        Value::Float(widened)
    }
}

impl fmt::Display for Value {
    /// Plain CSV-friendly text: integers in decimal, floats in Rust's shortest round-trip form
    /// without exponent (`NaN`, `inf` and `-inf` for the special values), text as is.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Unsigned(v) => write!(f, "{v}"),
            Value::Signed(v) => write!(f, "{v}"),
            Value::Float(v) => write!(f, "{v}"),
            Value::Text(v) => f.write_str(v),
        }
    }
}

/// A decoded payload: the message and one value per column.
#[derive(Debug, Clone)]
pub struct DecodedMessage<'ir> {
    /// The dictionary message.
    pub message: &'ir Message,
    /// `(column, value)` in the order of [`columns`]: fields in XML order (extensions included),
    /// arrays expanded to `field[0]`, `field[1]`, ...; `char` arrays are one text column.
    pub values: Vec<(String, Value)>,
}

impl<'ir> DecodedMessage<'ir> {
    /// The field behind the value at `column` (an index into [`DecodedMessage::values`]).
    pub fn field(&self, column: usize) -> Option<&'ir Field> {
        column_fields(self.message).nth(column)
    }

    /// The value of the column named `name`.
    pub fn get(&self, name: &str) -> Option<&Value> {
        self.values.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }
}

/// How many columns `field` takes: one per array element, one for a scalar or a `char` array.
fn column_count(field: &Field) -> usize {
    match field.ty.array {
        Some(n) if field.ty.primitive != Primitive::Char => usize::from(n),
        _ => 1,
    }
}

/// The field of every column, in column order.
fn column_fields(message: &Message) -> impl Iterator<Item = &Field> {
    message
        .fields
        .iter()
        .flat_map(|field| std::iter::repeat_n(field, column_count(field)))
}

/// The column names of `message`, in the order [`PayloadDecoder::decode`] yields values: wire
/// field names in XML order, extensions included; `field[0]`, `field[1]`, ... for arrays; one
/// column for a `char` array.
pub fn columns(message: &Message) -> Vec<String> {
    let mut out = Vec::new();
    for field in &message.fields {
        let name = &field.name.wire;
        match field.ty.array {
            Some(n) if field.ty.primitive != Primitive::Char => {
                out.extend((0..n).map(|i| format!("{name}[{i}]")));
            }
            _ => out.push(name.clone()),
        }
    }
    out
}

/// Decodes payloads by message id, with the layouts of an [`Ir`].
#[derive(Debug, Clone)]
pub struct PayloadDecoder<'ir> {
    ir: &'ir Ir,
    by_id: HashMap<u32, &'ir Message>,
    enums: HashMap<&'ir str, &'ir Enum>,
}

impl<'ir> PayloadDecoder<'ir> {
    /// Indexes the messages of every module by id.
    ///
    /// If several modules define the same id, the one that comes later in [`Ir::modules`] wins
    /// (modules are in dependency order, so a dialect overrides what it includes).
    pub fn new(ir: &'ir Ir) -> Self {
        let by_id = ir
            .modules
            .iter()
            .flat_map(|module| &module.messages)
            .map(|message| (message.id, message))
            .collect();
        let enums = ir.enums.iter().map(|e| (e.name.wire.as_str(), e)).collect();
        PayloadDecoder { ir, by_id, enums }
    }

    /// The IR this decoder reads.
    pub fn ir(&self) -> &'ir Ir {
        self.ir
    }

    /// The message with wire id `id`, if the dictionary has one.
    pub fn message(&self, id: u32) -> Option<&'ir Message> {
        self.by_id.get(&id).copied()
    }

    /// Decodes `payload` (without the id) as message `id`. A payload shorter than the message is
    /// zero-filled, bytes beyond it are ignored. `None` if the id is unknown.
    pub fn decode(&self, id: u32, payload: &[u8]) -> Option<DecodedMessage<'ir>> {
        let message = self.message(id)?;
        let mut buf = vec![0u8; message.max_len];
        let n = payload.len().min(buf.len());
        buf[..n].copy_from_slice(&payload[..n]);

        let mut values = Vec::new();
        for field in &message.fields {
            let primitive = field.ty.primitive;
            let name = &field.name.wire;
            let bytes = &buf[field.offset..field.offset + field.ty.size()];
            match field.ty.array {
                None => values.push((name.clone(), scalar(primitive, bytes))),
                Some(_) if primitive == Primitive::Char => {
                    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                    let text = String::from_utf8_lossy(&bytes[..end]).into_owned();
                    values.push((name.clone(), Value::Text(text)));
                }
                Some(_) => {
                    for (i, element) in bytes.chunks_exact(primitive.size()).enumerate() {
                        values.push((format!("{name}[{i}]"), scalar(primitive, element)));
                    }
                }
            }
        }
        Some(DecodedMessage { message, values })
    }

    /// Decodes an NDLCom frame payload: the message id in the first byte, the message payload
    /// after it. `None` if the frame payload is empty or the id is unknown.
    pub fn decode_frame(&self, frame_payload: &[u8]) -> Option<DecodedMessage<'ir>> {
        let (&id, payload) = frame_payload.split_first()?;
        self.decode(u32::from(id), payload)
    }

    /// The enum entry name(s) of `value` if `field` holds an enum, for display.
    ///
    /// A plain enum gives the entry's wire name (`None` for a value without an entry). A bitmask
    /// gives the names of the set bits joined by `|`, with bits that have no entry appended in
    /// hex (`MAV_MODE_FLAG_SAFETY_ARMED|0x100`); zero gives the zero entry if there is one.
    pub fn enum_label(&self, field: &Field, value: &Value) -> Option<String> {
        let e = self.enums.get(field.enum_name.as_deref()?)?;
        let value = match *value {
            Value::Unsigned(v) => v,
            Value::Signed(v) => u64::try_from(v).ok()?,
            Value::Float(_) | Value::Text(_) => return None,
        };
        if let Some(entry) = e.entries.iter().find(|entry| entry.value == value) {
            return Some(entry.name.wire.clone());
        }
        if !e.bitmask || value == 0 {
            return None;
        }
        let mut label = String::new();
        let mut rest = value;
        for entry in &e.entries {
            if entry.value.count_ones() == 1 && rest & entry.value != 0 {
                if !label.is_empty() {
                    label.push('|');
                }
                label.push_str(&entry.name.wire);
                rest &= !entry.value;
            }
        }
        if rest != 0 {
            if !label.is_empty() {
                label.push('|');
            }
            // Writing to a String cannot fail.
            let _ = write!(label, "{rest:#x}");
        }
        Some(label)
    }
}

/// One little-endian scalar; `bytes` is exactly `primitive.size()` long.
fn scalar(primitive: Primitive, bytes: &[u8]) -> Value {
    let mut raw = [0u8; 8];
    raw[..bytes.len()].copy_from_slice(bytes);
    let raw = u64::from_le_bytes(raw);
    let bits = 8 * bytes.len() as u32;
    // Sign-extends the low `bits` bits.
    let signed = || {
        let shift = 64 - bits;
        ((raw << shift) as i64) >> shift
    };
    match primitive {
        Primitive::U8 | Primitive::U16 | Primitive::U32 | Primitive::U64 => Value::Unsigned(raw),
        Primitive::I8 | Primitive::I16 | Primitive::I32 | Primitive::I64 => Value::Signed(signed()),
        Primitive::F32 => Value::from_f32(f32::from_bits(raw as u32)),
        Primitive::F64 => Value::Float(f64::from_bits(raw)),
        Primitive::Char => {
            let text = if raw == 0 {
                String::new()
            } else {
                String::from_utf8_lossy(bytes).into_owned()
            };
            Value::Text(text)
        }
    }
}

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
        decoder: &PayloadDecoder<'_>,
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

/// The message table a parser or router needs ([`MessageMeta`] per message, sorted by id),
/// built from the IR at run time.
///
/// If several modules define an id, the later one wins, as in [`PayloadDecoder::new`]. The table
/// and its names are leaked to get the `'static` lifetime the runtime's parsers take: call this
/// once per dictionary set a program loads, not per frame.
pub fn message_table(ir: &Ir) -> &'static [MessageMeta] {
    let mut by_id: BTreeMap<u32, MessageMeta> = BTreeMap::new();
    for message in ir.modules.iter().flat_map(|m| &m.messages) {
        let offset = |o: Option<usize>| o.and_then(|o| u8::try_from(o).ok());
        by_id.insert(
            message.id,
            MessageMeta {
                id: message.id,
                name: Box::leak(message.name.wire.clone().into_boxed_str()),
                crc_extra: message.crc_extra,
                min_len: u8::try_from(message.min_len).unwrap_or(u8::MAX),
                max_len: u8::try_from(message.max_len).unwrap_or(u8::MAX),
                target_system: offset(message.target_system),
                target_component: offset(message.target_component),
            },
        );
    }
    Box::leak(by_id.into_values().collect::<Vec<_>>().into_boxed_slice())
}

impl PayloadDecoder<'_> {
    /// Decodes `payload` as message `id` into pymavlink's `to_dict()` form, as pymavlink 2.4.50
    /// prints it: `{"mavpackettype": NAME, field: value, ...}` in XML order, extensions included,
    /// a short payload zero-filled.
    ///
    /// - integers as JSON integers (enums too), floats as the exact double of their value (`NaN`
    ///   and infinities, which JSON cannot hold, as `null`);
    /// - arrays as lists;
    /// - `char` fields and `char[N]` arrays as text: cut at the first NUL, bytes above 0x7f
    ///   shown as U+FFFD.
    ///
    /// `None` if the id is unknown.
    pub fn to_dict(&self, id: u32, payload: &[u8]) -> Option<serde_json::Value> {
        use serde_json::{Map, Value as Json};
        let message = self.message(id)?;
        let mut buf = vec![0u8; message.max_len];
        let n = payload.len().min(buf.len());
        buf[..n].copy_from_slice(&payload[..n]);
        let number = |primitive: Primitive, bytes: &[u8]| -> Json {
            match scalar(primitive, bytes) {
                Value::Unsigned(v) => Json::from(v),
                Value::Signed(v) => Json::from(v),
                // `scalar` widens through the shortest decimal; pymavlink widens exactly.
                Value::Float(_) if primitive == Primitive::F32 => {
                    let mut raw = [0u8; 4];
                    raw.copy_from_slice(bytes);
                    Json::from(f64::from(f32::from_le_bytes(raw)))
                }
                Value::Float(v) => Json::from(v),
                Value::Text(_) => Json::Null,
            }
        };
        let mut dict = Map::new();
        dict.insert("mavpackettype".into(), message.name.wire.clone().into());
        for field in &message.fields {
            let primitive = field.ty.primitive;
            let bytes = &buf[field.offset..field.offset + field.ty.size()];
            let value = match field.ty.array {
                _ if primitive == Primitive::Char => Json::from(python_text(bytes)),
                None => number(primitive, bytes),
                Some(_) => bytes
                    .chunks_exact(primitive.size())
                    .map(|element| number(primitive, element))
                    .collect(),
            };
            dict.insert(field.name.wire.clone(), value);
        }
        Some(Json::Object(dict))
    }
}

impl PayloadDecoder<'_> {
    /// A MAVLink frame's JSON members, in the form `ferrolink mavlink dump` prints and the Zenoh
    /// endpoint publishes: `"sysid":..,"compid":..,"seq":..,"msg":{<to_dict() form>}`, or for an
    /// id the dictionaries lack `"sysid":..,"compid":..,"seq":..,"msg":null,"id":N,
    /// "payload":"<hex>"`, without the braces (a caller may put members in front). The second
    /// value tells whether the id was known.
    pub fn frame_json_members(
        &self,
        sysid: u8,
        compid: u8,
        seq: u8,
        id: u32,
        payload: &[u8],
    ) -> (String, bool) {
        let head = format!("\"sysid\":{sysid},\"compid\":{compid},\"seq\":{seq}");
        match self.to_dict(id, payload) {
            Some(dict) => (format!("{head},\"msg\":{dict}"), true),
            None => (
                format!(
                    "{head},\"msg\":null,\"id\":{id},\"payload\":\"{}\"",
                    hex::encode(payload)
                ),
                false,
            ),
        }
    }

    /// The inverse of [`PayloadDecoder::to_dict`]: a message in pymavlink's `to_dict()` form
    /// (`{"mavpackettype": NAME, field: value, ...}`) as its id and full-length payload.
    ///
    /// Fields left out are zero. Integers must fit their field, floats may be given as integers,
    /// `null` is NaN, arrays are lists of at most the array's length, `char` fields are text of at
    /// most their length. `defaults` fills fields the object leaves out (a target taken from
    /// elsewhere, say). Errors name the field.
    pub fn from_dict(
        &self,
        dict: &serde_json::Value,
        defaults: &[(&str, u64)],
    ) -> Result<(u32, Vec<u8>), String> {
        use serde_json::Value as Json;
        let object = dict
            .as_object()
            .ok_or("a message is a JSON object with \"mavpackettype\"")?;
        let name = object
            .get("mavpackettype")
            .and_then(Json::as_str)
            .ok_or("\"mavpackettype\" (the message name) is missing")?;
        let message = self
            .by_id
            .values()
            .find(|m| m.name.wire == name)
            .ok_or_else(|| format!("no message {name} in the dictionaries"))?;
        let mut payload = vec![0u8; message.max_len];
        for (key, value) in object {
            if key == "mavpackettype" {
                continue;
            }
            let field = message
                .fields
                .iter()
                .find(|f| f.name.wire == *key)
                .ok_or_else(|| format!("{name} has no field {key}"))?;
            put_field(
                field,
                value,
                &mut payload[field.offset..field.offset + field.ty.size()],
            )
            .map_err(|e| format!("{name}.{key}: {e}"))?;
        }
        for (key, value) in defaults {
            if object.contains_key(*key) {
                continue;
            }
            if let Some(field) = message.fields.iter().find(|f| f.name.wire == *key) {
                let bytes = &mut payload[field.offset..field.offset + field.ty.size()];
                put_field(field, &Json::from(*value), bytes)
                    .map_err(|e| format!("{name}.{key}: {e}"))?;
            }
        }
        Ok((message.id, payload))
    }
}

/// What a frame made from JSON takes where the JSON says nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameDefaults {
    /// The sender's system id.
    pub sysid: u8,
    /// The sender's component id.
    pub compid: u8,
    /// The sequence number.
    pub seq: u8,
    /// `target_system` and `target_component`, for messages that have them.
    pub target: Option<(u8, u8)>,
}

impl PayloadDecoder<'_> {
    /// A JSON object as an unsigned MAVLink 2 frame: either the envelope
    /// `{"sysid":..,"compid":..,"seq":..,"msg":{<to_dict() form>}}` that
    /// [`PayloadDecoder::frame_json_members`] writes, or the message alone; whatever is left out
    /// comes from `defaults`. An unknown id (`"msg": null`) cannot be re-encoded and is an error.
    pub fn frame_from_json(
        &self,
        value: &serde_json::Value,
        defaults: FrameDefaults,
    ) -> Result<Vec<u8>, String> {
        use ferrolink_runtime::mavlink::{v2, Header};
        use serde_json::Value as Json;
        let (envelope, msg) = match value.get("msg") {
            Some(Json::Null) => {
                return Err("an unknown id (\"msg\": null) cannot be re-encoded".into());
            }
            Some(msg) => (value, msg),
            None => (&Json::Null, value),
        };
        let targets: Vec<(&str, u64)> = defaults
            .target
            .map(|(s, c)| {
                vec![
                    ("target_system", u64::from(s)),
                    ("target_component", u64::from(c)),
                ]
            })
            .unwrap_or_default();
        let (id, payload) = self.from_dict(msg, &targets)?;
        let crc_extra = self.message(id).map(|m| m.crc_extra).unwrap_or_default();
        let number = |name: &str, default: u8| -> Result<u8, String> {
            match envelope.get(name) {
                None => Ok(default),
                Some(v) => v
                    .as_u64()
                    .and_then(|v| u8::try_from(v).ok())
                    .ok_or_else(|| format!("\"{name}\" must be 0 to 255")),
            }
        };
        let header = Header::new(
            number("seq", defaults.seq)?,
            number("sysid", defaults.sysid)?,
            number("compid", defaults.compid)?,
        );
        let mut out = [0u8; v2::MAX_FRAME_LEN];
        let n = v2::encode_raw(header, id, crc_extra, &payload, &mut out)
            .map_err(|e| format!("{e:?}"))?;
        Ok(out[..n].to_vec())
    }
}

/// Writes one field's JSON value into its bytes.
fn put_field(field: &Field, value: &serde_json::Value, out: &mut [u8]) -> Result<(), String> {
    use serde_json::Value as Json;
    let primitive = field.ty.primitive;
    if primitive == Primitive::Char {
        let text = value.as_str().ok_or("expected text")?;
        if text.len() > out.len() {
            return Err(format!("text longer than {} bytes", out.len()));
        }
        out[..text.len()].copy_from_slice(text.as_bytes());
        return Ok(());
    }
    match (field.ty.array, value) {
        (Some(_), Json::Array(items)) => {
            let size = primitive.size();
            if items.len() * size > out.len() {
                return Err(format!("more than {} elements", out.len() / size));
            }
            for (item, chunk) in items.iter().zip(out.chunks_exact_mut(size)) {
                put_scalar(primitive, item, chunk)?;
            }
            Ok(())
        }
        (Some(_), _) => Err("expected a list".into()),
        (None, value) => put_scalar(primitive, value, out),
    }
}

/// Writes one number, little-endian, checking that it fits.
fn put_scalar(
    primitive: Primitive,
    value: &serde_json::Value,
    out: &mut [u8],
) -> Result<(), String> {
    let bits = 8 * out.len() as u32;
    let bytes: Vec<u8> = match primitive {
        Primitive::F32 => match value {
            serde_json::Value::Null => f32::NAN.to_le_bytes().to_vec(),
            v => (v.as_f64().ok_or("expected a number")? as f32)
                .to_le_bytes()
                .to_vec(),
        },
        Primitive::F64 => match value {
            serde_json::Value::Null => f64::NAN.to_le_bytes().to_vec(),
            v => v
                .as_f64()
                .ok_or("expected a number")?
                .to_le_bytes()
                .to_vec(),
        },
        Primitive::U8 | Primitive::U16 | Primitive::U32 | Primitive::U64 | Primitive::Char => {
            let v = value.as_u64().ok_or("expected an unsigned integer")?;
            if bits < 64 && v >> bits != 0 {
                return Err(format!("{v} does not fit {bits} bits"));
            }
            v.to_le_bytes().to_vec()
        }
        Primitive::I8 | Primitive::I16 | Primitive::I32 | Primitive::I64 => {
            let v = value.as_i64().ok_or("expected an integer")?;
            if bits < 64 && (v < -(1i64 << (bits - 1)) || v >= 1i64 << (bits - 1)) {
                return Err(format!("{v} does not fit {bits} signed bits"));
            }
            v.to_le_bytes().to_vec()
        }
    };
    let n = out.len();
    out.copy_from_slice(&bytes[..n]);
    Ok(())
}

/// `char` bytes as pymavlink 2.4.50 shows them: cut at the first NUL, then ASCII with every
/// byte above 0x7f replaced by U+FFFD (Python's `decode("ascii", errors="replace")`).
fn python_text(bytes: &[u8]) -> String {
    bytes
        .iter()
        .take_while(|&&b| b != 0)
        .map(|&b| {
            if b.is_ascii() {
                char::from(b)
            } else {
                '\u{fffd}'
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    use std::path::PathBuf;

    fn minimal() -> Ir {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join("definitions/mavlink/minimal.xml");
        crate::load(&[path]).expect("minimal.xml loads").ir
    }

    fn message<'a>(ir: &'a Ir, name: &str) -> &'a Message {
        ir.modules
            .iter()
            .flat_map(|m| &m.messages)
            .find(|m| m.name.wire == name)
            .expect("message exists")
    }

    /// `(field, offset)` in XML order, and the payload length.
    fn layout(message: &Message) -> (Vec<(&str, usize)>, usize) {
        let fields = message
            .fields
            .iter()
            .map(|f| (f.name.wire.as_str(), f.offset))
            .collect();
        (fields, message.max_len)
    }

    fn attitude_payload() -> Vec<u8> {
        let mut p = Vec::new();
        p.extend_from_slice(&123_456u32.to_le_bytes());
        for v in [0.1f32, -0.25, 3.0, 1e-3, -0.0, 1.5e7] {
            p.extend_from_slice(&v.to_le_bytes());
        }
        p
    }

    fn heartbeat_payload() -> Vec<u8> {
        let mut p = 0xDEAD_BEEFu32.to_le_bytes().to_vec();
        // type, autopilot, base_mode, system_status, mavlink_version
        p.extend_from_slice(&[11, 12, 0x81, 4, 3]);
        p
    }

    fn statustext_payload(text: &[u8]) -> Vec<u8> {
        let mut p = vec![4u8];
        let mut t = [0u8; 50];
        t[..text.len()].copy_from_slice(text);
        p.extend_from_slice(&t);
        p.extend_from_slice(&0x0102u16.to_le_bytes());
        p.push(7);
        p
    }

    fn rendered(decoded: &DecodedMessage<'_>) -> Vec<String> {
        decoded
            .values
            .iter()
            .map(|(c, v)| format!("{c}={v}"))
            .collect()
    }

    #[test]
    fn layouts_are_the_ones_the_payloads_are_built_for() {
        let ir = minimal();
        assert_eq!(
            layout(message(&ir, "ATTITUDE")),
            (
                vec![
                    ("time_boot_ms", 0),
                    ("roll", 4),
                    ("pitch", 8),
                    ("yaw", 12),
                    ("rollspeed", 16),
                    ("pitchspeed", 20),
                    ("yawspeed", 24),
                ],
                28
            )
        );
        assert_eq!(
            layout(message(&ir, "HEARTBEAT")),
            (
                vec![
                    ("type", 4),
                    ("autopilot", 5),
                    ("base_mode", 6),
                    ("custom_mode", 0),
                    ("system_status", 7),
                    ("mavlink_version", 8),
                ],
                9
            )
        );
        assert_eq!(
            layout(message(&ir, "STATUSTEXT")),
            (
                vec![("severity", 0), ("text", 1), ("id", 51), ("chunk_seq", 53)],
                54
            )
        );
        assert_eq!(
            layout(message(&ir, "COMMAND_ACK")),
            (
                vec![
                    ("command", 0),
                    ("result", 2),
                    ("progress", 3),
                    ("result_param2", 4),
                    ("target_system", 8),
                    ("target_component", 9),
                ],
                10
            )
        );
    }

    #[test]
    fn decodes_attitude_with_shortest_f32() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        let decoded = decoder.decode(30, &attitude_payload()).expect("known id");
        assert_eq!(decoded.message.name.wire, "ATTITUDE");
        assert_eq!(
            decoded.values,
            vec![
                ("time_boot_ms".to_owned(), Value::Unsigned(123_456)),
                ("roll".to_owned(), Value::Float(0.1)),
                ("pitch".to_owned(), Value::Float(-0.25)),
                ("yaw".to_owned(), Value::Float(3.0)),
                ("rollspeed".to_owned(), Value::Float(0.001)),
                ("pitchspeed".to_owned(), Value::Float(-0.0)),
                ("yawspeed".to_owned(), Value::Float(15_000_000.0)),
            ]
        );
        assert_eq!(
            rendered(&decoded),
            [
                "time_boot_ms=123456",
                "roll=0.1",
                "pitch=-0.25",
                "yaw=3",
                "rollspeed=0.001",
                "pitchspeed=-0",
                "yawspeed=15000000",
            ]
        );
        assert_eq!(decoded.get("roll"), Some(&Value::Float(0.1)));
        assert_eq!(
            columns(decoded.message),
            [
                "time_boot_ms",
                "roll",
                "pitch",
                "yaw",
                "rollspeed",
                "pitchspeed",
                "yawspeed"
            ]
        );
    }

    #[test]
    fn f32_widening_round_trips() {
        for v in [
            0.1f32,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::MAX,
            -f32::EPSILON,
            16_777_217.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ] {
            let Value::Float(w) = Value::from_f32(v) else {
                unreachable!()
            };
            assert_eq!((w as f32).to_bits(), v.to_bits(), "{v}");
            assert_eq!(w.to_string(), v.to_string(), "{v}");
        }
        let Value::Float(nan) = Value::from_f32(f32::from_bits(0x7fc0_0123)) else {
            unreachable!()
        };
        assert_eq!((nan as f32).to_bits(), 0x7fc0_0123);
        assert_eq!(Value::from_f32(f32::NAN).to_string(), "NaN");
    }

    #[test]
    fn decodes_heartbeat_and_enum_labels() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        let decoded = decoder.decode(0, &heartbeat_payload()).expect("known id");
        assert_eq!(
            rendered(&decoded),
            [
                "type=11",
                "autopilot=12",
                "base_mode=129",
                "custom_mode=3735928559",
                "system_status=4",
                "mavlink_version=3",
            ]
        );
        let labels: Vec<_> = (0..decoded.values.len())
            .map(|i| decoder.enum_label(decoded.field(i).expect("column"), &decoded.values[i].1))
            .collect();
        assert_eq!(
            labels,
            [
                Some("MAV_TYPE_SURFACE_BOAT".to_owned()),
                Some("MAV_AUTOPILOT_PX4".to_owned()),
                Some("MAV_MODE_FLAG_CUSTOM_MODE_ENABLED|MAV_MODE_FLAG_SAFETY_ARMED".to_owned()),
                None,
                Some("MAV_STATE_ACTIVE".to_owned()),
                None,
            ]
        );
        let base_mode = decoded.field(2).expect("column");
        assert_eq!(
            decoder
                .enum_label(base_mode, &Value::Unsigned(0x180))
                .as_deref(),
            Some("MAV_MODE_FLAG_SAFETY_ARMED|0x100")
        );
        assert_eq!(decoder.enum_label(base_mode, &Value::Unsigned(0)), None);
        let status = decoded.field(4).expect("column");
        assert_eq!(decoder.enum_label(status, &Value::Unsigned(99)), None);
    }

    #[test]
    fn decodes_statustext_and_extensions() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        let decoded = decoder
            .decode(253, &statustext_payload(b"Low battery, \"RTL\"\0junk"))
            .expect("known id");
        assert_eq!(
            decoded.values,
            vec![
                ("severity".to_owned(), Value::Unsigned(4)),
                (
                    "text".to_owned(),
                    Value::Text("Low battery, \"RTL\"".to_owned())
                ),
                ("id".to_owned(), Value::Unsigned(0x0102)),
                ("chunk_seq".to_owned(), Value::Unsigned(7)),
            ]
        );

        // All 50 bytes used: no terminator; invalid UTF-8 is replaced.
        let mut full = [b'x'; 50];
        full[0] = 0xff;
        let decoded = decoder
            .decode(253, &statustext_payload(&full))
            .expect("known id");
        let Value::Text(text) = &decoded.values[1].1 else {
            panic!("text column")
        };
        assert_eq!(text.chars().count(), 50);
        assert!(text.starts_with("\u{fffd}xx"));

        // Signed extension field.
        let payload = [76, 1, 5, 42, 0xfe, 0xff, 0xff, 0xff, 1, 2];
        let decoded = decoder.decode(77, &payload).expect("known id");
        assert_eq!(
            rendered(&decoded),
            [
                "command=332",
                "result=5",
                "progress=42",
                "result_param2=-2",
                "target_system=1",
                "target_component=2",
            ]
        );
    }

    #[test]
    fn short_payloads_are_zero_filled_long_ones_cut() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        // ATTITUDE cut after roll.
        let mut payload = 1u32.to_le_bytes().to_vec();
        payload.extend_from_slice(&0.5f32.to_le_bytes());
        let decoded = decoder.decode(30, &payload).expect("known id");
        assert_eq!(
            rendered(&decoded),
            [
                "time_boot_ms=1",
                "roll=0.5",
                "pitch=0",
                "yaw=0",
                "rollspeed=0",
                "pitchspeed=0",
                "yawspeed=0",
            ]
        );
        // COMMAND_ACK cut inside result_param2: the missing high bytes are zero, not sign bits.
        let decoded = decoder.decode(77, &[76, 1, 5, 42, 0xfe]).expect("known id");
        assert_eq!(decoded.get("result_param2"), Some(&Value::Signed(254)));
        assert_eq!(decoded.get("target_system"), Some(&Value::Unsigned(0)));
        // Nothing but the id: every field zero, extensions and text too.
        let decoded = decoder.decode(253, &[]).expect("known id");
        assert_eq!(
            rendered(&decoded),
            ["severity=0", "text=", "id=0", "chunk_seq=0"]
        );
        // Trailing bytes beyond max_len are ignored.
        let mut long = heartbeat_payload();
        long.extend_from_slice(&[0xaa; 8]);
        let decoded = decoder.decode(0, &long).expect("known id");
        assert_eq!(
            decoded.values.last().map(|(_, v)| v),
            Some(&Value::Unsigned(3))
        );
    }

    #[test]
    fn unknown_ids_and_empty_frames() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        assert!(decoder.decode(31, &attitude_payload()).is_none());
        assert!(decoder.decode(1 << 20, &[]).is_none());
        assert!(decoder.decode_frame(&[]).is_none());
        assert!(decoder.decode_frame(&[99, 1, 2]).is_none());
        let decoded = decoder.decode_frame(&[0, 1]).expect("HEARTBEAT");
        assert_eq!(decoded.get("custom_mode"), Some(&Value::Unsigned(1)));
    }

    #[test]
    fn arrays_expand_to_one_column_per_element() {
        let ir = minimal();
        let ftp = message(&ir, "FILE_TRANSFER_PROTOCOL");
        let cols = columns(ftp);
        assert_eq!(cols.len(), 3 + 251);
        assert_eq!(
            &cols[..5],
            [
                "target_network",
                "target_system",
                "target_component",
                "payload[0]",
                "payload[1]"
            ]
        );
        assert_eq!(cols.last().map(String::as_str), Some("payload[250]"));

        let decoder = PayloadDecoder::new(&ir);
        let decoded = decoder.decode(110, &[1, 2, 3, 10, 11]).expect("known id");
        let names: Vec<_> = decoded.values.iter().map(|(n, _)| n.clone()).collect();
        assert_eq!(names, cols);
        assert_eq!(decoded.get("payload[1]"), Some(&Value::Unsigned(11)));
        assert_eq!(decoded.get("payload[2]"), Some(&Value::Unsigned(0)));
        assert_eq!(
            decoded.field(200).map(|f| f.name.wire.as_str()),
            Some("payload")
        );
        assert!(decoded.field(cols.len()).is_none());
    }

    #[test]
    fn later_module_wins_on_duplicate_ids() {
        let mut ir = minimal();
        let mut dialect = ir.modules[0].clone();
        dialect.messages.retain(|m| m.id == 30);
        dialect.messages[0].name.wire = "ATTITUDE_OVERRIDE".to_owned();
        ir.modules.push(dialect);
        let decoder = PayloadDecoder::new(&ir);
        let decoded = decoder.decode(30, &attitude_payload()).expect("known id");
        assert_eq!(decoded.message.name.wire, "ATTITUDE_OVERRIDE");
        assert_eq!(
            decoder.message(0).map(|m| m.name.wire.as_str()),
            Some("HEARTBEAT")
        );
    }

    #[test]
    fn csv_export() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        let tmp = tempfile::tempdir().expect("tempdir");
        let dir = tmp.path().join("export");
        let mut export = CsvExport::new(&dir).expect("export dir");

        let frame = |id: u8, payload: Vec<u8>| [vec![id], payload].concat();
        let meta = |t_us, counter| RowMeta {
            t_us,
            sender: 1,
            receiver: 2,
            counter,
        };
        let log: Vec<(RowMeta, Vec<u8>)> = vec![
            (meta(1_000, 0), frame(0, heartbeat_payload())),
            (meta(1_500, 1), frame(30, attitude_payload())),
            (
                meta(2_000, 2),
                frame(253, statustext_payload(b"Low battery, \"RTL\"")),
            ),
            (meta(2_500, 3), frame(200, vec![0xde, 0xad])),
            (meta(3_000, 4), vec![]),
            (meta(3_500, 5), frame(30, vec![2, 0, 0, 0])),
            (
                meta(4_000, 6),
                frame(253, statustext_payload(b"line one\nline two")),
            ),
        ];
        let mut decoded = 0;
        for (meta, payload) in &log {
            decoded += u32::from(export.record(&decoder, meta, payload).expect("write"));
        }
        assert_eq!(decoded, 5);

        let report = export.finish().expect("finish");
        let report: Vec<_> = report
            .into_iter()
            .map(|(path, rows)| {
                let name = path
                    .strip_prefix(&dir)
                    .expect("in dir")
                    .display()
                    .to_string();
                (name, rows)
            })
            .collect();
        assert_eq!(
            report,
            [
                ("ATTITUDE.csv".to_owned(), 2),
                ("HEARTBEAT.csv".to_owned(), 1),
                ("STATUSTEXT.csv".to_owned(), 2),
                ("unknown.csv".to_owned(), 2),
            ]
        );

        let read = |name: &str| fs::read_to_string(dir.join(name)).expect("written");
        insta::assert_snapshot!(read("ATTITUDE.csv"), @r"
        t_us,sender,receiver,counter,time_boot_ms,roll,pitch,yaw,rollspeed,pitchspeed,yawspeed
        1500,1,2,1,123456,0.1,-0.25,3,0.001,-0,15000000
        3500,1,2,5,2,0,0,0,0,0,0
        ");
        insta::assert_snapshot!(read("HEARTBEAT.csv"), @r"
        t_us,sender,receiver,counter,type,autopilot,base_mode,custom_mode,system_status,mavlink_version
        1000,1,2,0,11,12,129,3735928559,4,3
        ");
        insta::assert_snapshot!(read("STATUSTEXT.csv"), @r#"
        t_us,sender,receiver,counter,severity,text,id,chunk_seq
        2000,1,2,2,4,"Low battery, ""RTL""",258,7
        4000,1,2,6,4,"line one
        line two",258,7
        "#);
        insta::assert_snapshot!(read("unknown.csv"), @r"
        t_us,sender,receiver,counter,id,payload_hex
        2500,1,2,3,200,dead
        3000,1,2,4,,
        ");
    }

    #[test]
    fn csv_export_rejects_a_second_layout_under_one_name() {
        let ir = minimal();
        let mut changed = ir.clone();
        let mut dialect = changed.modules[0].clone();
        dialect.messages.retain(|m| m.id == 0);
        dialect.messages[0].fields.pop();
        changed.modules.push(dialect);

        let tmp = tempfile::tempdir().expect("tempdir");
        let mut export = CsvExport::new(tmp.path()).expect("export dir");
        let meta = RowMeta::default();
        let full = PayloadDecoder::new(&ir).decode(0, &heartbeat_payload());
        export
            .write(&meta, &full.expect("known id"))
            .expect("first layout");
        let short = PayloadDecoder::new(&changed).decode(0, &heartbeat_payload());
        let short = short.expect("known id");
        assert_eq!(short.values.len(), 5);
        let err = export.write(&meta, &short).expect_err("second layout");
        assert_eq!(err.kind(), io::ErrorKind::Other);
    }

    #[test]
    fn from_dict_inverts_to_dict() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        let statustext = statustext_payload(b"GPS: no fix");
        for (id, payload) in [
            (0, heartbeat_payload()),
            (30, attitude_payload()),
            (253, statustext),
        ] {
            let dict = decoder.to_dict(id, &payload).expect("known id");
            // Through text: floats are written so that they read back to the same value.
            let text = dict.to_string();
            let dict: serde_json::Value = serde_json::from_str(&text).expect("json");
            let (back_id, back) = decoder.from_dict(&dict, &[]).expect("reads back");
            assert_eq!(back_id, id);
            assert_eq!(back[..payload.len()], payload[..], "{dict}");
            assert!(back[payload.len()..].iter().all(|&b| b == 0));
        }
    }

    #[test]
    fn from_dict_fills_defaults_and_names_bad_fields() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        let ping = serde_json::json!({"mavpackettype": "PING", "seq": 7});
        let (id, payload) = decoder
            .from_dict(&ping, &[("target_system", 3), ("seq", 99)])
            .expect("encodes");
        assert_eq!(id, 4);
        let dict = decoder.to_dict(id, &payload).expect("known");
        assert_eq!(dict["seq"], 7, "given fields win over defaults");
        assert_eq!(dict["target_system"], 3);
        assert_eq!(dict["time_usec"], 0);
        let bad = |value: serde_json::Value| decoder.from_dict(&value, &[]).expect_err("bad");
        assert_eq!(
            bad(serde_json::json!({"mavpackettype": "PING", "target_system": 300})),
            "PING.target_system: 300 does not fit 8 bits"
        );
        assert_eq!(
            bad(serde_json::json!({"mavpackettype": "PING", "speed": 1})),
            "PING has no field speed"
        );
        assert_eq!(
            bad(serde_json::json!({"mavpackettype": "NOPE"})),
            "no message NOPE in the dictionaries"
        );
        assert_eq!(
            bad(serde_json::json!({"seq": 1})),
            "\"mavpackettype\" (the message name) is missing"
        );
    }

    #[test]
    fn frame_json_members_for_known_and_unknown_ids() {
        let ir = minimal();
        let decoder = PayloadDecoder::new(&ir);
        let (known, is_known) = decoder.frame_json_members(1, 2, 3, 0, &heartbeat_payload());
        assert!(is_known);
        let value: serde_json::Value = serde_json::from_str(&format!("{{{known}}}")).expect("json");
        assert_eq!(value["msg"]["mavpackettype"], "HEARTBEAT");
        assert!(
            known.starts_with(r#""sysid":1,"compid":2,"seq":3,"msg":"#),
            "{known}"
        );
        let (unknown, is_known) = decoder.frame_json_members(1, 2, 3, 60_000, &[0xde, 0xad]);
        assert!(!is_known);
        assert_eq!(
            unknown,
            r#""sysid":1,"compid":2,"seq":3,"msg":null,"id":60000,"payload":"dead""#
        );
    }
}
