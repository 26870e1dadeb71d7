//! `tcp://HOST[:PORT]` (client) and `tcp-listen://[HOST]:PORT` (server, most recent client wins).

use std::io::{self, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError, Weak};
use std::thread;
use std::time::{Duration, Instant};

use crate::{
    is_timeout, resolve, socket_timeout, write_error, Halves, LinkReader, LinkWriter, WRITE_TIMEOUT,
};

/// How long a client waits for each address of the server to answer.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// How often the accept thread looks for new clients and for both halves being gone.
const ACCEPT_POLL: Duration = Duration::from_millis(20);

/// Longest wait a reader does in one call; keeps `Instant + timeout` from overflowing.
const MAX_WAIT: Duration = Duration::from_secs(365 * 24 * 3600);

/// Sets up a connected stream for small, latency-sensitive frames.
fn configure(stream: &TcpStream) -> io::Result<()> {
    configure_with(stream, WRITE_TIMEOUT)
}

/// Sets up a connected stream, writes giving up after `write_timeout`.
fn configure_with(stream: &TcpStream, write_timeout: std::time::Duration) -> io::Result<()> {
    // Accepted sockets inherit the listener's non-blocking flag on some systems.
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    stream.set_write_timeout(Some(write_timeout))
}

/// The halves of one connected stream (a client, or one client of a server), writes giving up
/// after `write_timeout`. Reading reports the other side closing as `UnexpectedEof`.
pub(crate) fn stream_halves(
    stream: TcpStream,
    write_timeout: std::time::Duration,
) -> io::Result<Halves> {
    configure_with(&stream, write_timeout)?;
    let reader = TcpReader {
        stream: stream.try_clone()?,
    };
    Ok((Box::new(reader), Box::new(TcpWriter { stream })))
}

/// Errors after which a connection is of no further use.
fn is_disconnect(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::BrokenPipe
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::NotConnected
            | io::ErrorKind::UnexpectedEof
    )
}

/// Connects to the first address of `host` that answers within [`CONNECT_TIMEOUT`].
pub(crate) fn connect(host: &str, port: u16) -> io::Result<Halves> {
    let mut last_error = None;
    for addr in resolve(host, port)? {
        match TcpStream::connect_timeout(&addr, CONNECT_TIMEOUT) {
            Ok(stream) => return stream_halves(stream, WRITE_TIMEOUT),
            Err(e) => last_error = Some(e),
        }
    }
    Err(last_error.unwrap_or_else(|| io::Error::from(io::ErrorKind::NotFound)))
}

#[derive(Debug)]
struct TcpReader {
    stream: TcpStream,
}

impl LinkReader for TcpReader {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        self.stream
            .set_read_timeout(Some(socket_timeout(timeout)))?;
        match self.stream.read(buf) {
            Ok(0) => Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "the other side closed the connection",
            )),
            Ok(n) => Ok(n),
            Err(e) if is_timeout(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }
}

#[derive(Debug)]
struct TcpWriter {
    stream: TcpStream,
}

impl LinkWriter for TcpWriter {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.stream.write_all(bytes).map_err(write_error)
    }
}

/// Listens on `host:port` and accepts clients on a background thread, which ends once both
/// halves are dropped (closing the listener).
pub(crate) fn listen(host: &str, port: u16) -> io::Result<Halves> {
    let listener = TcpListener::bind(&resolve(host, port)?[..])?;
    listener.set_nonblocking(true)?;
    let shared = Arc::new(Shared::default());
    let weak = Arc::downgrade(&shared);
    thread::Builder::new()
        .name(format!("tcp-listen {}", listener.local_addr()?))
        .spawn(move || accept_loop(&listener, &weak))?;
    let reader = ListenReader {
        shared: Arc::clone(&shared),
        peer: None,
    };
    Ok((
        Box::new(reader),
        Box::new(ListenWriter { shared, peer: None }),
    ))
}

