//! Where a program's logs go: a file it appends to, or a directory that gets a new numbered
//! file per run, the oldest deleted to keep a number of files or some free space, as
//! mavlink-router keeps its logs.

use std::fs::{File, OpenOptions};
use std::io;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// How many logs a directory keeps, and how much room it leaves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Retention {
    /// Delete the oldest logs while there are more than this (the new one included).
    pub max_files: Option<usize>,
    /// Delete the oldest logs while the disk has less free than this many bytes.
    pub min_free_bytes: Option<u64>,
}

/// A log opened by [`open`]: its path, the file, and the logs deleted to make room.
#[derive(Debug)]
pub struct Opened {
    /// Where it is.
    pub path: PathBuf,
    /// The file, positioned at its end.
    pub file: File,
    /// Older logs deleted for [`Retention`], oldest first.
    pub deleted: Vec<PathBuf>,
}

/// Opens where a log goes. A directory gets a new file per call,
/// `NNNNN-YYYY-MM-DD_HH-MM-SS.tlog` (a counter one past the highest there, and the time in
/// UTC), never overwriting one; then the oldest of its numbered logs, never the new one, are
/// deleted as `retention` asks. A path ending in `.tlog`, or anything there that is not a
/// directory (a file, a FIFO), is a file, appended to (created if need be): a restart adds to
/// it, never truncates it. A directory is never created: a path that is neither is an error
/// with a hint, as is a file in a directory that does not exist.
pub fn open(path: &Path, retention: Retention) -> io::Result<Opened> {
    let named = |e: io::Error, p: &Path| io::Error::new(e.kind(), format!("{}: {e}", p.display()));
    if is_file(path) {
        let file = OpenOptions::new()
            .append(true)
            .create(true)
            .open(path)
            .map_err(|e| {
                let hint = missing_dir_hint(path);
                io::Error::new(e.kind(), format!("{}: {e}{hint}", path.display()))
            })?;
        return Ok(Opened {
            path: path.to_path_buf(),
            file,
            deleted: Vec::new(),
        });
    }
    if !path.is_dir() {
        return Err(not_a_directory(path));
    }
    let mut logs = numbered(path)?;
    let time = humantime::format_rfc3339_seconds(SystemTime::now()).to_string();
    let time = time
        .trim_end_matches('Z')
        .replace('T', "_")
        .replace(':', "-");
    let mut counter = logs.last().map_or(1, |(n, _)| n + 1);
    let (new, file) = loop {
        let candidate = path.join(format!("{counter:05}-{time}.tlog"));
        match OpenOptions::new()
            .append(true)
            .create_new(true)
            .open(&candidate)
        {
            Ok(file) => break (candidate, file),
            // Another program took the name first: the next number.
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => counter += 1,
            Err(e) => return Err(named(e, &candidate)),
        }
    };
    let mut deleted = Vec::new();
    let too_many =
        |logs: &[(u64, PathBuf)]| retention.max_files.is_some_and(|max| logs.len() + 1 > max);
    let too_full = || {
        retention
            .min_free_bytes
            .is_some_and(|min| free_bytes(path).is_some_and(|free| free < min))
    };
    while !logs.is_empty() && (too_many(&logs) || too_full()) {
        let (_, oldest) = logs.remove(0);
        std::fs::remove_file(&oldest).map_err(|e| named(e, &oldest))?;
        deleted.push(oldest);
    }
    Ok(Opened {
        path: new,
        file,
        deleted,
    })
}

/// Whether [`open`] could open a log at `path` (a `.tlog` file whose directory exists, or a
/// directory), without opening one: the same errors, at once.
pub fn check(path: &Path) -> io::Result<()> {
    if is_file(path) {
        let hint = missing_dir_hint(path);
        if hint.is_empty() {
            return Ok(());
        }
        return Err(io::Error::new(
            io::ErrorKind::NotFound,
            format!("{}: no such directory{hint}", path.display()),
        ));
    }
    if path.is_dir() {
        return Ok(());
    }
    Err(not_a_directory(path))
}

