//! The MAVLink dictionaries a command knows: the standard dialects built into the binary
//! (`--dialect ardupilotmega`), files (`--dialect my.xml`), or, without `--dialect`, the
//! command's default built-in dialect. Built-in files load from memory through the same frontend
//! as files on disk, with the same diagnostics.
//!
//! Nothing here uses generated bindings, so the CLI keeps working (and can regenerate
//! `generated/`) even when the checked-in bindings do not compile.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ferrolink_dialects::definitions;
use ferrolink_dictionary::ir::Ir;
use ferrolink_runtime::mavlink::MessageMeta;
use ferrolink_traffic::{message_table, PayloadDecoder};

/// What commands that read traffic decode with when no `--dialect` is given, as mavlogdump
/// does.
pub const DEFAULT: &str = "ardupilotmega";

/// What the router checks and routes with when no `--dialect` is given: every standard
/// dialect, so that the services' messages are routed by their targets, not broadcast.
pub const ROUTER_DEFAULT: &str = "all";

/// The folder the standard dialects seem to be in, in paths and diagnostics.
const BUILT_IN: &str = "[built-in]";

/// The folder our own definitions (and the services') seem to be in.
const OWN_DIR: &str = "[built-in]/ferrolink";

/// Our own MAVLink definitions (`definitions/mavlink/`), as built into the binary.
const OWN: &[(&str, &str)] = &[
    (
        "minimal.xml",
        include_str!("../../definitions/mavlink/minimal.xml"),
    ),
    ("usv.xml", include_str!("../../definitions/mavlink/usv.xml")),
    (
        "bench.xml",
        include_str!("../../definitions/mavlink/bench.xml"),
    ),
];

/// The microservices' messages and enums, as the runtime's state machines know them.
const SERVICES: &[(&str, &str)] = &[(
    "microservices.xml",
    include_str!("../../definitions/runtime/microservices.xml"),
)];

/// Loaded dictionaries: the IR, for decoding, and the message table, for parsers and routers.
#[derive(Debug)]
pub struct Dialects {
    /// The checked IR, shared with the decoders made from it.
    pub ir: Arc<Ir>,
    /// Every message, sorted by id, shared with the parsers and routers that check with it.
    pub table: Arc<[MessageMeta]>,
}

/// Where `--dialect VALUE` points: a file, or else a built-in dialect of that name.
fn resolve(value: &Path) -> Result<PathBuf, String> {
    if value.is_file() {
        return Ok(value.to_path_buf());
    }
    let name = value.to_str().filter(|v| !v.contains(['/', '\\']));
    name.and_then(built_in).ok_or_else(|| {
        format!(
            "--dialect {}: no such file, and no built-in dialect has that name (built in: {})",
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

/// Reads a file, from memory when it is in [`BUILT_IN`].
fn read(path: &Path) -> std::io::Result<String> {
    if !path.starts_with(BUILT_IN) {
        return std::fs::read_to_string(path);
    }
    let text = match path.strip_prefix(OWN_DIR) {
        Ok(file) => [OWN, SERVICES]
            .concat()
            .into_iter()
            .find(|(n, _)| Path::new(n) == file)
            .map(|(_, t)| t),
        Err(_) => path
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
    /// when there are none. Warnings are printed to stderr; errors (all of them, with
    /// file:line:col) make this fail.
    pub fn load(given: &[PathBuf], default: &str) -> Result<Self, String> {
        let inputs = if given.is_empty() {
            vec![built_in(default).ok_or_else(|| format!("no built-in dialect {default}"))?]
        } else {
            given.iter().map(|v| resolve(v)).collect::<Result<_, _>>()?
        };
        let checked =
            ferrolink_dictionary::load_with(&inputs, &[], &read).map_err(|f| f.to_string())?;
        for w in &checked.warnings {
            eprintln!("{w}\n");
        }
        Ok(Self::new(checked.ir))
    }

    /// Our own definitions.
    pub fn own() -> Result<Self, String> {
        Self::built_in(OWN)
    }

    /// The microservices' messages and enums (common.xml's), as the runtime's state machines
    /// know them: the names of MAV_CMD and MAV_RESULT values.
    pub fn services() -> Result<Self, String> {
        Self::built_in(SERVICES)
    }

    fn built_in(texts: &[(&str, &str)]) -> Result<Self, String> {
        let files: Vec<PathBuf> = texts
            .iter()
            .map(|(n, _)| Path::new(OWN_DIR).join(n))
            .collect();
        let checked =
            ferrolink_dictionary::load_with(&files, &[], &read).map_err(|f| f.to_string())?;
        Ok(Self::new(checked.ir))
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

    fn new(ir: Ir) -> Self {
        Self {
            table: message_table(&ir),
            ir: Arc::new(ir),
        }
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
