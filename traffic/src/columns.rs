//! Frames into columns: one Arrow table per message type, built straight from the payloads
//! (no value per message on the way), for pandas, polars, DuckDB and Parquet.
//!
//! Each table has a `timestamp` column (a `.tlog`'s seconds since the Unix epoch, as pymavlink's
//! `_timestamp`; null in a raw capture), `sysid`, `compid`, optionally `log` (which file a row
//! came from), then one column per field in XML order, extensions included. A field keeps its
//! name where it has one of ours (FOLLOW_TARGET's `timestamp`): ours then starts with an
//! underscore (`_timestamp`, pymavlink's attribute). The fields' columns are:
//! - numbers in their wire type (`float` as float32, `uint16_t` as uint16, ...);
//! - numeric arrays as fixed-size lists;
//! - `char` fields and arrays as strings, as pymavlink shows them (cut at the first NUL, bytes
//!   above 0x7f as U+FFFD).
//!
//! ```
//! use ferrolink_traffic::{columns::Tables, Dialects};
//!
//! let decoder = Dialects::load(&[], "common").unwrap().decoder();
//! let mut tables = Tables::new(decoder, None).unwrap();
//! // ATTITUDE (id 30), truncated to its first field: time_boot_ms = 10000.
//! tables.push(Some(1_700_000_000_000_000), 1, 1, 30, &[0x10, 0x27]);
//! let (name, batch) = &tables.finish()[0];
//! assert_eq!((name.as_str(), batch.num_rows(), batch.num_columns()), ("ATTITUDE", 1, 10));
//! ```

use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};
use std::sync::Arc;

use arrow_array::types::{
    Float32Type, Float64Type, Int16Type, Int32Type, Int64Type, Int8Type, UInt16Type, UInt32Type,
    UInt64Type, UInt8Type,
};
use arrow_array::{
    ArrayRef, ArrowPrimitiveType, DictionaryArray, FixedSizeListArray, Float64Array,
    PrimitiveArray, RecordBatch, StringArray, UInt8Array,
};
use arrow_schema::{DataType, Field as ArrowField, Schema, SchemaRef};
use ferrolink_dictionary::ir::{Field, Message, Primitive};

use crate::value::python_text;
use crate::PayloadDecoder;

/// One field's values, every element of every row in order.
#[derive(Debug)]
enum Values {
    U8(Vec<u8>),
    U16(Vec<u16>),
    U32(Vec<u32>),
    U64(Vec<u64>),
    I8(Vec<i8>),
    I16(Vec<i16>),
    I32(Vec<i32>),
    I64(Vec<i64>),
    F32(Vec<f32>),
    F64(Vec<f64>),
    Text(Vec<String>),
}

impl Values {
    fn new(primitive: Primitive) -> Self {
        match primitive {
            Primitive::U8 => Values::U8(Vec::new()),
            Primitive::U16 => Values::U16(Vec::new()),
            Primitive::U32 => Values::U32(Vec::new()),
            Primitive::U64 => Values::U64(Vec::new()),
            Primitive::I8 => Values::I8(Vec::new()),
            Primitive::I16 => Values::I16(Vec::new()),
            Primitive::I32 => Values::I32(Vec::new()),
            Primitive::I64 => Values::I64(Vec::new()),
            Primitive::F32 => Values::F32(Vec::new()),
            Primitive::F64 => Values::F64(Vec::new()),
            Primitive::Char => Values::Text(Vec::new()),
        }
    }

    /// Appends the field's bytes: a `char` field as one text, else every element.
    fn push(&mut self, bytes: &[u8]) {
        macro_rules! le {
            ($v:expr, $t:ty) => {
                $v.extend(
                    bytes
                        .chunks_exact(size_of::<$t>())
                        .map(|b| <$t>::from_le_bytes(b.try_into().unwrap_or_default())),
                )
            };
        }
        match self {
            Values::U8(v) => v.extend_from_slice(bytes),
            Values::U16(v) => le!(v, u16),
            Values::U32(v) => le!(v, u32),
            Values::U64(v) => le!(v, u64),
            Values::I8(v) => v.extend(bytes.iter().map(|&b| b as i8)),
            Values::I16(v) => le!(v, i16),
            Values::I32(v) => le!(v, i32),
            Values::I64(v) => le!(v, i64),
            Values::F32(v) => le!(v, f32),
            Values::F64(v) => le!(v, f64),
            Values::Text(v) => v.push(python_text(bytes)),
        }
    }

