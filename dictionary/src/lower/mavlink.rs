//! Lowering MAVLink dialects: modules in dependency order, with their include closures; enums
//! merged by name across files (as mavgen does), entries sorted by value; per message the wire
//! order (base fields stably sorted by element size, largest first, then extensions in XML
//! order), offsets, `MIN_LEN`/`MAX_LEN`, CRC_EXTRA and target offsets; per enum the integer type
//! that holds every value and every field that uses it.

use std::collections::HashMap;

use crate::frontend::mavlink::Loaded;
use crate::ident;
use crate::ir::{Enum, Ir, Message, Module, Primitive};

/// Builds the IR of the MAVLink dialects (rings are added by [`super::tosnet::lower`]). Problems are
/// left to [`crate::check`]; lowering never fails.
pub fn lower(loaded: Loaded) -> Ir {
    let mut ir = Ir::default();
    let mut enum_index: HashMap<String, usize> = HashMap::new();
    for (m, file) in loaded.files.into_iter().enumerate() {
        let mut module = Module {
            name: ident::file_module_name(&file.source.path),
            path: file.source.path.display().to_string(),
            version: file.version,
            dialect: file.dialect,
            includes: file.includes,
            closure: Vec::new(),
            messages: file.messages,
            enums: Vec::new(),
            description: String::new(),
            span: Some(crate::diag::Span::new(&file.source, 0, 0)),
        };
        for mut e in file.enums {
            match enum_index.get(&e.name.wire) {
                Some(&i) => merge_enum(&mut ir.enums[i], e),
                None => {
                    e.module = m;
                    enum_index.insert(e.name.wire.clone(), ir.enums.len());
                    module.enums.push(ir.enums.len());
                    ir.enums.push(e);
                }
            }
        }
        for msg in &mut module.messages {
            layout(msg);
        }
        ir.modules.push(module);
    }
    for i in 0..ir.modules.len() {
        let mut closure = Vec::new();
        collect_closure(&ir.modules, i, &mut closure);
        ir.modules[i].closure = closure;
    }
    for e in &mut ir.enums {
        e.entries.sort_by_key(|entry| entry.value);
    }
    assign_enum_reprs(&mut ir, &enum_index);
    ir
}

/// Dependency order: includes (depth first) before the module itself, each once.
fn collect_closure(modules: &[Module], i: usize, out: &mut Vec<usize>) {
    if out.contains(&i) {
        return;
    }
    for &inc in &modules[i].includes {
        collect_closure(modules, inc, out);
    }
    out.push(i);
}

/// Merges a later definition into the first, fixing implicit values that would clash as mavgen
/// does.
fn merge_enum(into: &mut Enum, other: Enum) {
    let other_low = other.entries.iter().map(|e| e.value).min().unwrap_or(0);
    let mut other_high = other.entries.iter().map(|e| e.value).max().unwrap_or(0);
    let into_low = into.entries.iter().map(|e| e.value).min().unwrap_or(0);
    let into_high = into.entries.iter().map(|e| e.value).max().unwrap_or(0);
    if into_low <= other_high && into_high >= other_low {
        for entry in &mut into.entries {
            if entry.implicit && entry.value <= other_high {
                entry.value = other_high + 1;
                other_high = entry.value;
            }
        }
    }
    if into.description.is_empty() {
        into.description = other.description;
    }
    into.entries.extend(other.entries);
}

/// Wire order, offsets, lengths, CRC_EXTRA and target offsets of one message.
pub fn layout(msg: &mut Message) {
    let mut base: Vec<usize> = (0..msg.fields.len())
        .filter(|&i| !msg.fields[i].extension)
        .collect();
    // A stable sort: equal sizes keep their XML order.
    base.sort_by_key(|&i| std::cmp::Reverse(msg.fields[i].ty.primitive.size()));
    let extensions = (0..msg.fields.len()).filter(|&i| msg.fields[i].extension);
    msg.wire_order = base.iter().copied().chain(extensions).collect();

    let mut offset = 0;
    msg.min_len = 0;
    for &i in &msg.wire_order {
        let f = &mut msg.fields[i];
        f.offset = offset;
        offset += f.ty.size();
        if !f.extension {
            msg.min_len = offset;
        }
        let is_target_system = f.name.wire == "target_system"
            || (msg.name.wire == "MANUAL_CONTROL" && f.name.wire == "target");
        if is_target_system {
            msg.target_system = Some(f.offset);
        } else if f.name.wire == "target_component" {
            msg.target_component = Some(f.offset);
        }
    }
    msg.max_len = offset;
    msg.crc_extra = crc_extra(msg);
}

/// CRC_EXTRA exactly as mavgen computes it: the name, then each base field's C type, name and
/// array length in wire order, folded to one byte.
pub fn crc_extra(msg: &Message) -> u8 {
    let mut crc = ferrolink_crc().digest();
    crc.update(msg.name.wire.as_bytes());
    crc.update(b" ");
    for &i in &msg.wire_order {
        let f = &msg.fields[i];
        if f.extension {
            break;
        }
        crc.update(f.ty.primitive.c_name().as_bytes());
        crc.update(b" ");
        crc.update(f.name.wire.as_bytes());
        crc.update(b" ");
        if let Some(n) = f.ty.array {
            crc.update(&[n]);
        }
    }
    let crc = crc.finalize();
    ((crc & 0xFF) ^ (crc >> 8)) as u8
}

fn ferrolink_crc() -> &'static crc::Crc<u16> {
    static CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_MCRF4XX);
    &CRC
}

/// The narrowest unsigned type holding every entry value and as wide as every field that uses
/// the enum.
fn assign_enum_reprs(ir: &mut Ir, enum_index: &HashMap<String, usize>) {
    let mut width = vec![1usize; ir.enums.len()];
    for (i, e) in ir.enums.iter().enumerate() {
        let max = e.entries.iter().map(|x| x.value).max().unwrap_or(0);
        width[i] = match max {
            0..=0xFF => 1,
            0x100..=0xFFFF => 2,
            0x1_0000..=0xFFFF_FFFF => 4,
            _ => 8,
        };
    }
    for module in &ir.modules {
        for msg in &module.messages {
            for f in &msg.fields {
                if let Some(&i) = f.enum_name.as_ref().and_then(|n| enum_index.get(n)) {
                    if f.ty.primitive.is_integer() && f.ty.array.is_none() {
                        width[i] = width[i].max(f.ty.primitive.size());
                    }
                }
            }
        }
    }
    for (e, w) in ir.enums.iter_mut().zip(width) {
        e.repr = match w {
            1 => Primitive::U8,
            2 => Primitive::U16,
            4 => Primitive::U32,
            _ => Primitive::U64,
        };
    }
}
