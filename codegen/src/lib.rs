//! Ferrolink's Rust generator: MAVLink XML dialects, TosNet register maps and ModRob-1
//! dictionaries and robots (TOML) to Rust bindings for `ferrolink-runtime`.
//!
//! The dictionary is read, lowered and checked by `ferrolink-dictionary`; this crate emits Rust
//! from its IR, one backend per protocol:
//!
//! ```text
//! ferrolink_dictionary::load -> backend (quote!: mavlink, tosnet, modrob)
//!   -> format (prettyplease) -> write (if changed)
//! ```
//!
//! Use it from `build.rs` through [`Config`]:
//!
//! ```no_run
//! // build.rs
//! ferrolink_codegen::Config::new()
//!     .input("definitions/mavlink/usv.xml")
//!     .compile()
//!     .unwrap_or_else(|e| panic!("{e}"));
//! ```
//!
//! and include the result with `include!(concat!(env!("OUT_DIR"), "/ferrolink.rs"));`.
#![forbid(unsafe_code)]

pub mod backend;
mod config;
pub mod format;

pub use backend::mavlink::SerdeMode;
pub use config::{Config, Generated};
pub use ferrolink_dictionary::write::GeneratedFile;
pub use ferrolink_dictionary::{Carrier, Diagnostic, Failed};

#[cfg(feature = "toml")]
use ferrolink_dictionary::{check, ident};
use ferrolink_dictionary::{diag, ir, write};
use ferrolink_dictionary::{load_for, Checked};
