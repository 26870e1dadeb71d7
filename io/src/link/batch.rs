//! Many datagrams a system call: a UDP reader takes what has arrived with one `recvmmsg`, and
//! the datagrams sent on its thread go out together when it next waits for one, in the same
//! system call as the wait where the kernel allows it ([`uring`](super::uring)), one `sendmmsg`
//! per socket otherwise. Other threads send what a batch held back once it is handled (and any
//! lock the sink took is released).
//!
//! Senders that allow it ([`Options::pack_up_to`](super::Options::pack_up_to)) also share
//! datagrams: what a reader sends to one address between two waits goes out in as few
//! datagrams as fit, each frame whole and in order.
//!
//! On systems without these calls, each datagram is one call, as before.

use std::cell::RefCell;
use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::ops::Range;
use std::sync::Arc;
use std::time::{Duration, Instant};

#[cfg(target_os = "linux")]
use super::uring::{Ring, Woken};

/// Datagrams read at most per call.
pub(crate) const BATCH: usize = 64;
/// Datagrams a call may read when the reader is woken for one at a time.
#[cfg(target_os = "linux")]
const MIN_ROOM: usize = 4;
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

/// Datagrams given to one `sendmmsg`.
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
const SEND_BATCH: usize = 64;

/// What a batch holds back, and the room to send it in: kept on each thread from batch to
/// batch, so that once a thread has seen its largest batch, a batch allocates nothing.
#[derive(Default)]
struct Outbox {
    /// Whether a batch is running on this thread.
    open: bool,
    /// Whether this thread reads a UDP socket ([`Inbox`]): it holds every send back until it
    /// next waits for a datagram.
    reader: bool,
    /// Each write's route and its bytes in `bytes`, in the order written.
    sends: Vec<(Route, Range<usize>)>,
    bytes: Vec<u8>,
    /// The writes in the order they go out: (socket's rank, address's rank, write).
    order: Vec<(usize, usize, usize)>,
    /// The sockets and addresses in the order first written to.
    seen: Vec<(*const UdpSocket, SocketAddr)>,
    /// The datagrams: the write whose route they take, and their bytes in `wire`.
    datagrams: Vec<(usize, Range<usize>)>,
    wire: Vec<u8>,
    #[cfg(target_os = "linux")]
    sender: Option<Sendmmsg>,
}

/// The room `sendmmsg` needs: headers and addresses for [`SEND_BATCH`] datagrams.
#[cfg(target_os = "linux")]
struct Sendmmsg {
    headers: nix::sys::socket::MultiHeaders<nix::sys::socket::SockaddrStorage>,
    addrs: Vec<Option<nix::sys::socket::SockaddrStorage>>,
}

thread_local! {
    static OUTBOX: RefCell<Outbox> = RefCell::new(Outbox::default());
}

/// Runs `handle` with the sends of UDP [`Sender`](super::Sender)s on this thread held back,
/// then sends them, one system call per socket where the system allows (on a UDP reader's
/// thread, when it next waits), the frames bound for one address sharing datagrams where its
/// sender allows ([`Options::pack_up_to`](super::Options::pack_up_to)).
///
/// The link layer's readers hand each read's events to their sink inside one; an endpoint
/// built outside this crate does the same with what it gets at once (Zenoh's samples).
pub fn batch<R>(handle: impl FnOnce() -> R) -> R {
    let nested = OUTBOX.with(|o| std::mem::replace(&mut o.borrow_mut().open, true));
    if nested {
        return handle();
    }
    let _open = Open;
    handle()
}

/// A running batch: ended and sent when dropped, even if its handler panics.
struct Open;

impl Drop for Open {
    fn drop(&mut self) {
        OUTBOX.with(|o| {
            let mut outbox = o.borrow_mut();
            outbox.open = false;
            if !outbox.reader {
                outbox.flush();
            }
        });
    }
}

/// Holds a write back until the batch ends (on a UDP reader's thread, until it next waits);
/// `false` when no batch is running (send it now).
pub(crate) fn defer(route: &Route, bytes: &[u8]) -> bool {
    OUTBOX.with(|o| {
        let mut outbox = o.borrow_mut();
        if !outbox.open && !outbox.reader {
            return false;
        }
        let start = outbox.bytes.len();
        outbox.bytes.extend_from_slice(bytes);
        let end = outbox.bytes.len();
        outbox.sends.push((route.clone(), start..end));
        true
    })
}

