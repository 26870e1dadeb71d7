//! The router's logs, run after run: `--tlog DIR` gets a new numbered file per run and never
//! overwrites one, `--tlog FILE.tlog` is appended to, `main.conf`'s `Log`, `MaxLogFiles` and
//! `MinFreeSpace` keep a directory as mavlink-router does, and a log cut short by `kill -9`
//! reads back to its last whole record.

mod common;

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::Duration;

use ferrolink_io::mavlink::tlog::read_tlog;
use ferrolink_runtime::mavlink::{v2, Header};
use ferrolink_test_support::free_port;

/// A HEARTBEAT from system `sysid` (id 0, CRC_EXTRA 50).
fn heartbeat(sysid: u8, seq: u8) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(seq, sysid, 1), 0, 50, &[0; 9], &mut out).expect("fits");
    out[..n].to_vec()
}

/// Starts a router on a `udpin` port with `args` and waits until it is ready.
fn router(args: &[&str]) -> (Child, u16) {
    let port = free_port();
    let mut child = Command::new(common::ferrolink())
        .args(["mavlink", "router", &format!("udpin://127.0.0.1:{port}")])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the router starts");
    common::wait_ready(&mut child);
    (child, port)
}

/// Sends `n` heartbeats of system `sysid` to `port`, a millisecond apart.
fn send(port: u16, sysid: u8, n: u8) {
    let sock = UdpSocket::bind("127.0.0.1:0").expect("bind");
    for seq in 0..n {
        sock.send_to(&heartbeat(sysid, seq), ("127.0.0.1", port))
            .expect("send");
        thread::sleep(Duration::from_millis(1));
    }
}

/// Stops a router with SIGTERM and returns its stderr.
fn stop(child: Child) -> String {
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let out = child.wait_with_output().expect("the router exits");
    assert!(out.status.success(), "{out:?}");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// One run: a router logging with `args`, `n` heartbeats of system `sysid`, stopped.
fn run(args: &[&str], sysid: u8, n: u8) -> String {
    let (child, port) = router(args);
    send(port, sysid, n);
    thread::sleep(Duration::from_millis(200));
    stop(child)
}

/// The systems of the frames of a log, in order, and whether it read to its end cleanly.
fn systems(path: &Path) -> (Vec<u8>, u64, u64) {
    let data = std::fs::read(path).expect("the log");
    let mut systems = Vec::new();
    let stats = read_tlog(&data, &[], |r| systems.push(r.frame.header().sysid));
    (systems, stats.skipped_bytes, stats.truncated_bytes)
}

fn logs(dir: &Path) -> Vec<PathBuf> {
    let mut logs: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("the directory")
        .map(|e| e.expect("an entry").path())
        .collect();
    logs.sort();
    logs
}

#[test]
fn a_directory_gets_a_new_log_per_run_and_a_file_is_appended_to() {
    let dir = tempfile::tempdir().expect("tempdir");
    let logs_dir = dir.path().join("logs");
    std::fs::create_dir(&logs_dir).expect("mkdir");
    let arg = logs_dir.to_str().unwrap();
    let said = run(&["--tlog", arg], 1, 20);
    run(&["--tlog", arg], 2, 30);
    let files = logs(&logs_dir);
    assert_eq!(files.len(), 2, "{files:?}");
    assert!(
        said.contains(&format!("tlog: writing {}", files[0].display())),
        "{said}"
    );
    let names: Vec<String> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert!(
        names[0].starts_with("00001-") && names[1].starts_with("00002-"),
        "{names:?}"
    );
    assert_eq!(systems(&files[0]), (vec![1; 20], 0, 0));
    assert_eq!(systems(&files[1]), (vec![2; 30], 0, 0));

    let file = dir.path().join("flight.tlog");
    let arg = file.to_str().unwrap();
    run(&["--tlog", arg], 3, 10);
    run(&["--tlog", arg], 4, 10);
    let (got, skipped, truncated) = systems(&file);
    assert_eq!(got, [vec![3; 10], vec![4; 10]].concat());
    assert_eq!((skipped, truncated), (0, 0));
}

#[test]
fn main_conf_keeps_the_log_directory_within_its_limits() {
    let dir = tempfile::tempdir().expect("tempdir");
    let logs_dir = dir.path().join("logs");
    std::fs::create_dir(&logs_dir).expect("mkdir");
    let conf = dir.path().join("main.conf");
    std::fs::write(
        &conf,
        format!(
            "[General]\nTcpServerPort = 0\nLog = {}\nMaxLogFiles = 2\n",
            logs_dir.display()
        ),
    )
    .expect("write main.conf");
    let conf = conf.to_str().unwrap();
    for sysid in 1..=3 {
        let said = run(&["--config", conf], sysid, 5);
        if sysid == 3 {
            assert!(
                said.contains("00001-") && said.contains("deleted"),
                "{said}"
            );
        }
    }
    let files = logs(&logs_dir);
    let kept: Vec<Vec<u8>> = files.iter().map(|f| systems(f).0).collect();
    assert_eq!(kept, [vec![2; 5], vec![3; 5]], "{files:?}");
}

#[test]
fn a_log_cut_short_by_kill_9_reads_back_to_its_last_whole_record() {
    let dir = tempfile::tempdir().expect("tempdir");
    let logs_dir = dir.path().join("logs");
    std::fs::create_dir(&logs_dir).expect("mkdir");
    let (mut child, port) = router(&["--tlog", logs_dir.to_str().unwrap()]);
    send(port, 7, 200);
    // The router hands its records to the file once a second.
    thread::sleep(Duration::from_millis(1500));
    child.kill().expect("kill -9");
    let _ = child.wait();
    let files = logs(&logs_dir);
    assert_eq!(files.len(), 1);
    let (got, skipped, _truncated) = systems(&files[0]);
    assert_eq!(
        got,
        vec![7; 200],
        "every record handed over was written whole"
    );
    assert_eq!(skipped, 0);
}

/// A HEARTBEAT from `sysid` with `autopilot` (8: not a vehicle), armed or not.
fn heartbeat_armed(sysid: u8, seq: u8, autopilot: u8, armed: bool) -> Vec<u8> {
    let payload = [
        0,
        0,
        0,
        0,
        2,
        autopilot,
        if armed { 128 | 1 } else { 1 },
        4,
        3,
    ];
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(seq, sysid, 1), 0, 50, &payload, &mut out).expect("fits");
    out[..n].to_vec()
}

