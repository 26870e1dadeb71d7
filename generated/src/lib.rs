//! Checked-in Ferrolink bindings for the dictionaries in `definitions/`.
//!
//! Regenerate with
//!
//! ```sh
//! cargo run -p ferrolink-cli -- generate definitions/mavlink/*.xml --out generated/src/mavlink --serde-feature serde
//! cargo run -p ferrolink-cli -- generate definitions/tosnet/*.toml --out generated/src/tosnet
//! cargo run -p ferrolink-cli -- generate definitions/modrob/*.toml --out generated/src/modrob
//! ```
//!
//! A test fails when these files are stale.
#![no_std]

// Formatted by the generator (prettyplease); rustfmt would make it stale.
#[rustfmt::skip]
pub mod mavlink;
#[rustfmt::skip]
pub mod tosnet;
#[rustfmt::skip]
pub mod modrob;
