//! Checks on the MAVLink part of the IR: everything mavgen rejects, and the name collisions that
//! only a Rust backend can hit.

use std::collections::{HashMap, HashSet};

use super::{report_dup, MAX_FIELDS, MAX_PAYLOAD};
use crate::diag::{Code, Diagnostics, Span};
use crate::ir::{Ir, Message};

/// Reports every problem in the MAVLink part of `ir`: messages, names, includes and enums.
pub fn check(ir: &Ir, diags: &mut Diagnostics) {
    let enum_names: HashSet<&str> = ir.enums.iter().map(|e| e.name.wire.as_str()).collect();
    for module in &ir.modules {
        for msg in &module.messages {
            check_message(msg, &enum_names, diags);
        }
        check_item_names(ir, module, diags);
    }
    check_closures(ir, diags);
    for e in &ir.enums {
        let mut names: HashMap<&str, &Option<Span>> = HashMap::new();
        let mut values: HashMap<u64, (&str, &Option<Span>)> = HashMap::new();
        let mut rust: HashMap<&str, (&str, &Option<Span>)> = HashMap::new();
        for entry in &e.entries {
            let span = entry.span.clone().or(e.span.clone());
            if let Some(first) = names.insert(&entry.name.wire, &entry.span) {
                report_dup(
                    diags,
                    Code::DuplicateEntryName,
                    span,
                    first,
                    format!(
                        "enum `{}` has entry `{}` twice",
                        e.name.wire, entry.name.wire
                    ),
                );
                continue;
            }
            if let Some((other, first)) =
                values.insert(entry.value, (&entry.name.wire, &entry.span))
            {
                report_dup(
                    diags,
                    Code::DuplicateEntryValue,
                    span,
                    first,
                    format!(
                        "enum `{}`: `{}` has value {}, like `{other}`",
                        e.name.wire, entry.name.wire, entry.value
                    ),
                );
                continue;
            }
            if let Some((other, first)) =
                rust.insert(&entry.name.rust, (&entry.name.wire, &entry.span))
            {
                report_dup(
                    diags,
                    Code::NameCollision,
                    span,
                    first,
                    format!(
                        "enum `{}`: `{}` and `{other}` both become `{}`",
                        e.name.wire, entry.name.wire, entry.name.rust
                    ),
                );
            }
        }
    }
}

fn check_message(msg: &Message, enums: &HashSet<&str>, diags: &mut Diagnostics) {
    let Some(span) = msg.span.clone() else { return };
    if msg.fields.is_empty() {
        diags.report(
            Code::EmptyMessage,
            span.clone(),
            format!("message `{}` has no fields", msg.name.wire),
            "empty message",
        );
    }
    if msg.fields.len() > MAX_FIELDS {
        diags.report(
            Code::TooManyFields,
            span.clone(),
            format!(
                "message `{}` has {} fields, more than {MAX_FIELDS}",
                msg.name.wire,
                msg.fields.len()
            ),
            "too many fields",
        );
    }
    if msg.max_len > MAX_PAYLOAD {
        diags.report(
            Code::PayloadTooLong,
            span.clone(),
            format!(
                "message `{}` has a {}-byte payload, more than {MAX_PAYLOAD}",
                msg.name.wire, msg.max_len
            ),
            "payload too long",
        );
    }
    let mut wire: HashMap<&str, &Option<Span>> = HashMap::new();
    let mut rust: HashMap<&str, (&str, &Option<Span>)> = HashMap::new();
    for f in &msg.fields {
        if let Some(first) = wire.insert(&f.name.wire, &f.span) {
            report_dup(
                diags,
                Code::DuplicateField,
                f.span.clone(),
                first,
                format!(
                    "message `{}` has field `{}` twice",
                    msg.name.wire, f.name.wire
                ),
            );
        } else if let Some((other, first)) = rust.insert(&f.name.rust, (&f.name.wire, &f.span)) {
            report_dup(
                diags,
                Code::NameCollision,
                f.span.clone(),
                first,
                format!(
                    "message `{}`: fields `{}` and `{other}` both become `{}`",
                    msg.name.wire, f.name.wire, f.name.rust
                ),
            );
        }
        if let (Some(name), Some(at)) = (&f.enum_name, &f.enum_span) {
            if !enums.contains(name.as_str()) {
                diags.report(
                    Code::MissingEnum,
                    at.clone(),
                    format!(
                        "field `{}` names enum `{name}`, which does not exist",
                        f.name.wire
                    ),
                    "no such enum",
                );
            }
        }
    }
}

