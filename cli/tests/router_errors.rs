//! What `ferrolink mavlink router` says about a command line it cannot run: each error names the
//! value or path and gives a hint, and the router exits at once with status 1 instead of
//! running (or retrying forever).

use std::process::Command;

/// Stderr of a router run that must fail at once.
fn refused(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_ferrolink"))
        .args(["mavlink", "router", "--run-for", "5"])
        .args(args)
        .output()
        .expect("ferrolink runs");
    assert_eq!(out.status.code(), Some(1), "{args:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_tlog_in_a_missing_directory() {
    insta::assert_snapshot!(refused(&["--tlog", "/nonexistent/dir/x.tlog", "udpin://127.0.0.1:0"]), @r"
    tlog /nonexistent/dir/x.tlog: No such file or directory (os error 2)
      hint: the directory /nonexistent/dir does not exist
    ");
}

/// The same from mavlink-router's `Log` key, which names a directory: the error names the tlog
/// by what it is, since no `--tlog` was given.
#[test]
fn a_main_conf_log_directory_that_is_missing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let config = dir.path().join("main.conf");
    std::fs::write(
        &config,
        "[General]\nLog = /nonexistent/dir\n\n[UdpEndpoint a]\nMode = Server\nAddress = 127.0.0.1\nPort = 0\n",
    )
    .expect("write");
    insta::assert_snapshot!(refused(&["--config", config.to_str().expect("utf-8")]), @r"
    tlog /nonexistent/dir: no such directory
      hint: create it for a log per run, or give a file name ending in .tlog
    ");
}

#[test]
fn a_word_for_a_baud_rate() {
    let err = refused(&["serial:///dev/null:abc"]);
    // The hint lists every accepted form; the first lines are the point.
    let head: Vec<&str> = err.lines().take(3).collect();
    insta::assert_snapshot!(head.join("\n"), @r#"
    bad baud rate "abc": expected digits, e.g. :57600
      serial:///dev/null:abc
                         ^
    "#);
    assert!(err.contains("hint: accepted forms: "), "{err}");
}

#[test]
fn a_peer_expiry_of_zero() {
    insta::assert_snapshot!(refused(&["--peer-expiry", "0", "udpin://127.0.0.1:0"]), @r"
    peer expiry 0 s: every UDP peer would be forgotten at once
      hint: give the seconds a UDP peer may be quiet before it is forgotten, e.g. --peer-expiry 10 (the default)
    ");
}

#[test]
fn a_configuration_without_endpoints() {
    let dir = tempfile::tempdir().expect("tempdir");
    let config = dir.path().join("router.toml");
    std::fs::write(&config, "# nothing to route\n").expect("write");
    insta::assert_snapshot!(refused(&["--config", config.to_str().expect("utf-8")]), @r"
    no endpoints to route between
      hint: give them as arguments (udpin://0.0.0.0:14550 serial:///dev/ttyACM0:57600 ...) or as [[endpoint]] tables in the --config file
    ");
}

#[test]
fn an_output_queue_of_zero_bytes() {
    insta::assert_snapshot!(refused(&["--queue-bytes", "0", "udpin://127.0.0.1:0"]), @r"
    --queue-bytes 0: less than the largest MAVLink frame (280 bytes), which could never be queued
      hint: give the bytes a slow peer may have waiting, e.g. --queue-bytes 65536 (the default)
    ");
}

#[test]
fn an_output_queue_smaller_than_a_frame() {
    insta::assert_snapshot!(refused(&["--queue-bytes", "279", "udpin://127.0.0.1:0"]), @r"
    --queue-bytes 279: less than the largest MAVLink frame (280 bytes), which could never be queued
      hint: give the bytes a slow peer may have waiting, e.g. --queue-bytes 65536 (the default)
    ");
}

#[test]
fn statistics_without_pause() {
    insta::assert_snapshot!(refused(&["--stats", "0", "udpin://127.0.0.1:0"]), @r"
    --stats 0: the table would be printed without pause
      hint: give the seconds between tables, e.g. --stats 1 (0.1 at the least)
    ");
}

#[test]
fn seconds_out_of_range() {
    let out = Command::new(env!("CARGO_BIN_EXE_ferrolink"))
        .args([
            "mavlink",
            "router",
            "--run-for",
            "1e300",
            "udpin://127.0.0.1:0",
        ])
        .output()
        .expect("ferrolink runs");
    assert_eq!(out.status.code(), Some(2), "a usage error");
    insta::assert_snapshot!(String::from_utf8_lossy(&out.stderr), @r"
    error: invalid value '1e300' for '--run-for <SECS>': use a number of seconds from 0 to 1e9 (about 31 years), e.g. 10 or 0.5

    For more information, try '--help'.
    ");
}

#[test]
fn the_same_port_twice() {
    let port = ferrolink_test_support::free_port();
    let uri = format!("udpin://127.0.0.1:{port}");
    let err = refused(&[&uri, &uri]).replace(&port.to_string(), "PORT");
    insta::assert_snapshot!(err, @r"
    udpin://127.0.0.1:PORT: Address already in use (os error 98)
      hint: another program (or another endpoint given here) listens on this port; `ss -lunp` and `ss -ltnp` name it
    ");
}

/// A Zenoh endpoint listening where another program listens: said as for UDP and TCP.
#[cfg(feature = "zenoh")]
#[test]
fn a_zenoh_listen_port_taken() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = taken.local_addr().expect("addr").port();
    let uri = format!("zenoh://?mode=peer&listen=tcp/127.0.0.1:{port}");
    let err = refused(&[&uri, "udpin://127.0.0.1:0"]).replace(&port.to_string(), "PORT");
    insta::assert_snapshot!(err, @r"
    zenoh://?mode=peer&listen=tcp/127.0.0.1:PORT&encoding=raw&prefix=ferrolink: listen=tcp/127.0.0.1:PORT: Address already in use (os error 98)
      hint: another program (or another endpoint given here) listens on this port; `ss -lunp` and `ss -ltnp` name it
    ");
}

// The hint lists the forms this build accepts, Zenoh's among them.
#[cfg(feature = "zenoh")]
#[test]
fn a_udpout_to_port_zero() {
    insta::assert_snapshot!(refused(&["udpout://127.0.0.1:0"]), @r"
    port 0: nothing can be sent to port 0; give the port the peer listens on
      udpout://127.0.0.1:0
                         ^
      hint: accepted forms: udpin://HOST:PORT, udpout://HOST:PORT[?replies=any], udpbcast://ADDR:PORT, udpmcast://GROUP:PORT[?iface=NAME], tcpin://HOST:PORT, tcpout://HOST:PORT, serial://PATH[:BAUD], pty://NAME, zenoh://?mode=peer|client&listen=tcp/HOST:PORT&connect=tcp/HOST:PORT&encoding=raw|json&prefix=NAME (listen and connect repeat; at least one); pymavlink spellings (udpin:HOST:PORT, tcp:HOST:PORT, serial:PATH:BAUD) work too
    ");
}

#[test]
fn a_filter_with_a_message_id_past_24_bits() {
    let dir = tempfile::tempdir().expect("tempdir");
    let config = dir.path().join("router.toml");
    std::fs::write(
        &config,
        "[[endpoint]]\nuri = \"udpin://127.0.0.1:0\"\nallow_msg_out = [0, 99999999]\n",
    )
    .expect("write");
    let err = refused(&["--config", config.to_str().expect("utf-8")]);
    insta::assert_snapshot!(err.replace(config.to_str().expect("utf-8"), "router.toml"), @r"
    router.toml: endpoint #1 (udpin://127.0.0.1:0): allow_msg_out lists message id 99999999, past the largest a frame carries (16777215)
      hint: message ids are 24 bits
    ");
}

#[cfg(feature = "zenoh")]
#[test]
fn a_zenoh_runtime_variable_that_does_not_parse() {
    let out = Command::new(env!("CARGO_BIN_EXE_ferrolink"))
        .args(["mavlink", "router", "--run-for", "5", "udpin://127.0.0.1:0"])
        .arg("zenoh://?mode=peer&listen=tcp/127.0.0.1:0")
        .env("ZENOH_RUNTIME", "(rx: (worker_threads: \"two\"))")
        .output()
        .expect("ferrolink runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    // Zenoh's own parser, run before Zenoh starts: its words, no panic.
    insta::assert_snapshot!(err, @r#"
    ZENOH_RUNTIME="(rx: (worker_threads: \"two\"))" is not a Zenoh runtime configuration: SpannedError { code: ExpectedInteger, span: Span { start: Position { line: 1, col: 22 }, end: Position { line: 1, col: 23 } } }
      hint: it is RON, e.g. ZENOH_RUNTIME='(rx: (worker_threads: 2))'; unset it for ferrolink's default (all of Zenoh on one worker thread)
    "#);
}
