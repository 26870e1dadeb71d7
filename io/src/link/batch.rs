//! Many datagrams a system call: a UDP reader takes what has arrived with one `recvmmsg`, and
//! the datagrams its sink sends while it handles them go out together, one `sendmmsg` per
//! socket, once the batch is handled (and any lock the sink took is released).
//!
//! On systems without these calls, each datagram is one call, as before.

use std::cell::RefCell;
use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::ops::Range;
use std::sync::Arc;

/// Datagrams read at most per call.
pub(crate) const BATCH: usize = 64;
/// Room for each datagram of a batch: the largest UDP datagram fits. (The buffer is allocated
/// zeroed, so the kernel maps its pages only as datagrams fill them.)
pub(crate) const DATAGRAM_ROOM: usize = 64 * 1024;

/// Datagrams waiting for the end of the batch.
#[derive(Default)]
struct Outbox {
    sends: Vec<(Arc<UdpSocket>, SocketAddr, Range<usize>)>,
    bytes: Vec<u8>,
}

thread_local! {
    static OUTBOX: RefCell<Option<Outbox>> = const { RefCell::new(None) };
}

/// Runs `handle` with the sends of UDP [`Sender`](super::Sender)s on this thread held back,
/// then sends them, one system call per socket where the system allows.
pub(crate) fn batch<R>(handle: impl FnOnce() -> R) -> R {
    let nested = OUTBOX.with(|o| o.borrow().is_some());
    if nested {
        return handle();
    }
    OUTBOX.with(|o| *o.borrow_mut() = Some(Outbox::default()));
    let result = handle();
    if let Some(outbox) = OUTBOX.with(|o| o.borrow_mut().take()) {
        flush(outbox);
    }
    result
}

/// Holds a datagram back until the batch ends; `false` when no batch is running (send it now).
pub(crate) fn defer(socket: &Arc<UdpSocket>, to: SocketAddr, bytes: &[u8]) -> bool {
    OUTBOX.with(|o| match o.borrow_mut().as_mut() {
        Some(outbox) => {
            let start = outbox.bytes.len();
            outbox.bytes.extend_from_slice(bytes);
            outbox
                .sends
                .push((socket.clone(), to, start..outbox.bytes.len()));
            true
        }
        None => false,
    })
}

/// Sends what a batch held back, in order per socket. A datagram the kernel refuses is lost, as
/// a UDP datagram may be.
fn flush(mut outbox: Outbox) {
    // Group by socket, keeping each socket's order.
    outbox.sends.sort_by_key(|(socket, ..)| Arc::as_ptr(socket));
    let mut rest = &outbox.sends[..];
    while let Some((first, ..)) = rest.first() {
        let n = rest
            .iter()
            .take_while(|(s, ..)| Arc::ptr_eq(s, first))
            .count();
        let (group, tail) = rest.split_at(n);
        send_all(first, group, &outbox.bytes);
        rest = tail;
    }
}

