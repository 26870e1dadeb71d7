//! Stream endpoints' threads: a `tcpin` endpoint's accept and its clients, a `tcpout`
//! connection, a serial device and a pty. Each peer has a reader thread that reports what it
//! reads, its pauses and its end, and wakes at the endpoint's stop without polling.

use super::*;

/// Lets `listener`'s accept wait up to [`WOKEN_PATIENCE`] for a client, so that an idle
/// endpoint wakes only for clients and its stop; `false` where it cannot (then it is polled).
pub(super) fn wait_for_clients(listener: &TcpListener) -> bool {
    #[cfg(unix)]
    {
        let patience = nix::sys::time::TimeVal::new(WOKEN_PATIENCE.as_secs() as _, 0);
        nix::sys::socket::setsockopt(
            listener,
            nix::sys::socket::sockopt::ReceiveTimeout,
            &patience,
        )
        .is_ok()
    }
    #[cfg(not(unix))]
    {
        let _ = listener;
        false
    }
}

pub(super) fn tcp_in(
    index: usize,
    name: &str,
    listener: &TcpListener,
    queue: OutputQueue,
    stop: &Arc<Stop>,
    events: &Sink,
) {
    let clients = Arc::new(AtomicUsize::new(0));
    while !stop.is_set() {
        match listener.accept() {
            // The connection that wakes a stopped endpoint, or a client just after its stop.
            Ok(_) if stop.is_set() => return,
            Ok((stream, from)) if clients.load(Ordering::Relaxed) >= MAX_TCP_CLIENTS => {
                let _ = stream.shutdown(Shutdown::Both);
                let _ = crate::printer::stderr().line(format!(
                    "{name}: client {from} refused and closed: {MAX_TCP_CLIENTS} clients are \
                     connected"
                ));
            }
            Ok((stream, from)) => {
                let peer_name = format!("{name} <- {from}");
                let (events, stop) = (events.clone(), stop.clone());
                clients.fetch_add(1, Ordering::Relaxed);
                let served = Arc::clone(&clients);
                let spawned = spawn(name, move || {
                    stream_peer(index, &peer_name, stream, queue, &stop, &events);
                    served.fetch_sub(1, Ordering::Relaxed);
                });
                if spawned.is_err() {
                    clients.fetch_sub(1, Ordering::Relaxed);
                }
            }
            Err(e) if is_timeout(&e) => thread::sleep(Duration::from_millis(20)),
            Err(_) => thread::sleep(POLL),
        }
    }
}

/// Serves one connected TCP stream until it closes; returns why it ended.
fn stream_peer(
    index: usize,
    name: &str,
    stream: TcpStream,
    queue: OutputQueue,
    stop: &Stop,
    events: &Sink,
) -> Option<String> {
    // Watched, so that a stop wakes its reader at once.
    let watched = stop.watch(&stream);
    let why = match crate::tcp::stream_halves(stream) {
        Ok((reader, writer)) => read_peer(index, name, reader, writer, queue, stop, events),
        Err(e) => Some(e.to_string()),
    };
    if let Some(s) = stop.forget(watched) {
        let _ = s.shutdown(Shutdown::Both);
    }
    why
}

/// Reports a peer up, forwards its reads, and reports it down when reading fails. Returns the
/// reason, or `None` if the endpoint was stopped or nobody listens any more.
fn read_peer(
    index: usize,
    name: &str,
    reader: Box<dyn LinkReader>,
    writer: Box<dyn LinkWriter>,
    queue: OutputQueue,
    stop: &Stop,
    events: &Sink,
) -> Option<String> {
    let peer = match peer_up(index, name, writer, queue, events) {
        Ok(peer) => peer?,
        Err(e) => return Some(e.to_string()),
    };
    read_until_down(peer, reader, stop, events)
}

/// A stream peer: its number, and its output queue when it has one.
pub(super) struct StreamPeer {
    id: PeerId,
    queue: Option<Arc<Queue>>,
}

impl Drop for StreamPeer {
    /// The peer is down or its endpoint stopped: its writer thread ends.
    fn drop(&mut self) {
        if let Some(queue) = &self.queue {
            queue.close();
        }
    }
}