impl Outbox {
    /// Sends what the batch held back, in order per address, and empties the outbox (keeping
    /// its room, unless a rare batch made it large). A datagram the kernel refuses is lost, as
    /// a UDP datagram may be.
    fn flush(&mut self) {
        if self.sends.is_empty() {
            return;
        }
        self.pack();
        self.send_packed();
        self.clear();
    }

    /// Sends the datagrams [`Outbox::pack`] laid out, one `sendmmsg` per socket.
    fn send_packed(&mut self) {
        let mut rest = 0..self.datagrams.len();
        while let Some(&(first, _)) = self.datagrams.get(rest.start) {
            let socket = Arc::clone(&self.sends[first].0.socket);
            let n = self.datagrams[rest.clone()]
                .iter()
                .take_while(|(w, _)| Arc::ptr_eq(&self.sends[*w].0.socket, &socket))
                .count();
            self.send_all(&socket, rest.start..rest.start + n);
            rest.start += n;
        }
    }

    /// Empties the outbox, keeping its room unless a rare batch made it large.
    fn clear(&mut self) {
        self.sends.clear();
        self.bytes.clear();
        const KEEP: usize = 1 << 20;
        if self.bytes.capacity() > KEEP || self.wire.capacity() > KEEP {
            *self = Outbox {
                open: self.open,
                reader: self.reader,
                ..Outbox::default()
            };
        }
    }

    /// Puts the writes in send order ([`Outbox::order`]) and lays out the datagrams: grouped by
    /// socket, then address, sockets and addresses in the order they were first written to (the
    /// peer a frame was handed to first is sent to first, in every batch), the writes to each
    /// address in the order written. Each write's bytes are whole in one datagram, and runs of
    /// writes to one address share one while they fit the route's [`Route::pack_up_to`].
    fn pack(&mut self) {
        self.seen.clear();
        self.order.clear();
        for (i, (route, _)) in self.sends.iter().enumerate() {
            let key = (Arc::as_ptr(&route.socket), route.to);
            let socket = self.seen.iter().position(|(s, _)| *s == key.0);
            let address = match self.seen.iter().position(|k| *k == key) {
                Some(at) => at,
                None => {
                    self.seen.push(key);
                    self.seen.len() - 1
                }
            };
            self.order.push((socket.unwrap_or(address), address, i));
        }
        self.order.sort_unstable();
        self.datagrams.clear();
        self.wire.clear();
        // The address of the last datagram.
        let mut last = None;
        for &(_, address, w) in &self.order {
            let (route, bytes) = &self.sends[w];
            let start = self.wire.len();
            self.wire
                .extend_from_slice(self.bytes.get(bytes.clone()).unwrap_or_default());
            let end = self.wire.len();
            match self.datagrams.last_mut() {
                Some((_, datagram))
                    if last == Some(address) && end - datagram.start <= route.pack_up_to =>
                {
                    datagram.end = end;
                }
                _ => {
                    self.datagrams.push((w, start..end));
                    last = Some(address);
                }
            }
        }
    }

    /// Sends what is held back and waits for `readable` in one system call, with `ring` (set up
    /// on first use); `None` if nothing was held back, or if the kernel gives no ring (then
    /// what was held back has been sent the usual way, and the caller waits).
    #[cfg(target_os = "linux")]
    fn send_and_wait(
        &mut self,
        ring: &mut Option<Option<Ring>>,
        readable: &UdpSocket,
        until: Option<Instant>,
    ) -> Option<Woken> {
        if self.sends.is_empty() {
            return None;
        }
        self.pack();
        let woken = match ring.get_or_insert_with(Ring::new) {
            Some(r) => {
                let datagrams = self.datagrams.iter().map(|(w, bytes)| {
                    let route = &self.sends[*w].0;
                    (&*route.socket, route.to, bytes.clone())
                });
                match r.send_and_wait(datagrams, &mut self.wire, readable, until) {
                    Ok(woken) => Some(woken),
                    Err(_) => {
                        // Without the ring from now on; what it did not send is lost.
                        *ring = Some(None);
                        None
                    }
                }
            }
            None => {
                self.send_packed();
                None
            }
        };
        self.clear();
        woken
    }

