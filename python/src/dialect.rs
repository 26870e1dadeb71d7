//! Dialects by built-in name (`"ardupilotmega"`) or XML file path, each loaded once per process.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use ferrolink_runtime::mavlink::MessageMeta;
use ferrolink_traffic::{Dialects, PayloadDecoder};
use pyo3::prelude::*;

use crate::error;

/// A loaded dialect: its decoder, the parsers' table, and message ids by name.
#[derive(Debug)]
pub struct Loaded {
    pub decoder: PayloadDecoder,
    pub table: Arc<[MessageMeta]>,
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
    });
    loaded.push((name.to_owned(), Arc::clone(&d)));
    Ok(d)
}

/// The built-in dialects' names.
#[pyfunction]
pub fn dialects() -> Vec<&'static str> {
    ferrolink_traffic::dialect::names()
}
