//! Many datagrams a system call: a UDP reader takes what has arrived with one `recvmmsg`, and
//! the datagrams its sink sends while it handles them go out together, one `sendmmsg` per
//! socket, once the batch is handled (and any lock the sink took is released).
//!
//! Senders that allow it ([`Options::pack_up_to`](super::Options::pack_up_to)) also share
//! datagrams: what a batch sends to one address goes out in as few datagrams as fit, each
//! frame whole and in order.
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

/// Where a held-back write goes: the socket, the address, and the largest datagram it may share
/// with the writes after it (0: a datagram of its own).
#[derive(Clone)]
pub(crate) struct Route {
    pub(crate) socket: Arc<UdpSocket>,
    pub(crate) to: SocketAddr,
    pub(crate) pack_up_to: usize,
}

/// A datagram that fits any path: the size QUIC relies on (RFC 9000, 14.1), below the MTU of
/// Ethernet, Wi-Fi and the usual tunnels (WireGuard, IPsec, PPPoE) with their headers.
pub const PACKED_DATAGRAM: usize = 1200;

/// Datagrams waiting for the end of the batch: each write's route and its bytes in `bytes`.
#[derive(Default)]
struct Outbox {
    sends: Vec<(Route, Range<usize>)>,
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

/// Holds a write back until the batch ends; `false` when no batch is running (send it now).
pub(crate) fn defer(route: &Route, bytes: &[u8]) -> bool {
    OUTBOX.with(|o| match o.borrow_mut().as_mut() {
        Some(outbox) => {
            let start = outbox.bytes.len();
            outbox.bytes.extend_from_slice(bytes);
            outbox
                .sends
                .push((route.clone(), start..outbox.bytes.len()));
            true
        }
        None => false,
    })
}

/// Sends what a batch held back, in order per address. A datagram the kernel refuses is lost,
/// as a UDP datagram may be.
fn flush(mut outbox: Outbox) {
    let sends = in_send_order(std::mem::take(&mut outbox.sends));
    let datagrams = pack(&sends);
    let mut rest = &datagrams[..];
    while let Some((first, _)) = rest.first() {
        let n = rest
            .iter()
            .take_while(|(r, _)| Arc::ptr_eq(&r.socket, &first.socket))
            .count();
        let (group, tail) = rest.split_at(n);
        send_all(&first.socket, group, &outbox.bytes);
        rest = tail;
    }
}

/// The writes grouped by socket, then address, keeping the order of the writes to each address,
/// and sockets and addresses in the order they were first written to: the peer a frame was
/// handed to first is sent to first, in every batch.
fn in_send_order(sends: Vec<(Route, Range<usize>)>) -> Vec<(Route, Range<usize>)> {
    let mut seen: Vec<(*const UdpSocket, SocketAddr)> = Vec::new();
    let mut rank = |route: &Route| {
        let key = (Arc::as_ptr(&route.socket), route.to);
        let socket = seen.iter().position(|(s, _)| *s == key.0);
        let address = seen.iter().position(|k| *k == key).unwrap_or_else(|| {
            seen.push(key);
            seen.len() - 1
        });
        (socket.unwrap_or(address), address)
    };
    let mut ranked: Vec<_> = sends.into_iter().map(|s| (rank(&s.0), s)).collect();
    // Stable: writes to one address keep their order.
    ranked.sort_by_key(|(rank, _)| *rank);
    ranked.into_iter().map(|(_, send)| send).collect()
}

/// The datagrams of writes [in send order](in_send_order): each write's bytes are whole in one datagram, and runs of
/// writes to one address share one while they fit the route's [`Route::pack_up_to`]. The
/// writes' bytes lie back to back in the outbox in the order they were written, so a datagram
/// is a list of ranges.
fn pack(sends: &[(Route, Range<usize>)]) -> Vec<(&Route, Vec<Range<usize>>)> {
    let mut datagrams: Vec<(&Route, Vec<Range<usize>>, usize)> = Vec::with_capacity(sends.len());
    for (route, bytes) in sends {
        if let Some((last, parts, len)) = datagrams.last_mut() {
            let fits = *len + bytes.len() <= route.pack_up_to;
            if fits && Arc::ptr_eq(&last.socket, &route.socket) && last.to == route.to {
                parts.push(bytes.clone());
                *len += bytes.len();
                continue;
            }
        }
        datagrams.push((route, vec![bytes.clone()], bytes.len()));
    }
    datagrams
        .into_iter()
        .map(|(route, parts, _)| (route, parts))
        .collect()
}

/// One datagram: where it goes and the ranges of the outbox's bytes it carries.
type Datagram<'a> = (&'a Route, Vec<Range<usize>>);

