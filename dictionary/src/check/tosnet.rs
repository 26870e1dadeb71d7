//! Checks on TosNet register maps: the protocol's limits (16-byte areas, node ids 0..=15, at
//! most 15 nodes, at most 8 registers per node with indices 0..=7), overlapping fields,
//! duplicates, and names that collide in the generated Rust.

use std::collections::HashMap;

use super::report_dup;
use crate::diag::{Code, Diagnostics, Span};
use crate::ident;
use crate::ir::{AreaLayout, Ring, RingNode};

/// Bytes in an in or out area.
pub const AREA_LEN: usize = 16;
/// The largest node id.
pub const MAX_NODE_ID: u8 = 15;
/// The most nodes a ring may have.
pub const MAX_NODES: usize = 15;
/// The most registers a node may have.
pub const MAX_REGISTERS: usize = 8;
/// The largest register index.
pub const MAX_REGISTER_INDEX: u8 = 7;

/// Constants every node type gets from its `NodeId` implementation.
const NODE_CONSTS: &[&str] = &["ID", "NAME", "OUT_MASK", "IN_MASK"];

/// Reports every problem in `rings`.
pub fn check(rings: &[Ring], diags: &mut Diagnostics) {
    for ring in rings {
        check_ring(ring, diags);
    }
}

fn area_what(area: &AreaLayout) -> String {
    if area.inline {
        format!("inline area `{}`", area.name.wire)
    } else {
        format!("area `{}`", area.name.wire)
    }
}

fn check_ring(ring: &Ring, diags: &mut Diagnostics) {
    for area in &ring.areas {
        check_area(area, diags);
    }
    check_type_names(ring, diags);
    let mut ids: HashMap<u8, &RingNode> = HashMap::new();
    let mut names: HashMap<&str, &RingNode> = HashMap::new();
    for (n, node) in ring.nodes.iter().enumerate() {
        let Some(span) = node.span.clone() else {
            continue;
        };
        if n == MAX_NODES {
            diags.report(
                Code::TooManyNodes,
                span.clone(),
                format!(
                    "ring `{}` has {} nodes, more than {MAX_NODES}",
                    ring.name.wire,
                    ring.nodes.len()
                ),
                format!("node {}", n + 1),
            );
        }
        let id_span = node.id_span.clone().unwrap_or(span);
        if node.id > MAX_NODE_ID {
            diags.report(
                Code::NodeIdOutOfRange,
                id_span.clone(),
                format!("node `{}` has id {}, out of range", node.name.wire, node.id),
                format!("ids are 0..={MAX_NODE_ID}"),
            );
        } else if let Some(first) = ids.get(&node.id) {
            report_dup(
                diags,
                Code::DuplicateNodeId,
                Some(id_span),
                &first.id_span,
                format!(
                    "node id {} is used by `{}` and `{}`",
                    node.id, first.name.wire, node.name.wire
                ),
            );
        } else {
            ids.insert(node.id, node);
        }
        if let Some(first) = names.get(node.name.wire.as_str()) {
            report_dup(
                diags,
                Code::DuplicateNodeName,
                node.span.clone(),
                &first.span,
                format!(
                    "ring `{}` has node `{}` twice",
                    ring.name.wire, node.name.wire
                ),
            );
        } else {
            names.insert(&node.name.wire, node);
        }
        check_node(node, diags);
    }
}

fn check_area(area: &AreaLayout, diags: &mut Diagnostics) {
    let what = area_what(area);
    let mut wire: HashMap<&str, &Option<Span>> = HashMap::new();
    let mut rust: HashMap<&str, (&str, &Option<Span>)> = HashMap::new();
    for f in &area.fields {
        if let Some(first) = wire.insert(&f.name.wire, &f.span) {
            report_dup(
                diags,
                Code::DuplicateAreaField,
                f.span.clone(),
                first,
                format!("{what} has field `{}` twice", f.name.wire),
            );
        } else if let Some((other, first)) = rust.insert(&f.name.rust, (&f.name.wire, &f.span)) {
            report_dup(
                diags,
                Code::NameCollision,
                f.span.clone(),
                first,
                format!(
                    "{what}: fields `{}` and `{other}` both become `{}`",
                    f.name.wire, f.name.rust
                ),
            );
        }
    }
    if let Some(f) = area
        .fields
        .iter()
        .find(|f| f.offset + f.ty.size() > AREA_LEN)
    {
        if let Some(span) = f.span.clone() {
            diags.report(
                Code::AreaTooLong,
                span,
                format!(
                    "field `{}` of {what} takes bytes {}..{}, past the {AREA_LEN}-byte area",
                    f.name.wire,
                    f.offset,
                    f.offset + f.ty.size()
                ),
                format!("ends past byte {AREA_LEN}"),
            );
        }
    }
    for (j, b) in area.fields.iter().enumerate() {
        let b_range = b.offset..b.offset + b.ty.size();
        let overlapped = area.fields[..j].iter().find(|a| {
            let a_range = a.offset..a.offset + a.ty.size();
            a_range.start < b_range.end && b_range.start < a_range.end
        });
        let (Some(a), Some(span)) = (overlapped, b.span.clone()) else {
            continue;
        };
        let d = diags.report(
            Code::OverlappingFields,
            span,
            format!(
                "fields `{}` (bytes {}..{}) and `{}` (bytes {}..{}) of {what} overlap",
                a.name.wire,
                a.offset,
                a.offset + a.ty.size(),
                b.name.wire,
                b_range.start,
                b_range.end
            ),
            "overlaps an earlier field",
        );
        if let Some(first) = &a.span {
            d.notes.push((first.clone(), "the earlier field".into()));
        }
    }
}

