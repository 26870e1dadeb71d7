//! MAVLink messages (and NDLCom payloads, which MAVLink-style XML describes) and enums.

use std::collections::{BTreeMap, HashSet};

use super::{pair, type_name, Category, Findings, Kind, Pair, Subject};
use crate::ir::{Enum, Field, Ir, Message};

pub(super) fn diff(old: &Ir, new: &Ir, out: &mut Findings) {
    messages(old, new, out);
    enums(old, new, out);
}

/// Every message of a run by wire name; a name defined by two files counts once (the first).
fn by_name(ir: &Ir) -> BTreeMap<&str, &Message> {
    let mut map = BTreeMap::new();
    for m in ir.modules.iter().flat_map(|m| &m.messages) {
        map.entry(m.name.wire.as_str()).or_insert(m);
    }
    map
}

fn messages(old: &Ir, new: &Ir, out: &mut Findings) {
    let (olds, news) = (by_name(old), by_name(new));
    let mut paired = Vec::new();
    let mut gone = Vec::new();
    for (name, &o) in &olds {
        match news.get(name) {
            Some(&n) => paired.push((o, n)),
            None => gone.push(o),
        }
    }
    // A message whose name is gone but whose id is now another new name's: renamed.
    let mut renamed_to = HashSet::new();
    for o in gone {
        let renamed = news
            .values()
            .find(|n| n.id == o.id && !olds.contains_key(n.name.wire.as_str()));
        match renamed {
            Some(&n) => {
                renamed_to.insert(n.name.wire.as_str());
                paired.push((o, n));
            }
            None => {
                let subject = Subject::new(Kind::Message, &o.name.wire, o.span.as_ref(), None);
                out.add(
                    &subject,
                    Category::Wire,
                    "message-removed",
                    o.id,
                    None::<u32>,
                    format!(
                        "message {} (id {}) is gone: the new side drops it as unknown",
                        o.name.wire, o.id
                    ),
                );
            }
        }
    }
    for (name, n) in &news {
        if !olds.contains_key(name) && !renamed_to.contains(name) {
            let subject = Subject::new(Kind::Message, *name, None, n.span.as_ref());
            out.add(
                &subject,
                Category::Safe,
                "message-added",
                None::<u32>,
                n.id,
                format!("new message, id {}", n.id),
            );
        }
    }
    for (o, n) in paired {
        message(o, n, out);
    }
}

fn message(o: &Message, n: &Message, out: &mut Findings) {
    let subject = Subject::new(
        Kind::Message,
        &n.name.wire,
        o.span.as_ref(),
        n.span.as_ref(),
    );
    if o.id != n.id {
        let subject = Subject::new(
            Kind::Message,
            &n.name.wire,
            o.id_span.as_ref(),
            n.id_span.as_ref(),
        );
        out.add(
            &subject,
            Category::Wire,
            "message-id",
            o.id,
            n.id,
            format!("message id changed from {} to {}", o.id, n.id),
        );
    }
    if o.crc_extra != n.crc_extra || o.name.wire != n.name.wire {
        let causes = crc_causes(o, n);
        let reason = format!(
            "CRC_EXTRA changed from {} to {}: {}",
            o.crc_extra,
            n.crc_extra,
            if causes.is_empty() {
                "the base fields' layout changed".to_owned()
            } else {
                causes.join("; ")
            }
        );
        let f = out.add(
            &subject,
            Category::Wire,
            "crc-extra",
            o.crc_extra,
            n.crc_extra,
            reason,
        );
        f.crc_extra = Some((o.crc_extra, n.crc_extra));
    }
    if o.name.wire == n.name.wire {
        out.rust_name(&subject, &o.name.rust, &n.name.rust);
    }
    out.description(&subject, &o.description, &n.description);
    out.deprecation(&subject, &o.deprecated, &n.deprecated);
    if o.wip != n.wip {
        out.add(
            &subject,
            Category::Safe,
            "wip",
            o.wip,
            n.wip,
            if n.wip {
                "now work in progress"
            } else {
                "no longer work in progress"
            },
        );
    }
    extensions(o, n, out);
    for nf in &n.fields {
        let Some(of) = o.fields.iter().find(|f| f.name.wire == nf.name.wire) else {
            continue;
        };
        field(n, of, nf, out);
    }
}

