//! Checked-in Ferrolink bindings for the dictionaries in `definitions/`.
//!
//! Regenerate with `cargo run -p ferrolink-codegen --features cli -- generate
//! definitions/mavlink/*.xml --out generated/src/mavlink --serde-feature serde`; a test fails
//! when these files are stale.
#![no_std]

// Formatted by the generator (prettyplease); rustfmt would make it stale.
#[rustfmt::skip]
pub mod mavlink;
