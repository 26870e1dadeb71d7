//! Real `ferrolink ndlcom bridge` processes: three chained over UDP loopback, and two over a
//! pseudo-terminal where the machine allows it.

use std::process::{Child, Command, Stdio};
use std::thread::sleep;
use std::time::Duration;

use ferrolink_io::ndlcom::bridge::MAX_INTERFACES;
use ferrolink_test_support::free_port;
use serde_json::Value;

fn bridge(args: &[String]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_ferrolink"))
        .args(["ndlcom", "bridge", "--json", "--no-commands"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starts")
}

/// The JSON events a finished bridge printed.
fn events(child: Child) -> Vec<Value> {
    let out = child.wait_with_output().expect("finishes");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "bridge failed: {}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

fn last<'a>(events: &'a [Value], kind: &str) -> &'a Value {
    events
        .iter()
        .rev()
        .find(|e| e["event"] == kind)
        .unwrap_or_else(|| panic!("no {kind} event in {events:?}"))
}

fn stat(events: &[Value], interface: usize, key: &str) -> u64 {
    last(events, "stats")["interfaces"][interface][key]
        .as_u64()
        .expect("a counter")
}

fn s(x: impl ToString) -> String {
    x.to_string()
}

#[test]
fn three_bridges_over_udp() {
    let (ab, ba, bc, cb) = (free_port(), free_port(), free_port(), free_port());
    // A (id 1) <-> B (id 2) <-> C (id 3); A pings C through B.
    let c = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{cb}:{bc}"),
        s("-i"),
        s(3),
        s("--run-for"),
        s(3.0),
    ]);
    let b = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{ba}:{ab}"),
        s("-u"),
        format!("udp://127.0.0.1:{bc}:{cb}"),
        s("-i"),
        s(2),
        s("--run-for"),
        s(2.6),
    ]);
    sleep(Duration::from_millis(400));
    let a = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{ab}:{ba}"),
        s("-i"),
        s(1),
        s("--ping"),
        s(3),
        s("--ping-every"),
        s(0.1),
        s("--run-for"),
        s(1.5),
    ]);
    let (a, b, c) = (events(a), events(b), events(c));

    // Every ping was answered from the other end.
    let pings = stat(&a, 0, "tx_frames");
    let replies: Vec<&Value> = a.iter().filter(|e| e["event"] == "ping_reply").collect();
    assert!(pings >= 10, "{pings} pings");
    assert_eq!(replies.len() as u64, pings);
    assert!(replies.iter().all(|r| r["from"] == 3));
    assert_eq!(last(&c, "stats")["interfaces"][0]["tx_frames"], pings);

    // B learned where 1 and 3 are (from the transit frames, Algorithm 1).
    let routes = &last(&b, "routes")["routes"];
    let names = |i: usize| last(&b, "stats")["interfaces"][i]["interface"].clone();
    let route = |id: u64| {
        routes
            .as_array()
            .expect("routes")
            .iter()
            .find(|r| r["id"] == id)
            .map(|r| r["interface"].clone())
    };
    assert_eq!(route(1), Some(names(0)));
    assert_eq!(route(3), Some(names(1)));

    // The statistics add up along the chain.
    assert_eq!(stat(&a, 0, "tx_frames"), stat(&b, 0, "rx_frames"));
    assert_eq!(stat(&a, 0, "tx_bytes"), stat(&b, 0, "rx_bytes"));
    assert_eq!(stat(&b, 1, "tx_frames"), stat(&c, 0, "rx_frames"));
    assert_eq!(stat(&c, 0, "tx_bytes"), stat(&b, 1, "rx_bytes"));
    assert_eq!(stat(&b, 0, "tx_frames"), stat(&a, 0, "rx_frames"));
    assert_eq!(stat(&b, 0, "rx_frames"), stat(&b, 1, "tx_frames"));
    for e in [&a, &b, &c] {
        for i in 0..e.len().min(1) {
            assert_eq!(stat(e, i, "crc_failures") + stat(e, i, "dropped"), 0);
        }
    }
    assert_eq!(last(&b, "missed")["total"], 0);
}