    /// Sends `datagrams` (a range of [`Outbox::datagrams`], all from `socket`).
    #[cfg(target_os = "linux")]
    fn send_all(&mut self, socket: &UdpSocket, datagrams: Range<usize>) {
        use nix::sys::socket::{sendmmsg, MsgFlags, MultiHeaders, SockaddrStorage};
        use std::io::IoSlice;
        use std::os::fd::AsRawFd;

        let room = self.sender.get_or_insert_with(|| Sendmmsg {
            headers: MultiHeaders::preallocate(SEND_BATCH, None),
            addrs: Vec::with_capacity(SEND_BATCH),
        });
        let mut pending = &self.datagrams[datagrams];
        while !pending.is_empty() {
            let now = &pending[..pending.len().min(SEND_BATCH)];
            let mut slices = [[IoSlice::new(&[])]; SEND_BATCH];
            room.addrs.clear();
            for (slice, (w, bytes)) in slices.iter_mut().zip(now) {
                *slice = [IoSlice::new(
                    self.wire.get(bytes.clone()).unwrap_or_default(),
                )];
                room.addrs
                    .push(Some(SockaddrStorage::from(self.sends[*w].0.to)));
            }
            let sent = sendmmsg(
                socket.as_raw_fd(),
                &mut room.headers,
                &slices[..now.len()],
                &room.addrs,
                [],
                MsgFlags::empty(),
            )
            .map(Iterator::count);
            match sent {
                Ok(n) if n > 0 => pending = pending.get(n..).unwrap_or_default(),
                Err(nix::errno::Errno::EINTR) => {}
                // The first datagram was refused (an ICMP error pending, a full buffer): skip
                // it and carry on with the rest.
                _ => pending = pending.get(1..).unwrap_or_default(),
            }
        }
    }

    #[cfg(not(target_os = "linux"))]
    fn send_all(&mut self, socket: &UdpSocket, datagrams: Range<usize>) {
        for (w, bytes) in &self.datagrams[datagrams] {
            let datagram = self.wire.get(bytes.clone()).unwrap_or_default();
            let _ = socket.send_to(datagram, self.sends[*w].0.to);
        }
    }
}

/// The receive buffer asked for on every UDP endpoint's socket: at 50,000 datagrams a second,
/// tens of milliseconds of traffic, so that a reader the scheduler keeps waiting on a busy
/// machine loses nothing. The kernel caps it at `net.core.rmem_max`.
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
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

/// Room to read a batch of datagrams into, for the one thread that reads a UDP socket: while it
/// lives, the UDP datagrams sent on that thread are held back until the thread next waits.
pub(crate) struct Inbox {
    buf: Vec<u8>,
    got: Vec<(usize, Option<SocketAddr>)>,
    /// How many datagrams the next receive may take: doubled while receives fill it, up to
    /// [`BATCH`], halved while they take less than a quarter of it. A reader woken for one
    /// datagram at a time sets up a few headers, not [`BATCH`].
    #[cfg(target_os = "linux")]
    room: usize,
    #[cfg(target_os = "linux")]
    headers: nix::sys::socket::MultiHeaders<nix::sys::socket::SockaddrStorage>,
    /// The ring that sends and waits in one call: not set up yet, or set up (`None` where the
    /// kernel gives none).
    #[cfg(target_os = "linux")]
    ring: Option<Option<Ring>>,
    /// The socket's read timeout, for a blocking receive: relative to each receive, so one set
    /// for `until` at `set_at` may wake late by as much as a receive starts after `set_at`. It
    /// is set again only when a receive would wake more than `tolerance` away from the `until`
    /// it is given, not on every receive: one system call fewer per batch.
    timeout: Option<(Option<Instant>, Instant)>,
    tolerance: Duration,
}

