//! `ferrolink mavlink export FILE... --parquet DIR`: logs into one Parquet file per message
//! type, every log's rows together with a `log` column naming the file.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ferrolink_io::mavlink::tlog::LogReader;
use ferrolink_traffic::parquet::ParquetExport;

/// Reads `files` in order into `dir`.
pub fn run(
    dialect: &[PathBuf],
    types: Option<&[String]>,
    raw: bool,
    dir: &Path,
    files: &[PathBuf],
) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let dialects = crate::dialect::load(dialect, crate::dialect::DEFAULT)?;
    // Every file must open before anything is written.
    let readers = files
        .iter()
        .map(|file| LogReader::open(file, &dialects.table[..], raw))
        .collect::<Result<Vec<_>, _>>()?;
    let mut export = ParquetExport::new(dir, dialects.decoder(), types)?;
    let mut summary = Vec::new();
    for (file, mut reader) in files.iter().zip(readers) {
        let unreadable = |e: io::Error| format!("{}: {e}", file.display());
        export.set_log(&file.display().to_string());
        let mut failed = None;
        let mut rows = 0u64;
        let stats = reader
            .read_all(|record| {
                let frame = &record.frame;
                if failed.is_some() {
                    return;
                }
                let header = frame.header();
                rows += u64::from(export.wants(frame.msg_id()));
                let pushed = export.push(
                    record.t_us,
                    header.sysid,
                    header.compid,
                    frame.msg_id(),
                    frame.payload(),
                );
                if let Err(e) = pushed {
                    failed = Some(e);
                }
            })
            .map_err(unreadable)?;
        if let Some(e) = failed {
            return Err(format!("{}: {e}", dir.display()).into());
        }
        summary.push(serde_json::json!({
            "log": file.display().to_string(), "frames": stats.frames, "rows": rows,
            "recovered_after_damage": stats.resynced, "skipped_bytes": stats.skipped_bytes,
            "truncated_bytes": stats.truncated_bytes,
        }));
    }
    let written = export
        .finish()
        .map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut out = io::stdout().lock();
    for line in summary {
        writeln!(out, "{line}")?;
    }
    for (path, rows) in written {
        writeln!(
            out,
            "{}",
            serde_json::json!({"file": path.display().to_string(), "rows": rows})
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
