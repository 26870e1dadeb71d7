//! The one read loop: frames of any protocol out of any link.
//!
//! [`Framed`] opens an [`Endpoint`] and gives every peer of it (each UDP sender, each TCP
//! client, the serial device) a stream parser of its own, any
//! [`Deframer`]: MAVLink's, NDLCom's, ModRob-1 UART.B-1's, TosNet's, or [`Datagrams`] where
//! each datagram is one frame. So every protocol runs on every link, and interleaved peers
//! never corrupt each other's frames.
//!
//! ```no_run
//! use ferrolink_io::{framed::Framed, link::Endpoint};
//! use ferrolink_runtime::modrob::parser::Parser;
//! use std::time::Duration;
//!
//! // ModRob-1 UART.B-1 on a serial device.
//! let endpoint = Endpoint::Serial("/dev/ttyUSB0".into(), 115_200);
//! let mut uart = Framed::open(&endpoint, Parser::new)?;
//! loop {
//!     uart.wait(Some(Duration::from_secs(1)), |_peer, message| println!("{message:?}"))?;
//! }
//! # Ok::<(), std::io::Error>(())
//! ```
//!
//! Events are handed from the link's threads to the `Framed` through a channel: blocking
//! ([`Blocking`], with [`Framed::wait`]) or, with the `tokio` feature, async (`Async`, with
//! `Framed::next`).

use std::collections::HashMap;
use std::io;
use std::net::SocketAddr;
use std::sync::{mpsc, Arc};
use std::time::Duration;

use ferrolink_runtime::framing::{Deframer, Feed};

use crate::link::{self, Endpoint, Event, PeerId, Sender};

/// A link event, moved to the thread that reads frames.
#[derive(Debug)]
pub enum Owned {
    /// A peer appeared.
    Up(PeerId, Sender),
    /// Bytes from a peer.
    Rx(PeerId, Vec<u8>),
    /// A stream peer paused after sending ([`Event::Quiet`]).
    Quiet(PeerId),
    /// A peer went away.
    Down(PeerId),
}

impl From<Event<'_>> for Owned {
    fn from(event: Event<'_>) -> Self {
        match event {
            Event::Up { peer, sender, .. } => Owned::Up(peer, sender),
            Event::Rx { peer, bytes, .. } => Owned::Rx(peer, bytes.to_vec()),
            Event::Quiet { peer } => Owned::Quiet(peer),
            Event::Down { peer, .. } => Owned::Down(peer),
        }
    }
}

/// How a [`Framed`] waits for its endpoint's events: [`Blocking`] or, with the `tokio`
/// feature, `Async`.
pub trait Events: Sized {
    /// Starts receiving, and gives the sink the endpoint reports to.
    fn new() -> (Self, link::Sink);
    /// An event that is already there; `Err` once the endpoint stopped and every event was
    /// taken.
    fn try_next(&mut self) -> Result<Option<Owned>, Stopped>;
}

/// The endpoint's threads stopped: no event will come.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stopped;

/// Events for the blocking API.
#[derive(Debug)]
pub struct Blocking(mpsc::Receiver<Owned>);

impl Events for Blocking {
    fn new() -> (Self, link::Sink) {
        let (tx, rx) = mpsc::channel();
        (Blocking(rx), Arc::new(move |e| tx.send(e.into()).is_ok()))
    }

    fn try_next(&mut self) -> Result<Option<Owned>, Stopped> {
        match self.0.try_recv() {
            Ok(event) => Ok(Some(event)),
            Err(mpsc::TryRecvError::Empty) => Ok(None),
            Err(mpsc::TryRecvError::Disconnected) => Err(Stopped),
        }
    }
}

/// Events for the async API (feature `tokio`; it needs no particular runtime).
#[cfg(feature = "tokio")]
#[derive(Debug)]
pub struct Async(tokio::sync::mpsc::UnboundedReceiver<Owned>);

#[cfg(feature = "tokio")]
impl Events for Async {
    fn new() -> (Self, link::Sink) {
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        (Async(rx), Arc::new(move |e| tx.send(e.into()).is_ok()))
    }

    fn try_next(&mut self) -> Result<Option<Owned>, Stopped> {
        match self.0.try_recv() {
            Ok(event) => Ok(Some(event)),
            Err(tokio::sync::mpsc::error::TryRecvError::Empty) => Ok(None),
            Err(tokio::sync::mpsc::error::TryRecvError::Disconnected) => Err(Stopped),
        }
    }
}

/// The framing of links where every read is one whole frame (UDP, for protocols that put one
/// frame in each datagram): each `feed` hands its input out as one frame.
#[derive(Debug, Clone, Copy, Default)]
pub struct Datagrams {
    stats: DatagramStats,
}

/// What [`Datagrams`] handed out.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DatagramStats {
    /// Frames (datagrams) handed out.
    pub frames: u64,
    /// Empty datagrams, dropped.
    pub empty: u64,
}

impl ferrolink_runtime::framing::Counters for DatagramStats {
    fn frames(&self) -> u64 {
        self.frames
    }