impl Inbox {
    /// Room for a reader whose receives may wake up to `tolerance` after the `until` they are
    /// given.
    pub(crate) fn new(tolerance: Duration) -> Inbox {
        OUTBOX.with(|o| o.borrow_mut().reader = true);
        Inbox {
            buf: vec![0; BATCH * DATAGRAM_ROOM],
            got: Vec::with_capacity(BATCH),
            #[cfg(target_os = "linux")]
            room: MIN_ROOM,
            #[cfg(target_os = "linux")]
            headers: nix::sys::socket::MultiHeaders::preallocate(BATCH, None),
            #[cfg(target_os = "linux")]
            ring: None,
            timeout: None,
            tolerance,
        }
    }

    /// Sends what this thread held back, then waits (until `until` at most) for a datagram and
    /// takes what else has arrived with it, up to [`BATCH`]. A wait that ends without one is a
    /// [`TimedOut`](io::ErrorKind::TimedOut) or [`WouldBlock`](io::ErrorKind::WouldBlock)
    /// error.
    #[cfg(target_os = "linux")]
    pub(crate) fn receive(
        &mut self,
        socket: &UdpSocket,
        until: Option<Instant>,
    ) -> io::Result<usize> {
        use nix::sys::socket::MsgFlags;

        let waited = OUTBOX.with(|o| o.borrow_mut().send_and_wait(&mut self.ring, socket, until));
        match waited {
            Some(Woken::TimedOut) => Err(io::ErrorKind::TimedOut.into()),
            Some(Woken::Readable) => self.take(socket, MsgFlags::MSG_DONTWAIT),
            None => {
                self.wait_until(socket, until);
                self.take(socket, MsgFlags::MSG_WAITFORONE)
            }
        }
    }

