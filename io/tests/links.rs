//! The link layer for real, opened from NDLCom interface URIs: UDP and TCP over loopback,
//! pseudo-terminals, and the serial code path on the slave side of a pty pair.

use std::io;
use std::net::{TcpListener, TcpStream, UdpSocket};
use std::sync::{mpsc, Arc};
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_io::link::{self, PeerId, Sender};
use ferrolink_io::ndlcom::Interface;
use ferrolink_test_support::free_port;

/// Longest any single step of a test may take before it counts as hung.
const PATIENCE: Duration = Duration::from_secs(5);

/// What an endpoint reported, owned.
#[derive(Debug)]
enum Ev {
    Up(PeerId, String, Sender),
    Rx(PeerId, Vec<u8>),
    Down(PeerId, String),
}

/// An open endpoint and the events it reported.
struct Opened {
    handle: link::Handle,
    events: mpsc::Receiver<Ev>,
}

/// A sink that sends every event, owned, to the receiver it returns.
fn events() -> (link::Sink, mpsc::Receiver<Ev>) {
    let (tx, events) = mpsc::channel();
    let sink: link::Sink = Arc::new(move |event| {
        let ev = match event {
            link::Event::Up {
                peer, name, sender, ..
            } => Ev::Up(peer, name, sender),
            link::Event::Rx { peer, bytes, .. } => Ev::Rx(peer, bytes.to_vec()),
            link::Event::Down { peer, why } => Ev::Down(peer, why),
            link::Event::Quiet { .. } => return true,
        };
        tx.send(ev).is_ok()
    });
    (sink, events)
}

fn try_open(uri: &str) -> io::Result<Opened> {
    let interface: Interface = uri.parse().unwrap_or_else(|e| panic!("{uri}: {e}"));
    let (sink, events) = events();
    let handle = link::open(0, &interface.endpoint, link::Options::default(), sink)?;
    Ok(Opened { handle, events })
}

fn open(uri: &str) -> Opened {
    try_open(uri).unwrap_or_else(|e| panic!("opening {uri}: {e}"))
}

fn open_err(uri: &str) -> io::Error {
    match try_open(uri) {
        Ok(_) => panic!("{uri} should not open"),
        Err(e) => e,
    }
}

impl Opened {
    fn next(&self) -> Ev {
        self.events
            .recv_timeout(PATIENCE)
            .expect("no event in time")
    }

    /// The next event, which must be a peer coming up.
    fn up(&self) -> (PeerId, String, Sender) {
        match self.next() {
            Ev::Up(peer, name, sender) => (peer, name, sender),
            other => panic!("expected a peer to come up, got {other:?}"),
        }
    }

    /// The next event, which must be a peer going down; returns why.
    fn down(&self, expected: PeerId) -> String {
        match self.next() {
            Ev::Down(peer, why) if peer == expected => why,
            other => panic!("expected peer {expected} to go down, got {other:?}"),
        }
    }

    /// The next read, which must come from `expected`.
    fn datagram(&self, expected: PeerId) -> Vec<u8> {
        match self.next() {
            Ev::Rx(peer, bytes) if peer == expected => bytes,
            other => panic!("expected bytes from peer {expected}, got {other:?}"),
        }
    }

    /// Reads from `peer` until exactly `n` bytes arrived.
    fn read_exactly(&self, peer: PeerId, n: usize) -> Vec<u8> {
        let mut got = Vec::new();
        while got.len() < n {
            got.extend(self.datagram(peer));
        }
        assert_eq!(got.len(), n, "more bytes than expected arrived");
        got
    }

    /// Asserts that nothing is reported within `wait`.
    fn quiet(&self, wait: Duration) {
        if let Ok(ev) = self.events.recv_timeout(wait) {
            panic!("unexpected {ev:?}");
        }
    }
}

