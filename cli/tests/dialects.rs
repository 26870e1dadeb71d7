//! The built-in dialects on the command line: `ferrolink mavlink dialects` lists them, and
//! `--dialect` takes a built-in name (any case) or a file, with a clear error for neither.

mod common;

use std::io::Write;
use std::process::{Command, Stdio};

use common::ferrolink;

/// Runs `ferrolink ARGS` with `stdin`; returns stdout, stderr and whether it succeeded.
fn run(args: &[&str], stdin: &str) -> (String, String, bool) {
    let mut child = Command::new(ferrolink())
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run ferrolink");
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(stdin.as_bytes())
        .expect("write stdin");
    let out = child.wait_with_output().expect("wait");
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        out.status.success(),
    )
}

#[test]
fn dialects_lists_every_built_in_dialect() {
    let (out, err, ok) = run(&["mavlink", "dialects"], "");
    assert!(ok, "{err}");
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect();
    assert_eq!(lines.len(), 19, "{out}");
    let line = |name: &str| {
        lines
            .iter()
            .find(|l| l["name"] == name)
            .unwrap_or_else(|| panic!("no {name} in {out}"))
    };
    // The counts of pymavlink 2.4.50's modules, includes and merged enums in.
    assert_eq!(
        line("ardupilotmega"),
        &serde_json::json!({"name": "ardupilotmega", "messages": 301, "enums": 207})
    );
    assert_eq!(line("common")["messages"], 210);
    assert_eq!(line("all")["messages"], 353);
    assert!(out.starts_with(r#"{"name": "all", "messages": 353, "enums": 232}"#));
}

/// Without `--dialect`, encode and decode know ardupilotmega; a built-in name works in any case.
#[test]
fn dialect_takes_a_built_in_name() {
    // SENSOR_OFFSETS (150) is ArduPilot's.
    let json = r#"{"mavpackettype": "SENSOR_OFFSETS", "mag_ofs_x": 7}"#;
    let (out, err, ok) = run(&["mavlink", "encode"], json);
    assert!(ok, "{err}");
    assert!(out.starts_with("fd"), "{out}");
    let (common, err, ok) = run(&["mavlink", "encode", "--dialect", "COMMON"], json);
    assert!(
        !ok && common.is_empty(),
        "common has no SENSOR_OFFSETS: {common}"
    );
    assert!(err.contains("SENSOR_OFFSETS"), "{err}");
    let heartbeat = r#"{"mavpackettype": "HEARTBEAT", "type": 2}"#;
    let (out, err, ok) = run(&["mavlink", "encode", "--dialect", "minimal"], heartbeat);
    assert!(ok && out.starts_with("fd"), "{err}");
}

#[test]
fn an_unknown_dialect_is_a_clear_error() {
    let (out, err, ok) = run(&["mavlink", "dump", "--dialect", "ardupilot", "x.tlog"], "");
    assert!(!ok && out.is_empty());
    insta::assert_snapshot!(err.trim_end(), @"--dialect ardupilot: no such file, and no built-in dialect has that name (built in: all, ardupilotmega, ASLUAV, AVSSUAS, common, csAirLink, cubepilot, development, icarous, loweheiser, matrixpilot, minimal, paparazzi, python_array_test, standard, storm32, test, ualberta, uAvionix)");
}