    /// Receives with `recvmmsg`.
    #[cfg(target_os = "linux")]
    fn take(&mut self, socket: &UdpSocket, flags: nix::sys::socket::MsgFlags) -> io::Result<usize> {
        use nix::sys::socket::recvmmsg;
        use std::io::IoSliceMut;
        use std::os::fd::AsRawFd;

        self.got.clear();
        let mut slices: [[IoSliceMut<'_>; 1]; BATCH] =
            std::array::from_fn(|_| [IoSliceMut::new(&mut [])]);
        for (slice, chunk) in slices
            .iter_mut()
            .zip(self.buf.chunks_mut(DATAGRAM_ROOM))
            .take(self.room)
        {
            *slice = [IoSliceMut::new(chunk)];
        }
        let received = recvmmsg(
            socket.as_raw_fd(),
            &mut self.headers,
            slices.iter_mut().take(self.room),
            flags,
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
        let n = self.got.len();
        if n == self.room {
            self.room = (2 * n).min(BATCH);
        } else if 4 * n < self.room {
            self.room = (self.room / 2).max(MIN_ROOM);
        }
        Ok(n)
    }

    #[cfg(not(target_os = "linux"))]
    pub(crate) fn receive(
        &mut self,
        socket: &UdpSocket,
        until: Option<Instant>,
    ) -> io::Result<usize> {
        OUTBOX.with(|o| o.borrow_mut().flush());
        self.wait_until(socket, until);
        self.got.clear();
        let room = self.buf.get_mut(..DATAGRAM_ROOM).unwrap_or_default();
        let (n, from) = socket.recv_from(room)?;
        self.got.push((n, Some(from)));
        Ok(1)
    }

    /// Sets the socket's read timeout for `until`, when the one set would not do: a receive
    /// starting now would wake more than `tolerance` before or after `until`.
    fn wait_until(&mut self, socket: &UdpSocket, until: Option<Instant>) {
        let now = Instant::now();
        let tolerance = self.tolerance;
        let fits = match (self.timeout, until) {
            (Some((None, _)), None) => true,
            (Some((Some(set_for), set_at)), Some(until)) => {
                let wakes = now + set_for.saturating_duration_since(set_at);
                wakes <= until + tolerance && until <= wakes + tolerance
            }
            _ => false,
        };
        if !fits {
            let wait = until.map(|t| {
                t.saturating_duration_since(now)
                    .max(Duration::from_millis(1))
            });
            let _ = socket.set_read_timeout(wait);
            self.timeout = Some((until, now));
        }
    }

    /// The datagrams of the last [`Inbox::receive`], with their senders.
    pub(crate) fn datagrams(&self) -> impl Iterator<Item = (&[u8], Option<SocketAddr>)> + '_ {
        self.got.iter().enumerate().map(|(i, &(n, from))| {
            let at = i * DATAGRAM_ROOM;
            (self.buf.get(at..at + n).unwrap_or_default(), from)
        })
    }
}

impl Drop for Inbox {
    /// The thread reads no more: what it held back goes out now, and its sends from now on
    /// go out at once.
    fn drop(&mut self) {
        OUTBOX.with(|o| {
            let mut outbox = o.borrow_mut();
            outbox.reader = false;
            outbox.flush();
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::thread;

    fn route(socket: &Arc<UdpSocket>, port: u16, pack_up_to: usize) -> Route {
        Route {
            socket: socket.clone(),
            to: SocketAddr::from(([127, 0, 0, 1], port)),
            pack_up_to,
        }
    }

    /// The datagrams an outbox makes of writes of `lens` bytes each (write `i` is `lens[i]`
    /// bytes of value `i`) to `routes` in turn: (socket, port, bytes) each.
    fn packed(routes: &[Route], lens: &[usize]) -> Vec<(*const UdpSocket, u16, Vec<u8>)> {
        let mut outbox = Outbox::default();
        for (i, &n) in lens.iter().enumerate() {
            let start = outbox.bytes.len();
            outbox.bytes.extend(std::iter::repeat_n(i as u8, n));
            let end = outbox.bytes.len();
            outbox
                .sends
                .push((routes[i % routes.len()].clone(), start..end));
        }
        outbox.pack();
        outbox
            .datagrams
            .iter()
            .map(|(w, bytes)| {
                let route = &outbox.sends[*w].0;
                (
                    Arc::as_ptr(&route.socket),
                    route.to.port(),
                    outbox.wire[bytes.clone()].to_vec(),
                )
            })
            .collect()
    }

    /// `n` bytes of each write in `writes`, one after the other.
    fn of(writes: &[(u8, usize)]) -> Vec<u8> {
        writes
            .iter()
            .flat_map(|&(i, n)| std::iter::repeat_n(i, n))
            .collect()
    }

    #[test]
    fn writes_to_one_address_share_datagrams_while_they_fit() {
        let s = Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind"));
        let p = Arc::as_ptr(&s);
        assert_eq!(
            packed(&[route(&s, 1, 100)], &[40, 40, 40, 150, 10]),
            [
                (p, 1, of(&[(0, 40), (1, 40)])),
                (p, 1, of(&[(2, 40)])),
                // Longer than a datagram may be: alone, whole.
                (p, 1, of(&[(3, 150)])),
                (p, 1, of(&[(4, 10)])),
            ]
        );
    }

    #[test]
    fn without_packing_each_write_is_a_datagram() {
        let s = Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind"));
        let p = Arc::as_ptr(&s);
        assert_eq!(
            packed(&[route(&s, 1, 0)], &[10, 10]),
            [(p, 1, of(&[(0, 10)])), (p, 1, of(&[(1, 10)]))]
        );
    }

    #[test]
    fn the_flush_keeps_each_address_in_order_and_never_mixes_addresses_or_sockets() {
        let (s, t) = (
            Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind")),
            Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind")),
        );
        let (ps, pt) = (Arc::as_ptr(&s), Arc::as_ptr(&t));
        // Fan-out as a router writes it: each frame to 2 and 1 on one socket, 1 on another.
        let routes = [route(&s, 2, 1200), route(&s, 1, 1200), route(&t, 1, 1200)];
        // In the order first written to: socket s (port 2, then 1), then socket t.
        assert_eq!(
            packed(&routes, &[5; 9]),
            [
                (ps, 2, of(&[(0, 5), (3, 5), (6, 5)])),
                (ps, 1, of(&[(1, 5), (4, 5), (7, 5)])),
                (pt, 1, of(&[(2, 5), (5, 5), (8, 5)])),
            ]
        );
        // Writes to one address that others come between still share its datagrams.
        let routes = [route(&t, 1, 1200), route(&s, 2, 1200), route(&t, 1, 1200)];
        assert_eq!(
            packed(&routes, &[5; 3]),
            [(pt, 1, of(&[(0, 5), (2, 5)])), (ps, 2, of(&[(1, 5)]))]
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

    #[test]
    fn more_datagrams_than_one_call_sends_all_arrive_in_order() {
        let out = Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind"));
        let rx = UdpSocket::bind("127.0.0.1:0").expect("bind");
        widen_receive_buffer(&rx);
        rx.set_read_timeout(Some(std::time::Duration::from_secs(2)))
            .expect("timeout");
        let to = Route {
            socket: out.clone(),
            to: rx.local_addr().expect("bound"),
            pack_up_to: 0,
        };
        let n = 3 * SEND_BATCH + 5;
        batch(|| {
            for i in 0..n {
                assert!(defer(&to, &(i as u32).to_le_bytes()));
            }
        });
        let mut buf = [0u8; 64];
        for i in 0..n {
            let got = rx.recv(&mut buf).expect("a datagram");
            assert_eq!(buf[..got], (i as u32).to_le_bytes());
        }
    }

    #[test]
    fn a_reader_takes_a_burst_whole_and_in_order_taking_more_a_call_as_it_comes() {
        let rx = UdpSocket::bind("127.0.0.1:0").expect("bind");
        widen_receive_buffer(&rx);
        let tx = UdpSocket::bind("127.0.0.1:0").expect("bind");
        let to = rx.local_addr().expect("bound");
        let n = 300u32;
        for i in 0..n {
            tx.send_to(&i.to_le_bytes(), to).expect("send");
        }
        let mut inbox = Inbox::new(Duration::ZERO);
        let (mut got, mut calls) = (Vec::new(), Vec::new());
        while got.len() < n as usize {
            calls.push(inbox.receive(&rx, None).expect("datagrams"));
            for (bytes, from) in inbox.datagrams() {
                assert_eq!(from, Some(tx.local_addr().expect("bound")));
                got.push(u32::from_le_bytes(bytes.try_into().expect("4 bytes")));
            }
        }
        assert_eq!(got, (0..n).collect::<Vec<_>>());
        #[cfg(target_os = "linux")]
        {
            assert_eq!(calls[..5], [4, 8, 16, 32, 64], "{calls:?}");
            // Woken for one datagram at a time, it sets up fewer headers again.
            for _ in 0..4 {
                tx.send_to(b"one", to).expect("send");
                assert_eq!(inbox.receive(&rx, None).expect("a datagram"), 1);
            }
            assert_eq!(inbox.room, MIN_ROOM);
        }
    }

    #[test]
    fn a_batch_whose_handler_panics_still_ends() {
        let out = Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind"));
        let rx = UdpSocket::bind("127.0.0.1:0").expect("bind");
        rx.set_read_timeout(Some(std::time::Duration::from_secs(2)))
            .expect("timeout");
        let to = Route {
            socket: out,
            to: rx.local_addr().expect("bound"),
            pack_up_to: PACKED_DATAGRAM,
        };
        let panicked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            batch(|| {
                assert!(defer(&to, b"before"));
                panic!("a handler's bug");
            })
        }));
        assert!(panicked.is_err());
        let mut buf = [0u8; 64];
        let n = rx.recv(&mut buf).expect("what was deferred went out");
        assert_eq!(&buf[..n], b"before");
        assert!(!defer(&to, b"after"), "no batch is running any more");
    }

    /// A reader thread's inbox, with the ring (where the kernel gives one) or without.
    fn reader_inbox(ring: bool) -> Inbox {
        #[cfg(target_os = "linux")]
        {
            let mut inbox = Inbox::new(Duration::ZERO);
            if !ring {
                inbox.ring = Some(None);
            }
            inbox
        }
        #[cfg(not(target_os = "linux"))]
        {
            let _ = ring;
            Inbox::new(Duration::ZERO)
        }
    }

    /// Two sockets of the reader's, a peer each, and the socket it reads.
    struct Fanout {
        routes: [Route; 2],
        peers: [UdpSocket; 2],
        read: UdpSocket,
    }

    fn fanout() -> Fanout {
        let peer = || {
            let p = UdpSocket::bind("127.0.0.1:0").expect("bind");
            p.set_read_timeout(Some(Duration::from_secs(2)))
                .expect("timeout");
            p
        };
        let peers = [peer(), peer()];
        let routes = [0, 1].map(|i| Route {
            socket: Arc::new(UdpSocket::bind("127.0.0.1:0").expect("bind")),
            to: peers[i].local_addr().expect("bound"),
            pack_up_to: PACKED_DATAGRAM,
        });
        let read = UdpSocket::bind("127.0.0.1:0").expect("bind");
        Fanout {
            routes,
            peers,
            read,
        }
    }

    fn recv(socket: &UdpSocket) -> Vec<u8> {
        let mut buf = [0u8; 2048];
        let n = socket.recv(&mut buf).expect("a datagram");
        buf[..n].to_vec()
    }

    #[test]
    fn a_reader_holds_its_sends_until_it_waits_and_they_go_out_before_it_sleeps() {
        for ring in [true, false] {
            let f = fanout();
            let waker = UdpSocket::bind("127.0.0.1:0").expect("bind");
            let read_at = f.read.local_addr().expect("bound");
            thread::scope(|scope| {
                let reader = scope.spawn(|| {
                    let mut inbox = reader_inbox(ring);
                    batch(|| {
                        assert!(defer(&f.routes[0], b"one"));
                        assert!(defer(&f.routes[1], b"two"));
                        assert!(defer(&f.routes[0], b"three"));
                    });
                    // Held past the batch, and outside one too, on a reader's thread.
                    assert!(defer(&f.routes[1], b"four"));
                    let got = inbox.receive(&f.read, None).expect("a datagram");
                    let (bytes, _) = inbox.datagrams().next().expect("one");
                    (got, bytes.to_vec())
                });
                // They arrive while the reader sleeps, packed per peer: nothing has woken it.
                assert_eq!(recv(&f.peers[0]), b"onethree", "ring: {ring}");
                assert_eq!(recv(&f.peers[1]), b"twofour", "ring: {ring}");
                assert!(!reader.is_finished());
                waker.send_to(b"wake", read_at).expect("send");
                assert_eq!(reader.join().expect("reader"), (1, b"wake".to_vec()));
            });
        }
    }

    #[test]
    fn a_reader_whose_wait_times_out_has_sent_and_reads_on() {
        for ring in [true, false] {
            let f = fanout();
            let mut inbox = reader_inbox(ring);
            assert!(defer(&f.routes[0], b"held"));
            let until = Instant::now() + Duration::from_millis(30);
            let e = inbox
                .receive(&f.read, Some(until))
                .expect_err("nothing to read");
            assert!(crate::is_timeout(&e), "ring: {ring}: {e}");
            assert_eq!(recv(&f.peers[0]), b"held");
            // The next wait, with nothing held, reads what arrives.
            let from = UdpSocket::bind("127.0.0.1:0").expect("bind");
            from.send_to(b"later", f.read.local_addr().expect("bound"))
                .expect("send");
            assert!(defer(&f.routes[1], b"again"));
            let got = loop {
                match inbox.receive(&f.read, None) {
                    Ok(n) => break n,
                    // A poll left by the wait that timed out may wake it early once.
                    Err(e) if crate::is_timeout(&e) => continue,
                    Err(e) => panic!("{e}"),
                }
            };
            assert_eq!(got, 1);
            assert_eq!(inbox.datagrams().next().map(|d| d.0), Some(&b"later"[..]));
            assert_eq!(recv(&f.peers[1]), b"again");
        }
    }

    #[test]
    fn a_reader_that_ends_sends_what_it_held_and_then_sends_at_once() {
        for ring in [true, false] {
            let f = fanout();
            let inbox = reader_inbox(ring);
            assert!(defer(&f.routes[0], b"held"));
            drop(inbox);
            assert_eq!(recv(&f.peers[0]), b"held");
            assert!(!defer(&f.routes[0], b"now"));
        }
    }
}