/// A path ending in `.tlog`, or anything there but a directory (a file, a FIFO).
fn is_file(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "tlog") || path.exists() && !path.is_dir()
}

fn not_a_directory(path: &Path) -> io::Error {
    io::Error::new(
        io::ErrorKind::NotFound,
        format!(
            "{}: no such directory\n  hint: create it for a log per run, or give a file \
             name ending in .tlog",
            path.display()
        ),
    )
}

/// For a file that could not be created: a hint line when its directory does not exist.
pub(crate) fn missing_dir_hint(path: &Path) -> String {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => {
            format!("\n  hint: the directory {} does not exist", dir.display())
        }
        _ => String::new(),
    }
}

/// The logs of `dir` named `NNNNN-...tlog`, by number.
fn numbered(dir: &Path) -> io::Result<Vec<(u64, PathBuf)>> {
    let mut logs = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let number = name
            .strip_suffix(".tlog")
            .and_then(|n| n.split_once('-'))
            .and_then(|(n, _)| n.parse::<u64>().ok());
        if let Some(n) = number {
            logs.push((n, path));
        }
    }
    logs.sort();
    Ok(logs)
}

/// The bytes free for us on the file system of `dir`.
#[cfg(unix)]
// The counts are the platform's C types: u64 here, 32 bits on some.
#[allow(clippy::useless_conversion)]
fn free_bytes(dir: &Path) -> Option<u64> {
    let stat = nix::sys::statvfs::statvfs(dir).ok()?;
    Some(u64::from(stat.blocks_available()).saturating_mul(u64::from(stat.fragment_size())))
}

#[cfg(not(unix))]
fn free_bytes(_: &Path) -> Option<u64> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_directory_gets_a_numbered_file_per_run_and_keeps_what_it_is_told() {
        let dir = tempfile::tempdir().expect("tempdir");
        let logs = dir.path().join("logs");
        let missing = open(&logs, Retention::default()).unwrap_err().to_string();
        assert!(missing.contains("no such directory"), "{missing}");
        std::fs::create_dir(&logs).expect("mkdir");
        let mut names = Vec::new();
        for _ in 0..3 {
            let opened = open(&logs, Retention::default()).expect("opens");
            names.push(
                opened
                    .path
                    .file_name()
                    .unwrap()
                    .to_string_lossy()
                    .into_owned(),
            );
        }
        assert!(
            names[0].starts_with("00001-") && names[2].starts_with("00003-"),
            "{names:?}"
        );
        assert!(names
            .iter()
            .all(|n| n.len() == "00001-2026-11-29_07-10-00.tlog".len()));
        // Three more, keeping two: the oldest go, never the new one.
        let keep = Retention {
            max_files: Some(2),
            min_free_bytes: None,
        };
        let opened = open(&logs, keep).expect("opens");
        assert_eq!(opened.deleted.len(), 2);
        assert!(opened
            .path
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with("00004-"));
        let left: Vec<u64> = numbered(&logs)
            .unwrap()
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        assert_eq!(left, [3, 4]);
        // Asking for more room than any disk has deletes every other log, never the new one.
        let room = Retention {
            max_files: None,
            min_free_bytes: Some(u64::MAX),
        };
        let opened = open(&logs, room).expect("opens");
        let left: Vec<u64> = numbered(&logs)
            .unwrap()
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        assert_eq!((opened.deleted.len(), left), (2, vec![5]));
    }

    #[test]
    fn a_tlog_file_is_appended_to() {
        use std::io::Write;
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("flight.tlog");
        for run in 0..2u8 {
            let mut opened = open(&path, Retention::default()).expect("opens");
            opened.file.write_all(&[run; 3]).expect("writes");
        }
        assert_eq!(std::fs::read(&path).unwrap(), [0, 0, 0, 1, 1, 1]);
    }
}