/// Reports a new stream peer that writes through `writer` (with an output queue and its
/// writer thread, unless the policy is to wait); `None` if nobody listens.
pub(super) fn peer_up(
    index: usize,
    name: &str,
    writer: Box<dyn LinkWriter>,
    policy: OutputQueue,
    events: &Sink,
) -> io::Result<Option<StreamPeer>> {
    let writer = Arc::new(Mutex::new(writer));
    let queue = match policy.overflow {
        Overflow::Wait => None,
        Overflow::DropNewest | Overflow::DropOldest => {
            Some(Queue::start(name, policy, writer.clone())?)
        }
    };
    let peer = StreamPeer {
        id: next_peer(),
        queue: queue.clone(),
    };
    let up = Event::Up {
        endpoint: index,
        peer: peer.id,
        name: name.to_owned(),
        sender: Sender(SenderKind::Stream(writer, queue), None),
    };
    Ok(events(up).then_some(peer))
}

/// Reports what `peer` sends until its stream fails (then reports it down and returns why) or
/// the endpoint stops.
pub(super) fn read_until_down(
    peer: StreamPeer,
    mut reader: Box<dyn LinkReader>,
    stop: &Stop,
    events: &Sink,
) -> Option<String> {
    let id = peer.id;
    let mut buf = vec![0u8; 16 * 1024];
    // When the last bytes came, until the peer is reported quiet after them.
    let mut last_rx: Option<Instant> = None;
    let why = loop {
        if stop.is_set() {
            return None;
        }
        // A TCP reader is woken at a stop by its socket's shutdown, a device's by the bell; a
        // reader with neither looks now and then.
        let idle = if reader.woken_at_stop() {
            WOKEN_PATIENCE
        } else {
            POLL
        };
        let timeout = last_rx.map_or(idle, |t| QUIET.saturating_sub(t.elapsed()).min(idle));
        match reader.read(&mut buf, timeout) {
            Ok(0) => {
                if last_rx.is_some_and(|t| t.elapsed() >= QUIET) {
                    last_rx = None;
                    events(Event::Quiet { peer: id }).then_some(())?;
                }
            }
            Ok(n) => {
                let at = Instant::now();
                last_rx = Some(at);
                let rx = Event::Rx {
                    peer: id,
                    bytes: &buf[..n],
                    at,
                };
                // Datagrams sent while handling these bytes go out together.
                batch::batch(|| events(rx)).then_some(())?;
            }
            // The stop shut the socket down: stopped, not down.
            Err(_) if stop.is_set() => return None,
            Err(e) => break e.to_string(),
        }
    };
    events(Event::Down {
        peer: id,
        why: why.clone(),
    })
    .then_some(())?;
    Some(why)
}

pub(super) fn tcp_out(
    index: usize,
    name: &str,
    host: &str,
    port: u16,
    queue: OutputQueue,
    stop: &Stop,
    events: &Sink,
) {
    let first = Duration::from_millis(50);
    let mut backoff = first;
    while !stop.is_set() {
        let connected = resolve(host, port)
            .and_then(|addr| TcpStream::connect_timeout(&addr, Duration::from_secs(2)));
        match connected {
            Ok(stream) => {
                backoff = first;
                if stream_peer(index, name, stream, queue, stop, events).is_none() {
                    return;
                }
            }
            Err(_) => {
                stop.sleep(backoff);
                backoff = (backoff * 2).min(MAX_BACKOFF);
            }
        }
    }
}

pub(super) fn serial(
    index: usize,
    name: &str,
    path: &str,
    baud: u32,
    queue: OutputQueue,
    stop: &Stop,
    events: &Sink,
) {
    let mut reported = false;
    while !stop.is_set() {
        match crate::serial::open_serial(path, baud, stop.bell()) {
            Ok((reader, writer)) => {
                reported = false;
                if read_peer(index, name, reader, writer, queue, stop, events).is_none() {
                    return;
                }
            }
            Err(e) => {
                if !reported {
                    let _ = crate::printer::stderr()
                        .line(format!("{name}: {e}; retrying every second"));
                    reported = true;
                }
            }
        }
        stop.sleep(Duration::from_secs(1));
    }
}
