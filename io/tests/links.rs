//! The transports for real: UDP and TCP over loopback, pseudo-terminals, and the serial code
//! path on the slave side of a pty pair.

use std::io;
use std::net::{TcpListener, UdpSocket};
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_io::{Endpoint, Link, LinkReader, LinkWriter};

/// Longest any single step of a test may take before it counts as hung.
const PATIENCE: Duration = Duration::from_secs(5);

fn open(uri: &str) -> Link {
    let endpoint: Endpoint = uri.parse().unwrap_or_else(|e| panic!("{uri}: {e}"));
    Link::open(&endpoint).unwrap_or_else(|e| panic!("opening {uri}: {e}"))
}

fn open_err(uri: &str) -> io::Error {
    let endpoint: Endpoint = uri.parse().unwrap_or_else(|e| panic!("{uri}: {e}"));
    match Link::open(&endpoint) {
        Ok(link) => panic!("{uri} should not open, got {link:?}"),
        Err(e) => e,
    }
}

/// Two UDP ports that were free a moment ago (bound together so they differ).
fn free_udp_ports() -> (u16, u16) {
    let a = UdpSocket::bind("127.0.0.1:0").unwrap();
    let b = UdpSocket::bind("127.0.0.1:0").unwrap();
    (
        a.local_addr().unwrap().port(),
        b.local_addr().unwrap().port(),
    )
}

fn free_tcp_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Reads until exactly `n` bytes arrived; panics if that takes longer than [`PATIENCE`] or the
/// reader returns more (the peer sent something unexpected).
fn read_exactly(reader: &mut dyn LinkReader, n: usize) -> Vec<u8> {
    let deadline = Instant::now() + PATIENCE;
    let mut got = Vec::new();
    let mut buf = vec![0; 65536];
    while got.len() < n {
        assert!(
            Instant::now() < deadline,
            "only {} of {n} bytes arrived: {got:?}",
            got.len()
        );
        let k = reader
            .read(&mut buf, Duration::from_millis(100))
            .expect("read failed");
        got.extend_from_slice(&buf[..k]);
    }
    assert_eq!(got.len(), n, "more bytes than expected arrived");
    got
}

/// Asserts that nothing arrives within `wait`, and that the read really waited that long.
fn assert_quiet(reader: &mut dyn LinkReader, wait: Duration) {
    let mut buf = [0; 256];
    let start = Instant::now();
    let n = reader.read(&mut buf, wait).expect("idle read failed");
    assert_eq!(n, 0, "unexpected bytes {:?}", &buf[..n]);
    let waited = start.elapsed();
    assert!(
        waited >= wait.mul_f32(0.9),
        "read returned after {waited:?}, expected to wait {wait:?}"
    );
}

/// Every byte value, with the ones a cooked terminal would eat or translate (CR, LF, ^C, ^D,
/// ^S/^Q, DEL, the NDLCom flag 0x7E) repeated in a row.
fn all_bytes() -> Vec<u8> {
    let mut bytes: Vec<u8> = (0..=255).collect();
    bytes.extend_from_slice(b"\r\n\r\r\n\n\x03\x04\x11\x13\x7f\x7e\x7d\x00\xff");
    bytes
}

/// Writes on one side and checks the other receives exactly that.
fn exchange(writer: &mut dyn LinkWriter, reader: &mut dyn LinkReader, bytes: &[u8]) {
    writer.write_all(bytes).expect("write failed");
    assert_eq!(read_exactly(reader, bytes.len()), bytes);
}

// ---------------------------------------------------------------------------------------------
// UDP

