//! What the CLI's tests share: the binary, a router's start, the workspace, and the reference
//! Python.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};

/// The `ferrolink` binary under test.
pub fn ferrolink() -> &'static str {
    env!("CARGO_BIN_EXE_ferrolink")
}

/// Waits for a router's `ready` line on its (piped) stdout.
pub fn wait_ready(router: &mut Child) {
    let mut line = String::new();
    BufReader::new(router.stdout.as_mut().expect("stdout"))
        .read_line(&mut line)
        .expect("read");
    assert!(line.starts_with("ready"), "{line}");
}

/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A Python with pymavlink (`FERROLINK_PYTHON`, else `.venv/bin/python`) and pymavlink's
/// dialect folder.
pub fn pymavlink() -> Option<(PathBuf, PathBuf)> {
    let python = std::env::var_os("FERROLINK_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join(".venv/bin/python"));
    let out = Command::new(&python)
        .args([
            "-c",
            "import pymavlink, os; print(os.path.dirname(pymavlink.__file__))",
        ])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let dir = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    Some((python, dir.join("dialects/v20")))
}

/// The real captures, `../shared/captures` beside the repository: `None`, after a one-line
/// note, when the directory is not there. Where it is there, tests that read it are required.
pub fn captures() -> Option<PathBuf> {
    let dir = workspace().join("../shared/captures");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipped: ../shared/captures is not there");
        None
    }
}

/// Says why a test did nothing, and fails if the full run requires pymavlink.
pub fn skip(why: &str) {
    assert!(
        std::env::var_os("FERROLINK_REQUIRE_PYMAVLINK").is_none(),
        "{why}, but FERROLINK_REQUIRE_PYMAVLINK is set"
    );
    eprintln!("skipped: {why}");
}

/// Runs a checks script of `tests/mavlink/` against the router (`--router`, `--dialect-dir`,
/// `--workdir`) and returns its output; fails unless every check passed. `None` when pymavlink
/// is missing (after [`skip`]).
pub fn run_router_checks(script: &str) -> Option<String> {
    let Some((python, dialects)) = pymavlink() else {
        skip("pymavlink is missing");
        return None;
    };
    Some(run_checks(
        &python,
        &format!("mavlink/{script}"),
        &[
            "--router".as_ref(),
            ferrolink().as_ref(),
            "--dialect-dir".as_ref(),
            dialects.as_os_str(),
        ],
    ))
}

/// Runs the checks script `tests/SCRIPT` with `python`, `args` and a fresh `--workdir`, and
/// returns its output. Each check prints `ok`, `FAIL` or `skip` and the script ends with
/// `N passed, M failed`; the test fails unless every check passed.
pub fn run_checks(python: &Path, script: &str, args: &[&std::ffi::OsStr]) -> String {
    let workdir = tempfile::tempdir().expect("a scratch directory");
    let out = Command::new(python)
        .arg(workspace().join("tests").join(script))
        .args(args)
        .arg("--workdir")
        .arg(workdir.path())
        .output()
        .unwrap_or_else(|e| panic!("cannot run {script}: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    eprintln!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "some checks failed:\n{stdout}");
    assert!(stdout.contains(" 0 failed"), "{stdout}");
    stdout
}

/// Fails when a check of `stdout` was skipped for want of `tool` while the full run, which
/// installs it, sets `require` (e.g. `FERROLINK_REQUIRE_TSHARK`).
pub fn require_no_skip(stdout: &str, require: &str, tool: &str) {
    require_no_skip_but(stdout, require, tool, &[]);
}

/// Like [`require_no_skip`], but the checks named in `allowed` may skip.
pub fn require_no_skip_but(stdout: &str, require: &str, tool: &str, allowed: &[&str]) {
    let allowed = |line: &str| {
        allowed
            .iter()
            .any(|name| line.starts_with(&format!("skip {name}:")))
    };
    if std::env::var_os(require).is_some() {
        assert!(
            !stdout.lines().any(|l| l.starts_with("skip") && !allowed(l)),
            "a check was skipped although {tool} is installed:\n{stdout}"
        );
    }
}