    fn dropped(&self) -> u64 {
        self.empty
    }

    fn each(&self, f: &mut dyn FnMut(&'static str, u64)) {
        f("frames", self.frames);
        f("empty", self.empty);
    }
}

impl Deframer for Datagrams {
    type Frame<'p> = &'p [u8];
    type Stats = DatagramStats;

    fn feed<'p, 'a: 'p>(&'p mut self, input: &'a [u8]) -> Feed<'a, &'p [u8]> {
        if input.is_empty() {
            return Feed::Consumed;
        }
        self.stats.frames += 1;
        Feed::Frame {
            frame: input,
            remaining: &[],
        }
    }

    fn stats(&self) -> &DatagramStats {
        &self.stats
    }

    fn take_stats(&mut self) -> DatagramStats {
        std::mem::take(&mut self.stats)
    }

    fn finish(&mut self) {}
}

struct Peer<D> {
    sender: Sender,
    deframer: D,
}

/// The peers of an endpoint, each with its writer and a parser of its own: what [`Framed`]
/// keeps, and what a program that takes an endpoint's events on the endpoint's own threads
/// keeps (the shared MAVLink connection).
pub struct PeerTable<D> {
    peers: HashMap<PeerId, Peer<D>>,
    new: Box<dyn FnMut() -> D + Send>,
}

impl<D> std::fmt::Debug for PeerTable<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PeerTable")
            .field("peers", &self.peers.len())
            .finish_non_exhaustive()
    }
}

impl<D: Deframer> PeerTable<D> {
    /// No peers yet; each that comes gets a parser from `new`.
    pub fn new(new: impl FnMut() -> D + Send + 'static) -> Self {
        Self {
            peers: HashMap::new(),
            new: Box::new(new),
        }
    }

    /// How many peers are connected now.
    pub fn len(&self) -> usize {
        self.peers.len()
    }

    /// Whether no peer is connected.
    pub fn is_empty(&self) -> bool {
        self.peers.is_empty()
    }

    /// Every peer's parser, to change a setting.
    pub fn deframers_mut(&mut self) -> impl Iterator<Item = &mut D> {
        self.peers.values_mut().map(|p| &mut p.deframer)
    }

    /// Every peer's counters.
    pub fn stats(&self) -> impl Iterator<Item = (PeerId, &D::Stats)> {
        self.peers.iter().map(|(&id, p)| (id, p.deframer.stats()))
    }

    /// The writer of peer `peer`, while it is connected.
    pub fn sender(&self, peer: PeerId) -> Option<&Sender> {
        self.peers.get(&peer).map(|p| &p.sender)
    }

    /// Takes in one event: a new peer gets its own parser; its bytes go through that parser,
    /// and `on_frame` gets every frame they complete; when it pauses, its parser judges what it
    /// holds (frames behind a false start come out); a peer that goes away loses the frame it
    /// was sending (counted by its parser) and is forgotten.
    pub fn handle(&mut self, event: Event<'_>, mut on_frame: impl FnMut(PeerId, D::Frame<'_>)) {
        match event {
            Event::Up { peer, sender, .. } => {
                let deframer = (self.new)();
                self.peers.insert(peer, Peer { sender, deframer });
            }
            Event::Rx { peer, bytes, .. } => {
                if let Some(p) = self.peers.get_mut(&peer) {
                    p.deframer.feed_all(bytes, |frame| on_frame(peer, frame));
                }
            }
            Event::Quiet { peer } => {
                if let Some(p) = self.peers.get_mut(&peer) {
                    p.deframer.drain_stalled(|frame| on_frame(peer, frame));
                }
            }
            Event::Down { peer, .. } => {
                if let Some(mut p) = self.peers.remove(&peer) {
                    p.deframer.finish();
                }
            }
        }
    }

    /// Sends `bytes` (a whole encoded frame) to every peer. Fails if there is no peer (`name`
    /// says which endpoint), or every write failed.
    pub fn send_all(&self, bytes: &[u8], name: &dyn std::fmt::Display) -> io::Result<()> {
        if self.peers.is_empty() {
            return Err(io::Error::new(
                io::ErrorKind::NotConnected,
                format!("{name}: no peer yet"),
            ));
        }
        let mut last_error = None;
        let mut sent = 0;
        // A host heard on a broadcast address or multicast group is reached by what is sent
        // there.
        let reached = |sender: &Sender| {
            sender
                .reached_through()
                .is_some_and(|g| self.peers.contains_key(&g))
        };
        for peer in self.peers.values().filter(|p| !reached(&p.sender)) {
            match peer.sender.send(bytes) {
                Ok(()) => sent += 1,
                Err(e) => last_error = Some(e),
            }
        }
        match (sent, last_error) {
            (0, Some(e)) => Err(e),
            _ => Ok(()),
        }
    }
}

/// An endpoint whose peers' bytes become frames (see the [module documentation](self)).
pub struct Framed<D, E = Blocking> {
    endpoint: Endpoint,
    handle: link::Handle,
    events: E,
    peers: PeerTable<D>,
}

