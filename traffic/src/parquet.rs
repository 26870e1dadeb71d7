//! The tables of [`columns`](crate::columns) as Parquet files, one per message type, for many
//! logs at once: `DIR/NAME.parquet`, snappy-compressed, with a `log` column naming each row's
//! file. DuckDB, polars, pandas and Spark read them as they are.
//!
//! Rows are written in row groups as they come, so a fleet's logs need no more memory than a
//! row group of each message type.

use std::collections::BTreeMap;
use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};

use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::properties::WriterProperties;

use crate::columns::Tables;
use crate::PayloadDecoder;

/// Rows a message type gathers before they go out as a row group.
const ROW_GROUP: usize = 64 * 1024;

/// Writes frames of many logs into one Parquet file per message type.
#[derive(Debug)]
pub struct ParquetExport {
    dir: PathBuf,
    tables: Tables,
    writers: BTreeMap<String, (PathBuf, ArrowWriter<File>, u64)>,
}

impl ParquetExport {
    /// An export into `dir` (created if need be) of the messages named in `types`, or of all.
    pub fn new(
        dir: &Path,
        decoder: PayloadDecoder,
        types: Option<&[String]>,
    ) -> Result<Self, String> {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        Ok(ParquetExport {
            dir: dir.to_path_buf(),
            tables: Tables::new(decoder, types)?,
            writers: BTreeMap::new(),
        })
    }

    /// Rows from now on come from the log named `log` (its `log` column).
    pub fn set_log(&mut self, log: &str) {
        self.tables.set_log(log);
    }

    /// Whether frames of id `id` go into the export.
    pub fn wants(&self, id: u32) -> bool {
        self.tables.wants(id)
    }

    /// Appends a frame as a row (frames not wanted are skipped); a message type's rows go out
    /// as a row group once there are 65,536.
    pub fn push(
        &mut self,
        t_us: Option<u64>,
        sysid: u8,
        compid: u8,
        id: u32,
        payload: &[u8],
    ) -> io::Result<()> {
        if self.tables.push(t_us, sysid, compid, id, payload) >= ROW_GROUP {
            self.write(ROW_GROUP)?;
        }
        Ok(())
    }

    fn write(&mut self, min_rows: usize) -> io::Result<()> {
        for (name, batch) in self.tables.take_full(min_rows) {
            let writer = match self.writers.entry(name) {
                std::collections::btree_map::Entry::Occupied(w) => w.into_mut(),
                std::collections::btree_map::Entry::Vacant(slot) => {
                    let path = self.dir.join(format!("{}.parquet", slot.key()));
                    let file = File::create(&path)?;
                    let props = WriterProperties::builder()
                        .set_compression(Compression::SNAPPY)
                        .set_max_row_group_row_count(Some(ROW_GROUP))
                        .build();
                    let writer = ArrowWriter::try_new(file, batch.schema(), Some(props))
                        .map_err(io::Error::other)?;
                    slot.insert((path, writer, 0))
                }
            };
            writer.1.write(&batch).map_err(io::Error::other)?;
            writer.2 += batch.num_rows() as u64;
        }
        Ok(())
    }

    /// Writes what is left and closes the files: each file's path and row count, by message
    /// name.
    pub fn finish(mut self) -> io::Result<Vec<(PathBuf, u64)>> {
        self.write(1)?;
        let mut written = Vec::new();
        for (_, (path, writer, rows)) in self.writers {
            writer.close().map_err(io::Error::other)?;
            written.push((path, rows));
        }
        Ok(written)
    }
}