/// A bridge that prints every frame to a standard output nobody reads (a terminal paused with
/// Ctrl-S, a pager left open) loses lines, not frames: it goes on answering pings. Before, its
/// one loop waited on stdout, so nothing was forwarded or answered, and what arrived piled up in
/// memory.
#[test]
fn a_bridge_whose_stdout_is_not_read_forwards_on() {
    let (xy, yx) = (free_port(), free_port());
    let x = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{xy}:{yx}"),
        s("-i"),
        s(1),
        s("--print"),
        s("all"),
        s("--run-for"),
        s(3.5),
    ]);
    if !ferrolink_test_support::shrink_pipe(x.stdout.as_ref().expect("stdout")) {
        eprintln!("note: pipes cannot be shrunk here; a full stdout is not tried");
    }
    sleep(Duration::from_millis(300));
    // A hundred pings a second, each printed with its answer: a page of pipe fills at once.
    let y = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{yx}:{xy}"),
        s("-i"),
        s(2),
        s("--ping"),
        s(1),
        s("--ping-every"),
        s(0.01),
        s("--run-for"),
        s(2.5),
    ]);
    let y = events(y);
    let pings = last(&y, "stats")["pings_sent"].as_u64().expect("pings");
    let answered = last(&y, "stats")["pings_answered"]
        .as_u64()
        .expect("answered");
    assert!(pings >= 100, "{pings} pings");
    assert!(
        answered * 10 >= pings * 9,
        "{answered} of {pings} pings answered"
    );
    let out = x.wait_with_output().expect("finishes");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A bridge whose `--log` nobody reads (a FIFO into a program that stopped, a disk that
/// stalls) goes on answering pings, and the log gets every line once it is read. Before, its
/// one loop wrote the log: once the pipe was full, nothing was forwarded or answered.
#[test]
fn a_bridge_whose_log_is_not_read_forwards_on() {
    let dir = tempfile::tempdir().expect("scratch");
    let log = dir.path().join("frames.jsonl");
    let Some(mut reader) = ferrolink_test_support::unread_fifo(&log) else {
        eprintln!("note: no FIFOs with one-page pipes here; an unread log is not tried");
        return;
    };
    let (xy, yx) = (free_port(), free_port());
    let x = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{xy}:{yx}"),
        s("-i"),
        s(1),
        s("--log"),
        log.display().to_string(),
        s("--run-for"),
        s(3.5),
    ]);
    sleep(Duration::from_millis(300));
    // A hundred pings a second, each logged: a page of pipe fills at once.
    let y = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{yx}:{xy}"),
        s("-i"),
        s(2),
        s("--ping"),
        s(1),
        s("--ping-every"),
        s(0.01),
        s("--run-for"),
        s(2.5),
    ]);
    let y = events(y);
    let pings = last(&y, "stats")["pings_sent"].as_u64().expect("pings");
    let answered = last(&y, "stats")["pings_answered"]
        .as_u64()
        .expect("answered");
    assert!(pings >= 100, "{pings} pings");
    assert!(
        answered * 10 >= pings * 9,
        "{answered} of {pings} pings answered"
    );
    // Now the log is read, and gets what waited for it.
    let reading = std::thread::spawn(move || ferrolink_test_support::read_to_close(&mut reader));
    let out = x.wait_with_output().expect("finishes");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(reading.join().expect("read")).expect("utf-8");
    let frames = text
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).expect("a JSON line"))
        .filter(|v| v.get("frame").is_some())
        .count() as u64;
    assert!(
        frames >= answered,
        "{frames} frames logged, {answered} answered"
    );
}