/// Why the CRC_EXTRA of a message changed: its name and its base fields' names, types, array
/// lengths and wire order are what the checksum seed hashes.
fn crc_causes(o: &Message, n: &Message) -> Vec<String> {
    let mut causes = Vec::new();
    if o.name.wire != n.name.wire {
        causes.push(format!(
            "message renamed from {} to {}",
            o.name.wire, n.name.wire
        ));
    }
    let base = |m: &'_ Message| {
        m.fields
            .iter()
            .filter(|f| !f.extension)
            .cloned()
            .collect::<Vec<Field>>()
    };
    let (ob, nb) = (base(o), base(n));
    let has = |list: &[Field], name: &str| list.iter().any(|f| f.name.wire == name);
    // A name gone from one position and a new one in its place, of the same type: a rename.
    let mut renamed = HashSet::new();
    for (i, of) in ob.iter().enumerate() {
        if has(&nb, &of.name.wire) {
            continue;
        }
        match nb.get(i) {
            Some(nf) if !has(&ob, &nf.name.wire) && nf.ty == of.ty => {
                renamed.insert(nf.name.wire.clone());
                causes.push(format!(
                    "field {} renamed to {}",
                    of.name.wire, nf.name.wire
                ));
            }
            _ => causes.push(format!("base field {} removed", of.name.wire)),
        }
    }
    for nf in &nb {
        if !has(&ob, &nf.name.wire) && !renamed.contains(&nf.name.wire) {
            causes.push(format!("base field {} added", nf.name.wire));
        }
    }
    for nf in &nb {
        let Some(of) = ob.iter().find(|f| f.name.wire == nf.name.wire) else {
            continue;
        };
        if of.ty.primitive != nf.ty.primitive || of.ty.mavlink_version != nf.ty.mavlink_version {
            causes.push(format!(
                "field {} type changed from {} to {}",
                nf.name.wire,
                type_name(of),
                type_name(nf)
            ));
        } else if of.ty.array != nf.ty.array {
            causes.push(format!(
                "field {} array length changed from {} to {}",
                nf.name.wire,
                of.ty.array.unwrap_or(1),
                nf.ty.array.unwrap_or(1)
            ));
        }
    }
    // The fields both sides have, in wire order: a different sequence is a reorder.
    let common = |m: &Message, other: &[Field]| -> Vec<String> {
        m.wire_order
            .iter()
            .map(|&i| &m.fields[i])
            .filter(|f| !f.extension && has(other, &f.name.wire))
            .map(|f| f.name.wire.clone())
            .collect()
    };
    let (oc, nc) = (common(o, &nb), common(n, &ob));
    if oc != nc {
        let moved: Vec<&str> = oc
            .iter()
            .zip(&nc)
            .filter(|(a, b)| a != b)
            .map(|(a, _)| a.as_str())
            .collect();
        causes.push(format!(
            "fields reordered on the wire ({})",
            moved.join(", ")
        ));
    }
    causes
}

/// Extension fields are compared by position: the new side must append only.
fn extensions(o: &Message, n: &Message, out: &mut Findings) {
    fn ext(m: &Message) -> Vec<&Field> {
        m.fields.iter().filter(|f| f.extension).collect()
    }
    let (oe, ne) = (ext(o), ext(n));
    for (i, of) in oe.iter().enumerate() {
        let name = format!("{}.{}", n.name.wire, of.name.wire);
        match ne.get(i) {
            None => {
                let subject = Subject::new(Kind::Field, name, of.span.as_ref(), n.span.as_ref());
                out.add(&subject, Category::Wire, "extension-removed", type_name(of), None::<String>, format!("extension field {} removed: the new side ignores what old senders put there", of.name.wire));
            }
            Some(nf) if nf.name.wire != of.name.wire || nf.ty != of.ty => {
                let subject = Subject::new(Kind::Field, name, of.span.as_ref(), nf.span.as_ref());
                out.add(
                    &subject,
                    Category::Wire,
                    "extension-changed",
                    format!("{} {}", type_name(of), of.name.wire),
                    format!("{} {}", type_name(nf), nf.name.wire),
                    format!(
                        "extension field {} at offset {} is now {} {}",
                        of.name.wire,
                        of.offset,
                        type_name(nf),
                        nf.name.wire
                    ),
                );
            }
            Some(_) => {}
        }
    }
    for nf in ne.iter().skip(oe.len()) {
        let subject = Subject::new(
            Kind::Field,
            format!("{}.{}", n.name.wire, nf.name.wire),
            None,
            nf.span.as_ref(),
        );
        out.add(
            &subject,
            Category::Safe,
            "extension-added",
            None::<String>,
            type_name(nf),
            format!("extension field appended at offset {}", nf.offset),
        );
    }
}

/// What a field means: its enum, units, multiplier and limits, its Rust name and description.
fn field(m: &Message, of: &Field, nf: &Field, out: &mut Findings) {
    let subject = Subject::new(
        Kind::Field,
        format!("{}.{}", m.name.wire, nf.name.wire),
        of.span.as_ref(),
        nf.span.as_ref(),
    );
    if of.enum_name != nf.enum_name {
        out.add(
            &subject,
            Category::Semantic,
            "field-enum",
            of.enum_name.clone(),
            nf.enum_name.clone(),
            format!(
                "values now read through {} instead of {}",
                nf.enum_name.as_deref().unwrap_or("no enum"),
                of.enum_name.as_deref().unwrap_or("no enum")
            ),
        );
    }
    out.field_meaning(&subject, of, nf);
    out.rust_name(&subject, &of.name.rust, &nf.name.rust);
    out.description(&subject, &of.description, &nf.description);
}

