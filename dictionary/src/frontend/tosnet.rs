//! The TosNet register-map frontend: a TOML file with a top-level `[ring]` table.
//!
//! ```toml
//! [ring]
//! description = "A master and one section"
//!
//! [areas.motor_target]
//! description = "Set points from the master"
//! fields = [{ name = "position", type = "float", unit = "rad" }]
//!
//! [[nodes]]
//! id = 1
//! name = "section1"
//! registers = [
//!   { index = 0, name = "motor1", in = "motor_target", out = { fields = [{ name = "current", type = "float" }] } },
//! ]
//! ```
//!
//! This module only reads what the file says. Area names are resolved and offsets computed in
//! [`crate::lower::tosnet`]; the protocol's limits are checked in [`crate::check`].

use std::sync::Arc;

use super::toml::{Item, Table};
use super::TypeSyntax;
use crate::diag::{Diagnostics, SourceFile, Span};
use crate::ident;
use crate::ir::{Field, Name};

const ROOT_KEYS: &[&str] = &["ring", "areas", "nodes"];
const RING_KEYS: &[&str] = &["description"];
const AREA_KEYS: &[&str] = &["description", "fields"];
const FIELD_KEYS: &[&str] = &["name", "type", "offset", "unit", "description"];
const NODE_KEYS: &[&str] = &["id", "name", "description", "registers"];
const REGISTER_KEYS: &[&str] = &["index", "name", "description", "in", "out"];

/// The largest value an id, index or offset may be written with; the checker applies the
/// protocol's smaller limits, so that their diagnostics name them.
const MAX_SMALL: u64 = u8::MAX as u64;

/// One register map as written.
#[derive(Debug)]
pub struct ParsedRing {
    /// The source.
    pub source: Arc<SourceFile>,
    /// `[ring] description`.
    pub description: String,
    /// The `[ring]` header.
    pub span: Span,
    /// `[areas.NAME]` tables in file order.
    pub areas: Vec<ParsedArea>,
    /// `[[nodes]]` in file order.
    pub nodes: Vec<ParsedNode>,
}

/// An area layout as written, named or inline.
#[derive(Debug)]
pub struct ParsedArea {
    /// The name under `[areas]`; empty for an inline area.
    pub name: String,
    /// Description text.
    pub description: String,
    /// The fields that could be read.
    pub fields: Vec<ParsedField>,
    /// The area's name, or its inline table.
    pub span: Span,
}

/// A field with the offset it was given, if any (the IR field's offset is not set yet).
#[derive(Debug)]
pub struct ParsedField {
    /// The field.
    pub field: Field,
    /// `offset`, if written.
    pub offset: Option<usize>,
}

/// A node as written.
#[derive(Debug)]
pub struct ParsedNode {
    /// `id`.
    pub id: u8,
    /// The `id` value.
    pub id_span: Span,
    /// `name`.
    pub name: String,
    /// Description text.
    pub description: String,
    /// The registers that could be read.
    pub registers: Vec<ParsedRegister>,
    /// The `[[nodes]]` header.
    pub span: Span,
}

/// A register as written.
#[derive(Debug)]
pub struct ParsedRegister {
    /// `index`.
    pub index: u8,
    /// The `index` value.
    pub index_span: Span,
    /// `name`.
    pub name: String,
    /// Description text.
    pub description: String,
    /// `in`.
    pub in_area: Option<AreaRef>,
    /// `out`.
    pub out_area: Option<AreaRef>,
    /// The register's table.
    pub span: Span,
}

/// The `in` or `out` of a register.
#[derive(Debug)]
pub enum AreaRef {
    /// The name of an area under `[areas]`.
    Named {
        /// The name.
        name: String,
        /// Its text.
        span: Span,
    },
    /// An inline `{ description, fields }` table.
    Inline(ParsedArea),
}

/// Reads a register map from a parsed document whose top level has a `ring` key.
pub fn read(source: &Arc<SourceFile>, root: &Table<'_, '_>, diags: &mut Diagnostics) -> ParsedRing {
    root.check_keys(ROOT_KEYS, diags);
    let ring_table = root
        .get("ring")
        .and_then(|item| item.as_table("`[ring]`", diags));
    let mut ring = ParsedRing {
        source: source.clone(),
        description: String::new(),
        span: ring_table
            .as_ref()
            .map_or_else(|| root.span.clone(), |t| t.span.clone()),
        areas: Vec::new(),
        nodes: Vec::new(),
    };
    if let Some(t) = &ring_table {
        t.check_keys(RING_KEYS, diags);
        ring.description = t
            .optional_str("description", diags)
            .unwrap_or("")
            .to_string();
    }
    if let Some(areas) = root
        .get("areas")
        .and_then(|item| item.as_table("`[areas]`", diags))
    {
        for item in areas.entries() {
            let ok = super::check_name(item.key, &item.key_span, diags);
            let what = format!("area `{}`", item.key);
            let Some(table) = item.as_table(what, diags) else {
                continue;
            };
            let mut area = read_area(&table, diags);
            area.name = item.key.to_string();
            area.span = item.key_span.clone();
            if ok {
                ring.areas.push(area);
            }
        }
    }
    if let Some(nodes) = root
        .required("nodes", diags)
        .and_then(|item| item.as_array(diags))
    {
        for (n, item) in nodes.iter().enumerate() {
            if let Some(table) = item.as_table(format!("node {}", n + 1), diags) {
                if let Some(node) = read_node(table, diags) {
                    ring.nodes.push(node);
                }
            }
        }
    }
    ring
}