fn accept_loop(listener: &TcpListener, shared: &Weak<Shared>) {
    loop {
        let accepted = listener.accept();
        let Some(shared) = shared.upgrade() else {
            return;
        };
        match accepted {
            Ok((stream, _addr)) => {
                // A client we cannot set up is dropped (disconnected) right away.
                if configure(&stream).is_ok() {
                    shared.install(stream);
                }
            }
            // WouldBlock: no client waiting. Anything else (out of file descriptors, a client
            // that gave up during the handshake) is worth another try later, too.
            Err(_) => {
                drop(shared);
                thread::sleep(ACCEPT_POLL);
            }
        }
    }
}

/// The listener's state, shared by the accept thread and both halves.
#[derive(Debug, Default)]
struct Shared {
    active: Mutex<Active>,
    /// Signalled whenever a client connects.
    connected: Condvar,
}

/// The current client. `id` counts the clients accepted so far, so a half can tell whether
/// its copy of the stream is still the current one.
#[derive(Debug, Default)]
struct Active {
    id: u64,
    stream: Option<TcpStream>,
}

/// A half's own handle on a client: its id and a clone of the stream.
type Peer = Option<(u64, TcpStream)>;

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Active> {
        self.active.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Makes `stream` the current client, disconnecting the previous one.
    fn install(&self, stream: TcpStream) {
        let mut active = self.lock();
        if let Some(old) = active.stream.take() {
            let _ = old.shutdown(Shutdown::Both);
        }
        active.id += 1;
        active.stream = Some(stream);
        self.connected.notify_all();
    }

    /// Forgets client `id` after it went away, unless a newer client replaced it already.
    fn disconnect(&self, id: u64) {
        let mut active = self.lock();
        if active.id == id {
            if let Some(old) = active.stream.take() {
                let _ = old.shutdown(Shutdown::Both);
            }
        }
    }
}

/// Brings a half's `peer` up to date with the current client (`None` if there is none).
fn refresh(active: &Active, peer: &mut Peer) -> io::Result<()> {
    match &active.stream {
        None => *peer = None,
        Some(_) if matches!(peer, Some((id, _)) if *id == active.id) => {}
        Some(stream) => *peer = Some((active.id, stream.try_clone()?)),
    }
    Ok(())
}

#[derive(Debug)]
struct ListenReader {
    shared: Arc<Shared>,
    peer: Peer,
}

impl LinkReader for ListenReader {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        let deadline = Instant::now() + timeout.min(MAX_WAIT);
        loop {
            // Wait for a client.
            let mut active = self.shared.lock();
            loop {
                refresh(&active, &mut self.peer)?;
                if self.peer.is_some() {
                    break;
                }
                let left = deadline.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    return Ok(0);
                }
                active = self
                    .shared
                    .connected
                    .wait_timeout(active, left)
                    .unwrap_or_else(PoisonError::into_inner)
                    .0;
            }
            drop(active);

            let Some((id, stream)) = &mut self.peer else {
                continue;
            };
            let left = deadline.saturating_duration_since(Instant::now());
            stream.set_read_timeout(Some(socket_timeout(left)))?;
            match stream.read(buf) {
                Ok(0) => {}
                Ok(n) => return Ok(n),
                Err(e) if is_timeout(&e) => return Ok(0),
                Err(e) if is_disconnect(&e) => {}
                Err(e) => return Err(e),
            }
            // The client left (or was replaced): wait for the next one.
            let id = *id;
            self.peer = None;
            self.shared.disconnect(id);
        }
    }
}

#[derive(Debug)]
struct ListenWriter {
    shared: Arc<Shared>,
    peer: Peer,
}

impl LinkWriter for ListenWriter {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        refresh(&self.shared.lock(), &mut self.peer)?;
        let Some((id, stream)) = &mut self.peer else {
            return Err(io::Error::new(
                io::ErrorKind::NotConnected,
                "no TCP client connected",
            ));
        };
        stream.write_all(bytes).map_err(|e| {
            if is_disconnect(&e) {
                self.shared.disconnect(*id);
            }
            write_error(e)
        })
    }
}
