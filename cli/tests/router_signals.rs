//! `ferrolink mavlink router` takes signals as daemons do: SIGHUP reloads the endpoints of the
//! configuration file and keeps the router running; without a file it is logged and ignored;
//! under `nohup` (SIGHUP ignored from the start) it stays ignored; SIGTERM stops the router with
//! status 0. A standard output, a tlog or a statistics file nobody reads holds none of it up.
//!
//! Before, SIGHUP ended the router even under `nohup`, so a router started from an SSH session
//! died with the session.

mod common;

use std::io::{BufRead, BufReader, Read};
use std::net::UdpSocket;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_runtime::mavlink::{v2, Header};
use ferrolink_test_support::free_port;

fn heartbeat(sysid: u8) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(0, sysid, 1), 0, 50, &[0; 9], &mut out).expect("fits");
    out[..n].to_vec()
}

/// Starts the router through `sh` (`prelude` may set up signals, as `nohup` does) and waits
/// for its `ready` line.
fn start(prelude: &str, args: &[String]) -> Child {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("{prelude} exec \"$0\" mavlink router \"$@\""))
        .arg(env!("CARGO_BIN_EXE_ferrolink"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the router starts");
    common::wait_ready(&mut child);
    child
}

fn signal(child: &Child, name: &str) {
    let ok = Command::new("kill")
        .args([format!("-{name}"), child.id().to_string()])
        .status()
        .expect("kill runs")
        .success();
    assert!(ok, "kill -{name}");
}

/// Stops the router with SIGTERM and returns its stderr; it must exit with status 0.
fn stop(mut child: Child) -> String {
    signal(&child, "TERM");
    let status = exit(&mut child);
    let mut err = String::new();
    child
        .stderr
        .take()
        .expect("stderr")
        .read_to_string(&mut err)
        .expect("read");
    assert_eq!(status.code(), Some(0), "{err}");
    err
}

fn alive(child: &mut Child) -> bool {
    child.try_wait().expect("wait").is_none()
}

/// Whether a peer sending to `to_port` hears a heartbeat sent into `from_port`.
fn routes(from_port: u16, to_port: u16) -> bool {
    let listener = UdpSocket::bind("127.0.0.1:0").expect("bind");
    listener
        .set_read_timeout(Some(Duration::from_millis(100)))
        .expect("timeout");
    let talker = UdpSocket::bind("127.0.0.1:0").expect("bind");
    let mut buf = [0u8; 512];
    for _ in 0..20 {
        let _ = listener.send_to(&heartbeat(255), ("127.0.0.1", to_port));
        let _ = talker.send_to(&heartbeat(1), ("127.0.0.1", from_port));
        if let Ok(n) = listener.recv(&mut buf) {
            if buf[..n] == heartbeat(1)[..] {
                return true;
            }
        }
    }
    false
}

fn write_config(path: &Path, ports: &[u16]) {
    let text: String = ports
        .iter()
        .map(|p| format!("[[endpoint]]\nuri = \"udpin://127.0.0.1:{p}\"\n\n"))
        .collect();
    std::fs::write(path, text).expect("config written");
}

#[test]
fn sighup_reloads_the_configuration_file() {
    let dir = tempfile::tempdir().expect("scratch");
    let config = dir.path().join("router.toml");
    let (a, b, c) = (free_port(), free_port(), free_port());
    write_config(&config, &[a, b]);
    let mut router = start("", &["--config".into(), config.display().to_string()]);
    assert!(routes(a, b), "A to B before the reload");
    assert!(!routes(a, c), "C is not configured yet");

    // B goes, C comes.
    write_config(&config, &[a, c]);
    signal(&router, "HUP");
    thread::sleep(Duration::from_millis(500));
    assert!(alive(&mut router), "SIGHUP ended the router");
    assert!(routes(a, c), "A to C after the reload");
    assert!(!routes(a, b), "B is still open after the reload");

    // A broken file is reported, and what runs keeps running.
    std::fs::write(&config, "[[endpoint]]\nuri = 7\n").expect("written");
    signal(&router, "HUP");
    thread::sleep(Duration::from_millis(300));
    assert!(alive(&mut router), "a broken file ended the router");
    assert!(routes(a, c), "A to C after a failed reload");

    let err = stop(router);
    assert!(err.contains("reload: opened udpin://127.0.0.1:"), "{err}");
    assert!(err.contains("reload: closing udpin://127.0.0.1:"), "{err}");
    assert!(err.contains("reload: kept the running endpoints"), "{err}");
}

#[test]
fn sighup_without_a_file_is_ignored() {
    let (a, b) = (free_port(), free_port());
    let mut router = start(
        "",
        &[
            format!("udpin://127.0.0.1:{a}"),
            format!("udpin://127.0.0.1:{b}"),
        ],
    );
    signal(&router, "HUP");
    thread::sleep(Duration::from_millis(300));
    assert!(alive(&mut router), "SIGHUP ended the router");
    assert!(routes(a, b), "routing after SIGHUP");
    let err = stop(router);
    assert!(err.contains("no configuration file to reload"), "{err}");
}

#[test]
fn an_ignored_sighup_stays_ignored() {
    let dir = tempfile::tempdir().expect("scratch");
    let config = dir.path().join("router.toml");
    let (a, b, c) = (free_port(), free_port(), free_port());
    write_config(&config, &[a, b]);
    // What `nohup` does before it runs a program.
    let mut router = start(
        "trap '' HUP;",
        &["--config".into(), config.display().to_string()],
    );
    write_config(&config, &[a, c]);
    signal(&router, "HUP");
    thread::sleep(Duration::from_millis(300));
    assert!(alive(&mut router), "SIGHUP ended the router under nohup");
    assert!(
        routes(a, b),
        "the endpoints changed although SIGHUP is ignored"
    );
    let err = stop(router);
    assert!(!err.contains("SIGHUP"), "{err}");
}

/// How many times the main thread of process `pid` has been scheduled in, where the kernel
/// keeps schedstat.
fn main_thread_runs(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/task/{pid}/schedstat")).ok()?;
    stat.split_whitespace().nth(2)?.parse().ok()
}

/// An idle router sleeps: its main thread until a signal, its UDP readers until a datagram, a
/// `tcpin` endpoint's accept until a client, and a connected client's reader until it sends
/// (those two also every 2 s, a safety net should what wakes them at a stop not come).
#[test]
fn an_idle_router_sleeps_until_a_signal_wakes_it() {
    let (a, b, c) = (free_port(), free_port(), free_port());
    let dir = tempfile::tempdir().expect("tempdir");
    let pty = dir.path().join("ttyIdle");
    let router = start(
        "",
        &[
            format!("udpin://127.0.0.1:{a}"),
            format!("udpin://127.0.0.1:{b}"),
            format!("tcpin://127.0.0.1:{c}"),
            format!("pty://{}", pty.display()),
        ],
    );
    let _client = std::net::TcpStream::connect(("127.0.0.1", c)).expect("connect");
    // A program attached to the pseudo-terminal, as an autopilot's serial link would be.
    let _attached = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(&pty)
        .expect("attach to the pty");
    thread::sleep(Duration::from_millis(300));
    let (Some(before), Some(sleeps)) = (main_thread_runs(router.id()), reader_sleeps(router.id()))
    else {
        eprintln!("note: no /proc schedstat here; the wake-up count is not checked");
        stop(router);
        return;
    };
    // Before, the main thread looked at its stop flag once a second, the accept every 20 ms
    // and the TCP client's and the pty's readers every 200 ms: 137 sleeps in 2.5 s, and 12 of
    // them the pty's after the rest were gone.
    thread::sleep(Duration::from_millis(2_500));
    assert_eq!(
        main_thread_runs(router.id()),
        Some(before),
        "the idle router woke"
    );
    let slept = reader_sleeps(router.id()).expect("sleeps") - sleeps;
    assert!(
        slept <= 5,
        "the idle router's other threads slept {slept} times"
    );
    // SIGTERM still stops it at once (`stop` waits at most 5 s).
    stop(router);
}

/// How many times the threads of process `pid` other than the main one have gone to sleep
/// (voluntary context switches: a preemption is not one), where the kernel says.
fn reader_sleeps(pid: u32) -> Option<u64> {
    let mut sleeps = 0;
    for task in std::fs::read_dir(format!("/proc/{pid}/task")).ok()? {
        let task = task.ok()?.path();
        if task.file_name()? == pid.to_string().as_str() {
            continue;
        }
        let status = std::fs::read_to_string(task.join("status")).ok()?;
        let line = status
            .lines()
            .find(|l| l.starts_with("voluntary_ctxt_switches:"))?;
        sleeps += line.split_whitespace().nth(1)?.parse::<u64>().ok()?;
    }
    Some(sleeps)
}

/// A UDP reader sleeps until a datagram comes, and wakes without one only when a peer has gone
/// quiet for the peer expiry. Before, it also woke once per expiry to look at peers that were
/// all still talking, and on an idle router those wake-ups were a tenth of its CPU time.
#[test]
fn readers_whose_peers_keep_talking_wake_only_for_their_datagrams() {
    let (a, b) = (free_port(), free_port());
    let router = start(
        "",
        &[
            format!("udpin://127.0.0.1:{a}"),
            format!("udpin://127.0.0.1:{b}"),
            "--peer-expiry".into(),
            "0.5".into(),
        ],
    );
    let peers = [a, b].map(|port| {
        let s = UdpSocket::bind("127.0.0.1:0").expect("bind");
        s.connect(("127.0.0.1", port)).expect("connect");
        s
    });
    let say = |i: usize| peers[i].send(&heartbeat(i as u8 + 1)).expect("send");
    // Both admitted, then quiet a while: whatever the start cost is behind us.
    say(0);
    say(1);
    thread::sleep(Duration::from_millis(200));
    let Some(before) = reader_sleeps(router.id()) else {
        eprintln!("note: no /proc status here; the wake-up count is not checked");
        stop(router);
        return;
    };
    // A heartbeat every 100 ms from each peer, 50 ms apart, for 3 s: six expiries.
    let rounds = 30;
    for _ in 0..rounds {
        say(0);
        thread::sleep(Duration::from_millis(50));
        say(1);
        thread::sleep(Duration::from_millis(50));
    }
    let sleeps = reader_sleeps(router.id()).expect("still there") - before;
    stop(router);
    // One wake-up a datagram; a few to spare for the machine.
    let datagrams = 2 * rounds;
    assert!(
        sleeps <= datagrams + 4,
        "{sleeps} wake-ups for {datagrams} datagrams"
    );
}

/// A router whose standard output nobody reads (a terminal paused with Ctrl-S, a pipe into a
/// program that stopped) goes on routing, and stops on SIGTERM. Before, it printed the
/// statistics table while holding the routing lock: once the pipe was full nothing was routed,
/// and SIGTERM did nothing.
#[test]
fn a_router_whose_stdout_is_not_read_routes_on_and_stops_on_sigterm() {
    let (a, b) = (free_port(), free_port());
    let router = start(
        "",
        &[
            format!("udpin://127.0.0.1:{a}"),
            format!("udpin://127.0.0.1:{b}"),
            "--stats".into(),
            "0.1".into(),
        ],
    );
    if !ferrolink_test_support::shrink_pipe(router.stdout.as_ref().expect("stdout")) {
        eprintln!("note: pipes cannot be shrunk here; a full stdout is not tried");
    }
    // Ten tables a second fill a page of pipe within a second.
    assert!(routes(a, b), "A to B at first");
    thread::sleep(Duration::from_secs(2));
    assert!(routes(a, b), "A to B with stdout full");
    stop(router);
}

/// A router whose tlog and statistics file nobody reads (FIFOs into a program that stopped,
/// or a disk that stalls) goes on routing and stops on SIGTERM; it says how many tlog records
/// it could not write, and those written and those lost add up. Before, it wrote both while
/// holding the routing lock: once the pipe was full, nothing was routed.
#[test]
fn a_router_whose_tlog_and_statistics_file_are_not_read_routes_on() {
    let dir = tempfile::tempdir().expect("scratch");
    let (tlog, stats) = (dir.path().join("flight.tlog"), dir.path().join("stats"));
    let (Some(mut tlog_reader), Some(mut stats_reader)) = (
        ferrolink_test_support::unread_fifo(&tlog),
        ferrolink_test_support::unread_fifo(&stats),
    ) else {
        eprintln!("note: no FIFOs with one-page pipes here; an unread tlog is not tried");
        return;
    };
    let (a, b) = (free_port(), free_port());
    let mut router = start(
        "",
        &[
            format!("udpin://127.0.0.1:{a}"),
            format!("udpin://127.0.0.1:{b}"),
            "--tlog".into(),
            tlog.display().to_string(),
            "--stats-json".into(),
            stats.display().to_string(),
            // Should the test fail, the router does not outlive it for long.
            "--run-for".into(),
            "120".into(),
        ],
    );
    let stderr = router.stderr.take().expect("stderr");
    let (noted, note) = mpsc::channel();
    let stderr = thread::spawn(move || {
        let mut all = String::new();
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if line.contains("record(s) not written") {
                let _ = noted.send(());
            }
            all += &line;
            all.push('\n');
        }
        all
    });
    assert!(routes(a, b), "A to B at first");
    // Datagrams of 80 heartbeats, until the router says it lost tlog records: past the 4 MiB
    // it holds for its tlog.
    let one = heartbeat(7);
    let datagram: Vec<u8> = one.repeat(80);
    let talker = UdpSocket::bind("127.0.0.1:0").expect("bind");
    let deadline = Instant::now() + Duration::from_secs(60);
    while note.try_recv().is_err() {
        assert!(Instant::now() < deadline, "no tlog record was lost");
        for _ in 0..20 {
            let _ = talker.send_to(&datagram, ("127.0.0.1", a));
        }
        thread::sleep(Duration::from_millis(2));
    }
    // What the flood left queued in the router's socket goes first.
    drain(b);
    assert!(
        routes(a, b),
        "A to B with the tlog and the statistics file stalled"
    );

    // Read what was written, then stop the router.
    let tlog_reading =
        thread::spawn(move || ferrolink_test_support::read_to_close(&mut tlog_reader));
    let stats_reading =
        thread::spawn(move || ferrolink_test_support::read_to_close(&mut stats_reader));
    signal(&router, "TERM");
    let status = exit(&mut router);
    let err = stderr.join().expect("stderr read");
    let written = tlog_reading.join().expect("tlog read");
    let stats = String::from_utf8(stats_reading.join().expect("stats read")).expect("utf-8");
    assert_eq!(
        status.code(),
        Some(1),
        "the lost records make the status 1: {err}"
    );
    let line = err
        .lines()
        .find(|l| l.contains("record(s) not written: the file did not keep up"))
        .unwrap_or_else(|| panic!("no count of the lost records: {err}"));
    let counts: Vec<u64> = line
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    let [dropped, records] = counts[..] else {
        panic!("{line}")
    };
    assert!(dropped > 0, "{line}");
    // Every record is a heartbeat of the same length; the file holds whole records only.
    let record = 8 + one.len();
    assert_eq!(written.len() % record, 0, "a record was cut");
    assert_eq!(
        written.len() / record + dropped as usize,
        records as usize,
        "{line}"
    );
    let last: serde_json::Value =
        serde_json::from_str(stats.lines().last().expect("a line")).expect("JSON");
    assert_eq!(last["tlog_records"], records, "{stats}");
    assert_eq!(last["tlog_dropped"], dropped, "{stats}");
}