#[test]
fn udp_loopback() {
    let (pa, pb) = free_udp_ports();
    let a = open(&format!("udp://127.0.0.1:{pa}:{pb}&3,4"));
    let b = open(&format!("udp://127.0.0.1:{pb}:{pa}"));
    assert_eq!(a.name(), format!("udp://127.0.0.1:{pa}:{pb}&3,4"));
    let (mut ar, mut aw) = a.split();
    let (mut br, mut bw) = b.split();

    // Nothing pending: Ok(0) after the timeout, also with a zero timeout.
    assert_quiet(&mut *ar, Duration::from_millis(100));
    assert_eq!(ar.read(&mut [0; 16], Duration::ZERO).unwrap(), 0);

    let mut buf = vec![0; 65536];
    aw.write_all(b"hello").unwrap();
    let n = br.read(&mut buf, PATIENCE).unwrap();
    assert_eq!(&buf[..n], b"hello");

    // Datagram boundaries are kept: one write, one read.
    bw.write_all(&[1, 2, 3]).unwrap();
    bw.write_all(&[4]).unwrap();
    let n = ar.read(&mut buf, PATIENCE).unwrap();
    assert_eq!(&buf[..n], [1, 2, 3]);
    let n = ar.read(&mut buf, PATIENCE).unwrap();
    assert_eq!(&buf[..n], [4]);

    // A large datagram arrives whole, and empty writes send nothing.
    let big: Vec<u8> = (0..60_000).map(|i| (i * 7) as u8).collect();
    aw.write_all(&[]).unwrap();
    aw.write_all(&big).unwrap();
    let n = br.read(&mut buf, PATIENCE).unwrap();
    assert_eq!(&buf[..n], big);
    assert_quiet(&mut *br, Duration::from_millis(50));
}