impl<D, E> std::fmt::Debug for Framed<D, E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Framed")
            .field("endpoint", &self.endpoint.to_string())
            .field("peers", &self.peers.peers.len())
            .finish_non_exhaustive()
    }
}

impl<D: Deframer + 'static, E: Events> Framed<D, E> {
    /// Opens `endpoint`; every peer gets a parser from `new`. Sockets are bound before this
    /// returns; `tcpout` and `serial` connect in the background and keep reconnecting.
    pub fn open(endpoint: &Endpoint, new: impl FnMut() -> D + Send + 'static) -> io::Result<Self> {
        let (events, sink) = E::new();
        let handle = link::open(0, endpoint, link::Options::default(), sink)?;
        Ok(Framed {
            endpoint: endpoint.clone(),
            handle,
            events,
            peers: PeerTable::new(new),
        })
    }

    /// The endpoint.
    pub fn endpoint(&self) -> &Endpoint {
        &self.endpoint
    }

    /// The bound local address, for `udpin`, `udpout` and `tcpin` endpoints.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.handle.local_addr()
    }

    /// How many peers are connected now.
    pub fn peers(&self) -> usize {
        self.peers.len()
    }

    /// Every peer's parser, to change a setting.
    pub fn deframers_mut(&mut self) -> impl Iterator<Item = &mut D> {
        self.peers.deframers_mut()
    }

    /// Every peer's counters.
    pub fn stats(&self) -> impl Iterator<Item = (PeerId, &D::Stats)> {
        self.peers.stats()
    }

    /// Takes in one event, as [`PeerTable::handle`] does.
    pub fn handle(&mut self, event: Owned, on_frame: impl FnMut(PeerId, D::Frame<'_>)) {
        let event = match event {
            Owned::Up(peer, sender) => Event::Up {
                endpoint: 0,
                peer,
                name: String::new(),
                sender,
            },
            Owned::Rx(peer, ref bytes) => Event::Rx {
                peer,
                bytes,
                at: std::time::Instant::now(),
            },
            Owned::Quiet(peer) => Event::Quiet { peer },
            Owned::Down(peer) => Event::Down {
                peer,
                why: String::new(),
            },
        };
        self.peers.handle(event, on_frame);
    }

    /// Takes in everything that arrived, without waiting. An error once the endpoint stopped.
    pub fn poll(&mut self, mut on_frame: impl FnMut(PeerId, D::Frame<'_>)) -> io::Result<()> {
        loop {
            match self.events.try_next() {
                Ok(Some(event)) => self.handle(event, &mut on_frame),
                Ok(None) => return Ok(()),
                Err(Stopped) => return Err(self.stopped()),
            }
        }
    }

    /// Sends to any address from the endpoint's bound UDP socket, for protocols that fan out to
    /// a list of addresses on a shared medium (ModRob's Ethernet-1). `None` if the endpoint is
    /// no UDP socket.
    pub fn sender_to(&self, to: SocketAddr) -> Option<Sender> {
        self.handle.sender_to(to)
    }

    /// Sends `bytes` (a whole encoded frame) to every peer. Fails if there is no peer, or every
    /// write failed.
    pub fn send(&self, bytes: &[u8]) -> io::Result<()> {
        self.peers.send_all(bytes, &self.endpoint)
    }

    /// The error for an endpoint whose threads stopped.
    pub fn stopped(&self) -> io::Error {
        io::Error::new(
            io::ErrorKind::BrokenPipe,
            format!("{}: the endpoint stopped", self.endpoint),
        )
    }
}

impl<D: Deframer + 'static> Framed<D, Blocking> {
    /// Waits up to `timeout` (`None`: as long as it takes) for an event, takes it in, then
    /// everything else that arrived. `Ok(false)` when nothing came in time; an error only when
    /// the endpoint stopped.
    pub fn wait(
        &mut self,
        timeout: Option<Duration>,
        mut on_frame: impl FnMut(PeerId, D::Frame<'_>),
    ) -> io::Result<bool> {
        let event = match timeout {
            Some(timeout) => match self.events.0.recv_timeout(timeout) {
                Ok(event) => event,
                Err(mpsc::RecvTimeoutError::Timeout) => return Ok(false),
                Err(mpsc::RecvTimeoutError::Disconnected) => return Err(self.stopped()),
            },
            None => self.events.0.recv().map_err(|_| self.stopped())?,
        };
        self.handle(event, &mut on_frame);
        self.poll(on_frame)?;
        Ok(true)
    }
}

#[cfg(feature = "tokio")]
impl<D: Deframer + 'static> Framed<D, Async> {
    /// Waits for an event and takes it in, then everything else that arrived. An error only
    /// when the endpoint stopped.
    pub async fn next(&mut self, mut on_frame: impl FnMut(PeerId, D::Frame<'_>)) -> io::Result<()> {
        match self.events.0.recv().await {
            Some(event) => self.handle(event, &mut on_frame),
            None => return Err(self.stopped()),
        }
        self.poll(on_frame)
    }
}
