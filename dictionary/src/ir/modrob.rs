//! The ModRob-1 part of the IR: module dictionaries, their variables, and robots.

use super::*;
use crate::diag::Span;

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
