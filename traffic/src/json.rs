//! pymavlink's `to_dict()` JSON form, and JSON back to MAVLink frames.

use ferrolink_dictionary::ir::{Field, Primitive};

use crate::value::{python_text, wire_value};
use crate::{PayloadDecoder, Value};

impl PayloadDecoder {
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
            match wire_value(primitive, bytes) {
                Value::Unsigned(v) => Json::from(v),
                Value::Signed(v) => Json::from(v),
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

impl PayloadDecoder {
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
            .messages()
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

impl PayloadDecoder {
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
pub(crate) fn put_field(
    field: &Field,
    value: &serde_json::Value,
    out: &mut [u8],
) -> Result<(), String> {
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
