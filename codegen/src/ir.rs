//! The format-neutral intermediate representation every frontend lowers into and every backend
//! reads.
//!
//! Names keep both spellings: `wire` is the dictionary's own (what goes into CRC_EXTRA, JSON and
//! docs) and `rust` is the identifier the backend emits. With the `serde` feature the IR
//! serialises, so that `ferrolink ir` can dump it, the dictionary tools can render it and tests
//! can snapshot it. Source spans are kept for diagnostics but not serialised.

use crate::diag::Span;

/// A name in both spellings.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Name {
    /// As written in the dictionary, e.g. `HEARTBEAT`, `type`.
    pub wire: String,
    /// As emitted in Rust, e.g. `Heartbeat`, `r#type`.
    pub rust: String,
}

/// Everything one generator run reads: one module per MAVLink dictionary file, one ring per
/// TosNet register map.
#[derive(Debug, Clone, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Ir {
    /// MAVLink modules in dependency order: a module comes after everything it includes.
    pub modules: Vec<Module>,
    /// All enums of the run, merged by wire name across files.
    pub enums: Vec<Enum>,
    /// TosNet register maps, one per file.
    pub rings: Vec<Ring>,
    /// ModRob-1 module dictionaries, one per file: those given and those a robot names.
    pub modrob: Vec<ModrobModule>,
    /// ModRob-1 robots (composite modules), one per file.
    pub robots: Vec<Robot>,
}

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

/// A TosNet register map: one ring, its area layouts and its nodes. One per file.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
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
    #[cfg_attr(feature = "serde", serde(skip))]
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
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
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
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The area's name or inline table.
    pub span: Option<Span>,
}

/// A node of a ring.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct RingNode {
    /// 0..=15 (larger values are reported by the checker).
    pub id: u8,
    /// `section1` / `Section1`.
    pub name: Name,
    /// Description text.
    pub description: String,
    /// Registers in file order.
    pub registers: Vec<Register>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The node's table.
    pub span: Option<Span>,
    #[cfg_attr(feature = "serde", serde(skip))]
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
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
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
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The register's table.
    pub span: Option<Span>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The `index` value.
    pub index_span: Option<Span>,
}

/// A ModRob-1 module dictionary: one module kind and its variables. One per file.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct ModrobModule {
    /// File stem and Rust module name.
    pub name: Name,
    /// `[module] name`: how robots and tools call the dictionary.
    pub dictionary: String,
    /// The file, as given or as a robot names it.
    pub path: String,
    /// `[module] kind`.
    pub kind: String,
    /// `[module] mi`: the MI the module uses unless a robot gives another.
    pub module_id: u16,
    /// `[module] uuid`, as 16 bytes.
    pub uuid: Option<[u8; 16]>,
    /// `[module] info`: text for a person, sent piecewise.
    pub info: String,
    /// `[module] description`.
    pub description: String,
    /// Variables in file order.
    pub variables: Vec<ModrobVariable>,
    /// CRC-32 of the variable table, for stored images (computed by lowering).
    pub fingerprint: u32,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The `[module]` header.
    pub span: Option<Span>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// `info`, if written.
    pub info_span: Option<Span>,
}

impl ModrobModule {
    /// How many VIs the variables take (an array takes one per element).
    pub fn vi_count(&self) -> usize {
        self.variables.iter().map(|v| v.count as usize).sum()
    }

    /// The variable holding `vi`, and the element index within it.
    pub fn variable_at(&self, vi: u8) -> Option<(&ModrobVariable, u8)> {
        self.variables.iter().find_map(|v| {
            let offset = vi.checked_sub(v.vi)?;
            (u16::from(offset) < u16::from(v.count)).then_some((v, offset))
        })
    }

    /// The variable named `name`, or the element `name[i]` of an array variable, as its VI.
    pub fn vi_of(&self, name: &str) -> Option<(&ModrobVariable, u8)> {
        let (base, index) = match name.strip_suffix(']').and_then(|n| n.split_once('[')) {
            Some((base, i)) => (base, Some(i.parse::<u8>().ok()?)),
            None => (name, None),
        };
        let v = self.variables.iter().find(|v| v.name.wire == base)?;
        match (index, v.count) {
            (None, 1) => Some((v, v.vi)),
            (Some(i), n) if n > 1 && i < n => Some((v, v.vi.checked_add(i)?)),
            _ => None,
        }
    }
}