/// A peer that floods the bridge faster than it forwards costs bounded memory: what it sends
/// beyond [`BACKLOG_BYTES`] waiting is dropped and counted as its `rx_overruns`, and pings on
/// another interface are still answered. Before, every datagram waited in an unbounded queue:
/// 360 MB after 8 s of one Python flood.
///
/// [`BACKLOG_BYTES`]: ferrolink_io::ndlcom::bridge::BACKLOG_BYTES
#[test]
fn a_flooding_peer_costs_bounded_memory_and_only_its_own_frames() {
    let (fx, xf, xy, yx) = (free_port(), free_port(), free_port(), free_port());
    let x = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{fx}:{xf}"),
        s("-u"),
        format!("udp://127.0.0.1:{xy}:{yx}"),
        s("-i"),
        s(1),
        s("--run-for"),
        s(4.0),
    ]);
    sleep(Duration::from_millis(300));
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flood = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            // Broadcasts, 20 frames a datagram.
            let frame = [
                0x7e, 0xff, 0x02, 0x03, 0x05, 0x01, 0x02, 0x03, 0x04, 0x05, 0x34, 0xa8, 0x7e,
            ]
            .repeat(20);
            let socket = std::net::UdpSocket::bind(("127.0.0.1", xf)).expect("bind");
            let mut sent = 0u64;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                for _ in 0..100 {
                    let _ = socket.send_to(&frame, ("127.0.0.1", fx));
                    sent += 1;
                }
            }
            sent
        })
    };
    let y = bridge(&[
        s("-u"),
        format!("udp://127.0.0.1:{yx}:{xy}"),
        s("-i"),
        s(2),
        s("--ping"),
        s(1),
        s("--ping-every"),
        s(0.05),
        s("--run-for"),
        s(2.5),
    ]);
    let mut most_kb = 0;
    for _ in 0..25 {
        sleep(Duration::from_millis(100));
        let status =
            std::fs::read_to_string(format!("/proc/{}/status", x.id())).unwrap_or_default();
        if let Some(kb) = status
            .lines()
            .find_map(|l| l.strip_prefix("VmRSS:"))
            .and_then(|v| v.split_whitespace().next()?.parse::<u64>().ok())
        {
            most_kb = most_kb.max(kb);
        }
    }
    let y = events(y);
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let sent = flood.join().expect("flooded");
    let x = events(x);
    assert!(
        most_kb < 64 * 1024,
        "{most_kb} kB resident after {sent} datagrams"
    );
    let pings = last(&y, "stats")["pings_sent"].as_u64().expect("pings");
    let answered = last(&y, "stats")["pings_answered"]
        .as_u64()
        .expect("answered");
    assert!(
        answered * 10 >= pings * 8,
        "{answered} of {pings} pings answered"
    );
    // What the flood brought in and what it lost add up to no more than it sent.
    let taken = stat(&x, 0, "rx_bytes") / 13 / 20;
    let overruns = stat(&x, 0, "rx_overruns");
    assert!(taken + overruns <= sent, "{taken} + {overruns} > {sent}");
}

/// An idle bridge sleeps: its main loop wakes for input and for timers that are due (no
/// statistics, pings or cut-through frames in flight here), where it used to wake every 5 ms.
#[test]
fn an_idle_bridge_sleeps() {
    let (a, b) = (free_port(), free_port());
    let mut x = bridge(&[s("-u"), format!("udp://127.0.0.1:{a}:{b}"), s("-i"), s(1)]);
    let runs = || -> Option<u64> {
        let stat = std::fs::read_to_string(format!("/proc/{0}/task/{0}/schedstat", x.id())).ok()?;
        stat.split_whitespace().nth(2)?.parse().ok()
    };
    sleep(Duration::from_millis(300));
    let Some(before) = runs() else {
        eprintln!("note: no /proc schedstat here; the wake-up count is not checked");
        let _ = x.kill();
        let _ = x.wait();
        return;
    };
    sleep(Duration::from_secs(1));
    let woke = runs().expect("still there") - before;
    let _ = x.kill();
    let _ = x.wait();
    assert!(
        woke <= 5,
        "the idle bridge's main thread ran {woke} times in 1 s"
    );
}