/// Area structs and node types share the ring's module.
fn check_type_names(ring: &Ring, diags: &mut Diagnostics) {
    let items = ring
        .areas
        .iter()
        .map(|a| (&a.name, area_what(a), &a.span))
        .chain(
            ring.nodes
                .iter()
                .map(|n| (&n.name, format!("node `{}`", n.name.wire), &n.span)),
        );
    let mut seen: HashMap<&str, (String, &Option<Span>)> = HashMap::new();
    for (name, what, span) in items {
        match seen.get(name.rust.as_str()) {
            // The same node twice: reported as a duplicate node name.
            Some((other, _)) if *other == what => {}
            Some((other, first)) => {
                let Some(span) = span.clone() else { continue };
                let d = diags.report(
                    Code::NameCollision,
                    span,
                    format!("{what} and {other} both become `{}`", name.rust),
                    "defined here",
                );
                if let Some(first) = first {
                    d.notes.push((first.clone(), "the other one".into()));
                }
            }
            None => {
                seen.insert(&name.rust, (what, span));
            }
        }
    }
}

/// The items a register adds to its node's type: its index constant and an accessor and a
/// setter per area it has.
fn register_items(wire: &str, has_in: bool, has_out: bool) -> Vec<String> {
    let mut items = vec![ident::const_name(wire)];
    for (area, used) in [("in", has_in), ("out", has_out)] {
        if used {
            let (get, set) = ident::register_fns(wire, area);
            items.extend([get, set]);
        }
    }
    items
}

fn check_node(node: &RingNode, diags: &mut Diagnostics) {
    let what = format!("node `{}`", node.name.wire);
    if let Some(extra) = node.registers.get(MAX_REGISTERS) {
        if let Some(span) = extra.span.clone() {
            diags.report(
                Code::TooManyRegisters,
                span,
                format!(
                    "{what} has {} registers, more than {MAX_REGISTERS}",
                    node.registers.len()
                ),
                format!("register {}", MAX_REGISTERS + 1),
            );
        }
    }
    let mut indices: HashMap<u8, &Option<Span>> = HashMap::new();
    let mut names: HashMap<&str, &Option<Span>> = HashMap::new();
    let mut items: HashMap<String, (&str, &Option<Span>)> = NODE_CONSTS
        .iter()
        .map(|c| (c.to_string(), ("", &None)))
        .collect();
    for reg in &node.registers {
        let index_span = reg.index_span.clone().or(reg.span.clone());
        if reg.index > MAX_REGISTER_INDEX {
            if let Some(span) = index_span {
                diags.report(
                    Code::RegisterIndexOutOfRange,
                    span,
                    format!(
                        "register `{}` of {what} has index {}, out of range",
                        reg.name.wire, reg.index
                    ),
                    format!("indices are 0..={MAX_REGISTER_INDEX}"),
                );
            }
        } else if let Some(first) = indices.get(&reg.index) {
            report_dup(
                diags,
                Code::DuplicateRegisterIndex,
                index_span,
                first,
                format!("{what} has register index {} twice", reg.index),
            );
        } else {
            indices.insert(reg.index, &reg.index_span);
        }
        if let Some(first) = names.insert(&reg.name.wire, &reg.span) {
            report_dup(
                diags,
                Code::DuplicateRegisterName,
                reg.span.clone(),
                first,
                format!("{what} has register `{}` twice", reg.name.wire),
            );
            continue;
        }
        for item in register_items(
            &reg.name.wire,
            reg.in_area.is_some(),
            reg.out_area.is_some(),
        ) {
            let Some((other, first)) = items.get(&item) else {
                items.insert(item, (&reg.name.wire, &reg.span));
                continue;
            };
            let Some(span) = reg.span.clone() else {
                continue;
            };
            let message = if other.is_empty() {
                format!(
                    "register `{}` of {what} makes `{item}`, a constant of every node's `NodeId` implementation",
                    reg.name.wire
                )
            } else {
                format!(
                    "registers `{}` and `{other}` of {what} both make `{item}`",
                    reg.name.wire
                )
            };
            let d = diags.report(Code::NameCollision, span, message, "defined here");
            if let Some(first) = first {
                d.notes.push((first.clone(), "the other one".into()));
            }
        }
    }
}
