//! The format-neutral intermediate representation every frontend lowers into and every backend
//! reads.
//!
//! Names keep both spellings: `wire` is the dictionary's own (what goes into CRC_EXTRA, JSON and
//! docs) and `rust` is the identifier the backend emits. The IR serialises with serde so that
//! `ferrolink ir` can dump it and tests can snapshot it. Source spans are kept for diagnostics but
//! not serialised.

use serde::Serialize;

use crate::diag::Span;

/// A name in both spellings.
#[derive(Debug, Clone, Serialize, PartialEq, Eq)]
pub struct Name {
    /// As written in the dictionary, e.g. `HEARTBEAT`, `type`.
    pub wire: String,
    /// As emitted in Rust, e.g. `Heartbeat`, `r#type`.
    pub rust: String,
}

/// Everything one generator run reads: one module per MAVLink dictionary file, one ring per
/// TosNet register map.
#[derive(Debug, Clone, Serialize, Default)]
pub struct Ir {
    /// MAVLink modules in dependency order: a module comes after everything it includes.
    pub modules: Vec<Module>,
    /// All enums of the run, merged by wire name across files.
    pub enums: Vec<Enum>,
    /// TosNet register maps, one per file.
    pub rings: Vec<Ring>,
}

/// One dictionary file.
#[derive(Debug, Clone, Serialize)]
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
    #[serde(skip)]
    /// Where the file starts.
    pub span: Option<Span>,
}

/// A `<deprecated>` or `<superseded>` marker.
#[derive(Debug, Clone, Serialize, Default, PartialEq, Eq)]
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
#[derive(Debug, Clone, Serialize)]
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
    #[serde(skip)]
    /// The `<message>` tag.
    pub span: Option<Span>,
    #[serde(skip)]
    /// The `id` attribute value.
    pub id_span: Option<Span>,
}

/// A scalar wire type.
#[derive(Debug, Clone, Copy, Serialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[serde(rename_all = "lowercase")]
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
#[derive(Debug, Clone, Copy, Serialize, PartialEq, Eq)]
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
#[derive(Debug, Clone, Serialize)]
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
    #[serde(skip)]
    /// The `<field>` tag.
    pub span: Option<Span>,
    #[serde(skip)]
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
#[derive(Debug, Clone, Serialize)]
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
    #[serde(skip)]
    /// The first `<enum>` tag.
    pub span: Option<Span>,
}

/// An enum entry.
#[derive(Debug, Clone, Serialize)]
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
    #[serde(skip)]
    /// The `<entry>` tag.
    pub span: Option<Span>,
}

/// A command parameter of an enum entry.
#[derive(Debug, Clone, Serialize)]
pub struct Param {
    /// 1..=7.
    pub index: u8,
    /// Description text.
    pub description: String,
    /// Attributes (label, units, enum, increment, minValue, maxValue, default, reserved, ...).
    pub attrs: Vec<(String, String)>,
}

/// A TosNet register map: one ring, its area layouts and its nodes. One per file.
#[derive(Debug, Clone, Serialize)]
pub struct Ring {
    /// File stem and Rust module name.
    pub name: Name,
    /// The file, as given.
    pub path: String,
    /// `[ring] description`.
    pub description: String,
    /// Area layouts: the named ones in file order, then the inline ones in node and register
    /// order.
    pub areas: Vec<AreaLayout>,
    /// Nodes in file order.
    pub nodes: Vec<RingNode>,
    #[serde(skip)]
    /// The `[ring]` header.
    pub span: Option<Span>,
}

impl Ring {
    /// The registers enabled in the whole ring: per node, those with an in or an out area. This
    /// is `r` in the cycle-rate model.
    pub fn enabled_registers(&self) -> usize {
        self.nodes
            .iter()
            .map(|n| {
                n.registers
                    .iter()
                    .filter(|r| r.in_area.is_some() || r.out_area.is_some())
                    .count()
            })
            .sum()
    }
}

/// The layout of a 16-byte in or out area: one struct in the generated code.
#[derive(Debug, Clone, Serialize)]
pub struct AreaLayout {
    /// `motor_target` / `MotorTarget`; an inline area is named after its node, register and
    /// direction (`section1_motor1_out`).
    pub name: Name,
    /// Defined inline in a register rather than under `[areas]`.
    pub inline: bool,
    /// Description text.
    pub description: String,
    /// Fields in file order, with their byte offsets in the area (`extension` and the enum
    /// parts are unused).
    pub fields: Vec<Field>,
    /// Bytes up to the end of the last field (gaps included).
    pub len: usize,
    #[serde(skip)]
    /// The area's name or inline table.
    pub span: Option<Span>,
}

/// A node of a ring.
#[derive(Debug, Clone, Serialize)]
pub struct RingNode {
    /// 0..=15 (larger values are reported by the checker).
    pub id: u8,
    /// `section1` / `Section1`.
    pub name: Name,
    /// Description text.
    pub description: String,
    /// Registers in file order.
    pub registers: Vec<Register>,
    #[serde(skip)]
    /// The node's table.
    pub span: Option<Span>,
    #[serde(skip)]
    /// The `id` value.
    pub id_span: Option<Span>,
}

impl RingNode {
    /// Registers whose out area the node writes (bit r = register r).
    pub fn out_mask(&self) -> u8 {
        self.mask(|r| r.out_area.is_some())
    }

    /// Registers whose in area the master writes (bit r = register r).
    pub fn in_mask(&self) -> u8 {
        self.mask(|r| r.in_area.is_some())
    }

    fn mask(&self, used: impl Fn(&Register) -> bool) -> u8 {
        self.registers
            .iter()
            .filter(|r| used(r) && r.index < 8)
            .fold(0, |m, r| m | 1 << r.index)
    }
}

/// A register of a node: an in area (master -> node) and an out area (node -> everyone), each
/// optional.
#[derive(Debug, Clone, Serialize)]
pub struct Register {
    /// 0..=7 (larger values are reported by the checker).
    pub index: u8,
    /// `motor1` / `motor1`.
    pub name: Name,
    /// Description text.
    pub description: String,
    /// The in area's layout, as an index into [`Ring::areas`].
    pub in_area: Option<usize>,
    /// The out area's layout, as an index into [`Ring::areas`].
    pub out_area: Option<usize>,
    #[serde(skip)]
    /// The register's table.
    pub span: Option<Span>,
    #[serde(skip)]
    /// The `index` value.
    pub index_span: Option<Span>,
}
