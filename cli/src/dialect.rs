//! The MAVLink dictionaries a command knows: the files given with `--dialect`, loaded through
//! the generator's frontend at start, or else our own definitions, built into the binary.
//!
//! Nothing here uses generated bindings, so the CLI keeps working (and can regenerate
//! `generated/`) even when the checked-in bindings do not compile.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use ferrolink_dictionary::ir::Ir;
use ferrolink_runtime::mavlink::MessageMeta;
use ferrolink_traffic::{message_table, PayloadDecoder};

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

/// Loaded dictionaries: the IR, for decoding, and the message table, for parsers and routers.
#[derive(Debug)]
pub struct Dialects {
    /// The checked IR, shared with the decoders made from it.
    pub ir: Arc<Ir>,
    /// Every message, sorted by id, shared with the parsers and routers that check with it.
    pub table: Arc<[MessageMeta]>,
}

impl Dialects {
    /// Loads `files`, or our own definitions when there are none. Warnings are printed to
    /// stderr; errors (all of them, with file:line:col) make this fail.
    pub fn load(files: &[PathBuf]) -> Result<Self, String> {
        if files.is_empty() {
            return Self::own();
        }
        let checked = ferrolink_dictionary::load(files).map_err(|failed| failed.to_string())?;
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
        Self::built_in(&[(
            "microservices.xml",
            include_str!("../../definitions/runtime/microservices.xml"),
        )])
    }

    fn built_in(texts: &[(&str, &str)]) -> Result<Self, String> {
        let dir = tempfile::tempdir().map_err(|e| format!("a temporary directory: {e}"))?;
        let mut files = Vec::new();
        for (name, text) in texts {
            let path = dir.path().join(name);
            std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            files.push(path);
        }
        let checked = ferrolink_dictionary::load(&files).map_err(|failed| failed.to_string())?;
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