/// The fields and description of an area table (named or inline); the caller names it.
fn read_area(table: &Table<'_, '_>, diags: &mut Diagnostics) -> ParsedArea {
    table.check_keys(AREA_KEYS, diags);
    let mut area = ParsedArea {
        name: String::new(),
        description: table
            .optional_str("description", diags)
            .unwrap_or("")
            .to_string(),
        fields: Vec::new(),
        span: table.span.clone(),
    };
    let fields = table
        .required("fields", diags)
        .and_then(|item| item.as_array(diags))
        .unwrap_or_default();
    for item in &fields {
        if let Some(field) = read_field(item, &table.what, diags) {
            area.fields.push(field);
        }
    }
    area
}

fn read_field(item: &Item<'_, '_>, area: &str, diags: &mut Diagnostics) -> Option<ParsedField> {
    let mut table = item.as_table(item.what.clone(), diags)?;
    let name = table.required("name", diags).and_then(|i| i.as_name(diags));
    if let Some(name) = name {
        table = table.described(format!("field `{name}` of {area}"));
    }
    table.check_keys(FIELD_KEYS, diags);
    let ty = table.required("type", diags).and_then(|i| {
        let text = i.as_str(diags)?;
        super::parse_type(text, &i.text_span(), TypeSyntax::Plain, diags)
    });
    let offset = table.get("offset").map(|i| i.as_uint(MAX_SMALL, diags));
    let unit = table.optional_str("unit", diags);
    let description = table.optional_str("description", diags).unwrap_or("");
    let (name, ty) = (name?, ty?);
    let offset = match offset {
        Some(written) => Some(written?),
        None => None,
    };
    Some(ParsedField {
        field: Field {
            name: Name {
                wire: name.to_string(),
                rust: ident::value_name(name),
            },
            ty,
            extension: false,
            offset: 0,
            enum_name: None,
            description: description.to_string(),
            attrs: unit
                .map(|u| ("units".to_string(), u.to_string()))
                .into_iter()
                .collect(),
            span: Some(table.span.clone()),
            enum_span: None,
        },
        offset: offset.map(|o| o as usize),
    })
}

/// A node; `None` (after reading everything in it) if its id or name is unusable.
fn read_node(mut table: Table<'_, '_>, diags: &mut Diagnostics) -> Option<ParsedNode> {
    let name = table.required("name", diags).and_then(|i| i.as_name(diags));
    if let Some(name) = name {
        table = table.described(format!("node `{name}`"));
    }
    table.check_keys(NODE_KEYS, diags);
    let id = table
        .required("id", diags)
        .and_then(|i| Some((i.as_uint(MAX_SMALL, diags)?, i.span)));
    let description = table.optional_str("description", diags).unwrap_or("");
    let mut registers = Vec::new();
    if let Some(items) = table.get("registers").and_then(|i| i.as_array(diags)) {
        for item in &items {
            let Some(reg_table) = item.as_table(item.what.clone(), diags) else {
                continue;
            };
            if let Some(r) = read_register(reg_table, &table.what, diags) {
                registers.push(r);
            }
        }
    }
    let (name, (id, id_span)) = (name?, id?);
    Some(ParsedNode {
        id: id as u8,
        id_span,
        name: name.to_string(),
        description: description.to_string(),
        registers,
        span: table.span.clone(),
    })
}

fn read_register(
    mut table: Table<'_, '_>,
    node: &str,
    diags: &mut Diagnostics,
) -> Option<ParsedRegister> {
    let name = table.required("name", diags).and_then(|i| i.as_name(diags));
    if let Some(name) = name {
        table = table.described(format!("register `{name}` of {node}"));
    }
    table.check_keys(REGISTER_KEYS, diags);
    let index = table
        .required("index", diags)
        .and_then(|i| Some((i.as_uint(MAX_SMALL, diags)?, i.span)));
    let description = table.optional_str("description", diags).unwrap_or("");
    let in_area = table
        .get("in")
        .and_then(|i| read_area_ref(&i, &table.what, "in", diags));
    let out_area = table
        .get("out")
        .and_then(|i| read_area_ref(&i, &table.what, "out", diags));
    let (name, (index, index_span)) = (name?, index?);
    Some(ParsedRegister {
        index: index as u8,
        index_span,
        name: name.to_string(),
        description: description.to_string(),
        in_area,
        out_area,
        span: table.span.clone(),
    })
}

/// `in = "motor_target"` or `in = { fields = [...] }`.
fn read_area_ref(
    item: &Item<'_, '_>,
    register: &str,
    direction: &str,
    diags: &mut Diagnostics,
) -> Option<AreaRef> {
    if let ::toml::de::DeValue::String(name) = item.value {
        return Some(AreaRef::Named {
            name: name.to_string(),
            span: item.text_span(),
        });
    }
    if !matches!(item.value, ::toml::de::DeValue::Table(_)) {
        item.wrong_type("an area's name or an inline area table", diags);
        return None;
    }
    let table = item.as_table(format!("the {direction} area of {register}"), diags)?;
    Some(AreaRef::Inline(read_area(&table, diags)))
}
