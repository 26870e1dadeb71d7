//! Decoding logged traffic with a dictionary, and exporting it to CSV.
//!
//! Nothing here uses generated code: the layout of every message comes from the [`Ir`] at run
//! time, so a log can be decoded with whatever dictionary the user points at.
//!
//! The payload rules are MAVLink's: values are little-endian at the [`Field::offset`]s of the
//! wire order, and a payload shorter than [`Message::max_len`] is zero-filled before decoding (the
//! MAVLink 2 truncation rule). NDLCom frames carry such a payload behind a one-byte message id;
//! [`PayloadDecoder::decode_frame`] and [`CsvExport::record`] take that frame payload as it is.
//!
//! ```no_run
//! use std::path::{Path, PathBuf};
//! use ferrolink_traffic::{CsvExport, PayloadDecoder, RowMeta};
//!
//! let checked = ferrolink_dictionary::load(&[PathBuf::from("minimal.xml")]).unwrap();
//! let decoder = PayloadDecoder::new(checked.ir);
//! let mut export = CsvExport::new(Path::new("export"))?;
//! let meta = RowMeta { t_us: 0, sender: 1, receiver: 2, counter: 0 };
//! export.record(&decoder, &meta, &[30, 0x10, 0x27])?; // ATTITUDE, time_boot_ms = 10000
//! for (path, rows) in export.finish()? {
//!     println!("{}: {rows} rows", path.display());
//! }
//! # Ok::<(), std::io::Error>(())
//! ```

#![forbid(unsafe_code)]

#[cfg(feature = "arrow")]
pub mod columns;
mod decode;
pub mod dialect;
mod export;
mod json;
#[cfg(feature = "parquet")]
pub mod parquet;
mod rest;
mod table;
#[cfg(test)]
mod tests;
mod value;

pub use decode::{columns, DecodedMessage, PayloadDecoder};
pub use dialect::Dialects;
pub use export::{CsvExport, RowMeta, UNKNOWN_FILE};
pub use json::FrameDefaults;
pub use table::message_table;
pub use value::{python_text, wire_value, Value};