#[cfg(target_os = "linux")]
fn send_all(
    socket: &UdpSocket,
    group: &[(Arc<UdpSocket>, SocketAddr, Range<usize>)],
    bytes: &[u8],
) {
    use nix::sys::socket::{sendmmsg, MsgFlags, MultiHeaders, SockaddrStorage};
    use std::io::IoSlice;
    use std::os::fd::AsRawFd;

    let mut pending = group;
    while !pending.is_empty() {
        let slices: Vec<[IoSlice<'_>; 1]> = pending
            .iter()
            .map(|(_, _, r)| [IoSlice::new(bytes.get(r.clone()).unwrap_or_default())])
            .collect();
        let addrs: Vec<Option<SockaddrStorage>> = pending
            .iter()
            .map(|(_, to, _)| Some(SockaddrStorage::from(*to)))
            .collect();
        let mut headers = MultiHeaders::<SockaddrStorage>::preallocate(slices.len(), None);
        let sent = sendmmsg(
            socket.as_raw_fd(),
            &mut headers,
            &slices,
            &addrs,
            [],
            MsgFlags::empty(),
        )
        .map(Iterator::count);
        match sent {
            Ok(n) if n > 0 => pending = pending.get(n..).unwrap_or_default(),
            Err(nix::errno::Errno::EINTR) => {}
            // The first datagram was refused (an ICMP error pending, a full buffer): skip it
            // and carry on with the rest.
            _ => pending = pending.get(1..).unwrap_or_default(),
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn send_all(
    socket: &UdpSocket,
    group: &[(Arc<UdpSocket>, SocketAddr, Range<usize>)],
    bytes: &[u8],
) {
    for (_, to, r) in group {
        let _ = socket.send_to(bytes.get(r.clone()).unwrap_or_default(), to);
    }
}

/// The receive buffer asked for on every UDP endpoint's socket: at 50,000 datagrams a second,
/// tens of milliseconds of traffic, so that a reader the scheduler keeps waiting on a busy
/// machine loses nothing. The kernel caps it at `net.core.rmem_max`.
pub(crate) const RECEIVE_BUFFER: usize = 2 << 20;

/// Asks for [`RECEIVE_BUFFER`] bytes of receive buffer; a system that gives less keeps its
/// default.
pub(crate) fn widen_receive_buffer(socket: &UdpSocket) {
    #[cfg(target_os = "linux")]
    {
        use nix::sys::socket::{setsockopt, sockopt::RcvBuf};
        let _ = setsockopt(socket, RcvBuf, &RECEIVE_BUFFER);
    }
    #[cfg(not(target_os = "linux"))]
    let _ = socket;
}

/// Room to read a batch of datagrams into.
pub(crate) struct Inbox {
    buf: Vec<u8>,
    got: Vec<(usize, Option<SocketAddr>)>,
    #[cfg(target_os = "linux")]
    headers: nix::sys::socket::MultiHeaders<nix::sys::socket::SockaddrStorage>,
}

impl Inbox {
    pub(crate) fn new() -> Inbox {
        Inbox {
            buf: vec![0; BATCH * DATAGRAM_ROOM],
            got: Vec::with_capacity(BATCH),
            #[cfg(target_os = "linux")]
            headers: nix::sys::socket::MultiHeaders::preallocate(BATCH, None),
        }
    }

    /// Waits (up to the socket's read timeout) for a datagram, and takes what else has arrived
    /// with it, up to [`BATCH`].
    #[cfg(target_os = "linux")]
    pub(crate) fn receive(&mut self, socket: &UdpSocket) -> io::Result<usize> {
        use nix::sys::socket::{recvmmsg, MsgFlags};
        use std::io::IoSliceMut;
        use std::os::fd::AsRawFd;

        self.got.clear();
        let mut slices: Vec<[IoSliceMut<'_>; 1]> = self
            .buf
            .chunks_mut(DATAGRAM_ROOM)
            .map(|c| [IoSliceMut::new(c)])
            .collect();
        let received = recvmmsg(
            socket.as_raw_fd(),
            &mut self.headers,
            slices.iter_mut(),
            MsgFlags::MSG_WAITFORONE,
            None,
        )
        .map_err(io::Error::from)?;
        for m in received {
            let from = m.address.and_then(|a| {
                a.as_sockaddr_in()
                    .map(|v4| SocketAddr::V4((*v4).into()))
                    .or_else(|| a.as_sockaddr_in6().map(|v6| SocketAddr::V6((*v6).into())))
            });
            self.got.push((m.bytes.min(DATAGRAM_ROOM), from));
        }
        Ok(self.got.len())
    }

    #[cfg(not(target_os = "linux"))]
    pub(crate) fn receive(&mut self, socket: &UdpSocket) -> io::Result<usize> {
        self.got.clear();
        let room = self.buf.get_mut(..DATAGRAM_ROOM).unwrap_or_default();
        let (n, from) = socket.recv_from(room)?;
        self.got.push((n, Some(from)));
        Ok(1)
    }

    /// The datagrams of the last [`Inbox::receive`], with their senders.
    pub(crate) fn datagrams(&self) -> impl Iterator<Item = (&[u8], Option<SocketAddr>)> + '_ {
        self.got.iter().enumerate().map(|(i, &(n, from))| {
            let at = i * DATAGRAM_ROOM;
            (self.buf.get(at..at + n).unwrap_or_default(), from)
        })
    }
}
