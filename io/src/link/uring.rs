//! Sending and sleeping in one system call: a UDP reader hands the datagrams it holds to an
//! io_uring and waits, in the same `io_uring_enter`, until its socket is readable again.
//!
//! With `sendmmsg` and then a blocking `recvmmsg`, a reader that sends to two peers makes three
//! system calls per wake-up, and each `sendmmsg` wakes a peer that, on a machine with few cores,
//! preempts the reader on its way back from the call: the reader is switched out and in once per
//! socket it sends from. Here the peers are woken while the reader is about to sleep anyway, and
//! the only switch is its own (measured in `cargo bench -p ferrolink-bench --bench router`).
//!
//! This is the link layer's one module with `unsafe` (beside a serial port's descriptor lent to a
//! poll, in `serial.rs`): the kernel reads the datagrams' bytes and
//! addresses through pointers, so they must stay where they are until it is done with them. See
//! [`Ring::send_and_wait`].
#![allow(unsafe_code)]

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::ops::Range;
use std::os::fd::{AsRawFd, RawFd};
use std::time::{Duration, Instant};

use io_uring::{opcode, types, IoUring};
use nix::sys::socket::{SockaddrLike, SockaddrStorage};

/// Submission slots: a batch with more datagrams is submitted in parts.
const ENTRIES: u32 = 128;
/// The poll's completion tag; a send's tag is its datagram's index.
const POLL: u64 = u64::MAX;

/// How a wait ended.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Woken {
    /// The socket is readable (or was, when an earlier wait's poll fired: reading may then
    /// find nothing).
    Readable,
    /// `until` passed first.
    TimedOut,
}

/// A reader thread's ring.
pub(crate) struct Ring {
    ring: IoUring,
    /// Whether a poll is in the ring that has not completed: a wait that timed out leaves it.
    polling: bool,
    /// The datagrams being sent: each one's socket and bytes (in the wire buffer).
    sends: Vec<(RawFd, Range<usize>)>,
    /// Their addresses, read by the kernel.
    addresses: Vec<SockaddrStorage>,
}

impl Ring {
    /// A ring, or `None` where the kernel has none to give (before Linux 5.11, which can wait
    /// with a timeout, or where io_uring is disabled, as some container sandboxes do).
    pub(crate) fn new() -> Option<Ring> {
        // A plain ring: one that posts completions only when the thread waits in it
        // (`setup_defer_taskrun`) cost as much CPU and added latency now and then (p50 at 1k
        // msg/s of 81 to 95 µs in three rounds of six, against 55 to 69 µs). A poll left by a
        // wait that timed out may then interrupt the reader's next blocking receive once
        // (EINTR), which it takes as a timeout.
        let ring = IoUring::builder().setup_submit_all().build(ENTRIES).ok()?;
        ring.params().is_feature_ext_arg().then(|| Ring {
            ring,
            polling: false,
            sends: Vec::new(),
            addresses: Vec::new(),
        })
    }

    /// Sends each datagram (from its socket, to its address, `wire[bytes]`), then waits until
    /// `readable` has something to read or `until` passes. A datagram the kernel refuses is
    /// lost, as a UDP datagram may be.
    ///
    /// It returns only when the kernel has finished with every datagram, so nothing it was
    /// given can be freed or moved under it. If that cannot be known (the ring itself failed,
    /// which a working kernel never does), `wire` and the addresses are left allocated for good
    /// and the error is returned: the caller then drops the ring and sends without one.
    ///
    /// A ring serves one reader: a poll left by a wait that timed out is for its socket.
    pub(crate) fn send_and_wait<'a>(
        &mut self,
        datagrams: impl Iterator<Item = (&'a UdpSocket, SocketAddr, Range<usize>)>,
        wire: &mut Vec<u8>,
        readable: &UdpSocket,
        until: Option<Instant>,
    ) -> io::Result<Woken> {
        // Every address is in place before the first is handed over: the vector must not grow
        // while the kernel may read it. (The sockets are borrowed for the whole call.)
        self.sends.clear();
        self.addresses.clear();
        for (socket, to, bytes) in datagrams {
            self.sends.push((socket.as_raw_fd(), bytes));
            self.addresses.push(SockaddrStorage::from(to));
        }
        let datagrams = &self.sends;
        let mut queued = 0;
        let mut seen = 0;
        let mut woken = None;
        loop {
            // Fill the submission queue with what is left, then the poll.
            while let Some((socket, bytes)) = datagrams.get(queued) {
                let Some(bytes) = wire.get(bytes.clone()) else {
                    // Not a datagram of `wire`: nothing to send, and nothing to wait for.
                    queued += 1;
                    seen += 1;
                    continue;
                };
                let to = &self.addresses[queued];
                let send = opcode::Send::new(
                    types::Fd(*socket),
                    bytes.as_ptr(),
                    u32::try_from(bytes.len()).unwrap_or(u32::MAX),
                )
                // Never retried in the background: a full socket buffer fails the send now.
                .flags(libc::MSG_DONTWAIT)
                .dest_addr(to.as_ptr())
                .dest_addr_len(to.len())
                .build()
                .user_data(queued as u64);
                // SAFETY: the bytes (in `wire`) and the address (in `self.addresses`) stay
                // where they are until this send's completion has been seen below, or, if
                // this function gives up, for good.
                if unsafe { self.ring.submission().push(&send) }.is_err() {
                    break;
                }
                queued += 1;
            }
            if queued == datagrams.len() && woken.is_none() && !self.polling {
                let poll = poll(readable.as_raw_fd());
                // SAFETY: a poll reads no memory of ours.
                if unsafe { self.ring.submission().push(&poll) }.is_ok() {
                    self.polling = true;
                }
            }
            let want = (queued - seen) + usize::from(woken.is_none() && self.polling);
            let submitted = match until {
                Some(until) => {
                    let left = types::Timespec::from(
                        until
                            .saturating_duration_since(Instant::now())
                            .max(Duration::from_micros(1)),
                    );
                    let args = types::SubmitArgs::new().timespec(&left);
                    self.ring.submitter().submit_with_args(want, &args)
                }
                None => self.ring.submitter().submit_and_wait(want),
            };
            let timed_out = match submitted {
                Ok(_) => false,
                Err(e) if e.raw_os_error() == Some(libc::ETIME) => true,
                Err(e)
                    if matches!(
                        e.raw_os_error(),
                        Some(libc::EINTR | libc::EAGAIN | libc::EBUSY)
                    ) =>
                {
                    false
                }
                Err(e) => {
                    // The kernel may still hold pointers into these: they stay allocated.
                    std::mem::forget(std::mem::take(wire));
                    std::mem::forget(std::mem::take(&mut self.addresses));
                    return Err(e);
                }
            };
            for completion in self.ring.completion() {
                if completion.user_data() == POLL {
                    self.polling = false;
                    woken = Some(Woken::Readable);
                } else {
                    seen += 1;
                }
            }
            if seen == datagrams.len() {
                if timed_out {
                    woken.get_or_insert(Woken::TimedOut);
                }
                if let Some(woken) = woken {
                    return Ok(woken);
                }
            }
        }
    }
}

