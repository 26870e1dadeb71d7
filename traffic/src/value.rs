//! One decoded value, scalars read from the wire, and `char` bytes as pymavlink shows them.

use std::fmt;

use ferrolink_dictionary::ir::Primitive;

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

/// One little-endian element exactly as pymavlink reads it: integers as they are, a `float`
/// widened exactly to `f64` (not through its shortest decimal, as [`Value::from_f32`] does),
/// a `char` as text; `bytes` is exactly `primitive.size()` long.
pub fn wire_value(primitive: Primitive, bytes: &[u8]) -> Value {
    match primitive {
        Primitive::F32 => {
            let mut raw = [0u8; 4];
            raw.copy_from_slice(bytes);
            Value::Float(f64::from(f32::from_le_bytes(raw)))
        }
        _ => scalar(primitive, bytes),
    }
}

/// One little-endian scalar; `bytes` is exactly `primitive.size()` long.
pub(crate) fn scalar(primitive: Primitive, bytes: &[u8]) -> Value {
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

/// `char` bytes as pymavlink 2.4.50 shows them: cut at the first NUL, then ASCII with every
/// byte above 0x7f replaced by U+FFFD (Python's `decode("ascii", errors="replace")`).
pub fn python_text(bytes: &[u8]) -> String {
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
