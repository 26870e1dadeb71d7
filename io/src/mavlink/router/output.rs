//! The router's own outputs beside routing (its lines on stderr, the files it writes) and what
//! it says when one of them fails.

use super::*;

/// Says `line` on stderr through the process's printer, so that a stderr nobody reads never
/// holds up routing.
pub(super) fn say(line: String) {
    let _ = printer::stderr().line(line);
}

/// Creates an output file (`what`: "tlog", "statistics file"); the error names it by what it
/// is, not by the option (it may come from a configuration file), with the path, and says when
/// the directory is missing.
pub(super) fn create(what: &str, path: &std::path::Path) -> io::Result<File> {
    File::create(path).map_err(|e| {
        let hint = tlog::files::missing_dir_hint(path);
        io::Error::new(e.kind(), format!("{what} {}: {e}{hint}", path.display()))
    })
}

/// The error of the output `what` (a file by what it is, `--stats` by its option, the only way
/// to ask for it), written to `path` (else to stdout), that failed with `e`:
/// said on stderr at once, since routing goes on without that output.
pub(super) fn give_up(what: &str, path: Option<&std::path::Path>, e: &io::Error) -> io::Error {
    let to = path.map_or_else(|| "stdout".to_owned(), |p| p.display().to_string());
    say(format!(
        "{what} {to}: {e}; no more is written to it, routing goes on"
    ));
    io::Error::new(
        e.kind(),
        format!("{what} {to}: {e} (given up while routing)"),
    )
}