/// A TCP client past the bridge's interfaces is closed at once, so that clients that keep
/// connecting cannot pile up threads and sockets in it. Before, each kept a thread and three
/// file descriptors for as long as it stayed connected.
#[test]
fn a_tcp_client_past_the_interfaces_is_closed() {
    use std::io::Read;

    let port = free_port();
    let x = bridge(&[
        s("-u"),
        format!("tcp-listen://127.0.0.1:{port}"),
        s("--run-for"),
        s(3.0),
    ]);
    sleep(Duration::from_millis(300));
    // One after the other, so that the last ones are those refused.
    let extra = 4;
    let clients: Vec<std::net::TcpStream> = (0..MAX_INTERFACES + extra)
        .map(|_| {
            let c = std::net::TcpStream::connect(("127.0.0.1", port)).expect("connects");
            sleep(Duration::from_millis(20));
            c
        })
        .collect();
    let ended = |mut c: &std::net::TcpStream, wait: u64| {
        c.set_read_timeout(Some(Duration::from_millis(wait)))
            .expect("timeout");
        // End of stream, or a reset: closed. A timeout: still open.
        match c.read(&mut [0u8; 16]) {
            Ok(0) => true,
            Err(e) => e.kind() == std::io::ErrorKind::ConnectionReset,
            Ok(_) => false,
        }
    };
    for c in &clients[MAX_INTERFACES..] {
        assert!(ended(c, 1000), "a refused client was left open");
    }
    for c in &clients[..MAX_INTERFACES] {
        assert!(!ended(c, 10), "a client with an interface was closed");
    }
    let x = events(x);
    let refused = x.iter().filter(|e| e["event"] == "link_refused").count();
    assert_eq!(refused, extra, "{x:?}");
}

#[test]
fn two_bridges_over_a_pty() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tty = dir.path().join("ttyNDL");
    let tty = tty.to_str().expect("utf-8");
    let a = bridge(&[
        s("-u"),
        format!("pty://{tty}"),
        s("-i"),
        s(1),
        s("--run-for"),
        s(2.0),
    ]);
    // Wait for the pty to appear; some sandboxes have no ptys at all.
    for _ in 0..50 {
        if std::fs::symlink_metadata(tty).is_ok() {
            break;
        }
        sleep(Duration::from_millis(20));
    }
    if std::fs::symlink_metadata(tty).is_err() {
        let out = a.wait_with_output().expect("finishes");
        eprintln!(
            "skipped: no pseudo-terminal on this machine ({})",
            String::from_utf8_lossy(&out.stderr).trim()
        );
        return;
    }
    let b = bridge(&[
        s("-u"),
        format!("serial://{tty}:921600"),
        s("-i"),
        s(2),
        s("--ping"),
        s(1),
        s("--ping-every"),
        s(0.1),
        s("--run-for"),
        s(1.2),
    ]);
    let (b, a) = (events(b), events(a));
    let replies = b.iter().filter(|e| e["event"] == "ping_reply").count() as u64;
    assert!(replies >= 8, "{replies} replies");
    assert_eq!(replies, stat(&b, 0, "tx_frames"));
    assert_eq!(stat(&a, 0, "rx_frames"), stat(&b, 0, "tx_frames"));
}

