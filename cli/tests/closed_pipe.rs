//! Every command that writes to stdout stops quietly when its reader goes away, as Unix tools do
//! (`ferrolink ... | head -1`): no panic, no error message, status 0. Each command runs with its
//! stdout on a pipe whose reading end is already closed, so its first write fails, whatever its
//! output's size; and once through a real `head -1`.

mod common;

use std::io::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};

use common::{ferrolink, workspace};

/// A HEARTBEAT in pymavlink's `to_dict()` form, for the encode commands.
const HEARTBEAT: &str = r#"{"mavpackettype":"HEARTBEAT","type":2,"autopilot":3,"base_mode":81,"custom_mode":7,"system_status":4,"mavlink_version":3}"#;

/// Runs `args` with `stdin` and a stdout nobody reads; fails on anything but a quiet exit 0.
fn closed_stdout(args: &[&str], stdin: &str) {
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let mut child = Command::new(ferrolink())
        .args(args)
        .current_dir(workspace())
        .stdin(Stdio::piped())
        .stdout(writer)
        .stderr(Stdio::piped())
        .spawn()
        .expect("ferrolink runs");
    let mut input = child.stdin.take().expect("stdin");
    // The command may stop before it reads everything.
    let _ = input.write_all(stdin.as_bytes());
    drop(input);
    let out = child.wait_with_output().expect("ferrolink exits");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !stderr.contains("panicked") && !stderr.contains("Broken pipe"),
        "ferrolink {}: {}\n{stderr}",
        args.join(" "),
        out.status
    );
}

/// A tlog of `n` heartbeats, 10 ms apart, made with `ferrolink mavlink encode`.
fn tlog(path: &Path, n: usize) {
    let mut child = Command::new(ferrolink())
        .args(["mavlink", "encode"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("ferrolink runs");
    let lines = format!("{HEARTBEAT}\n").repeat(n);
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(lines.as_bytes())
        .expect("lines written");
    let out = child.wait_with_output().expect("encode exits");
    assert!(out.status.success());
    let mut log = Vec::new();
    for (i, line) in String::from_utf8_lossy(&out.stdout).lines().enumerate() {
        log.extend_from_slice(&(1_700_000_000_000_000 + i as u64 * 10_000).to_be_bytes());
        log.extend_from_slice(&hex::decode(line).expect("hex frame"));
    }
    std::fs::write(path, log).expect("tlog written");
}

#[test]
fn every_stdout_command_stops_quietly_on_a_closed_pipe() {
    let dir = tempfile::tempdir().expect("a scratch directory");
    let log = dir.path().join("heartbeats.tlog");
    tlog(&log, 2000);
    let log = log.to_str().expect("utf-8 path");
    let plot = dir.path().join("rates.svg");
    let heartbeats = format!("{HEARTBEAT}\n").repeat(2000);
    let ndlcom = r#"{"receiver":1,"sender":2,"counter":3,"payload":"0102"}"#;
    let modrob = r#"{"type":"publication","module":258,"variable":3,"value":1.5}"#;
    let cases: &[(&[&str], String)] = &[
        (&["ir", "definitions/mavlink/minimal.xml"], String::new()),
        (
            &[
                "diff",
                "tools/tests/diff/old.xml",
                "tools/tests/diff/new.xml",
            ],
            String::new(),
        ),
        (&["mavlink", "encode"], heartbeats),
        (&["mavlink", "dump", log], String::new()),
        (
            &["mavlink", "stats", "--plot", plot.to_str().unwrap(), log],
            String::new(),
        ),
        (
            &[
                "mavlink",
                "router",
                "--run-for",
                "0.5",
                "udpin://127.0.0.1:0",
            ],
            String::new(),
        ),
        (&["ndlcom", "encode"], format!("{ndlcom}\n").repeat(500)),
        (
            &["ndlcom", "decode"],
            "7e0102030002010293f97e\n".repeat(500),
        ),
        (
            &["modrob", "encode", "--transport", "uart"],
            format!("{modrob}\n").repeat(500),
        ),
        (
            &["modrob", "decode", "--transport", "uart"],
            "5a06f0ee0b003412560200a7\n".repeat(500),
        ),
        (
            &["tosnet", "cycle", "--nodes", "4", "--registers", "8"],
            String::new(),
        ),
    ];
    for (args, stdin) in cases {
        closed_stdout(args, stdin);
    }
    assert!(
        plot.exists(),
        "the plot is written although stdout is closed"
    );
}

/// The same through a real `head -1` under `pipefail`: the pipeline succeeds and prints one line.
#[test]
fn piped_into_head() {
    let out = Command::new("bash")
        .arg("-c")
        .arg(format!(
            "set -o pipefail; {} ir definitions/mavlink/minimal.xml | head -1",
            ferrolink()
        ))
        .current_dir(workspace())
        .output()
        .expect("bash runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{}\n{stderr}", out.status);
    assert_eq!(String::from_utf8_lossy(&out.stdout), "{\n");
    assert!(stderr.is_empty(), "{stderr}");
}
