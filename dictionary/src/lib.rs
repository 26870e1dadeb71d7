//! Ferrolink's dictionary model: MAVLink XML dialects, TosNet register maps and ModRob-1
//! dictionaries and robots (TOML) read into one checked intermediate representation.
//!
//! The pipeline, one module per stage, and in each stage one submodule per protocol
//! (`mavlink`, `tosnet`, `modrob`):
//!
//! ```text
//! frontend (parse, with spans) -> lower (IR: wire order, lengths, CRC_EXTRA, area offsets)
//!   -> check (diagnostics)
//! ```
//!
//! Every backend starts from [`load`]: the Rust generator (`ferrolink-codegen`), run-time
//! decoding (`ferrolink-traffic`) and the dictionary tools (`ferrolink-tools`).
//!
//! ```no_run
//! let checked = ferrolink_dictionary::load(&["definitions/mavlink/usv.xml".into()])
//!     .unwrap_or_else(|failed| panic!("{failed}"));
//! for module in &checked.ir.modules {
//!     println!("{}: {} message(s)", module.name.wire, module.messages.len());
//! }
//! ```
#![forbid(unsafe_code)]

pub mod check;
pub mod diag;
pub mod frontend;
pub mod ident;
pub mod ir;
pub mod lower;
pub mod write;

pub use check::Carrier;
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
    load_with(inputs, carriers, &frontend::read_file)
}

/// Like [`load_for`], with every file (includes too) read through `read`: dictionaries built
/// into a program load from memory this way, with the same diagnostics.
///
/// ```
/// let text = r#"<mavlink><messages><message id="1" name="PING">
///   <field type="uint8_t" name="n"/></message></messages></mavlink>"#;
/// let read = |path: &std::path::Path| match path.to_str() {
///     Some("ping.xml") => Ok(text.to_string()),
///     _ => Err(std::io::ErrorKind::NotFound.into()),
/// };
/// let checked = ferrolink_dictionary::load_with(&["ping.xml".into()], &[], &read).unwrap();
/// assert_eq!(checked.ir.modules[0].messages[0].name.wire, "PING");
/// ```
pub fn load_with(
    inputs: &[PathBuf],
    carriers: &[check::Carrier],
    read: frontend::Read<'_>,
) -> Result<Checked, Failed> {
    let mut diags = diag::Diagnostics::default();
    let loaded = frontend::load(inputs, read, &mut diags);
    let read = loaded.paths().map(PathBuf::from).collect();
    #[allow(unused_mut)]
    let mut ir = lower::mavlink::lower(loaded.mavlink);
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
