//! The TosNet backend: one module per register map, built with `quote!`.
//!
//! Per area layout a plain struct with `read`/`write` on a 16-byte area at constant offsets; per
//! node a unit type implementing `ferrolink_runtime::tosnet::NodeId`, with an index constant,
//! accessors and setters per register. A setter takes the runtime's `OutWriter<'_, Node>` (only
//! the node itself has one) or `InWriter` (only the master has one), so the type system keeps
//! every node to what the protocol lets it write. Every path is absolute.

use proc_macro2::{Literal, TokenStream};
use quote::quote;

use super::{docs, ident, inner, lit, primitive};
use crate::check::tosnet::AREA_LEN;
use crate::ident as names;
use crate::ir::{AreaLayout, Field, Ir, Primitive, Register, Ring, RingNode};

/// Emits every ring of `ir`, in order, as (module name, tokens).
pub fn emit(ir: &Ir) -> Vec<(String, TokenStream)> {
    ir.rings
        .iter()
        .map(|ring| (ring.name.rust.clone(), emit_ring(ring)))
        .collect()
}

fn emit_ring(ring: &Ring) -> TokenStream {
    let file = ring.path.rsplit('/').next().unwrap_or(&ring.path);
    let mut text = format!("TosNet register map `{file}`.");
    if !ring.description.is_empty() {
        text = format!("{}\n\n{text}", ring.description);
    }
    let doc = inner(docs(&text));
    let mut nodes: Vec<&RingNode> = ring.nodes.iter().collect();
    nodes.sort_by_key(|n| n.id);
    let node_entries = nodes.iter().map(|n| {
        let (id, name) = (Literal::u8_unsuffixed(n.id), &n.name.wire);
        quote!((#id, #name))
    });
    let registers = lit(ring.enabled_registers());
    let areas = ring.areas.iter().map(emit_area);
    let node_items = ring.nodes.iter().map(|n| emit_node(ring, n));
    quote! {
        #doc

        /// The ring's nodes as (id, name), by id.
        pub const NODES: &[(u8, &str)] = &[ #( #node_entries ),* ];

        /// Registers enabled in the whole ring, each counted once whether it has an in area, an
        /// out area or both: `r` in the cycle-rate model.
        pub const REGISTERS: usize = #registers;

        #( #areas )*
        #( #node_items )*
    }
}

/// The field's Rust type: the scalar, or an array of it (`char[N]` is `[u8; N]`).
fn field_type(f: &Field) -> TokenStream {
    let t = primitive(f.ty.primitive);
    match f.ty.array {
        Some(n) => {
            let n = lit(n.into());
            quote!([#t; #n])
        }
        None => t,
    }
}

/// The type as written in the dictionary, e.g. `float` or `char[8]`.
fn c_type(f: &Field) -> String {
    let base = f.ty.primitive.c_name();
    match f.ty.array {
        Some(n) => format!("{base}[{n}]"),
        None => base.to_string(),
    }
}

fn field_doc(f: &Field) -> TokenStream {
    let mut facts = vec![format!("`{}`", c_type(f))];
    if f.ty.primitive == Primitive::Char && f.ty.array.is_some() {
        facts.push("text, NUL-padded".into());
    }
    if let Some(u) = f.attr("units") {
        facts.push(format!("unit: {u}"));
    }
    facts.push(format!("bytes {}..{}", f.offset, f.offset + f.ty.size()));
    docs(&format!("{}\n\n({})", f.description, facts.join(", ")))
}

fn emit_area(area: &AreaLayout) -> TokenStream {
    let name = ident(&area.name.rust);
    let wire = &area.name.wire;
    let mut text = area.description.clone();
    let origin = if area.inline {
        format!("Inline area `{wire}`")
    } else {
        format!("Area layout `{wire}`")
    };
    text.push_str(&format!("\n\n{origin}: {} of {AREA_LEN} bytes.", area.len));
    let doc = docs(&text);
    let len = lit(area.len);
    let area_len = lit(AREA_LEN);
    let fields = area.fields.iter().map(|f| {
        let (fname, ty, doc) = (ident(&f.name.rust), field_type(f), field_doc(f));
        quote! { #doc pub #fname: #ty, }
    });
    let offsets = area.fields.iter().map(|f| {
        let konst = ident(&format!("{}_OFFSET", names::const_name(&f.name.wire)));
        let at = lit(f.offset);
        let doc = format!(" Byte offset of `{}`.", f.name.wire);
        quote! { #[doc = #doc] pub const #konst: usize = #at; }
    });
    let gets = area.fields.iter().map(|f| {
        let (fname, at) = (ident(&f.name.rust), lit(f.offset));
        quote!(#fname: ::ferrolink_runtime::wire::get(area, #at),)
    });
    let puts = area.fields.iter().map(|f| {
        let (fname, at) = (ident(&f.name.rust), lit(f.offset));
        quote!(::ferrolink_runtime::wire::put(area, #at, self.#fname);)
    });
    let (read_body, write_body) = if area.fields.is_empty() {
        (quote!(let _ = area; Self {}), quote!(let _ = area;))
    } else {
        (quote!(Self { #( #gets )* }), quote!(#( #puts )*))
    };
    quote! {
        #doc
        #[derive(Debug, Clone, Copy, PartialEq, Default)]
        pub struct #name {
            #( #fields )*
        }

        impl #name {
            /// The layout's name in the register map.
            pub const NAME: &'static str = #wire;
            /// Bytes up to the end of the last field.
            pub const LEN: usize = #len;
            #( #offsets )*

            /// Reads the fields from an area.
            #[inline]
            pub fn read(area: &[u8; #area_len]) -> Self {
                #read_body
            }

            /// Writes the fields into an area; bytes outside the fields keep their value.
            #[inline]
            pub fn write(&self, area: &mut [u8; #area_len]) {
                #write_body
            }
        }
    }
}

/// A register mask as a binary literal, nibbles apart (`0b0000_0011`).
fn mask(m: u8) -> Literal {
    format!("0b{:04b}_{:04b}", m >> 4, m & 0xF)
        .parse()
        .unwrap_or_else(|_| Literal::u8_unsuffixed(m))
}

fn emit_node(ring: &Ring, node: &RingNode) -> TokenStream {
    let name = ident(&node.name.rust);
    let wire = &node.name.wire;
    let id = Literal::u8_unsuffixed(node.id);
    let mut text = node.description.clone();
    text.push_str(&format!("\n\nNode `{wire}`, id {}.", node.id));
    let area_name = |a: Option<usize>| a.map(|i| format!("[`{}`]", ring.areas[i].name.rust));
    for reg in &node.registers {
        let parts: Vec<String> = [
            area_name(reg.in_area).map(|a| format!("in {a}")),
            area_name(reg.out_area).map(|a| format!("out {a}")),
        ]
        .into_iter()
        .flatten()
        .collect();
        let parts = if parts.is_empty() {
            "no areas".to_string()
        } else {
            parts.join(", ")
        };
        text.push_str(&format!(
            "\n\nRegister {} `{}`: {parts}.",
            reg.index, reg.name.wire
        ));
    }
    let doc = docs(&text);
    let (out_mask, in_mask) = (mask(node.out_mask()), mask(node.in_mask()));
    let registers: Vec<TokenStream> = node
        .registers
        .iter()
        .map(|r| emit_register(ring, node, r))
        .collect();
    let inherent = (!registers.is_empty()).then(|| quote!(impl #name { #( #registers )* }));
    quote! {
        #doc
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
        pub struct #name;

        impl ::ferrolink_runtime::tosnet::NodeId for #name {
            const ID: u8 = #id;
            const NAME: &'static str = #wire;
            const OUT_MASK: u8 = #out_mask;
            const IN_MASK: u8 = #in_mask;
        }

        #inherent
    }
}

fn emit_register(ring: &Ring, node: &RingNode, reg: &Register) -> TokenStream {
    let wire = &reg.name.wire;
    let node_wire = &node.name.wire;
    let konst = ident(&names::const_name(wire));
    let index = Literal::u8_unsuffixed(reg.index);
    let id = Literal::u8_unsuffixed(node.id);
    let mut text = format!("Register index of `{wire}`.");
    if !reg.description.is_empty() {
        text = format!("{}\n\n{text}", reg.description);
    }
    let doc = docs(&text);
    let mut items = vec![quote! { #doc pub const #konst: u8 = #index; }];
    if let Some(a) = reg.out_area {
        let ty = ident(&ring.areas[a].name.rust);
        let (get, set) = names::register_fns(wire, "out");
        let (get, set) = (ident(&get), ident(&set));
        let get_doc = format!(" Reads `{wire}`'s out area, written by `{node_wire}`.");
        let set_doc =
            format!(" Writes `{wire}`'s out area, through `{node_wire}`'s own `OutWriter`.");
        items.push(quote! {
            #[doc = #get_doc]
            #[inline]
            pub fn #get(block: &::ferrolink_runtime::tosnet::Block) -> #ty {
                #ty::read(block.out_area(#id, Self::#konst))
            }

            #[doc = #set_doc]
            #[inline]
            pub fn #set(w: &mut ::ferrolink_runtime::tosnet::OutWriter<'_, Self>, value: &#ty) {
                value.write(w.area(Self::#konst));
            }
        });
    }
    if let Some(a) = reg.in_area {
        let ty = ident(&ring.areas[a].name.rust);
        let (get, set) = names::register_fns(wire, "in");
        let (get, set) = (ident(&get), ident(&set));
        let get_doc = format!(" Reads `{wire}`'s in area, written by the master.");
        let set_doc = format!(" Writes `{wire}`'s in area, through the master's `InWriter`.");
        items.push(quote! {
            #[doc = #get_doc]
            #[inline]
            pub fn #get(block: &::ferrolink_runtime::tosnet::Block) -> #ty {
                #ty::read(block.in_area(#id, Self::#konst))
            }

            #[doc = #set_doc]
            #[inline]
            pub fn #set(w: &mut ::ferrolink_runtime::tosnet::InWriter<'_>, value: &#ty) {
                value.write(w.area::<Self>(Self::#konst));
            }
        });
    }
    quote!(#( #items )*)
}