/// Whether setting a ModRob-1 variable from outside changes the module's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Direction {
    /// Setting it changes the module's state.
    Input,
    /// The module produces it.
    Output,
}

/// One variable of a ModRob-1 module, or an array of `count` variables at consecutive VIs.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct ModrobVariable {
    /// `speed_setpoint` / `SpeedSetpoint` (the `Var` variant).
    pub name: Name,
    /// Its VI (the first element's, for an array).
    pub vi: u8,
    /// 1, or the number of elements of an array.
    pub count: u8,
    /// SI unit or dimensionless kind, as written.
    pub unit: String,
    /// Input or output.
    pub direction: Direction,
    /// Lower limit.
    pub min: f64,
    /// Upper limit.
    pub max: f64,
    /// Value at power-up.
    pub default: f64,
    /// Kept in non-volatile memory.
    pub persist: bool,
    /// Publication rate at power-up, in Hz.
    pub rate: f64,
    /// Description text.
    pub description: String,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// Spans of the table and of the values checks point at.
    pub spans: VariableSpans,
}

/// Where a variable's parts are written.
#[derive(Debug, Clone, Default)]
pub struct VariableSpans {
    /// The variable's table.
    pub table: Option<Span>,
    /// `vi`.
    pub vi: Option<Span>,
    /// `name`.
    pub name: Option<Span>,
    /// `unit`.
    pub unit: Option<Span>,
    /// `min` (or the table).
    pub min: Option<Span>,
    /// `default` (or the table).
    pub default: Option<Span>,
    /// `rate` (or the table).
    pub rate: Option<Span>,
}

/// A ModRob-1 robot: a composite module with its networks, module instances and the leader's
/// stored configuration. One per file.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Robot {
    /// File stem and Rust module name.
    pub name: Name,
    /// The file, as given.
    pub path: String,
    /// `[robot] description`.
    pub description: String,
    /// Networks in file order.
    pub networks: Vec<RobotNetwork>,
    /// Instances in file order.
    pub instances: Vec<RobotInstance>,
    /// The leader, as an index into `instances`.
    pub leader: usize,
    /// Stored values, in file order.
    pub values: Vec<Setting>,
    /// Stored publication rates, in file order.
    pub rates: Vec<Setting>,
    /// Stored subscriptions, in file order.
    pub subscriptions: Vec<Subscription>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The `[robot]` header.
    pub span: Option<Span>,
}

/// The transport of a robot's network.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Transport {
    /// ModRob.CAN-1.
    Can,
    /// ModRob.UART.B-1.
    Uart,
    /// ModRob.SPI-1.
    Spi,
    /// ModRob.Ethernet-1.
    Ethernet,
}

/// A network of a robot.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct RobotNetwork {
    /// Its name.
    pub name: Name,
    /// Its transport.
    pub transport: Transport,
    /// Bit rate, bit/s.
    pub bitrate: u32,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// Its table.
    pub span: Option<Span>,
}

/// A module of a robot.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct RobotInstance {
    /// `drive_fl` / `DRIVE_FL` (its MI constant).
    pub name: Name,
    /// Its dictionary, as an index into [`Ir::modrob`].
    pub dictionary: usize,
    /// Its MI.
    pub module_id: u16,
    /// Its UUID on Ethernet-1.
    pub uuid: Option<[u8; 16]>,
    /// Its network, as an index into [`Robot::networks`].
    pub network: usize,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// Its table.
    pub span: Option<Span>,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// `mi`, if written.
    pub mi_span: Option<Span>,
}

/// A variable of a robot's instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct VarRef {
    /// Index into [`Robot::instances`].
    pub instance: usize,
    /// The VI.
    pub vi: u8,
}

/// A stored value or publication rate.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Setting {
    /// The variable.
    pub target: VarRef,
    /// The value, or the rate in Hz.
    pub value: f64,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The entry.
    pub span: Option<Span>,
}

/// A stored subscription: `target <- source`.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Subscription {
    /// The variable that is set.
    pub target: VarRef,
    /// The variable whose publications set it.
    pub source: VarRef,
    #[cfg_attr(feature = "serde", serde(skip))]
    /// The entry.
    pub span: Option<Span>,
}
