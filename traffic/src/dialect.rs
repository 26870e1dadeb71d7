//! The MAVLink dictionaries a program decodes with: the standard dialects built in
//! (`ardupilotmega`), or files (`my.xml`). Built-in files load from memory through the same
//! frontend as files on disk, with the same diagnostics; nothing here uses generated bindings.
//!
//! ```
//! use ferrolink_traffic::Dialects;
//!
//! let apm = Dialects::load(&[], "ardupilotmega").unwrap();
//! assert_eq!(apm.decoder().message(30).unwrap().name.wire, "ATTITUDE");
//! let err = Dialects::load(&["no-such-dialect".into()], "common").unwrap_err();
//! assert!(err.contains("no built-in dialect has that name"), "{err}");
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ferrolink_dialects::definitions;
use ferrolink_dictionary::ir::Ir;
use ferrolink_runtime::mavlink::MessageMeta;

use crate::{message_table, PayloadDecoder};

/// What programs that read traffic decode with when no dialect is given, as mavlogdump does.
pub const DEFAULT: &str = "ardupilotmega";

/// The folder the standard dialects seem to be in, in paths and diagnostics.
const BUILT_IN: &str = "[built-in]";

/// Loaded dictionaries: the IR, for decoding, and the message table, for parsers and routers.
#[derive(Debug, Clone)]
pub struct Dialects {
    /// The checked IR, shared with the decoders made from it.
    pub ir: Arc<Ir>,
    /// Every message, sorted by id, shared with the parsers and routers that check with it.
    pub table: Arc<[MessageMeta]>,
    /// The frontend's warnings, each with file:line:col, for the caller to show.
    pub warnings: Vec<String>,
}

/// Where a dialect argument points: a file, or else a built-in dialect of that name.
fn resolve(value: &Path) -> Result<PathBuf, String> {
    if value.is_file() {
        return Ok(value.to_path_buf());
    }
    let name = value.to_str().filter(|v| !v.contains(['/', '\\']));
    name.and_then(built_in).ok_or_else(|| {
        format!(
            "dialect {}: no such file, and no built-in dialect has that name (built in: {})",
            value.display(),
            names().join(", ")
        )
    })
}

/// The path of built-in dialect `name`.
fn built_in(name: &str) -> Option<PathBuf> {
    definitions::find(name).map(|d| Path::new(BUILT_IN).join(d.file))
}

/// The built-in dialects' names.
pub fn names() -> Vec<&'static str> {
    definitions::ALL.iter().map(|d| d.name).collect()
}

/// Files a program carries in memory: the folder they seem to be in, and `(name, text)` pairs.
type Extra<'a> = Option<(&'a Path, &'a [(&'a str, &'a str)])>;

/// Reads a file: one of `extra` when it is in its folder, a built-in dialect when it is in
/// [`BUILT_IN`], else from disk.
fn read(path: &Path, extra: Extra<'_>) -> std::io::Result<String> {
    if !path.starts_with(BUILT_IN) {
        return std::fs::read_to_string(path);
    }
    let text = match extra.and_then(|(dir, texts)| Some((path.strip_prefix(dir).ok()?, texts))) {
        Some((file, texts)) => texts
            .iter()
            .find(|(n, _)| Path::new(n) == file)
            .map(|(_, t)| *t),
        None => path
            .strip_prefix(BUILT_IN)
            .ok()
            .and_then(Path::to_str)
            .and_then(definitions::by_file)
            .map(|d| d.text),
    };
    text.map(str::to_string)
        .ok_or_else(|| std::io::ErrorKind::NotFound.into())
}

impl Dialects {
    /// Loads the dialects `given` (files, or built-in names), or the built-in dialect `default`
    /// when there are none. Errors (all of them, with file:line:col) make this fail; warnings
    /// are in [`Dialects::warnings`].
    pub fn load(given: &[PathBuf], default: &str) -> Result<Self, String> {
        let inputs = if given.is_empty() {
            vec![built_in(default).ok_or_else(|| format!("no built-in dialect {default}"))?]
        } else {
            given.iter().map(|v| resolve(v)).collect::<Result<_, _>>()?
        };
        let checked = ferrolink_dictionary::load_with(&inputs, &[], &|p: &Path| read(p, None))
            .map_err(|f| f.to_string())?;
        let warnings = checked.warnings.iter().map(|w| w.to_string()).collect();
        Ok(Self::new(checked.ir, warnings))
    }

    /// Loads files a program carries in memory, `(file name, text)`, which may include the
    /// standard dialects by name. `folder` is the folder they seem to be in, under `[built-in]`.
    pub fn from_texts(folder: &str, texts: &[(&str, &str)]) -> Result<Self, String> {
        let dir = Path::new(BUILT_IN).join(folder);
        let files: Vec<PathBuf> = texts.iter().map(|(n, _)| dir.join(n)).collect();
        let checked =
            ferrolink_dictionary::load_with(&files, &[], &|p: &Path| read(p, Some((&dir, texts))))
                .map_err(|f| f.to_string())?;
        let warnings = checked.warnings.iter().map(|w| w.to_string()).collect();
        Ok(Self::new(checked.ir, warnings))
    }

    fn new(ir: Ir, warnings: Vec<String>) -> Self {
        Self {
            table: message_table(&ir),
            ir: Arc::new(ir),
            warnings,
        }
    }

    /// The value of entry `name` of enum `enum_name` (`MAV_CMD`), the name with or without the
    /// enum's prefix, any case.
    pub fn entry_value(&self, enum_name: &str, name: &str) -> Option<u64> {
        let upper = name.to_ascii_uppercase();
        let prefixed = format!("{enum_name}_{upper}");
        self.ir
            .enums
            .iter()
            .filter(|e| e.name.wire == enum_name)
            .flat_map(|e| &e.entries)
            .find(|e| e.name.wire == upper || e.name.wire == prefixed)
            .map(|e| e.value)
    }

    /// The wire name of value `value` of enum `enum_name`.
    pub fn entry_name(&self, enum_name: &str, value: u64) -> Option<&str> {
        self.ir
            .enums
            .iter()
            .filter(|e| e.name.wire == enum_name)
            .flat_map(|e| &e.entries)
            .find(|e| e.value == value)
            .map(|e| e.name.wire.as_str())
    }

    /// Every message's wire name, by id (a later module's message wins, as in the table).
    pub fn names(&self) -> BTreeMap<u32, String> {
        self.ir
            .modules
            .iter()
            .flat_map(|m| &m.messages)
            .map(|m| (m.id, m.name.wire.clone()))
            .collect()
    }

    /// A decoder for payloads of these dictionaries.
    pub fn decoder(&self) -> PayloadDecoder {
        PayloadDecoder::new(self.ir.clone())
    }
}