#[test]
fn udp_halves_work_on_other_threads() {
    let (pa, pb) = free_udp_ports();
    let (_ar, mut aw) = open(&format!("udp://localhost:{pa}:{pb}")).split();
    let (mut br, _bw) = open(&format!("udp://127.0.0.1:{pb}:{pa}")).split();
    let receiver = thread::spawn(move || {
        let mut got = Vec::new();
        let mut buf = [0; 64];
        while got.len() < 10 {
            let n = br.read(&mut buf, PATIENCE).unwrap();
            assert!(n > 0, "timed out after {got:?}");
            got.push(buf[..n].to_vec());
        }
        got
    });
    let sender = thread::spawn(move || {
        for i in 0..10u8 {
            aw.write_all(&[i; 5]).unwrap();
        }
    });
    sender.join().unwrap();
    let got = receiver.join().unwrap();
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
    let (mut ar, mut aw) = open(&format!("udp://[::1]:{pa}:{pb}")).split();
    let (mut br, mut bw) = open(&format!("udp://[::1]:{pb}:{pa}")).split();
    exchange(&mut *aw, &mut *br, b"over six");
    exchange(&mut *bw, &mut *ar, b"and back");
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
fn tcp_listen_and_client() {
    let port = free_tcp_port();
    let server = open(&format!("tcp-listen://127.0.0.1:{port}"));
    assert_eq!(server.name(), format!("tcp-listen://127.0.0.1:{port}"));
    let (mut sr, mut sw) = server.split();

    // No client yet: writes fail, reads wait and return nothing.
    let err = sw.write_all(b"lost").unwrap_err();
    assert_eq!(err.kind(), io::ErrorKind::NotConnected, "{err}");
    assert_quiet(&mut *sr, Duration::from_millis(100));

    let (mut cr, mut cw) = open(&format!("tcp://127.0.0.1:{port}")).split();
    exchange(&mut *cw, &mut *sr, b"from the client");
    exchange(&mut *sw, &mut *cr, b"from the server");
    assert_quiet(&mut *cr, Duration::from_millis(50));

    // A megabyte each way at once, on other threads.
    let big: Vec<u8> = (0..1_000_000u32).map(|i| (i % 251) as u8).collect();
    let expected = big.clone();
    let server_side = thread::spawn(move || {
        let sending = thread::spawn(move || sw.write_all(&big).map(|()| sw));
        let got = read_exactly(&mut *sr, expected.len());
        assert!(got == expected, "server received different bytes");
        (sr, sending.join().unwrap().unwrap())
    });
    let big: Vec<u8> = (0..1_000_000u32).map(|i| (i % 251) as u8).collect();
    cw.write_all(&big).unwrap();
    assert!(read_exactly(&mut *cr, big.len()) == big);
    let (mut sr, mut sw) = server_side.join().unwrap();

    // A new client replaces the first, which is disconnected right away (before the server
    // halves next touch the link).
    let (mut cr2, mut cw2) = open(&format!("tcp://127.0.0.1:{port}")).split();
    let deadline = Instant::now() + PATIENCE;
    let err = loop {
        match cr.read(&mut [0; 16], Duration::from_millis(100)) {
            Ok(0) => assert!(Instant::now() < deadline, "first client not disconnected"),
            Ok(n) => panic!("first client got {n} bytes"),
            Err(e) => break e,
        }
    };
    assert_eq!(err.kind(), io::ErrorKind::UnexpectedEof, "{err}");
    exchange(&mut *cw2, &mut *sr, b"second client");
    exchange(&mut *sw, &mut *cr2, b"to the second");

    // The client leaving is no error for the server; writes then fail until the next one.
    drop((cr2, cw2));
    assert_quiet(&mut *sr, Duration::from_millis(200));
    let err = sw.write_all(b"lost").unwrap_err();
    assert_eq!(err.kind(), io::ErrorKind::NotConnected, "{err}");

    // A third client is served again.
    let (mut cr3, mut cw3) = open(&format!("tcp://127.0.0.1:{port}")).split();
    exchange(&mut *cw3, &mut *sr, b"third");
    exchange(&mut *sw, &mut *cr3, b"hello third");

    // The server going away ends the client link, and frees the port.
    drop((sr, sw));
    let err = cr3
        .read(&mut [0; 16], PATIENCE)
        .expect_err("the server is gone");
    assert_eq!(err.kind(), io::ErrorKind::UnexpectedEof, "{err}");
    let deadline = Instant::now() + PATIENCE;
    while TcpListener::bind(("127.0.0.1", port)).is_err() {
        assert!(Instant::now() < deadline, "the listener was not closed");
        thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn tcp_listen_read_waits_for_a_client() {
    let port = free_tcp_port();
    let (mut sr, _sw) = open(&format!("tcp-listen://:{port}")).split();
    let client = thread::spawn(move || {
        thread::sleep(Duration::from_millis(200));
        let (_cr, mut cw) = open(&format!("tcp://localhost:{port}")).split();
        cw.write_all(b"late").unwrap();
        thread::sleep(Duration::from_millis(500));
    });
    // One read call spans the wait for the client and for its bytes.
    let mut buf = [0; 16];
    let n = sr.read(&mut buf, PATIENCE).unwrap();
    assert_eq!(&buf[..n], b"late");
    client.join().unwrap();
}

#[test]
fn tcp_connect_refused_names_the_uri() {
    let port = free_tcp_port();
    let uri = format!("tcp://127.0.0.1:{port}");
    let err = open_err(&uri);
    assert_eq!(err.kind(), io::ErrorKind::ConnectionRefused, "{err}");
    assert!(err.to_string().starts_with(&uri), "{err}");
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
    use std::sync::mpsc;

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

    #[test]
    fn pty_attach_through_symlink() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyX");
        let uri = format!("pty://{}", path.display());
        let link = open(&uri);
        assert_eq!(link.name(), uri);
        let target = fs::read_link(&path).expect("the symlink was not created");
        assert!(target.starts_with("/dev/"), "{}", target.display());
        let (mut r, mut w) = link.split();

        // Nobody attached yet: reading is quiet, not an error.
        assert_quiet(&mut *r, Duration::from_millis(100));

        // Attach without touching the terminal settings: the pty must already be raw.
        let mut peer = open_plain(&path);
        let bytes = all_bytes();
        w.write_all(&bytes).unwrap();
        assert_eq!(read_file_exactly(&peer, bytes.len()), bytes);
        peer.write_all(&bytes).unwrap();
        assert_eq!(read_exactly(&mut *r, bytes.len()), bytes);

        // The peer leaving does not break the link, and a new one can attach.
        drop(peer);
        assert_quiet(&mut *r, Duration::from_millis(100));
        let mut peer = open_plain(&path);
        w.write_all(b"again").unwrap();
        assert_eq!(read_file_exactly(&peer, 5), b"again");
        peer.write_all(b"back").unwrap();
        assert_eq!(read_exactly(&mut *r, 4), b"back");
        drop(peer);

        // The symlink lives as long as either half.
        drop(r);
        assert!(is_symlink(&path));
        drop(w);
        assert!(!is_symlink(&path), "the symlink was not removed");
    }

    #[test]
    fn pty_attach_with_serialport() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyBridge");
        let (mut r, mut w) = open(&format!("pty://{}&7", path.display())).split();
        let mut peer = serialport::new(path.to_str().unwrap(), 921_600)
            .timeout(PATIENCE)
            .open()
            .expect("attaching with serialport");
        let bytes = all_bytes();
        w.write_all(&bytes).unwrap();
        let mut got = vec![0; bytes.len()];
        peer.read_exact(&mut got).unwrap();
        assert_eq!(got, bytes);
        peer.write_all(&bytes).unwrap();
        assert_eq!(read_exactly(&mut *r, bytes.len()), bytes);
    }

    #[test]
    fn pty_second_bridge_attaches_with_serial_uri() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyB");
        let (mut pr, mut pw) = open(&format!("pty://{}", path.display())).split();
        for _ in 0..2 {
            // Attaching twice in a row also checks that the serial link gives up its
            // exclusive claim on the pty (which stays open) when it is dropped.
            let (mut sr, mut sw) = open(&format!("serial://{}", path.display())).split();
            exchange(&mut *pw, &mut *sr, &all_bytes());
            exchange(&mut *sw, &mut *pr, &all_bytes());
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
        let err = open_err(&format!("pty://{}", path.display()));
        assert_eq!(err.kind(), io::ErrorKind::AlreadyExists, "{err}");
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
        let link = open(&format!("pty://{}", path.display()));
        let target = fs::read_link(&path).unwrap();
        assert_ne!(target, Path::new("/dev/pts/does-not-exist"));
        let mut peer = open_plain(&path);
        let (_r, mut w) = link.split();
        w.write_all(b"fresh").unwrap();
        assert_eq!(read_file_exactly(&peer, 5), b"fresh");
        peer.flush().unwrap();
    }

    #[test]
    fn pty_write_without_reader_times_out() {
        if pty_pair().is_none() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ttyIdle");
        let (_r, mut w) = open(&format!("pty://{}", path.display())).split();
        // Nobody drains the pty: once the kernel buffers are full, writes must fail (and
        // promptly) rather than block the caller forever.
        let chunk = [0x55u8; 1024];
        let start = Instant::now();
        let err = (0..16 * 1024)
            .find_map(|_| w.write_all(&chunk).err())
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
        let uri = format!("serial://{slave_path}:115200&0x01");
        let link = open(&uri);
        assert_eq!(link.name(), format!("serial://{slave_path}:115200&1"));

        // The device is exclusive while the link is open.
        let err = open_err(&format!("serial://{slave_path}"));
        assert!(err.to_string().contains(&slave_path), "{err}");

        let (mut r, mut w) = link.split();
        assert_quiet(&mut *r, Duration::from_millis(100));
        assert_eq!(r.read(&mut [0; 8], Duration::ZERO).unwrap(), 0);

        master.set_timeout(PATIENCE).unwrap();
        let bytes = all_bytes();
        w.write_all(&bytes).unwrap();
        let mut got = vec![0; bytes.len()];
        master.read_exact(&mut got).unwrap();
        assert_eq!(got, bytes);
        master.write_all(&bytes).unwrap();
        assert_eq!(read_exactly(&mut *r, bytes.len()), bytes);

        // Halves on other threads.
        let reader = thread::spawn(move || read_exactly(&mut *r, 3));
        master.write_all(b"abc").unwrap();
        assert_eq!(reader.join().unwrap(), b"abc");
        drop(w);

        // Released on drop: it opens again.
        let (mut r, _w) = open(&format!("serial://{slave_path}")).split();
        master.write_all(b"reopened").unwrap();
        assert_eq!(read_exactly(&mut *r, 8), b"reopened");
    }
}