/// Every byte value, with the ones a cooked terminal would eat or translate (CR, LF, ^C, ^D,
/// ^S/^Q, DEL, the NDLCom flag 0x7E) repeated in a row.
fn all_bytes() -> Vec<u8> {
    let mut bytes: Vec<u8> = (0..=255).collect();
    bytes.extend_from_slice(b"\r\n\r\r\n\n\x03\x04\x11\x13\x7f\x7e\x7d\x00\xff");
    bytes
}

/// Writes on one side and checks the other receives exactly that.
fn exchange(from: &Sender, to: &Opened, peer: PeerId, bytes: &[u8]) {
    from.send(bytes).expect("write failed");
    assert_eq!(to.read_exactly(peer, bytes.len()), bytes);
}

// ---------------------------------------------------------------------------------------------
// UDP

#[test]
fn udp_pair_loopback() {
    let (pa, pb) = (free_port(), free_port());
    let a = open(&format!("udp://127.0.0.1:{pa}:{pb}&3,4"));
    let b = open(&format!("udp://127.0.0.1:{pb}:{pa}"));
    // The one peer is up as soon as the endpoint is open, named by the URI.
    let (pa_peer, name, aw) = a.up();
    assert_eq!(name, format!("udp://127.0.0.1:{pa}:{pb}"));
    let (pb_peer, _, bw) = b.up();
    assert_eq!(a.handle.local_addr().map(|l| l.port()), Some(pa));
    a.quiet(Duration::from_millis(100));

    aw.send(b"hello").unwrap();
    assert_eq!(b.datagram(pb_peer), b"hello");

    // Datagram boundaries are kept: one write, one read.
    bw.send(&[1, 2, 3]).unwrap();
    bw.send(&[4]).unwrap();
    assert_eq!(a.datagram(pa_peer), [1, 2, 3]);
    assert_eq!(a.datagram(pa_peer), [4]);

    // A large datagram arrives whole.
    let big: Vec<u8> = (0..60_000).map(|i| (i * 7) as u8).collect();
    aw.send(&big).unwrap();
    assert_eq!(b.datagram(pb_peer), big);

    // Datagrams from any sender are the one peer's.
    let stranger = UdpSocket::bind("127.0.0.1:0").unwrap();
    stranger.send_to(b"hi", ("127.0.0.1", pa)).unwrap();
    assert_eq!(a.datagram(pa_peer), b"hi");
    a.quiet(Duration::from_millis(50));
    b.quiet(Duration::from_millis(50));
}

#[test]
fn udp_senders_work_on_other_threads() {
    let (pa, pb) = (free_port(), free_port());
    let a = open(&format!("udp://localhost:{pa}:{pb}"));
    let b = open(&format!("udp://127.0.0.1:{pb}:{pa}"));
    let (_, _, aw) = a.up();
    let (peer, _, _) = b.up();
    let sender = thread::spawn(move || {
        for i in 0..10u8 {
            aw.send(&[i; 5]).unwrap();
        }
    });
    sender.join().unwrap();
    let got: Vec<Vec<u8>> = (0..10).map(|_| b.datagram(peer)).collect();
    assert_eq!(got, (0..10u8).map(|i| vec![i; 5]).collect::<Vec<_>>());
}

#[test]
fn udp_ipv6_loopback() {
    let (Ok(a), Ok(b)) = (UdpSocket::bind("[::1]:0"), UdpSocket::bind("[::1]:0")) else {
        eprintln!("skipping: no IPv6 loopback on this machine");
        return;
    };
    let (pa, pb) = (
        a.local_addr().unwrap().port(),
        b.local_addr().unwrap().port(),
    );
    drop((a, b));
    let a = open(&format!("udp://[::1]:{pa}:{pb}"));
    let b = open(&format!("udp://[::1]:{pb}:{pa}"));
    let ((ap, _, aw), (bp, _, bw)) = (a.up(), b.up());
    exchange(&aw, &b, bp, b"over six");
    exchange(&bw, &a, ap, b"and back");
}

