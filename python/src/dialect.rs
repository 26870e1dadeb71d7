//! Dialects by built-in name (`"ardupilotmega"`) or XML file path, each loaded once per process.

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

impl Loaded {
    /// The ids of `types` (message names, any case; `BAD_DATA` asks for undecodable frames,
    /// the second value). `None` asks for all.
    pub fn wanted(
        &self,
        types: Option<Vec<String>>,
    ) -> PyResult<(Option<std::collections::HashSet<u32>>, bool)> {
        let Some(mut types) = types else {
            return Ok((None, true));
        };
        let before = types.len();
        types.retain(|t| !t.eq_ignore_ascii_case("BAD_DATA"));
        let bad = types.len() != before;
        let ids = self.decoder.ids_of(&types).map_err(error::value)?;
        Ok((Some(ids), bad))
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
