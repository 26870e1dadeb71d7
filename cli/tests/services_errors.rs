//! What `ferrolink mavlink param|mission|command|vehicle` say about what they cannot do: a bad
//! URI, an unreadable or malformed file, an unknown command name, a parameter nobody answers
//! for. Each prints a message and exits non-zero, never a panic.

use std::process::{Command, Output};

fn ferrolink(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ferrolink"))
        .arg("mavlink")
        .args(args)
        .output()
        .expect("ferrolink runs")
}

/// Stderr of a run that must fail with `code`.
fn refused(args: &[&str], code: i32) -> String {
    let out = ferrolink(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(code), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn a_bad_uri() {
    let err = refused(&["param", "list", "udpin://nowhere:99999"], 1);
    assert!(
        err.starts_with("udpin://nowhere:99999: bad port \"99999\""),
        "{err}"
    );
    assert!(err.contains("hint: accepted forms: "), "{err}");
}

#[test]
fn an_unknown_command_name() {
    insta::assert_snapshot!(refused(&["command", "udpin://127.0.0.1:0", "FLY_TO_THE_MOON"], 1), @"`FLY_TO_THE_MOON` is not a MAV_CMD name or number (e.g. COMPONENT_ARM_DISARM or 400)");
}

#[test]
fn a_bad_target_and_a_bad_type() {
    let err = refused(
        &[
            "param",
            "get",
            "udpin://127.0.0.1:0",
            "X",
            "--target",
            "1-1",
        ],
        2,
    );
    assert!(
        err.contains("write the target as SYS/COMP, e.g. 1/1"),
        "{err}"
    );
    insta::assert_snapshot!(refused(&["param", "set", "udpin://127.0.0.1:0", "X", "1", "--type", "INT64"], 1), @"--type INT64: use UINT8, INT8, UINT16, INT16, UINT32, INT32 or REAL32 (and with --ext UINT64, INT64, REAL64 or CUSTOM)");
    insta::assert_snapshot!(refused(&["param", "set", "udpin://127.0.0.1:0", "X", "1", "--type", "INT128", "--ext"], 1), @"--type INT128: use UINT8, INT8, UINT16, INT16, UINT32, INT32 or REAL32, UINT64, INT64, REAL64 or CUSTOM");
}

#[test]
fn unreadable_and_malformed_files() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.params");
    let err = refused(
        &[
            "vehicle",
            "--params",
            missing.to_str().unwrap(),
            "udpin://127.0.0.1:0",
        ],
        1,
    );
    assert!(err.contains("missing.params: cannot read it"), "{err}");
    let bad = dir.path().join("bad.params");
    std::fs::write(&bad, "1\t1\tA\t1.5\t6\n1\t1\tB\t1\t12\n").unwrap();
    let err = refused(
        &[
            "vehicle",
            "--params",
            bad.to_str().unwrap(),
            "udpin://127.0.0.1:0",
        ],
        1,
    );
    let err = err.replace(bad.to_str().unwrap(), "bad.params");
    insta::assert_snapshot!(err, @r"
    bad.params:1: `1.5` is not a value of type INT32
    bad.params:2: type `12` is not one of 1 to 10 (UINT8 to INT64, REAL32, REAL64)
    ");
    let wpl = dir.path().join("bad.waypoints");
    std::fs::write(&wpl, "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t1\t2\n").unwrap();
    let err = refused(
        &[
            "mission",
            "upload",
            "udpin://127.0.0.1:0",
            wpl.to_str().unwrap(),
        ],
        1,
    );
    let err = err.replace(wpl.to_str().unwrap(), "bad.waypoints");
    insta::assert_snapshot!(err, @"bad.waypoints: line 2: 10 fields; an item has 12: seq current frame command p1 p2 p3 p4 x y z autocontinue");
}

#[test]
fn a_parameter_nobody_answers_for() {
    let port = ferrolink_test_support::free_port();
    let mut vehicle = Command::new(env!("CARGO_BIN_EXE_ferrolink"))
        .args(["mavlink", "vehicle", "--run-for", "30"])
        .arg(format!("udpout://127.0.0.1:{port}"))
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let err = refused(
        &[
            "param",
            "get",
            &format!("udpin://127.0.0.1:{port}"),
            "NO_SUCH",
        ],
        1,
    );
    let _ = vehicle.kill();
    let _ = vehicle.wait();
    insta::assert_snapshot!(err, @"no answer about `NO_SUCH` from 1/1: the vehicle has no such parameter, or does not answer");
}
