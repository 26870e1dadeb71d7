//! The MAVLink part of the IR: dictionary files (modules), messages, fields and enums.

use super::*;
use crate::diag::Span;

/// One dictionary file.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Module {
    /// File stem and Rust module name.
    pub name: Name,
    /// The file, as given or resolved.
    pub path: String,
    /// `<version>`, if given.
    pub version: Option<u8>,
    /// `<dialect>`, if given.
    pub dialect: Option<u32>,
    /// Direct includes, as indices into [`Ir::modules`].
    pub includes: Vec<usize>,
    /// This module and everything it includes, transitively, in dependency order.
    pub closure: Vec<usize>,
    /// Messages defined in this file, in file order.
    pub messages: Vec<Message>,
    /// Enums first defined in this file, as indices into [`Ir::enums`].
    pub enums: Vec<usize>,
    /// Top-level description (e.g. from a leading comment or `<description>`), if any.
    pub description: String,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// Where the file starts.
    pub span: Option<Span>,
}

/// A `<deprecated>` or `<superseded>` marker.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Deprecation {
    /// `since` attribute.
    pub since: String,
    /// `replaced_by` attribute.
    pub replaced_by: String,
    /// The element's text.
    pub note: String,
    /// `superseded` rather than `deprecated`.
    pub superseded: bool,
}

/// A message.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Message {
    /// `HEARTBEAT` / `Heartbeat`.
    pub name: Name,
    /// 0..=2^24-1.
    pub id: u32,
    /// Description text.
    pub description: String,
    /// Deprecation marker.
    pub deprecated: Option<Deprecation>,
    /// Work in progress.
    pub wip: bool,
    /// Fields in XML order.
    pub fields: Vec<Field>,
    /// Indices into `fields`, in wire order (base fields sorted by element size, then extensions).
    pub wire_order: Vec<usize>,
    /// Payload length of the base fields.
    pub min_len: usize,
    /// Payload length with extensions.
    pub max_len: usize,
    /// The CRC_EXTRA seed.
    pub crc_extra: u8,
    /// Offset of `target_system` (or MANUAL_CONTROL's `target`).
    pub target_system: Option<usize>,
    /// Offset of `target_component`.
    pub target_component: Option<usize>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The `<message>` tag.
    pub span: Option<Span>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The `id` attribute value.
    pub id_span: Option<Span>,
}

/// A scalar wire type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Primitive {
    /// `uint8_t`
    U8,
    /// `int8_t`
    I8,
    /// `uint16_t`
    U16,
    /// `int16_t`
    I16,
    /// `uint32_t`
    U32,
    /// `int32_t`
    I32,
    /// `uint64_t`
    U64,
    /// `int64_t`
    I64,
    /// `float`
    F32,
    /// `double`
    F64,
    /// `char`: one byte of text
    Char,
}

impl Primitive {
    /// Bytes on the wire.
    pub const fn size(self) -> usize {
        match self {
            Primitive::U8 | Primitive::I8 | Primitive::Char => 1,
            Primitive::U16 | Primitive::I16 => 2,
            Primitive::U32 | Primitive::I32 | Primitive::F32 => 4,
            Primitive::U64 | Primitive::I64 | Primitive::F64 => 8,
        }
    }

    /// The C spelling used in CRC_EXTRA.
    pub const fn c_name(self) -> &'static str {
        match self {
            Primitive::U8 => "uint8_t",
            Primitive::I8 => "int8_t",
            Primitive::U16 => "uint16_t",
            Primitive::I16 => "int16_t",
            Primitive::U32 => "uint32_t",
            Primitive::I32 => "int32_t",
            Primitive::U64 => "uint64_t",
            Primitive::I64 => "int64_t",
            Primitive::F32 => "float",
            Primitive::F64 => "double",
            Primitive::Char => "char",
        }
    }

    /// Parses a C spelling, including the legacy `uint8` form.
    pub fn from_c(name: &str) -> Option<Self> {
        let name = name.strip_suffix("_t").unwrap_or(name);
        Some(match name {
            "uint8" => Primitive::U8,
            "int8" => Primitive::I8,
            "uint16" => Primitive::U16,
            "int16" => Primitive::I16,
            "uint32" => Primitive::U32,
            "int32" => Primitive::I32,
            "uint64" => Primitive::U64,
            "int64" => Primitive::I64,
            "float" => Primitive::F32,
            "double" => Primitive::F64,
            "char" => Primitive::Char,
            _ => return None,
        })
    }

    /// Whether this is an integer type (enums may ride on it).
    pub const fn is_integer(self) -> bool {
        !matches!(self, Primitive::F32 | Primitive::F64 | Primitive::Char)
    }
}

/// A field's type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct FieldType {
    /// Element type.
    pub primitive: Primitive,
    /// `Some(N)` for `type[N]`.
    pub array: Option<u8>,
    /// `uint8_t_mavlink_version`: always sent as the dialect's version.
    pub mavlink_version: bool,
}

impl FieldType {
    /// Bytes on the wire.
    pub fn size(&self) -> usize {
        self.primitive.size() * usize::from(self.array.unwrap_or(1))
    }
}

/// A field.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Field {
    /// `type` / `r#type`.
    pub name: Name,
    /// The type.
    pub ty: FieldType,
    /// After `<extensions/>`.
    pub extension: bool,
    /// Payload offset in wire order.
    pub offset: usize,
    /// Wire name of the enum this field holds, if any.
    pub enum_name: Option<String>,
    /// Description text.
    pub description: String,
    /// Further attributes: units, display, instance, invalid, multiplier, print_format, default,
    /// minValue, maxValue, increment, in source order.
    pub attrs: Vec<(String, String)>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The `<field>` tag.
    pub span: Option<Span>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The `enum` attribute value.
    pub enum_span: Option<Span>,
}

impl Field {
    /// The attribute `name`, if given.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }
}

/// An enum, merged across files.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Enum {
    /// `MAV_TYPE` / `MavType`.
    pub name: Name,
    /// A flag set rather than a list of values.
    pub bitmask: bool,
    /// Description text.
    pub description: String,
    /// Deprecation marker.
    pub deprecated: Option<Deprecation>,
    /// Entries sorted by value.
    pub entries: Vec<Entry>,
    /// The module it is emitted in (where it is first defined).
    pub module: usize,
    /// The unsigned integer type that holds every value and every field that uses it.
    pub repr: Primitive,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The first `<enum>` tag.
    pub span: Option<Span>,
}

/// An enum entry.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Entry {
    /// `MAV_TYPE_GENERIC` / `Generic` (the enum's prefix stripped).
    pub name: Name,
    /// The value.
    pub value: u64,
    /// The value was implicit (previous highest + 1).
    pub implicit: bool,
    /// Description text.
    pub description: String,
    /// Deprecation marker.
    pub deprecated: Option<Deprecation>,
    /// Work in progress.
    pub wip: bool,
    /// `<param>` elements (for MAV_CMD entries).
    pub params: Vec<Param>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The `<entry>` tag.
    pub span: Option<Span>,
}

/// A command parameter of an enum entry.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Param {
    /// 1..=7.
    pub index: u8,
    /// Description text.
    pub description: String,
    /// Attributes (label, units, enum, increment, minValue, maxValue, default, reserved, ...).
    pub attrs: Vec<(String, String)>,
}
