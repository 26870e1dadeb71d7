//! Ferrolink's dictionary tools, fed by the same checked IR as the Rust generator:
//!
//! - [`docs`]: a static documentation site (minijinja templates in `templates/docs/`);
//! - [`wireshark`]: Wireshark dissectors in Lua for MAVLink, NDLCom, ModRob-1 and TosNet
//!   (`templates/wireshark/`);
//! - [`diff`]: the compatibility checker behind `ferrolink diff`.
//!
//! ```no_run
//! let checked = ferrolink_dictionary::load(&["definitions/mavlink/usv.xml".into()])
//!     .unwrap_or_else(|failed| panic!("{failed}"));
//! let lua = ferrolink_tools::wireshark::generate(&checked.ir)?;
//! std::fs::write("ferrolink.lua", lua)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]

pub mod diff;
pub mod docs;
mod jinja;
pub mod wireshark;

use ferrolink_dictionary::{check, diag, ir, write};
