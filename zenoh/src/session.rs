//! What the Zenoh endpoints share: a session for a URI that closes when the endpoint is dropped,
//! subscribers that take other sessions' samples only, reader threads, and the note on stderr
//! about samples that carried nothing usable.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_io::link::{self, Event, PeerId, Sender};
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::Subscriber;
use zenoh::sample::{Locality, Sample};
use zenoh::Wait;

use crate::uri::ZenohUri;

/// How long a reader waits for a sample before it looks whether it should stop.
pub(crate) const POLL: Duration = Duration::from_millis(200);

/// A session and the threads that read from it; dropping it stops them (within [`POLL`]) and
/// closes the session.
#[derive(Debug)]
pub struct Running {
    session: zenoh::Session,
    name: String,
    stop: Arc<AtomicBool>,
    threads: Vec<thread::JoinHandle<()>>,
}

impl Running {
    /// Joins the network `uri` names.
    pub(crate) fn open(uri: &ZenohUri) -> io::Result<Running> {
        let name = uri.to_string();
        let config = uri.config().map_err(io::Error::other)?;
        let session = zenoh::open(config)
            .wait()
            .map_err(|e| io::Error::other(format!("{name}: {e}")))?;
        Ok(Running {
            session,
            name,
            stop: Arc::new(AtomicBool::new(false)),
            threads: Vec::new(),
        })
    }

    /// The session.
    pub(crate) fn session(&self) -> &zenoh::Session {
        &self.session
    }

    /// An error that names the endpoint.
    pub(crate) fn error(&self, e: impl std::fmt::Display) -> io::Error {
        io::Error::other(format!("{}: {e}", self.name))
    }

    /// Reports the endpoint's one peer up to `sink`, as endpoint `index` named by its URI,
    /// written to through `sender`; returns the peer.
    pub(crate) fn report_up(
        &self,
        index: usize,
        sender: Sender,
        sink: &link::Sink,
    ) -> io::Result<PeerId> {
        let peer = link::next_peer();
        let up = Event::Up {
            endpoint: index,
            peer,
            name: self.name.clone(),
            sender,
        };
        if sink(up) {
            Ok(peer)
        } else {
            Err(self.error("nobody listens for events"))
        }
    }

    /// A subscriber to `key` that takes only what other sessions put.
    pub(crate) fn subscribe_remote(
        &self,
        key: String,
    ) -> io::Result<Subscriber<FifoChannelHandler<Sample>>> {
        self.session
            .declare_subscriber(key)
            .allowed_origin(Locality::Remote)
            .wait()
            .map_err(|e| self.error(e))
    }

    /// Calls `step` on a thread named `name` until the endpoint is dropped or `step` says
    /// `false`; `step` waits at most [`POLL`] for something to do.
    pub(crate) fn spawn(
        &mut self,
        name: &str,
        mut step: impl FnMut() -> bool + Send + 'static,
    ) -> io::Result<()> {
        let stop = self.stop.clone();
        let thread = thread::Builder::new().name(name.into()).spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                if !step() {
                    return;
                }
            }
        })?;
        self.threads.push(thread);
        Ok(())
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        let _ = self.session.close().wait();
    }
}

/// Counts samples that carried nothing usable, and says so on stderr at most once a second.
#[derive(Debug, Default)]
pub(crate) struct Rejections {
    count: u64,
    last_note: Option<Instant>,
}

impl Rejections {
    /// Counts a sample on `key` rejected for `why`.
    pub(crate) fn note(&mut self, key: &str, why: &str) {
        self.count += 1;
        let now = Instant::now();
        if self
            .last_note
            .is_none_or(|t| now.duration_since(t) >= Duration::from_secs(1))
        {
            self.last_note = Some(now);
            eprintln!(
                "zenoh: sample on {key} rejected ({} so far): {why}",
                self.count
            );
        }
    }

    /// How many so far.
    #[cfg(test)]
    pub(crate) fn count(&self) -> u64 {
        self.count
    }
}