#[test]
fn udp_port_in_use_is_an_error_naming_the_uri() {
    let taken = UdpSocket::bind("0.0.0.0:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let uri = format!("udp://127.0.0.1:{port}:1");
    let err = open_err(&uri);
    assert_eq!(err.kind(), io::ErrorKind::AddrInUse);
    assert!(err.to_string().starts_with(&uri), "{err}");
}

// ---------------------------------------------------------------------------------------------
// TCP

#[test]
fn tcp_listen_serves_every_client() {
    let port = free_port();
    let server = open(&format!("tcp-listen://127.0.0.1:{port}"));
    server.quiet(Duration::from_millis(100));

    let first = open(&format!("tcp://127.0.0.1:{port}"));
    let (c1, c1_name, c1w) = first.up();
    assert_eq!(c1_name, format!("tcpout://127.0.0.1:{port}"));
    let (s1, s1_name, s1w) = server.up();
    assert!(
        s1_name.starts_with(&format!("tcpin://127.0.0.1:{port} <- 127.0.0.1:")),
        "{s1_name}"
    );
    exchange(&c1w, &server, s1, b"from the client");
    exchange(&s1w, &first, c1, b"from the server");

    // A second client is a peer of its own; the first one stays.
    let second = open(&format!("tcp://127.0.0.1:{port}"));
    let (c2, _, c2w) = second.up();
    let (s2, _, s2w) = server.up();
    assert_ne!(s1, s2);
    exchange(&c2w, &server, s2, b"second client");
    exchange(&s2w, &second, c2, b"to the second");
    exchange(&s1w, &first, c1, b"still the first");
    first.quiet(Duration::from_millis(50));

    // A megabyte each way at once with the first client, on other threads.
    let big: Vec<u8> = (0..1_000_000u32).map(|i| (i % 251) as u8).collect();
    let sending = {
        let (big, s1w) = (big.clone(), s1w.clone());
        thread::spawn(move || s1w.send(&big))
    };
    c1w.send(&big).unwrap();
    assert!(server.read_exactly(s1, big.len()) == big);
    assert!(first.read_exactly(c1, big.len()) == big);
    sending.join().unwrap().unwrap();

    // The second client leaving takes only its peer down.
    drop((second, c2w));
    let why = server.down(s2);
    assert!(why.contains("closed"), "{why}");
    exchange(&c1w, &server, s1, b"first again");

    // The server going away takes the client's peer down; it is not gone for good (see
    // `tcp_client_reconnects`).
    drop((server, s1w, s2w));
    first.down(c1);
}

/// A `tcpin` endpoint serves up to `MAX_TCP_CLIENTS` clients at once, each with a thread; one
/// past them is closed as soon as it is accepted, and a client is served again once one
/// leaves. Before, every client kept a thread and its descriptors for as long as it stayed.
#[test]
fn a_tcp_client_past_the_limit_is_closed_and_a_slot_that_frees_is_served() {
    use std::io::Read;

    let port = free_port();
    let server = open(&format!("tcp-listen://127.0.0.1:{port}"));
    let mut clients: Vec<TcpStream> = (0..link::MAX_TCP_CLIENTS)
        .map(|_| TcpStream::connect(("127.0.0.1", port)).expect("connect"))
        .collect();
    let ups: Vec<PeerId> = (0..link::MAX_TCP_CLIENTS).map(|_| server.up().0).collect();
    // Two more: closed at once, and never reported.
    for _ in 0..2 {
        let mut past = TcpStream::connect(("127.0.0.1", port)).expect("connect");
        past.set_read_timeout(Some(PATIENCE)).expect("timeout");
        let mut buf = [0u8; 1];
        let read = past.read(&mut buf);
        assert!(
            matches!(read, Ok(0)) || read.is_err_and(|e| e.kind() != io::ErrorKind::WouldBlock),
            "a client past the limit was kept"
        );
    }
    // The others stay open.
    clients[0]
        .set_read_timeout(Some(Duration::from_millis(100)))
        .expect("timeout");
    let read = clients[0].read(&mut [0u8; 1]);
    assert!(
        read.as_ref().is_err_and(|e| matches!(
            e.kind(),
            io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
        )),
        "{read:?}"
    );
    // One leaves (which peer it was depends on the order its thread reported it up in); a
    // newcomer gets its place.
    drop(clients.pop());
    match server.next() {
        Ev::Down(peer, _) => assert!(ups.contains(&peer), "{peer:?}"),
        other => panic!("expected a client to go down, got {other:?}"),
    }
    // Its thread may still be ending as it is reported down: a newcomer that comes in that
    // moment is refused, and comes again.
    let deadline = Instant::now() + PATIENCE;
    let mut newcomers = Vec::new();
    loop {
        newcomers.push(TcpStream::connect(("127.0.0.1", port)).expect("connect"));
        match server.events.recv_timeout(Duration::from_millis(200)) {
            Ok(Ev::Up(..)) => break,
            Ok(other) => panic!("expected the newcomer to come up, got {other:?}"),
            Err(_) => assert!(Instant::now() < deadline, "no newcomer was served"),
        }
    }
}

/// A stopped `tcpin` endpoint lets its port go at once: its accept waits without polling, and
/// is woken at the stop.
#[test]
fn a_stopped_tcp_server_closes_its_port_at_once() {
    let port = free_port();
    let server = open(&format!("tcp-listen://127.0.0.1:{port}"));
    drop(server);
    let start = Instant::now();
    while TcpStream::connect(("127.0.0.1", port)).is_ok() {
        assert!(
            start.elapsed() < Duration::from_secs(1),
            "the port stayed open"
        );
        thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn tcp_client_reconnects() {
    let port = free_port();
    // Nothing listens yet: opening is no error, the client keeps trying.
    let client = open(&format!("tcp://127.0.0.1:{port}"));
    client.quiet(Duration::from_millis(200));
    let accept = |listener: &TcpListener| {
        listener.set_nonblocking(false).unwrap();
        listener.accept().unwrap().0
    };
    let listener = TcpListener::bind(("127.0.0.1", port)).unwrap();
    let start = Instant::now();
    let mut stream: TcpStream = accept(&listener);
    let (peer, _, writer) = client.up();
    // The backoff is capped at 1 s.
    assert!(start.elapsed() < Duration::from_millis(1500));
    writer.send(b"ping").unwrap();
    let mut buf = [0; 4];
    std::io::Read::read_exact(&mut stream, &mut buf).unwrap();
    assert_eq!(&buf, b"ping");

    // The server drops the connection: down, then up again on the next accept.
    drop(stream);
    client.down(peer);
    let mut stream = accept(&listener);
    let (again, _, _) = client.up();
    assert_ne!(peer, again);
    std::io::Write::write_all(&mut stream, b"pong").unwrap();
    assert_eq!(client.read_exactly(again, 4), b"pong");
}

// ---------------------------------------------------------------------------------------------
// pty and serial

#[cfg(unix)]
mod tty {
    use super::*;
    use serialport::{SerialPort, TTYPort};
    use std::fs::{self, File, OpenOptions};
    use std::io::{Read, Write};
    use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
    use std::path::Path;

    /// A pty pair, or `None` (and a note why) where this machine cannot make one.
    fn pty_pair() -> Option<(TTYPort, TTYPort)> {
        match TTYPort::pair() {
            Ok(pair) => Some(pair),
            Err(e) => {
                eprintln!("skipping: cannot create a pseudo-terminal here: {e}");
                None
            }
        }
    }

    /// Opens a tty the plain way, leaving its terminal settings alone.
    fn open_plain(path: &Path) -> File {
        OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(libc::O_NOCTTY)
            .open(path)
            .unwrap_or_else(|e| panic!("opening {}: {e}", path.display()))
    }

    /// `read_exact` on a blocking file, giving up after [`PATIENCE`].
    fn read_file_exactly(file: &File, n: usize) -> Vec<u8> {
        let mut file = file.try_clone().unwrap();
        let (tx, rx) = mpsc::channel();
        thread::spawn(move || {
            let mut buf = vec![0; n];
            let _ = tx.send(file.read_exact(&mut buf).map(|()| buf));
        });
        rx.recv_timeout(PATIENCE)
            .unwrap_or_else(|_| panic!("{n} bytes did not arrive in time"))
            .unwrap()
    }

    fn is_symlink(path: &Path) -> bool {
        fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
    }

    /// Waits until `done` holds, for at most [`PATIENCE`].
    fn eventually(what: &str, done: impl Fn() -> bool) {
        let deadline = Instant::now() + PATIENCE;
        while !done() {
            assert!(Instant::now() < deadline, "{what}");
            thread::sleep(Duration::from_millis(10));
        }
    }

    #[test]
    fn pty_attach_through_symlink() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyX");
        let uri = format!("pty://{}", path.display());
        let pty = open(&uri);
        let target = fs::read_link(&path).expect("the symlink was not created");
        assert!(target.starts_with("/dev/"), "{}", target.display());
        let (peer, name, w) = pty.up();
        assert_eq!(name, uri);

        // Nobody attached yet: quiet, not down.
        pty.quiet(Duration::from_millis(100));

        // Attach without touching the terminal settings: the pty must already be raw.
        let mut attached = open_plain(&path);
        let bytes = all_bytes();
        w.send(&bytes).unwrap();
        assert_eq!(read_file_exactly(&attached, bytes.len()), bytes);
        attached.write_all(&bytes).unwrap();
        assert_eq!(pty.read_exactly(peer, bytes.len()), bytes);

        // The program leaving does not take the link down, and a new one can attach.
        drop(attached);
        pty.quiet(Duration::from_millis(100));
        let mut attached = open_plain(&path);
        w.send(b"again").unwrap();
        assert_eq!(read_file_exactly(&attached, 5), b"again");
        attached.write_all(b"back").unwrap();
        assert_eq!(pty.read_exactly(peer, 4), b"back");
        drop(attached);

        // The symlink goes with the endpoint and its sender.
        drop(pty);
        assert!(is_symlink(&path));
        drop(w);
        eventually("the symlink was not removed", || !is_symlink(&path));
    }

    #[test]
    fn pty_attach_with_serialport() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyBridge");
        let pty = open(&format!("pty://{}&7", path.display()));
        let (peer, _, w) = pty.up();
        let mut attached = serialport::new(path.to_str().unwrap(), 921_600)
            .timeout(PATIENCE)
            .open()
            .expect("attaching with serialport");
        let bytes = all_bytes();
        w.send(&bytes).unwrap();
        let mut got = vec![0; bytes.len()];
        attached.read_exact(&mut got).unwrap();
        assert_eq!(got, bytes);
        attached.write_all(&bytes).unwrap();
        assert_eq!(pty.read_exactly(peer, bytes.len()), bytes);
    }

    #[test]
    fn pty_second_bridge_attaches_with_serial_uri() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyB");
        let pty = open(&format!("pty://{}", path.display()));
        let (pp, _, pw) = pty.up();
        for _ in 0..2 {
            // Attaching twice in a row also checks that the serial endpoint gives up its
            // exclusive claim on the pty (which stays open) when it closes.
            let serial = open(&format!("serial://{}", path.display()));
            let (sp, _, sw) = serial.up();
            exchange(&pw, &serial, sp, &all_bytes());
            exchange(&sw, &pty, pp, &all_bytes());
            drop((serial, sw));
            // The stop wakes the reader, which lets the device go.
            eventually("the serial endpoint kept the device after its stop", || {
                serialport::new(path.to_str().unwrap(), 115_200)
                    .open_native()
                    .is_ok()
            });
        }
        // Root ignores the exclusive flag, so where the test runs as root (and can switch
        // users) check that an unprivileged user can attach, too.
        let device = fs::read_link(&path).unwrap();
        fs::set_permissions(&device, fs::Permissions::from_mode(0o666)).unwrap();
        if let Some(opened) = open_as_nobody(&device) {
            assert!(
                opened,
                "{} is still locked after the link closed",
                device.display()
            );
        }
    }

    /// Whether user `nobody` can open `path` read-write; `None` if we cannot switch users.
    fn open_as_nobody(path: &Path) -> Option<bool> {
        use std::os::unix::process::CommandExt;
        let status = std::process::Command::new("sh")
            .args(["-c", ": <> \"$0\"", path.to_str().unwrap()])
            .uid(65534)
            .gid(65534)
            .status()
            .ok()?;
        Some(status.success())
    }

    #[test]
    fn pty_refuses_to_replace_a_file() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notes.txt");
        fs::write(&path, "keep me").unwrap();
        let uri = format!("pty://{}", path.display());
        let err = open_err(&uri);
        assert_eq!(err.kind(), io::ErrorKind::AlreadyExists, "{err}");
        assert!(err.to_string().starts_with(&uri), "{err}");
        assert!(err.to_string().contains("not a symlink"), "{err}");
        assert_eq!(fs::read_to_string(&path).unwrap(), "keep me");
    }

    #[test]
    fn pty_replaces_a_stale_symlink() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyStale");
        std::os::unix::fs::symlink("/dev/pts/does-not-exist", &path).unwrap();
        let pty = open(&format!("pty://{}", path.display()));
        let target = fs::read_link(&path).unwrap();
        assert_ne!(target, Path::new("/dev/pts/does-not-exist"));
        let mut attached = open_plain(&path);
        let (_, _, w) = pty.up();
        w.send(b"fresh").unwrap();
        assert_eq!(read_file_exactly(&attached, 5), b"fresh");
        attached.flush().unwrap();
    }

    #[test]
    fn pty_write_without_reader_times_out() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyIdle");
        let pty = open(&format!("pty://{}", path.display()));
        let (_, _, w) = pty.up();
        // Nobody drains the pty: once the kernel buffers are full, writes must fail (and
        // promptly) rather than block the caller forever.
        let chunk = [0x55u8; 1024];
        let start = Instant::now();
        let err = (0..16 * 1024)
            .find_map(|_| w.send(&chunk).err())
            .expect("16 MiB went into a pty nobody reads");
        assert_eq!(err.kind(), io::ErrorKind::TimedOut, "{err}");
        assert!(start.elapsed() < PATIENCE, "took {:?}", start.elapsed());
    }

    #[test]
    fn serial_on_a_pty_slave() {
        let Some((mut master, slave)) = pty_pair() else {
            return;
        };
        let slave_path = slave.name().unwrap();
        let serial = open(&format!("serial://{slave_path}:115200&0x01"));
        let (peer, name, w) = serial.up();
        assert_eq!(name, format!("serial://{slave_path}:115200"));

        // The device is exclusive while it is open: a second endpoint does not come up.
        let second = open(&format!("serial://{slave_path}"));
        second.quiet(Duration::from_millis(300));
        drop(second);

        serial.quiet(Duration::from_millis(100));
        master.set_timeout(PATIENCE).unwrap();
        let bytes = all_bytes();
        w.send(&bytes).unwrap();
        let mut got = vec![0; bytes.len()];
        master.read_exact(&mut got).unwrap();
        assert_eq!(got, bytes);
        master.write_all(&bytes).unwrap();
        assert_eq!(serial.read_exactly(peer, bytes.len()), bytes);

        // Released on close: it opens again.
        drop((serial, w));
        let again = open(&format!("serial://{slave_path}"));
        let (peer, _, _) = again.up();
        master.write_all(b"reopened").unwrap();
        assert_eq!(again.read_exactly(peer, 8), b"reopened");
    }

    /// A device that hangs up while its reader waits (a USB adapter pulled out; here the pty's
    /// master closing under its slave) takes the link down: the wait beside the stop's bell
    /// wakes for the hang-up, and the reader does not spin on it.
    #[test]
    fn a_serial_device_that_hangs_up_takes_its_link_down() {
        let Some((master, slave)) = pty_pair() else {
            return;
        };
        let slave_path = slave.name().unwrap();
        let serial = open(&format!("serial://{slave_path}"));
        let (peer, _, _) = serial.up();
        serial.quiet(Duration::from_millis(100));
        drop((master, slave));
        serial.down(peer);
    }
}

