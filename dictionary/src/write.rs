//! The last stage: write files, and only those whose content changed, so builds stay incremental.

use std::io;
use std::path::Path;

/// A generated file: a path relative to the output directory, and its content.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GeneratedFile {
    /// Relative path, e.g. `common.rs`.
    pub name: String,
    /// Formatted source.
    pub content: String,
}

/// Writes `content` to `path` unless it already holds exactly that. Returns whether it wrote.
pub fn write_if_changed(path: &Path, content: &str) -> io::Result<bool> {
    if std::fs::read(path).is_ok_and(|old| old == content.as_bytes()) {
        return Ok(false);
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, content)?;
    Ok(true)
}

/// The files whose content under `dir` differs from what was generated (or that are missing).
pub fn stale<'a>(dir: &Path, files: &'a [GeneratedFile]) -> Vec<&'a str> {
    files
        .iter()
        .filter(|f| std::fs::read(dir.join(&f.name)).ok().as_deref() != Some(f.content.as_bytes()))
        .map(|f| f.name.as_str())
        .collect()
}

/// Writes every file under `dir`; returns the names written.
pub fn write_all(dir: &Path, files: &[GeneratedFile]) -> io::Result<Vec<String>> {
    let mut written = Vec::new();
    for f in files {
        if write_if_changed(&dir.join(&f.name), &f.content)? {
            written.push(f.name.clone());
        }
    }
    Ok(written)
}