/// Each record of a log as (system, armed).
fn flight(path: &Path) -> Vec<(u8, bool)> {
    let data = std::fs::read(path).expect("the log");
    let mut records = Vec::new();
    let stats = read_tlog(&data, &[], |r| {
        let armed = r.frame.payload().get(6).is_some_and(|m| m & 128 != 0);
        records.push((r.frame.header().sysid, armed));
    });
    assert_eq!((stats.skipped_bytes, stats.truncated_bytes), (0, 0));
    records
}

#[test]
fn while_armed_writes_a_log_per_flight_across_restarts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let logs_dir = dir.path().join("logs");
    std::fs::create_dir(&logs_dir).expect("mkdir");
    let args = [
        "--tlog",
        logs_dir.to_str().unwrap(),
        "--log-mode",
        "while-armed",
    ];
    let sock = UdpSocket::bind("127.0.0.1:0").expect("bind");
    let mut seq = 0u8;
    let mut say = |port: u16, sysid: u8, autopilot: u8, armed: bool, n: usize| {
        for _ in 0..n {
            let frame = heartbeat_armed(sysid, seq, autopilot, armed);
            sock.send_to(&frame, ("127.0.0.1", port)).expect("send");
            seq = seq.wrapping_add(1);
            thread::sleep(Duration::from_millis(2));
        }
    };
    let (child, port) = router(&args);
    // A ground station's heartbeat, armed flag or not, is not a vehicle's.
    say(port, 255, 8, true, 2);
    say(port, 1, 3, false, 3);
    assert!(logs(&logs_dir).is_empty(), "nothing logged before arming");
    // Flight 1, with a second vehicle armed meanwhile: logged, but it decides nothing.
    say(port, 1, 3, true, 3);
    say(port, 2, 3, true, 1);
    say(port, 1, 3, true, 1);
    say(port, 1, 3, false, 2);
    // Flight 2.
    say(port, 1, 3, true, 4);
    say(port, 1, 3, false, 1);
    thread::sleep(Duration::from_millis(200));
    let said = stop(child);
    assert!(said.contains("armed: a new flight's log"), "{said}");
    // Flight 3 runs when the router stops: its log is closed whole.
    let (child, port) = router(&args);
    say(port, 1, 3, true, 3);
    thread::sleep(Duration::from_millis(200));
    stop(child);

    let files = logs(&logs_dir);
    let names: Vec<String> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 3, "{names:?}");
    for (i, name) in names.iter().enumerate() {
        assert!(name.starts_with(&format!("{:05}-", i + 1)), "{names:?}");
    }
    let mut first = vec![(1, true); 3];
    first.extend([(2, true), (1, true), (1, false)]);
    assert_eq!(flight(&files[0]), first);
    let second = [vec![(1, true); 4], vec![(1, false)]].concat();
    assert_eq!(flight(&files[1]), second);
    assert_eq!(flight(&files[2]), vec![(1, true); 3]);
}

#[test]
fn while_armed_needs_a_place_for_its_logs_at_start() {
    let out = Command::new(common::ferrolink())
        .args([
            "mavlink",
            "router",
            "udpin://127.0.0.1:0",
            "--log-mode",
            "while-armed",
        ])
        .args(["--tlog", "/nonexistent/logs"])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("/nonexistent/logs: no such directory"),
        "{err}"
    );
}