/// A `udpin` endpoint on a free port whose peers expire after `expiry`.
fn open_udp_in(expiry: Duration) -> (Opened, u16) {
    let (port, _) = (free_port(), free_port());
    let (sink, events) = events();
    let options = link::Options {
        peer_expiry: expiry,
        ..link::Options::default()
    };
    let endpoint = link::Endpoint::UdpIn("127.0.0.1".into(), port);
    let handle = link::open(0, &endpoint, options, sink).expect("udpin opens");
    (Opened { handle, events }, port)
}

#[test]
fn quiet_udp_peers_expire_on_time_with_and_without_other_traffic() {
    let expiry = Duration::from_millis(400);
    // The reader sets its timeout again only when it would wake more than a sixteenth of the
    // expiry late; the rest is scheduling.
    let late = expiry / 16 + Duration::from_millis(150);
    let on_time = |down: Duration| {
        assert!(
            down >= expiry && down <= expiry + late,
            "down after {down:?}"
        )
    };
    let (opened, port) = open_udp_in(expiry);
    let to = ("127.0.0.1", port);
    let quiet = UdpSocket::bind("127.0.0.1:0").unwrap();
    let start = Instant::now();
    quiet.send_to(b"once", to).unwrap();
    let (quiet_peer, ..) = opened.up();
    opened.datagram(quiet_peer);

    // Another peer keeps sending: the quiet one goes down on time meanwhile.
    let busy = UdpSocket::bind("127.0.0.1:0").unwrap();
    let mut busy_peer = None;
    let mut quiet_down = None;
    let mut last_busy = start;
    while start.elapsed() < expiry + Duration::from_millis(300) {
        busy.send_to(b"busy", to).unwrap();
        last_busy = Instant::now();
        thread::sleep(Duration::from_millis(10));
        while let Ok(ev) = opened.events.try_recv() {
            match ev {
                Ev::Up(peer, ..) => busy_peer = Some(peer),
                Ev::Rx(..) => {}
                Ev::Down(peer, _) => {
                    assert_eq!(peer, quiet_peer, "the busy peer went down");
                    quiet_down.get_or_insert(start.elapsed());
                }
            }
        }
    }
    on_time(quiet_down.expect("the quiet peer went down"));
    // Then everything stops: the last peer goes down on time too.
    let busy_peer = busy_peer.expect("the busy peer came up");
    while let Ev::Rx(peer, _) = opened.next() {
        assert_eq!(peer, busy_peer);
    }
    on_time(last_busy.elapsed());

    // A peer that speaks once, well after the first, does not put off the first one's expiry
    // (a receive waits the timeout from its own start).
    let (first, second) = (
        UdpSocket::bind("127.0.0.1:0").unwrap(),
        UdpSocket::bind("127.0.0.1:0").unwrap(),
    );
    let start = Instant::now();
    first.send_to(b"first", to).unwrap();
    let (first_peer, ..) = opened.up();
    opened.datagram(first_peer);
    thread::sleep(expiry * 3 / 4 - start.elapsed());
    let second_at = Instant::now();
    second.send_to(b"second", to).unwrap();
    let (second_peer, ..) = opened.up();
    opened.datagram(second_peer);
    opened.down(first_peer);
    on_time(start.elapsed());
    opened.down(second_peer);
    on_time(second_at.elapsed());
    drop(opened.handle);
}