fn enums(old: &Ir, new: &Ir, out: &mut Findings) {
    for p in pair(&old.enums, &new.enums, |e| &e.name.wire) {
        match p {
            Pair::Both(o, n) => enumeration(o, n, out),
            Pair::Gone(o) => {
                let subject = Subject::new(Kind::Enum, &o.name.wire, o.span.as_ref(), None);
                out.add(
                    &subject,
                    Category::Api,
                    "enum-removed",
                    o.entries.len(),
                    None::<usize>,
                    "enum removed: the generated type is gone",
                );
            }
            Pair::Added(n) => {
                let subject = Subject::new(Kind::Enum, &n.name.wire, None, n.span.as_ref());
                let what = if n.bitmask { "bitmask" } else { "enum" };
                out.add(
                    &subject,
                    Category::Safe,
                    "enum-added",
                    None::<usize>,
                    n.entries.len(),
                    format!("new {what} with {} entries", n.entries.len()),
                );
            }
        }
    }
}

fn enumeration(o: &Enum, n: &Enum, out: &mut Findings) {
    let subject = Subject::new(Kind::Enum, &n.name.wire, o.span.as_ref(), n.span.as_ref());
    if o.bitmask != n.bitmask {
        let kind = |b: bool| if b { "bitmask" } else { "enum" };
        out.add(
            &subject,
            Category::Semantic,
            "enum-kind",
            kind(o.bitmask),
            kind(n.bitmask),
            format!(
                "now a {} (was a {}): values are read differently",
                kind(n.bitmask),
                kind(o.bitmask)
            ),
        );
    }
    out.rust_name(&subject, &o.name.rust, &n.name.rust);
    out.description(&subject, &o.description, &n.description);
    out.deprecation(&subject, &o.deprecated, &n.deprecated);
    let value_of = |e: &Enum, name: &str| {
        e.entries
            .iter()
            .find(|x| x.name.wire == name)
            .map(|x| x.value)
    };
    let name_at = |e: &'_ Enum, value: u64| {
        e.entries
            .iter()
            .find(|x| x.value == value)
            .map(|x| x.name.wire.clone())
    };
    let bit = |v: u64| {
        if n.bitmask {
            format!("{v:#x}")
        } else {
            v.to_string()
        }
    };
    let mut renamed = HashSet::new();
    for oe in &o.entries {
        let name = format!("{}.{}", n.name.wire, oe.name.wire);
        let Some(ne) = n.entries.iter().find(|x| x.name.wire == oe.name.wire) else {
            // Gone by name: the same value under a name the old side lacks is a rename.
            match name_at(n, oe.value).filter(|other| value_of(o, other).is_none()) {
                Some(other) => {
                    renamed.insert(other.clone());
                    let ne = n
                        .entries
                        .iter()
                        .find(|x| x.name.wire == other)
                        .expect("found by value");
                    let subject =
                        Subject::new(Kind::Entry, name, oe.span.as_ref(), ne.span.as_ref());
                    out.add(
                        &subject,
                        Category::Api,
                        "entry-renamed",
                        oe.name.wire.as_str(),
                        other.as_str(),
                        format!("renamed to {other}, value {} unchanged", bit(oe.value)),
                    );
                }
                None => {
                    let subject = Subject::new(Kind::Entry, name, oe.span.as_ref(), None);
                    out.add(
                        &subject,
                        Category::Api,
                        "entry-removed",
                        oe.value,
                        None::<u64>,
                        format!(
                            "entry removed (value {}); the value now decodes as unknown",
                            bit(oe.value)
                        ),
                    );
                }
            }
            continue;
        };
        let subject = Subject::new(Kind::Entry, name, oe.span.as_ref(), ne.span.as_ref());
        if oe.value != ne.value {
            let (code, what) = if n.bitmask {
                ("bitmask-bit", "flag moved")
            } else {
                ("entry-value", "renumbered")
            };
            out.add(
                &subject,
                Category::Semantic,
                code,
                oe.value,
                ne.value,
                format!("{what} from {} to {}", bit(oe.value), bit(ne.value)),
            );
        }
        out.rust_name(&subject, &oe.name.rust, &ne.name.rust);
        out.description(&subject, &oe.description, &ne.description);
        out.deprecation(&subject, &oe.deprecated, &ne.deprecated);
    }
    for ne in &n.entries {
        if value_of(o, &ne.name.wire).is_some() || renamed.contains(&ne.name.wire) {
            continue;
        }
        let subject = Subject::new(
            Kind::Entry,
            format!("{}.{}", n.name.wire, ne.name.wire),
            None,
            ne.span.as_ref(),
        );
        match name_at(o, ne.value) {
            Some(before) => {
                out.add(
                    &subject,
                    Category::Semantic,
                    "entry-value-reused",
                    before.as_str(),
                    ne.name.wire.as_str(),
                    format!(
                        "value {} meant {before} and now means {}",
                        bit(ne.value),
                        ne.name.wire
                    ),
                );
            }
            None => {
                out.add(
                    &subject,
                    Category::Safe,
                    "entry-added",
                    None::<u64>,
                    ne.value,
                    format!("new entry, value {}", bit(ne.value)),
                );
            }
        }
    }
}
