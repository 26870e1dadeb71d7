//! Conformance against pymavlink 2.4.50, the reference encoder: vectors for every message of
//! common.xml and all.xml (and of our own dialects) are generated with pymavlink, then the
//! conformance runner, built with bindings for that dialect, checks both directions byte-exact.
//!
//! Needs a Python with pymavlink 2.4.50: `FERROLINK_PYTHON`, else `.venv/bin/python` in the
//! workspace (`tests/run-all.sh` sets it up). Without one the test says so and passes, unless
//! `FERROLINK_REQUIRE_PYMAVLINK` is set, as the full test run does whenever the install worked.

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The reference Python and its dialect folder, if available.
fn pymavlink() -> Option<(PathBuf, PathBuf)> {
    let python = std::env::var_os("FERROLINK_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join(".venv/bin/python"));
    let out = Command::new(&python)
        .args(["-c", "import pymavlink, os; print(pymavlink.__version__ if hasattr(pymavlink,'__version__') else ''); print(os.path.dirname(pymavlink.__file__))"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let dir = PathBuf::from(text.lines().nth(1)?.trim());
    Some((python, dir.join("dialects/v20")))
}

fn scratch() -> PathBuf {
    let dir = workspace().join("target/conformance");
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scripts")
        .join(name)
}

fn run(cmd: &mut Command) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{cmd:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Builds the runner for `xml` (in its own target dir, as this test runs inside cargo) and runs
/// it with `args`.
fn runner(xml: &Path, args: &[&str]) -> String {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    run(Command::new(cargo)
        .current_dir(workspace())
        .env("FERROLINK_XML", xml)
        .args([
            "run",
            "--quiet",
            "--release",
            "-p",
            "ferrolink-conformance",
            "--target-dir",
        ])
        .arg(scratch().join("target"))
        .arg("--")
        .args(args))
}

fn check_dialect(python: &Path, xml: &Path, min_messages: usize) {
    let name = xml.file_stem().unwrap().to_string_lossy().into_owned();
    let vectors = scratch().join(format!("{name}.jsonl"));
    run(Command::new(python)
        .arg(script("gen_vectors.py"))
        .arg(xml)
        .arg(&vectors));
    let summary = runner(xml, &[vectors.to_str().unwrap()]);
    let line = summary.lines().last().unwrap_or_default().to_string();
    eprintln!("{name}: {line}");
    let passed: usize = line.split(' ').next().unwrap().parse().expect("N passed");
    assert!(line.ends_with(" 0 failed"), "{name}: {line}");
    assert!(passed >= min_messages, "{name}: only {passed} vectors");
}

fn require() -> Option<(PathBuf, PathBuf)> {
    let found = pymavlink();
    if found.is_none() {
        assert!(
            std::env::var_os("FERROLINK_REQUIRE_PYMAVLINK").is_none(),
            "pymavlink is required but not found (set FERROLINK_PYTHON)"
        );
        eprintln!("pymavlink not found: conformance skipped (run tests/run-all.sh)");
    }
    found
}

#[test]
fn common_xml_every_message_both_directions() {
    let Some((python, dialects)) = require() else {
        return;
    };
    check_dialect(&python, &dialects.join("common.xml"), 210);
}

#[test]
fn all_xml_every_message_both_directions() {
    let Some((python, dialects)) = require() else {
        return;
    };
    check_dialect(&python, &dialects.join("all.xml"), 353);
}

#[test]
fn our_dialects_match_the_reference() {
    let Some((python, _)) = require() else { return };
    for d in ["usv.xml", "bench.xml"] {
        check_dialect(&python, &workspace().join("definitions/mavlink").join(d), 9);
    }
}

/// A raw capture with garbage between frames decodes to exactly what pymavlink decodes.
#[test]
fn stream_capture_matches_pymavlink() {
    let Some((python, dialects)) = require() else {
        return;
    };
    let xml = dialects.join("common.xml");
    let (bin, expected) = (scratch().join("stream.bin"), scratch().join("stream.jsonl"));
    run(Command::new(&python)
        .arg(script("gen_stream.py"))
        .arg(&xml)
        .arg(&bin)
        .arg(&expected));
    let ours = runner(&xml, &["--stream", bin.to_str().unwrap()]);
    let parse = |text: &str| -> Vec<serde_json::Value> {
        text.lines()
            .filter(|l| !l.is_empty())
            .map(|l| serde_json::from_str(l).expect("json"))
            .collect()
    };
    let (ours, theirs) = (
        parse(&ours),
        parse(&std::fs::read_to_string(expected).unwrap()),
    );
    assert_eq!(ours.len(), theirs.len());
    for (a, b) in ours.iter().zip(&theirs) {
        assert_eq!(a, b);
    }
}
