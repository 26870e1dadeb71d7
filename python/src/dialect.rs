//! Dialects by built-in name (`"ardupilotmega"`) or XML file path, each loaded once per process.

use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use ferrolink_dictionary::ir::Message as IrMessage;
use ferrolink_runtime::mavlink::MessageMeta;
use ferrolink_traffic::{Dialects, PayloadDecoder};
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::error;

/// A loaded dialect: its decoder, the parsers' table, and its names as Python strings.
#[derive(Debug)]
pub struct Loaded {
    pub decoder: PayloadDecoder,
    pub table: Arc<[MessageMeta]>,
    /// Each message's name and field names as Python strings, made once: `get_type()` and
    /// `to_dict()` hand out the same objects every time.
    names: Mutex<HashMap<u32, Arc<Names>>>,
}

/// A message's name and field names, as Python strings.
#[derive(Debug)]
pub struct Names {
    pub message: Py<PyString>,
    pub fields: Vec<Py<PyString>>,
}

/// Which frames a reader hands out.
#[derive(Debug, Default)]
pub struct Wanted {
    /// Ids the dialect has (`None`: all).
    pub known: Option<HashSet<u32>>,
    /// Ids it lacks, asked for as `UNKNOWN_<id>` (`None`: all).
    pub unknown: Option<HashSet<u32>>,
}

impl Wanted {
    /// Whether a frame of id `id` (`known` to the dialect or not) is wanted.
    pub fn takes(&self, id: u32, known: bool) -> bool {
        let ids = if known { &self.known } else { &self.unknown };
        ids.as_ref().is_none_or(|ids| ids.contains(&id))
    }
}

impl Loaded {
    /// The names of message `message` (which has id `id`).
    pub fn names(&self, py: Python<'_>, id: u32, message: &IrMessage) -> Arc<Names> {
        let mut names = self.names.lock().unwrap_or_else(|p| p.into_inner());
        let made = names.entry(id).or_insert_with(|| {
            Arc::new(Names {
                message: PyString::intern(py, &message.name.wire).unbind(),
                fields: message
                    .fields
                    .iter()
                    .map(|f| PyString::intern(py, &f.name.wire).unbind())
                    .collect(),
            })
        });
        Arc::clone(made)
    }

    /// What `types` asks for: message names (any case), `UNKNOWN_<id>` for an id the dialect
    /// lacks, `BAD_DATA` (which a reader that skips damage never yields). `None` asks for all.
    pub fn wanted(&self, types: Option<Vec<String>>) -> PyResult<Wanted> {
        let Some(types) = types else {
            return Ok(Wanted::default());
        };
        let mut names = Vec::new();
        let mut unknown = HashSet::new();
        for t in types {
            let upper = t.to_ascii_uppercase();
            if upper == "BAD_DATA" {
                continue;
            }
            match upper.strip_prefix("UNKNOWN_").and_then(|n| n.parse().ok()) {
                Some(id) => {
                    unknown.insert(id);
                }
                None => names.push(t),
            }
        }
        let known = self.decoder.ids_of(&names).map_err(error::value)?;
        Ok(Wanted {
            known: Some(known),
            unknown: Some(unknown),
        })
    }
}

static LOADED: Mutex<Vec<(String, Arc<Loaded>)>> = Mutex::new(Vec::new());

/// The dialect `name` (built in) or at path `name`, loaded on first use. Errors (an unknown
/// name, a file that does not load, every diagnostic with file:line:col) are `ValueError`s.
pub fn load(name: &str) -> PyResult<Arc<Loaded>> {
    let mut loaded = LOADED.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((_, d)) = loaded.iter().find(|(n, _)| n == name) {
        return Ok(Arc::clone(d));
    }
    let dialects = Dialects::load(&[PathBuf::from(name)], name).map_err(error::value)?;
    let d = Arc::new(Loaded {
        decoder: dialects.decoder(),
        table: dialects.table.clone(),
        names: Mutex::new(HashMap::new()),
    });
    loaded.push((name.to_owned(), Arc::clone(&d)));
    Ok(d)
}

/// The built-in dialects' names.
#[pyfunction]
pub fn dialects() -> Vec<&'static str> {
    ferrolink_traffic::dialect::names()
}
