//! What the workspace's tests share.
//!
//! # Ports
//! A test that asks the kernel for a free port (bind to port 0, note it, close the socket) and
//! hands it to a daemon a moment later races every socket on the machine: the kernel picks the
//! source port of any other socket, in any process, from the same ephemeral range, and a busy
//! test run opens thousands. So the ports here come from *below* the ephemeral range, where the
//! kernel never hands anything out unasked; only our own tests compete for them there. Each
//! process starts at its own place (by process id) and walks forward, and a port is handed out
//! only once both a UDP and a TCP socket could bind it on loopback.
//!
//! `tests/mavlink/ports.py` does the same for the Python scripts, with the same layout, so the
//! two never start at the same place for different processes.

use std::net::{Ipv4Addr, TcpListener, UdpSocket};
use std::sync::atomic::{AtomicU32, Ordering};

/// The lowest port handed out. Below it sit the well-known and commonly configured ones.
const LOW: u16 = 12_000;
/// Ports between two processes' starting places.
const STRIDE: u32 = 40;

/// The first port of the kernel's ephemeral range (`ip_local_port_range`), 32768 if unknown.
fn ephemeral_low() -> u16 {
    std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .filter(|&p: &u16| p > LOW + 1_000)
        .unwrap_or(32_768)
}

/// Ports handed out by this process so far.
static NEXT: AtomicU32 = AtomicU32::new(0);

fn bindable(port: u16) -> bool {
    UdpSocket::bind((Ipv4Addr::LOCALHOST, port)).is_ok()
        && TcpListener::bind((Ipv4Addr::LOCALHOST, port)).is_ok()
}

/// `n` consecutive loopback ports, free for UDP and TCP, that no other socket is handed while
/// the caller sets up whatever binds them.
pub fn free_ports(n: u16) -> u16 {
    assert!((1..=64).contains(&n), "ask for 1 to 64 ports at a time");
    let span = u32::from(ephemeral_low() - LOW);
    let start = std::process::id().wrapping_mul(STRIDE) % span;
    for _ in 0..span {
        let offset = (start + NEXT.fetch_add(u32::from(n), Ordering::Relaxed)) % span;
        if offset + u32::from(n) > span {
            continue;
        }
        let first = LOW + offset as u16;
        if (first..first + n).all(bindable) {
            return first;
        }
    }
    panic!("no {n} free loopback ports below the ephemeral range");
}

/// One loopback port, free for UDP and TCP (see the crate's documentation).
pub fn free_port() -> u16 {
    free_ports(1)
}

/// Shrinks the pipe behind `fd` (a child's piped stdout, say) to one page, so that a test fills
/// it with a few kilobytes; `false` where the kernel cannot (not Linux).
pub fn shrink_pipe(fd: impl std::os::fd::AsFd) -> bool {
    #[cfg(target_os = "linux")]
    {
        use nix::fcntl::{fcntl, FcntlArg};
        fcntl(fd, FcntlArg::F_SETPIPE_SZ(4096)).is_ok()
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = fd;
        false
    }
}

/// Makes a FIFO at `path` and opens its reading end, without waiting for a writer, on a pipe
/// shrunk to one page: a program told to write there can open it, and is stuck once it has
/// written a few kilobytes, until the test reads (the returned end is non-blocking). `None`
/// where that cannot be done (not Linux).
pub fn unread_fifo(path: &std::path::Path) -> Option<std::fs::File> {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::fs::OpenOptionsExt;
        nix::unistd::mkfifo(path, nix::sys::stat::Mode::S_IRWXU).ok()?;
        let reader = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(nix::libc::O_NONBLOCK)
            .open(path)
            .ok()?;
        shrink_pipe(&reader).then_some(reader)
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = path;
        None
    }
}

/// Reads the non-blocking `reader` until its writers have all closed it.
pub fn read_to_close(reader: &mut impl std::io::Read) -> Vec<u8> {
    let mut got = Vec::new();
    let mut buf = [0u8; 65536];
    loop {
        match reader.read(&mut buf) {
            Ok(0) => return got,
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => panic!("read: {e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ports_are_below_the_ephemeral_range_distinct_and_bindable() {
        let low = ephemeral_low();
        let mut seen = std::collections::HashSet::new();
        for _ in 0..200 {
            let p = free_port();
            assert!((LOW..low).contains(&p), "{p}");
            assert!(seen.insert(p), "{p} handed out twice");
            assert!(bindable(p));
        }
        let first = free_ports(16);
        assert!(u32::from(first) + 16 <= u32::from(low));
        assert!((first..first + 16).all(|p| !seen.contains(&p)));
    }

    #[test]
    fn a_port_in_use_is_passed_over() {
        let p = free_port();
        let _held = UdpSocket::bind((Ipv4Addr::LOCALHOST, p + 1)).unwrap();
        let next = free_port();
        assert_ne!(next, p + 1);
    }
}
