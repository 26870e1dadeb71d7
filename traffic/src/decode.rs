//! Payloads to values with the IR's layout: [`PayloadDecoder`] and [`DecodedMessage`].

use std::collections::HashMap;
use std::fmt::Write as _;
use std::sync::Arc;

use ferrolink_dictionary::ir::{Enum, Field, Ir, Message, Primitive};

use crate::value::scalar;
use crate::Value;

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
pub(crate) fn column_count(field: &Field) -> usize {
    match field.ty.array {
        Some(n) if field.ty.primitive != Primitive::Char => usize::from(n),
        _ => 1,
    }
}

/// The field of every column, in column order.
pub(crate) fn column_fields(message: &Message) -> impl Iterator<Item = &Field> {
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
///
/// It shares the IR (an `Arc`): a decoder handed to threads that outlive the code that loaded
/// the dictionaries keeps it alive, and frees it with the last clone.
#[derive(Debug, Clone)]
pub struct PayloadDecoder {
    ir: Arc<Ir>,
    /// Where each message id is: (module, message) indices into the IR.
    by_id: HashMap<u32, (usize, usize)>,
    /// Each enum's index, by wire name.
    enums: HashMap<String, usize>,
}

impl PayloadDecoder {
    /// Indexes the messages of every module by id.
    ///
    /// If several modules define the same id, the one that comes later in [`Ir::modules`] wins
    /// (modules are in dependency order, so a dialect overrides what it includes).
    pub fn new(ir: impl Into<Arc<Ir>>) -> Self {
        let ir = ir.into();
        let by_id = ir
            .modules
            .iter()
            .enumerate()
            .flat_map(|(m, module)| {
                module
                    .messages
                    .iter()
                    .enumerate()
                    .map(move |(i, message)| (message.id, (m, i)))
            })
            .collect();
        let enums = ir
            .enums
            .iter()
            .enumerate()
            .map(|(i, e)| (e.name.wire.clone(), i))
            .collect();
        PayloadDecoder { ir, by_id, enums }
    }

    /// The IR this decoder reads.
    pub fn ir(&self) -> &Ir {
        &self.ir
    }

    /// The message with wire id `id`, if the dictionary has one.
    pub fn message(&self, id: u32) -> Option<&Message> {
        let &(m, i) = self.by_id.get(&id)?;
        self.ir.modules.get(m)?.messages.get(i)
    }

    /// Every message the decoder knows, one per id.
    pub fn messages(&self) -> impl Iterator<Item = &Message> {
        self.by_id.keys().filter_map(|&id| self.message(id))
    }

    /// The ids of the messages named `names` (wire names, any case). A name the dictionaries
    /// lack is an error, which lists the known names that start like it.
    pub fn ids_of(&self, names: &[String]) -> Result<std::collections::HashSet<u32>, String> {
        names
            .iter()
            .map(|name| {
                let found = self
                    .messages()
                    .find(|m| m.name.wire.eq_ignore_ascii_case(name))
                    .map(|m| m.id);
                found.ok_or_else(|| {
                    let stem: String = name.chars().take(3).collect::<String>().to_uppercase();
                    let mut close: Vec<&str> = self
                        .messages()
                        .map(|m| m.name.wire.as_str())
                        .filter(|n| !stem.is_empty() && n.starts_with(&stem))
                        .collect();
                    close.sort_unstable();
                    close.truncate(8);
                    match close.is_empty() {
                        true => format!("unknown message type {name:?}"),
                        false => format!(
                            "unknown message type {name:?} (known types like it: {})",
                            close.join(", ")
                        ),
                    }
                })
            })
            .collect()
    }

    pub(crate) fn enum_named(&self, name: &str) -> Option<&Enum> {
        self.ir.enums.get(*self.enums.get(name)?)
    }

    /// Decodes `payload` (without the id) as message `id`. A payload shorter than the message is
    /// zero-filled, bytes beyond it are ignored. `None` if the id is unknown.
    pub fn decode(&self, id: u32, payload: &[u8]) -> Option<DecodedMessage<'_>> {
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
    pub fn decode_frame(&self, frame_payload: &[u8]) -> Option<DecodedMessage<'_>> {
        let (&id, payload) = frame_payload.split_first()?;
        self.decode(u32::from(id), payload)
    }

    /// The enum entry name(s) of `value` if `field` holds an enum, for display.
    ///
    /// A plain enum gives the entry's wire name (`None` for a value without an entry). A bitmask
    /// gives the names of the set bits joined by `|`, with bits that have no entry appended in
    /// hex (`MAV_MODE_FLAG_SAFETY_ARMED|0x100`); zero gives the zero entry if there is one.
    pub fn enum_label(&self, field: &Field, value: &Value) -> Option<String> {
        let e = self.enum_named(field.enum_name.as_deref()?)?;
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