/// Type names within one module: messages, enums and the generated `Message` enum.
fn check_item_names(ir: &Ir, module: &crate::ir::Module, diags: &mut Diagnostics) {
    let mut seen: HashMap<String, (String, Option<Span>)> = HashMap::new();
    seen.insert(
        "Message".into(),
        ("the dialect's message enum".into(), None),
    );
    let items = module.messages.iter().map(|m| (&m.name, &m.span)).chain(
        module
            .enums
            .iter()
            .map(|&i| (&ir.enums[i].name, &ir.enums[i].span)),
    );
    for (name, span) in items {
        if let Some((other, first)) = seen.get(&name.rust) {
            if let Some(span) = span {
                let d = diags.report(
                    Code::NameCollision,
                    span.clone(),
                    format!("`{}` and {other} both become `{}`", name.wire, name.rust),
                    "defined here",
                );
                if let Some(first) = first {
                    d.notes.push((first.clone(), "the other one".into()));
                }
            }
        } else {
            seen.insert(
                name.rust.clone(),
                (format!("`{}`", name.wire), span.clone()),
            );
        }
    }
}

/// Message ids and names must be unique in every dialect with its includes. Each clash is
/// reported once, at the later definition. No two files of a run may become the same module.
fn check_closures(ir: &Ir, diags: &mut Diagnostics) {
    let mut reported: HashSet<(u32, String)> = HashSet::new();
    for module in &ir.modules {
        let mut ids: HashMap<u32, &Message> = HashMap::new();
        let mut names: HashMap<&str, &Message> = HashMap::new();
        for &m in &module.closure {
            for msg in &ir.modules[m].messages {
                if let Some(first) = ids.get(&msg.id) {
                    if reported.insert((msg.id, format!("id {}", msg.name.wire))) {
                        report_dup(
                            diags,
                            Code::DuplicateMessageId,
                            msg.id_span.clone().or(msg.span.clone()),
                            &first.id_span,
                            format!(
                                "message id {} is used by `{}` and `{}`",
                                msg.id, first.name.wire, msg.name.wire
                            ),
                        );
                    }
                } else {
                    ids.insert(msg.id, msg);
                }
                if let Some(first) = names.get(msg.name.wire.as_str()) {
                    if reported.insert((msg.id, format!("name {}", msg.name.wire))) {
                        report_dup(
                            diags,
                            Code::DuplicateMessageName,
                            msg.span.clone(),
                            &first.span,
                            format!("message `{}` is defined twice", msg.name.wire),
                        );
                    }
                } else {
                    names.insert(&msg.name.wire, msg);
                }
            }
        }
    }
    let mut modules: HashMap<&str, &str> = HashMap::new();
    let files = ir
        .modules
        .iter()
        .map(|m| (&m.name, &m.path, &m.span))
        .chain(ir.rings.iter().map(|r| (&r.name, &r.path, &r.span)));
    for (name, path, span) in files {
        if let Some(other) = modules.insert(&name.rust, path) {
            if let Some(span) = span {
                diags.report(
                    Code::NameCollision,
                    span.clone(),
                    format!(
                        "files `{path}` and `{other}` both become module `{}`",
                        name.rust
                    ),
                    "this file",
                );
            }
        }
    }
}
