//! Lowering TosNet register maps: area names resolved to indices, inline areas named after their
//! register (`section1_motor1_out`), field offsets and area lengths computed.
//!
//! An area name that resolves to nothing is reported here (E0412), as only this stage resolves
//! names; every other problem is left to [`crate::check`].

use std::collections::HashMap;

use crate::diag::{Code, Diagnostics, Span};
use crate::frontend::tosnet::{AreaRef, ParsedArea, ParsedRing};
use crate::ident;
use crate::ir::{AreaLayout, Name, Register, Ring, RingNode};

/// Builds one [`Ring`] per parsed register map.
pub fn lower(parsed: Vec<ParsedRing>, diags: &mut Diagnostics) -> Vec<Ring> {
    parsed.into_iter().map(|p| lower_ring(p, diags)).collect()
}

fn lower_ring(parsed: ParsedRing, diags: &mut Diagnostics) -> Ring {
    let mut ring = Ring {
        name: ident::file_module_name(&parsed.source.path),
        path: parsed.source.path.display().to_string(),
        description: parsed.description,
        areas: Vec::new(),
        nodes: Vec::new(),
        span: Some(parsed.span),
    };
    let mut by_name: HashMap<String, usize> = HashMap::new();
    for area in parsed.areas {
        let name = area.name.clone();
        by_name.entry(name.clone()).or_insert(ring.areas.len());
        ring.areas.push(lower_area(area, name, false));
    }
    for node in parsed.nodes {
        let mut registers = Vec::new();
        for reg in node.registers {
            let mut resolve = |area: Option<AreaRef>, direction: &str| match area? {
                AreaRef::Named { name, span } => {
                    let found = by_name.get(&name).copied();
                    if found.is_none() {
                        unknown_area(&name, span, &node.name, &reg.name, diags);
                    }
                    found
                }
                AreaRef::Inline(area) => {
                    let name = format!("{}_{}_{direction}", node.name, reg.name);
                    ring.areas.push(lower_area(area, name, true));
                    Some(ring.areas.len() - 1)
                }
            };
            let in_area = resolve(reg.in_area, "in");
            let out_area = resolve(reg.out_area, "out");
            registers.push(Register {
                index: reg.index,
                name: Name {
                    rust: ident::value_name(&reg.name),
                    wire: reg.name,
                },
                description: reg.description,
                in_area,
                out_area,
                span: Some(reg.span),
                index_span: Some(reg.index_span),
            });
        }
        ring.nodes.push(RingNode {
            id: node.id,
            name: Name {
                rust: ident::type_name(&node.name),
                wire: node.name,
            },
            description: node.description,
            registers,
            span: Some(node.span),
            id_span: Some(node.id_span),
        });
    }
    ring
}

fn unknown_area(name: &str, span: Span, node: &str, register: &str, diags: &mut Diagnostics) {
    diags.report(
        Code::UnknownArea,
        span,
        format!("register `{register}` of node `{node}` uses area `{name}`, which is not defined"),
        "no such area",
    );
}

/// Offsets (a field without `offset` starts right after the previous one) and the length.
fn lower_area(parsed: ParsedArea, wire: String, inline: bool) -> AreaLayout {
    let mut next = 0;
    let mut len = 0;
    let fields = parsed
        .fields
        .into_iter()
        .map(|p| {
            let mut field = p.field;
            field.offset = p.offset.unwrap_or(next);
            next = field.offset + field.ty.size();
            len = len.max(next);
            field
        })
        .collect();
    AreaLayout {
        name: Name {
            rust: ident::type_name(&wire),
            wire,
        },
        inline,
        description: parsed.description,
        fields,
        len,
        span: Some(parsed.span),
    }
}
