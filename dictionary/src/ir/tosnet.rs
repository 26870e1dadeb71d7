//! The TosNet part of the IR: a ring, its area layouts, nodes and registers.

use super::*;
use crate::diag::Span;

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