#[cfg(target_os = "linux")]
fn send_all(socket: &UdpSocket, group: &[Datagram<'_>], bytes: &[u8]) {
    use nix::sys::socket::{sendmmsg, MsgFlags, MultiHeaders, SockaddrStorage};
    use std::io::IoSlice;
    use std::os::fd::AsRawFd;

    let mut pending = group;
    while !pending.is_empty() {
        let slices: Vec<Vec<IoSlice<'_>>> = pending
            .iter()
            .map(|(_, parts)| {
                parts
                    .iter()
                    .map(|r| IoSlice::new(bytes.get(r.clone()).unwrap_or_default()))
                    .collect()
            })
            .collect();
        let addrs: Vec<Option<SockaddrStorage>> = pending
            .iter()
            .map(|(route, _)| Some(SockaddrStorage::from(route.to)))
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
fn send_all(socket: &UdpSocket, group: &[Datagram<'_>], bytes: &[u8]) {
    for (route, parts) in group {
        let datagram: Vec<u8> = parts
            .iter()
            .flat_map(|r| bytes.get(r.clone()).unwrap_or_default())
            .copied()
            .collect();
        let _ = socket.send_to(&datagram, route.to);
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

#[cfg(test)]
#[allow(clippy::single_range_in_vec_init)] // a datagram of one write
mod tests {
    use super::*;

    fn route(socket: &Arc<UdpSocket>, port: u16, pack_up_to: usize) -> Route {
        Route {
            socket: socket.clone(),
            to: SocketAddr::from(([127, 0, 0, 1], port)),
            pack_up_to,
        }
    }

    /// The writes of `lens` bytes each, back to back, to `routes` in turn.
    fn writes(routes: &[Route], lens: &[usize]) -> Vec<(Route, Range<usize>)> {
        let mut at = 0;
        lens.iter()
            .enumerate()
            .map(|(i, &n)| {
                at += n;
                (routes[i % routes.len()].clone(), at - n..at)
            })
            .collect()
    }

    fn shape(datagrams: &[Datagram<'_>]) -> Vec<(u16, Vec<Range<usize>>)> {
        datagrams
            .iter()
            .map(|(r, parts)| (r.to.port(), parts.clone()))
            .collect()
    }

    #[test]
    fn writes_to_one_address_share_datagrams_while_they_fit() {
        let s = Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind"));
        let sends = writes(&[route(&s, 1, 100)], &[40, 40, 40, 150, 10]);
        assert_eq!(
            shape(&pack(&sends)),
            [
                (1, vec![0..40, 40..80]),
                (1, vec![80..120]),
                // Longer than a datagram may be: alone, whole.
                (1, vec![120..270]),
                (1, vec![270..280]),
            ]
        );
    }

    #[test]
    fn without_packing_each_write_is_a_datagram() {
        let s = Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind"));
        let sends = writes(&[route(&s, 1, 0)], &[10, 10]);
        assert_eq!(shape(&pack(&sends)), [(1, vec![0..10]), (1, vec![10..20])]);
    }

    #[test]
    fn the_flush_keeps_each_address_in_order_and_never_mixes_addresses_or_sockets() {
        let (s, t) = (
            Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind")),
            Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind")),
        );
        // Fan-out as a router writes it: each frame to 2 and 1 on one socket, 1 on another.
        let routes = [route(&s, 2, 1200), route(&s, 1, 1200), route(&t, 1, 1200)];
        let sends = in_send_order(writes(&routes, &[5; 9]));
        let datagrams = pack(&sends);
        let shapes: Vec<_> = datagrams
            .iter()
            .map(|(r, parts)| (Arc::ptr_eq(&r.socket, &s), r.to.port(), parts.clone()))
            .collect();
        // In the order first written to: socket s (port 2, then 1), then socket t.
        assert_eq!(
            shapes,
            [
                (true, 2, vec![0..5, 15..20, 30..35]),
                (true, 1, vec![5..10, 20..25, 35..40]),
                (false, 1, vec![10..15, 25..30, 40..45]),
            ]
        );
    }

    #[test]
    fn a_batch_arrives_as_packed_datagrams() {
        let out = Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind"));
        let rx = UdpSocket::bind("127.0.0.1:0").expect("bind");
        rx.set_read_timeout(Some(std::time::Duration::from_secs(2)))
            .expect("timeout");
        let to = Route {
            socket: out.clone(),
            to: rx.local_addr().expect("bound"),
            pack_up_to: PACKED_DATAGRAM,
        };
        let frames: Vec<Vec<u8>> = (0..50u8).map(|i| vec![i; 40]).collect();
        batch(|| {
            for f in &frames {
                assert!(defer(&to, f));
            }
        });
        let mut got = Vec::new();
        let mut sizes = Vec::new();
        let mut buf = [0u8; 65536];
        while got.len() < 50 * 40 {
            let n = rx.recv(&mut buf).expect("a datagram");
            sizes.push(n);
            got.extend_from_slice(&buf[..n]);
        }
        assert_eq!(got, frames.concat());
        assert_eq!(sizes, [1200, 800]);
        // Outside a batch, a write is sent at once.
        assert!(!defer(&to, b"now"));
    }
}