/// Listens as a peer of `port` until nothing has come for 300 ms (at most 30 s).
fn drain(port: u16) {
    let listener = UdpSocket::bind("127.0.0.1:0").expect("bind");
    listener
        .set_read_timeout(Some(Duration::from_millis(300)))
        .expect("timeout");
    let _ = listener.send_to(&heartbeat(254), ("127.0.0.1", port));
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut buf = [0u8; 2048];
    while listener.recv(&mut buf).is_ok() {
        assert!(
            Instant::now() < deadline,
            "the router's backlog never drained"
        );
    }
}

/// Waits up to 5 s for the router to exit.
fn exit(child: &mut Child) -> std::process::ExitStatus {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            return status;
        }
        assert!(
            Instant::now() < deadline,
            "the router did not stop on SIGTERM"
        );
        thread::sleep(Duration::from_millis(20));
    }
}

/// A `zenoh://` endpoint of the file is opened once, at start: a reload that leaves it as it
/// was says nothing of it, one that changes it keeps the running one and says so.
#[cfg(feature = "zenoh")]
#[test]
fn sighup_keeps_the_zenoh_endpoint_and_says_when_it_changed() {
    let dir = tempfile::tempdir().expect("scratch");
    let config = dir.path().join("router.toml");
    let (a, b, c, z) = (free_port(), free_port(), free_port(), free_port());
    let write = |ports: &[u16], zenoh_port: u16| {
        write_config(&config, ports);
        let zenoh = format!(
            "[[endpoint]]\nuri = \"zenoh://?mode=peer&listen=tcp/127.0.0.1:{zenoh_port}\
             &prefix=reload{z}\"\n"
        );
        let text = std::fs::read_to_string(&config).expect("read") + &zenoh;
        std::fs::write(&config, text).expect("config written");
    };
    write(&[a, b], z);
    let mut router = start("", &["--config".into(), config.display().to_string()]);
    assert!(routes(a, b), "A to B before the reloads");

    // The UDP endpoints change, the Zenoh one does not.
    write(&[a, c], z);
    signal(&router, "HUP");
    thread::sleep(Duration::from_millis(500));
    assert!(routes(a, c), "A to C after the first reload");

    // The Zenoh one changes: kept as it runs, with a note.
    write(&[a, c], free_port());
    signal(&router, "HUP");
    thread::sleep(Duration::from_millis(500));
    assert!(alive(&mut router), "SIGHUP ended the router");
    assert!(routes(a, c), "A to C after the second reload");

    let err = stop(router);
    assert_eq!(
        err.matches("its zenoh:// endpoints changed").count(),
        1,
        "{err}"
    );
    assert!(err.contains("restart the router to change them"), "{err}");
}