    /// The values as one Arrow array, of elements (a list's values) or of rows.
    fn take(&mut self) -> ArrayRef {
        fn array<T: ArrowPrimitiveType>(v: &mut Vec<T::Native>) -> ArrayRef {
            Arc::new(PrimitiveArray::<T>::from_iter_values(std::mem::take(v)))
        }
        match self {
            Values::U8(v) => array::<UInt8Type>(v),
            Values::U16(v) => array::<UInt16Type>(v),
            Values::U32(v) => array::<UInt32Type>(v),
            Values::U64(v) => array::<UInt64Type>(v),
            Values::I8(v) => array::<Int8Type>(v),
            Values::I16(v) => array::<Int16Type>(v),
            Values::I32(v) => array::<Int32Type>(v),
            Values::I64(v) => array::<Int64Type>(v),
            Values::F32(v) => array::<Float32Type>(v),
            Values::F64(v) => array::<Float64Type>(v),
            Values::Text(v) => Arc::new(StringArray::from(std::mem::take(v))),
        }
    }
}

/// The Arrow type of one element of a field.
fn element_type(primitive: Primitive) -> DataType {
    match primitive {
        Primitive::U8 => DataType::UInt8,
        Primitive::U16 => DataType::UInt16,
        Primitive::U32 => DataType::UInt32,
        Primitive::U64 => DataType::UInt64,
        Primitive::I8 => DataType::Int8,
        Primitive::I16 => DataType::Int16,
        Primitive::I32 => DataType::Int32,
        Primitive::I64 => DataType::Int64,
        Primitive::F32 => DataType::Float32,
        Primitive::F64 => DataType::Float64,
        Primitive::Char => DataType::Utf8,
    }
}

/// The number of elements of a list column: arrays that are not `char` arrays.
fn list_len(field: &Field) -> Option<i32> {
    field
        .ty
        .array
        .filter(|_| field.ty.primitive != Primitive::Char)
        .map(i32::from)
}

/// The name of the column that says which file a row came from.
pub const LOG_COLUMN: &str = "log";

/// One message type's rows so far.
#[derive(Debug)]
struct Table {
    name: String,
    schema: SchemaRef,
    /// Each field's (offset, size) in the zero-filled payload.
    layout: Vec<(usize, usize)>,
    max_len: usize,
    timestamp: Vec<Option<f64>>,
    sysid: Vec<u8>,
    compid: Vec<u8>,
    /// Each row's log, an index into [`Tables::logs`].
    log: Option<Vec<i32>>,
    fields: Vec<Values>,
}

impl Table {
    fn new(message: &Message, log: bool) -> Self {
        // A field keeps its name; one of ours that it takes gets an underscore in front.
        let ours = |name: &str| match message.fields.iter().any(|f| f.name.wire == name) {
            true => format!("_{name}"),
            false => name.to_owned(),
        };
        let mut columns = vec![
            ArrowField::new(ours("timestamp"), DataType::Float64, true),
            ArrowField::new(ours("sysid"), DataType::UInt8, false),
            ArrowField::new(ours("compid"), DataType::UInt8, false),
        ];
        if log {
            let dictionary =
                DataType::Dictionary(Box::new(DataType::Int32), Box::new(DataType::Utf8));
            columns.push(ArrowField::new(ours(LOG_COLUMN), dictionary, false));
        }
        for field in &message.fields {
            let element = element_type(field.ty.primitive);
            let ty = match list_len(field) {
                Some(n) => {
                    DataType::FixedSizeList(Arc::new(ArrowField::new("item", element, false)), n)
                }
                None => element,
            };
            columns.push(ArrowField::new(&field.name.wire, ty, false));
        }
        Table {
            name: message.name.wire.clone(),
            schema: Arc::new(Schema::new(columns)),
            layout: message
                .fields
                .iter()
                .map(|f| (f.offset, f.ty.size()))
                .collect(),
            max_len: message.max_len,
            timestamp: Vec::new(),
            sysid: Vec::new(),
            compid: Vec::new(),
            log: log.then(Vec::new),
            fields: message
                .fields
                .iter()
                .map(|f| Values::new(f.ty.primitive))
                .collect(),
        }
    }

    fn rows(&self) -> usize {
        self.sysid.len()
    }

