//! mavlink2rest's JSON form of a message: rust-mavlink's serde form, which its REST API and
//! WebSocket speak. [`PayloadDecoder::to_rest`] writes it, [`PayloadDecoder::from_rest`] reads
//! it back, [`PayloadDecoder::rest_template`] gives a message's defaults.
//!
//! `{"type": NAME, field: value, ...}`:
//! - a field named `type` is `mavtype`;
//! - an enum value is `{"type": ENTRY}`; a value the dialect does not name stays a number
//!   (rust-mavlink drops the whole message instead);
//! - a bit mask is its flags' names joined by `" | "`, in the order the dialect declares them
//!   (`""` for none), bits the dialect does not name left out, as rust-mavlink's `bitflags`
//!   print them;
//! - a `char[N]` array is a string up to its first NUL (bytes that are not UTF-8 shown as
//!   U+FFFD, where rust-mavlink fails); other arrays, `uint8_t[N]` included, are lists of
//!   numbers; an enum array is a list of numbers;
//! - a `float` is the exact double of its value, NaN and infinities `null`;
//! - extension fields are always there, zero when a frame leaves them out.

use ferrolink_dictionary::ir::{Entry, Enum, Field, Primitive};
use serde_json::{Map, Value as Json};

use crate::json::put_field;
use crate::value::wire_value;
use crate::{PayloadDecoder, Value};

/// The key of `field` in the REST form.
fn key(field: &Field) -> &str {
    match field.name.wire.as_str() {
        "type" => "mavtype",
        name => name,
    }
}

/// The entries of `e` in the order the dialect declares them (rust-mavlink's order): those of
/// the file that defines the enum first, in file order, then those other files add.
fn declared(e: &Enum) -> Vec<&Entry> {
    let mut entries: Vec<&Entry> = e.entries.iter().collect();
    let home = e.span.as_ref().map(|s| std::sync::Arc::as_ptr(&s.file));
    entries.sort_by_key(|entry| match &entry.span {
        Some(span) => (home != Some(std::sync::Arc::as_ptr(&span.file)), span.start),
        None => (true, usize::MAX),
    });
    entries
}

/// A number as JSON: integers exactly, a float as the exact double, NaN and infinities `null`.
fn number(value: Value) -> Json {
    match value {
        Value::Unsigned(v) => Json::from(v),
        Value::Signed(v) => Json::from(v),
        Value::Float(v) => serde_json::Number::from_f64(v).map_or(Json::Null, Json::Number),
        Value::Text(t) => Json::from(t),
    }
}

impl PayloadDecoder {
    /// Decodes `payload` as message `id` into the REST form (see the [module](self)). A short
    /// payload is zero-filled. `None` if the id is unknown.
    pub fn to_rest(&self, id: u32, payload: &[u8]) -> Option<Json> {
        let message = self.message(id)?;
        let mut buf = vec![0u8; message.max_len];
        let n = payload.len().min(buf.len());
        buf[..n].copy_from_slice(&payload[..n]);
        let mut object = Map::new();
        object.insert("type".into(), message.name.wire.clone().into());
        let mut fields: Vec<&Field> = message.fields.iter().collect();
        fields.sort_by_key(|f| f.offset);
        for field in fields {
            let primitive = field.ty.primitive;
            let bytes = &buf[field.offset..field.offset + field.ty.size()];
            let value = match field.ty.array {
                Some(_) if primitive == Primitive::Char => {
                    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                    Json::from(String::from_utf8_lossy(&bytes[..end]).into_owned())
                }
                Some(_) => bytes
                    .chunks_exact(primitive.size())
                    .map(|element| number(wire_value(primitive, element)))
                    .collect(),
                None => {
                    let value = wire_value(primitive, bytes);
                    match self.field_enum(field) {
                        Some(e) => self.enum_json(e, &value).unwrap_or_else(|| number(value)),
                        None => number(value),
                    }
                }
            };
            object.insert(key(field).to_owned(), value);
        }
        Some(Json::Object(object))
    }

    /// The enum a scalar field holds, if any.
    fn field_enum(&self, field: &Field) -> Option<&Enum> {
        self.enum_named(field.enum_name.as_deref()?)
    }

