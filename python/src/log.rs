//! Logs: message by message ([`LogIter`]), as Arrow tables ([`load_tables`]), and into Parquet
//! files ([`save_parquet`]). Files are read a chunk at a time, so a log larger than memory
//! iterates in the memory of a chunk; damage is resynchronised as `ferrolink mavlink dump` does.

use std::collections::VecDeque;
use std::fs::File;
use std::path::PathBuf;
use std::sync::Arc;

use arrow_array::ffi_stream::FFI_ArrowArrayStream;
use arrow_array::{RecordBatch, RecordBatchIterator};
use ferrolink_io::mavlink::tlog::LogReader;
use ferrolink_runtime::mavlink::MessageMeta;
use ferrolink_traffic::columns::Tables;
use ferrolink_traffic::parquet::ParquetExport;
use pyo3::prelude::*;
use pyo3::types::PyCapsule;

use crate::dialect::{self, Loaded, Wanted};
use crate::{error, message};

/// A frame read, waiting to be handed out.
struct Pending {
    t_us: Option<u64>,
    id: u32,
    frame: Box<[u8]>,
}

/// Iterates over a log's messages, as pymavlink reads them.
#[pyclass(module = "ferrolink._native")]
pub struct LogIter {
    dialect: Arc<Loaded>,
    reader: LogReader<File, Arc<[MessageMeta]>>,
    wanted: Wanted,
    queue: VecDeque<Pending>,
    done: bool,
}

impl std::fmt::Debug for LogIter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogIter")
            .field("reader", &self.reader)
            .finish_non_exhaustive()
    }
}

#[pymethods]
impl LogIter {
    #[new]
    #[pyo3(signature = (path, dialect, types=None, raw=false))]
    fn new(path: PathBuf, dialect: &str, types: Option<Vec<String>>, raw: bool) -> PyResult<Self> {
        let dialect = dialect::load(dialect)?;
        let wanted = dialect.wanted(types)?;
        let reader = LogReader::open(&path, dialect.table.clone(), raw).map_err(error::io)?;
        Ok(LogIter {
            dialect,
            reader,
            wanted,
            queue: VecDeque::new(),
            done: false,
        })
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<Option<Py<PyAny>>> {
        while self.queue.is_empty() && !self.done {
            let LogIter {
                dialect,
                reader,
                wanted,
                queue,
                ..
            } = self;
            let decoder = &dialect.decoder;
            let more = py
                .detach(|| {
                    reader.next_chunk(|record| {
                        let id = record.frame.msg_id();
                        if wanted.takes(id, decoder.message(id).is_some()) {
                            queue.push_back(Pending {
                                t_us: record.t_us,
                                id,
                                frame: record.frame.as_bytes().into(),
                            });
                        }
                    })
                })
                .map_err(error::io)?;
            self.done = !more;
        }
        match self.queue.pop_front() {
            Some(p) => message::to_python(py, &self.dialect, p.frame, p.id, p.t_us).map(Some),
            None => Ok(None),
        }
    }

    /// What the reader found so far besides the frames: `{"frames": .., "recovered_after_damage":
    /// .., "bad_crc": .., "skipped_bytes": .., "truncated_bytes": ..}`.
    fn stats(&self) -> std::collections::BTreeMap<&'static str, u64> {
        let s = self.reader.stats();
        [
            ("frames", s.frames),
            ("unchecked", s.unchecked),
            ("recovered_after_damage", s.resynced),
            ("bad_crc", s.bad_crc),
            ("skipped_bytes", s.skipped_bytes),
            ("truncated_bytes", s.truncated_bytes),
        ]
        .into_iter()
        .collect()
    }
}

/// One message type's table, handed to pyarrow through the Arrow C stream interface
/// (`__arrow_c_stream__`), without a copy.
#[pyclass(module = "ferrolink._native")]
#[derive(Debug)]
pub struct ArrowTable {
    batch: Option<RecordBatch>,
}

#[pymethods]
impl ArrowTable {
    /// The table as an Arrow C stream capsule (once).
    #[pyo3(signature = (requested_schema=None))]
    fn __arrow_c_stream__<'py>(
        &mut self,
        py: Python<'py>,
        requested_schema: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyCapsule>> {
        let _ = requested_schema;
        let batch = self
            .batch
            .take()
            .ok_or_else(|| error::value("this table was already handed over"))?;
        let schema = batch.schema();
        let reader = RecordBatchIterator::new([Ok(batch)], schema);
        let stream = FFI_ArrowArrayStream::new(Box::new(reader));
        PyCapsule::new_with_value(py, stream, c"arrow_array_stream")
    }
}

/// Reads `path` into one table per message type: `[(name, table), ...]` in id order.
#[pyfunction]
#[pyo3(signature = (path, dialect, types=None, raw=false))]
pub fn load_tables(
    py: Python<'_>,
    path: PathBuf,
    dialect: &str,
    types: Option<Vec<String>>,
    raw: bool,
) -> PyResult<Vec<(String, ArrowTable)>> {
    let dialect = dialect::load(dialect)?;
    let mut tables =
        Tables::new(dialect.decoder.clone(), types.as_deref()).map_err(error::value)?;
    let mut reader = LogReader::open(&path, dialect.table.clone(), raw).map_err(error::io)?;
    py.detach(|| {
        reader.read_all(|record| {
            let (frame, header) = (&record.frame, record.frame.header());
            let payload = frame.payload();
            tables.push(
                record.t_us,
                header.sysid,
                header.compid,
                frame.msg_id(),
                payload,
            );
        })
    })
    .map_err(error::io)?;
    Ok(tables
        .finish()
        .into_iter()
        .map(|(name, batch)| (name, ArrowTable { batch: Some(batch) }))
        .collect())
}

/// Writes the logs `paths` into `out_dir`, one Parquet file per message type with a `log`
/// column: `[(name, path, rows)]`.
#[pyfunction]
#[pyo3(signature = (paths, out_dir, dialect, types=None, raw=false))]
pub fn save_parquet(
    py: Python<'_>,
    paths: Vec<PathBuf>,
    out_dir: PathBuf,
    dialect: &str,
    types: Option<Vec<String>>,
    raw: bool,
) -> PyResult<Vec<(String, String, u64)>> {
    let dialect = dialect::load(dialect)?;
    // Every file must open before anything is written.
    let readers = paths
        .iter()
        .map(|p| LogReader::open(p, dialect.table.clone(), raw))
        .collect::<Result<Vec<_>, _>>()
        .map_err(error::io)?;
    let mut export = ParquetExport::new(&out_dir, dialect.decoder.clone(), types.as_deref())
        .map_err(error::value)?;
    py.detach(|| -> std::io::Result<()> {
        for (path, mut reader) in paths.iter().zip(readers) {
            export.set_log(&path.display().to_string());
            let mut failed = None;
            reader.read_all(|record| {
                let frame = &record.frame;
                if failed.is_some() {
                    return;
                }
                let h = frame.header();
                if let Err(e) = export.push(
                    record.t_us,
                    h.sysid,
                    h.compid,
                    frame.msg_id(),
                    frame.payload(),
                ) {
                    failed = Some(e);
                }
            })?;
            if let Some(e) = failed {
                return Err(e);
            }
        }
        Ok(())
    })
    .map_err(error::io)?;
    let written = export.finish().map_err(error::io)?;
    Ok(written
        .into_iter()
        .map(|(path, rows)| {
            let name = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            (name, path.display().to_string(), rows)
        })
        .collect())
}