    /// The rows so far as a batch, and an empty table to go on with.
    fn take(&mut self, logs: &[String]) -> RecordBatch {
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(Float64Array::from(std::mem::take(&mut self.timestamp))),
            Arc::new(UInt8Array::from(std::mem::take(&mut self.sysid))),
            Arc::new(UInt8Array::from(std::mem::take(&mut self.compid))),
        ];
        if let Some(log) = &mut self.log {
            let keys = PrimitiveArray::<Int32Type>::from(std::mem::take(log));
            let values = Arc::new(StringArray::from_iter_values(logs));
            match DictionaryArray::try_new(keys, values) {
                Ok(column) => columns.push(Arc::new(column)),
                Err(_) => return RecordBatch::new_empty(Arc::clone(&self.schema)),
            }
        }
        let first = columns.len();
        for (i, values) in self.fields.iter_mut().enumerate() {
            let array = values.take();
            let column = match self.schema.field(first + i).data_type() {
                DataType::FixedSizeList(item, n) => {
                    Arc::new(FixedSizeListArray::new(Arc::clone(item), *n, array, None))
                }
                _ => array,
            };
            columns.push(column);
        }
        // The columns follow the schema by construction.
        RecordBatch::try_new(Arc::clone(&self.schema), columns)
            .unwrap_or_else(|_| RecordBatch::new_empty(Arc::clone(&self.schema)))
    }
}

/// Builds one Arrow table per message type from frames, as they are read.
#[derive(Debug)]
pub struct Tables {
    decoder: PayloadDecoder,
    /// The ids asked for (`None`: all).
    wanted: Option<HashSet<u32>>,
    /// The logs named so far; rows take the last.
    logs: Vec<String>,
    /// Tables by message id; frames of ids not wanted never get one.
    by_id: HashMap<u32, Table>,
    scratch: Vec<u8>,
}

impl Tables {
    /// Tables of the messages named in `types` (wire names, `ATTITUDE`), or of all. A name the
    /// dictionaries lack is an error that lists what is close to it.
    pub fn new(decoder: PayloadDecoder, types: Option<&[String]>) -> Result<Self, String> {
        let wanted = types.map(|names| decoder.ids_of(names)).transpose()?;
        Ok(Tables {
            decoder,
            wanted,
            logs: Vec::new(),
            by_id: HashMap::new(),
            scratch: Vec::new(),
        })
    }

    /// Every row pushed from now on has a [`LOG_COLUMN`] with value `log`.
    pub fn set_log(&mut self, log: &str) {
        self.logs.push(log.to_owned());
    }

    /// Whether frames of id `id` are wanted (asked for, and known).
    pub fn wants(&self, id: u32) -> bool {
        self.wanted.as_ref().is_none_or(|w| w.contains(&id)) && self.decoder.message(id).is_some()
    }

    /// Appends a frame's payload as a row of its message's table, and returns how many rows that
    /// table now holds. Ids not wanted are skipped (0); a short payload is zero-filled (the
    /// MAVLink 2 truncation rule).
    pub fn push(
        &mut self,
        t_us: Option<u64>,
        sysid: u8,
        compid: u8,
        id: u32,
        payload: &[u8],
    ) -> usize {
        let table = match self.by_id.entry(id) {
            Entry::Occupied(t) => t.into_mut(),
            Entry::Vacant(slot) => {
                let wanted = self.wanted.as_ref().is_none_or(|w| w.contains(&id));
                match self.decoder.message(id) {
                    Some(message) if wanted => {
                        slot.insert(Table::new(message, !self.logs.is_empty()))
                    }
                    _ => return 0,
                }
            }
        };
        self.scratch.clear();
        self.scratch.resize(table.max_len, 0);
        let n = payload.len().min(table.max_len);
        self.scratch[..n].copy_from_slice(&payload[..n]);
        // As pymavlink computes `_timestamp`: microseconds times 1e-6, to the same double.
        table.timestamp.push(t_us.map(|t| t as f64 * 1e-6));
        table.sysid.push(sysid);
        table.compid.push(compid);
        if let Some(rows) = &mut table.log {
            rows.push(self.logs.len() as i32 - 1);
        }
        for (values, &(offset, size)) in table.fields.iter_mut().zip(&table.layout) {
            values.push(&self.scratch[offset..offset + size]);
        }
        table.rows()
    }

    /// The tables of at least `min_rows` rows, by message name, as batches; they start over
    /// empty. A writer calls this as it goes, to hold no more than that many rows a type.
    pub fn take_full(&mut self, min_rows: usize) -> Vec<(String, RecordBatch)> {
        let mut full: Vec<(&u32, &mut Table)> = self
            .by_id
            .iter_mut()
            .filter(|(_, t)| t.rows() >= min_rows.max(1))
            .collect();
        full.sort_unstable_by_key(|(id, _)| **id);
        full.into_iter()
            .map(|(_, t)| (t.name.clone(), t.take(&self.logs)))
            .collect()
    }

    /// Every table with rows, by message name in id order.
    pub fn finish(mut self) -> Vec<(String, RecordBatch)> {
        self.take_full(1)
    }
}