    /// An enum value in the REST form: `{"type": ENTRY}`, or a bit mask's flag names; `None`
    /// for a plain enum's value without an entry.
    fn enum_json(&self, e: &Enum, value: &Value) -> Option<Json> {
        let value = match *value {
            Value::Unsigned(v) => v,
            Value::Signed(v) => u64::try_from(v).ok()?,
            Value::Float(_) | Value::Text(_) => return None,
        };
        if !e.bitmask {
            let entry = e.entries.iter().find(|entry| entry.value == value)?;
            let mut object = Map::new();
            object.insert("type".into(), entry.name.wire.clone().into());
            return Some(Json::Object(object));
        }
        let mut rest = value;
        let mut names: Vec<&str> = Vec::new();
        for entry in declared(e) {
            // As `bitflags` lists them: a flag all of whose bits are set, and which adds one
            // not listed yet.
            if value & entry.value == entry.value && rest & entry.value != 0 {
                rest &= !entry.value;
                names.push(&entry.name.wire);
            }
        }
        Some(Json::from(names.join(" | ")))
    }

    /// Reads an enum value in the REST form (or as a number): `{"type": ENTRY}`, flag names
    /// joined by `|` (a `0x` part taken as bits), or `{"bits": N}` as older rust-mavlink wrote
    /// bit masks.
    fn enum_value(&self, e: &Enum, value: &Json) -> Result<Json, String> {
        let entry = |name: &str| {
            e.entries
                .iter()
                .find(|entry| entry.name.wire == name)
                .map(|entry| entry.value)
                .ok_or_else(|| format!("{name} is not an entry of {}", e.name.wire))
        };
        match value {
            Json::Number(_) => Ok(value.clone()),
            Json::Object(o) => match (o.get("type"), o.get("bits")) {
                (Some(Json::String(name)), _) => Ok(Json::from(entry(name)?)),
                (_, Some(bits @ Json::Number(_))) => Ok(bits.clone()),
                _ => Err(format!(
                    "expected {{\"type\": ENTRY}} naming an entry of {}",
                    e.name.wire
                )),
            },
            Json::String(flags) => {
                let mut bits = 0;
                for flag in flags.split('|').map(str::trim).filter(|f| !f.is_empty()) {
                    bits |= match flag.strip_prefix("0x") {
                        Some(hex) => u64::from_str_radix(hex, 16)
                            .map_err(|_| format!("{flag:?} is not hex bits"))?,
                        None => entry(flag)?,
                    };
                }
                Ok(Json::from(bits))
            }
            _ => Err(format!("expected an entry of {}", e.name.wire)),
        }
    }

    /// The inverse of [`PayloadDecoder::to_rest`]: a message in the REST form as its id and
    /// full-length payload. Fields left out are zero; a key that is not a field is an error, as
    /// is a value that does not fit. Errors name the field.
    pub fn from_rest(&self, value: &Json) -> Result<(u32, Vec<u8>), String> {
        let object = value
            .as_object()
            .ok_or("a message is a JSON object with \"type\" (its name)")?;
        let name = object
            .get("type")
            .and_then(Json::as_str)
            .ok_or("\"type\" (the message name) is missing")?;
        let message = self
            .messages()
            .find(|m| m.name.wire == name)
            .ok_or_else(|| format!("no message {name} in the dialect"))?;
        let mut payload = vec![0u8; message.max_len];
        for (k, value) in object {
            if k == "type" {
                continue;
            }
            let field = message
                .fields
                .iter()
                .find(|f| key(f) == k)
                .ok_or_else(|| format!("{name} has no field {k}"))?;
            let value = match self.field_enum(field).filter(|_| field.ty.array.is_none()) {
                Some(e) => self
                    .enum_value(e, value)
                    .map_err(|err| format!("{name}.{k}: {err}"))?,
                None => value.clone(),
            };
            let bytes = &mut payload[field.offset..field.offset + field.ty.size()];
            put_field(field, &value, bytes).map_err(|err| format!("{name}.{k}: {err}"))?;
        }
        Ok((message.id, payload))
    }

    /// Message `name` with every field at its default, in the REST form, as mavlink2rest's
    /// helper gives it: numbers 0, an enum its first entry, a bit mask its first flag, text
    /// empty, `mavlink_version` the dialect's version. `None` for an unknown name.
    pub fn rest_template(&self, name: &str) -> Option<Json> {
        let message = self.messages().find(|m| m.name.wire == name)?;
        let mut template = self.to_rest(message.id, &[])?;
        for field in &message.fields {
            let value = match self.field_enum(field).filter(|_| field.ty.array.is_none()) {
                Some(e) => match declared(e).first() {
                    Some(first) if e.bitmask => Json::from(first.name.wire.clone()),
                    Some(first) => serde_json::json!({ "type": first.name.wire }),
                    None => continue,
                },
                None if field.ty.mavlink_version => {
                    let version = self.ir().modules.iter().filter_map(|m| m.version).max();
                    Json::from(version.unwrap_or(3))
                }
                None => continue,
            };
            template[key(field)] = value;
        }
        Some(template)
    }
}
