//! Ferrolink's generator: MAVLink XML dialects, TosNet register maps and ModRob-1 dictionaries
//! and robots (TOML) to Rust bindings for `ferrolink-runtime`.
//!
//! The pipeline, one module per stage:
//!
//! ```text
//! frontend (parse, with spans) -> lower (IR: wire order, lengths, CRC_EXTRA, area offsets)
//!   -> check (diagnostics) -> backend (quote!) -> format (prettyplease) -> write (if changed)
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
pub mod check;
mod config;
pub mod diag;
#[cfg(feature = "tools")]
pub mod diff;
pub mod format;
pub mod frontend;
pub mod ident;
pub mod ir;
pub mod lower;
#[cfg(feature = "traffic")]
pub mod traffic;
pub mod write;

pub use backend::rust::SerdeMode;
pub use check::Carrier;
pub use config::{Config, Generated};
pub use diag::{Diagnostic, Failed};

use std::path::PathBuf;

/// What the front half of the pipeline produces: the checked IR, every file read, and the
/// warnings.
#[derive(Debug)]
pub struct Checked {
    /// The IR.
    pub ir: ir::Ir,
    /// Every file read, includes too.
    pub read: Vec<PathBuf>,
    /// Warnings (errors make the run fail instead).
    pub warnings: Vec<Diagnostic>,
}

/// Parses, lowers and checks `inputs`: `.toml` files as TOML dictionaries (a `[ring]` table
/// makes a TosNet register map, `[module]` a ModRob-1 module dictionary, `[robot]` a ModRob-1
/// robot), all others as MAVLink XML. Every problem is reported in one go.
pub fn load(inputs: &[PathBuf]) -> Result<Checked, Failed> {
    load_for(inputs, &[])
}

/// Like [`load`], and also checks that every message fits each of `carriers`.
pub fn load_for(inputs: &[PathBuf], carriers: &[check::Carrier]) -> Result<Checked, Failed> {
    let mut diags = diag::Diagnostics::default();
    let loaded = frontend::load(inputs, &mut diags);
    let read = loaded.paths().map(PathBuf::from).collect();
    #[allow(unused_mut)]
    let mut ir = lower::lower(loaded.mavlink);
    #[cfg(feature = "toml")]
    {
        ir.rings = lower::tosnet::lower(loaded.rings, &mut diags);
        (ir.modrob, ir.robots) = lower::modrob::lower(loaded.modrob, loaded.robots, &mut diags);
    }
    check::check(&ir, &mut diags);
    for &carrier in carriers {
        check::check_carrier(&ir, carrier, &mut diags);
    }
    if diags.has_errors() {
        return Err(Failed(diags.into_vec()));
    }
    Ok(Checked {
        ir,
        read,
        warnings: diags.into_vec(),
    })
}
