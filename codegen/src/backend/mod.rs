//! Backends: IR to Rust tokens, one module per protocol, and the token helpers they share.

pub mod mavlink;
#[cfg(feature = "toml")]
pub mod modrob;
#[cfg(feature = "toml")]
pub mod tosnet;

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

use crate::ir::Primitive;

/// An identifier from a name that may be raw (`r#type`).
pub fn ident(name: &str) -> Ident {
    match name.strip_prefix("r#") {
        Some(raw) => Ident::new_raw(raw, Span::call_site()),
        None => Ident::new(name, Span::call_site()),
    }
}

/// Doc attributes from free text, wrapped at about 100 columns.
pub(crate) fn docs(text: &str) -> TokenStream {
    let mut lines = Vec::new();
    for para in text.split("\n\n") {
        if para.trim().is_empty() {
            continue;
        }
        if !lines.is_empty() {
            lines.push(String::new());
        }
        let mut line = String::new();
        for word in para.split_whitespace() {
            if !line.is_empty() && line.len() + word.len() > 96 {
                lines.push(std::mem::take(&mut line));
            }
            if !line.is_empty() {
                line.push(' ');
            }
            line.push_str(word);
        }
        lines.push(line);
    }
    let lines = lines.into_iter().map(|l| format!(" {l}"));
    quote! { #( #[doc = #lines] )* }
}

/// The Rust type of a scalar (`char` is a byte).
pub(crate) fn primitive(p: Primitive) -> TokenStream {
    match p {
        Primitive::U8 | Primitive::Char => quote!(u8),
        Primitive::I8 => quote!(i8),
        Primitive::U16 => quote!(u16),
        Primitive::I16 => quote!(i16),
        Primitive::U32 => quote!(u32),
        Primitive::I32 => quote!(i32),
        Primitive::U64 => quote!(u64),
        Primitive::I64 => quote!(i64),
        Primitive::F32 => quote!(f32),
        Primitive::F64 => quote!(f64),
    }
}

/// An unsuffixed `usize` literal.
pub(crate) fn lit(v: usize) -> Literal {
    Literal::usize_unsuffixed(v)
}

/// Turns outer doc attributes (`#[doc]`) into inner ones (`#![doc]`).
pub(crate) fn inner(outer: TokenStream) -> TokenStream {
    let mut out = TokenStream::new();
    for tt in outer {
        if let proc_macro2::TokenTree::Punct(p) = &tt {
            if p.as_char() == '#' {
                out.extend(quote!(#p !));
                continue;
            }
        }
        out.extend([tt]);
    }
    out
}