/// A one-shot poll for `fd` becoming readable.
fn poll(fd: RawFd) -> io_uring::squeue::Entry {
    opcode::PollAdd::new(types::Fd(fd), libc::POLLIN as u32)
        .build()
        .user_data(POLL)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ring; `None` (with a note) where the kernel gives none, unless the test run found that
    /// it does (`FERROLINK_REQUIRE_IO_URING`, set by `tests/run-all.sh`).
    fn ring() -> Option<Ring> {
        let ring = Ring::new();
        if ring.is_none() {
            assert!(
                std::env::var_os("FERROLINK_REQUIRE_IO_URING").is_none(),
                "this kernel gives io_uring rings, but Ring::new set none up"
            );
            let _ = crate::printer::stderr()
                .line("note: this kernel gives no io_uring; the link layer sends without one");
        }
        ring
    }

    fn bound() -> UdpSocket {
        let s = UdpSocket::bind("127.0.0.1:0").expect("bind");
        s.set_read_timeout(Some(Duration::from_secs(2)))
            .expect("timeout");
        s
    }

    #[test]
    fn more_datagrams_than_the_ring_has_slots_all_go_out_in_order() {
        let Some(mut ring) = ring() else { return };
        let (out, peer, read) = (bound(), bound(), bound());
        super::super::batch::widen_receive_buffer(&peer);
        let to = peer.local_addr().expect("bound");
        let n = 3 * ENTRIES as usize + 7;
        let mut wire: Vec<u8> = (0..n as u32).flat_map(u32::to_le_bytes).collect();
        let datagrams = (0..n).map(|i| (&out, to, 4 * i..4 * i + 4));
        let until = Some(Instant::now() + Duration::from_millis(20));
        let woken = ring
            .send_and_wait(datagrams, &mut wire, &read, until)
            .expect("sent");
        assert_eq!(woken, Woken::TimedOut);
        let mut buf = [0u8; 8];
        for i in 0..n as u32 {
            let got = peer.recv(&mut buf).expect("a datagram");
            assert_eq!(buf[..got], i.to_le_bytes());
        }
    }

    #[test]
    fn a_refused_datagram_is_lost_and_the_others_go_out() {
        let Some(mut ring) = ring() else { return };
        let (out, peer, read) = (bound(), bound(), bound());
        let to = peer.local_addr().expect("bound");
        // An IPv6 address from an IPv4 socket, and bytes that are not in the wire buffer.
        let nowhere: SocketAddr = "[::1]:9".parse().expect("address");
        let mut wire = b"firstsecond".to_vec();
        let datagrams = [
            (&out, nowhere, 0..5),
            (&out, to, 0..5),
            (&out, to, 5..99),
            (&out, to, 5..11),
        ];
        let waker = bound();
        waker
            .send_to(b"wake", read.local_addr().expect("bound"))
            .expect("send");
        let woken = ring
            .send_and_wait(datagrams.into_iter(), &mut wire, &read, None)
            .expect("sent");
        assert_eq!(woken, Woken::Readable);
        let mut buf = [0u8; 64];
        let n = peer.recv(&mut buf).expect("a datagram");
        assert_eq!(&buf[..n], b"first");
        let n = peer.recv(&mut buf).expect("a datagram");
        assert_eq!(&buf[..n], b"second");
    }
}