#[test]
fn a_tcp_server_interface_serves_every_client() {
    let port = free_port();
    let server_uri = format!("tcp-listen://127.0.0.1:{port}");
    // H (id 9) listens; B (id 2) and then A (id 1) connect as clients; A pings B through H.
    let h = bridge(&[
        s("-u"),
        server_uri.clone(),
        s("-i"),
        s(9),
        s("--run-for"),
        s(3.0),
    ]);
    sleep(Duration::from_millis(300));
    let client = |id: u64, run_for: f64, ping: &[String]| {
        let mut args = vec![
            s("-u"),
            format!("tcp://127.0.0.1:{port}"),
            s("-i"),
            s(id),
            s("--run-for"),
            s(run_for),
        ];
        args.extend_from_slice(ping);
        bridge(&args)
    };
    let b = client(2, 2.4, &[]);
    sleep(Duration::from_millis(300));
    let a = client(1, 1.5, &[s("--ping"), s(2), s("--ping-every"), s(0.1)]);
    let (a, b, h) = (events(a), events(b), events(h));

    let replies = a.iter().filter(|e| e["event"] == "ping_reply").count() as u64;
    assert!(replies >= 8, "{replies} replies");
    assert_eq!(replies, stat(&a, 0, "tx_frames"));
    assert_eq!(stat(&b, 0, "rx_frames"), replies);

    // H served both clients, each as an interface of its own, and learned who is where.
    let ups: Vec<&Value> = h.iter().filter(|e| e["event"] == "link_up").collect();
    assert_eq!(ups.len(), 2, "{ups:?}");
    assert_eq!(ups[0]["interface"], server_uri.as_str());
    assert_eq!(ups[0]["index"], 0);
    let second = ups[1]["interface"].as_str().expect("a name");
    assert!(
        second.starts_with(&format!("{server_uri} <- 127.0.0.1:")),
        "{second}"
    );
    assert_eq!(ups[1]["index"], 1);
    assert_eq!(stat(&h, 0, "rx_frames"), stat(&b, 0, "tx_frames"));
    assert_eq!(stat(&h, 1, "rx_frames"), stat(&a, 0, "tx_frames"));
    // A left first, then B: both reported, and the routes through them forgotten.
    let downs: Vec<&Value> = h.iter().filter(|e| e["event"] == "link_down").collect();
    assert_eq!(downs.len(), 2, "{downs:?}");
    assert_eq!(downs[0]["interface"], second);
    assert_eq!(last(&h, "routes")["routes"], serde_json::json!([]));
}

/// Two bridges joined only by Zenoh (peer mode on loopback), raw and JSON: one pings the other.
#[cfg(feature = "zenoh")]
#[test]
fn two_bridges_over_zenoh() {
    for encoding in ["raw", "json"] {
        let port = free_port();
        let prefix = format!("ndl{port}{encoding}");
        let zenoh = |role: &str| {
            format!("zenoh://?mode=peer&{role}=tcp/127.0.0.1:{port}&encoding={encoding}&prefix={prefix}")
        };
        let b = bridge(&[
            s("-u"),
            zenoh("listen"),
            s("-i"),
            s(2),
            s("--run-for"),
            s(3.5),
        ]);
        sleep(Duration::from_millis(500));
        let a = bridge(&[
            s("-u"),
            zenoh("connect"),
            s("-i"),
            s(1),
            s("--ping"),
            s(2),
            s("--ping-every"),
            s(0.1),
            s("--run-for"),
            s(2.5),
        ]);
        let (a, b) = (events(a), events(b));
        let replies = a.iter().filter(|e| e["event"] == "ping_reply").count() as u64;
        let pings = stat(&a, 0, "tx_frames");
        assert!(
            replies >= 10,
            "{encoding}: {replies} replies to {pings} pings"
        );
        assert!(replies <= pings);
        assert!(a
            .iter()
            .all(|e| e["event"] != "ping_reply" || e["from"] == 2));
        assert_eq!(
            stat(&b, 0, "tx_frames"),
            stat(&a, 0, "rx_frames"),
            "{encoding}"
        );
        // The interface is named by its canonical URI.
        let name = &last(&b, "stats")["interfaces"][0]["interface"];
        assert_eq!(name, &zenoh("listen"), "{encoding}");
    }
}
