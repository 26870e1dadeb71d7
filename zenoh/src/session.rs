//! What the Zenoh endpoints share: a session for a URI that closes when the endpoint is dropped,
//! subscribers that take other sessions' samples only, and the note on stderr about samples that
//! carried nothing usable.

use std::io;
use std::time::{Duration, Instant};

use ferrolink_io::link::{self, Event, PeerId, Sender};
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::Subscriber;
use zenoh::query::{Query, Queryable};
use zenoh::sample::{Locality, Sample};
use zenoh::Wait;

use crate::uri::ZenohUri;

/// What [`one_worker_thread`] sets `ZENOH_RUNTIME` to: every one of Zenoh's runtimes hands its
/// tasks over to the sending one, which has one worker thread.
pub const ONE_WORKER_THREAD: &str =
    "(rx: (handover: tx), acc: (handover: tx), app: (handover: tx), net: (handover: tx))";

/// Runs all of Zenoh's work (receiving, sending, accepting, routing) on one worker thread of its
/// own, unless `ZENOH_RUNTIME` already says how: by default Zenoh keeps five runtimes and six
/// threads, and a frame through a Zenoh link wakes three of them in turn. On one thread, a
/// frame from Zenoh is read, decoded and routed with no thread handing it to another.
///
/// Zenoh reads the variable when it first starts, so call this at the start of `main`, before
/// any thread is started.
pub fn one_worker_thread() {
    if std::env::var_os(RUNTIME_VAR).is_none() {
        std::env::set_var(RUNTIME_VAR, ONE_WORKER_THREAD);
    }
}

/// The variable Zenoh takes its runtimes' configuration from.
const RUNTIME_VAR: &str = "ZENOH_RUNTIME";

/// Zenoh reads `ZENOH_RUNTIME` when it first starts, and panics if it cannot parse it. Parse it
/// here first, with Zenoh's own parser, so that a bad value is an error that says what is wrong
/// with it instead. Done once per process (the panic hook is silenced meanwhile).
fn check_runtime_variable() -> io::Result<()> {
    static CHECKED: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    let checked = CHECKED.get_or_init(|| {
        let Some(value) = std::env::var_os(RUNTIME_VAR) else {
            return Ok(());
        };
        let hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let parsed = std::panic::catch_unwind(|| {
            let _ = &*zenoh_runtime::ZRUNTIME_PARAM;
        });
        std::panic::set_hook(hook);
        parsed.map_err(|panic| {
            let why = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("it does not parse");
            let why = why
                .strip_prefix("called `Result::unwrap()` on an `Err` value: ")
                .unwrap_or(why);
            format!(
                "{RUNTIME_VAR}={value:?} is not a Zenoh runtime configuration: {why}\n  \
                 hint: it is RON, e.g. {RUNTIME_VAR}='(rx: (worker_threads: 2))'; unset it for \
                 ferrolink's default (all of Zenoh on one worker thread)"
            )
        })
    });
    checked
        .clone()
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))
}

/// A session and the callbacks that take what arrives on it; dropping it undeclares them and
/// closes the session.
///
/// Samples and queries are handled in the callbacks, on Zenoh's own receiving task: a frame from
/// Zenoh is routed there, with no thread of ours to wake for it and none that wakes to look
/// whether it should stop.
#[derive(Debug)]
pub struct Running {
    session: zenoh::Session,
    name: String,
    subscribers: Vec<Subscriber<()>>,
    queryables: Vec<Queryable<()>>,
}

impl Running {
    /// Joins the network `uri` names.
    pub(crate) fn open(uri: &ZenohUri) -> io::Result<Running> {
        let name = uri.to_string();
        check_runtime_variable()?;
        let config = uri.config().map_err(io::Error::other)?;
        let session = zenoh::open(config)
            .wait()
            .map_err(|e| io::Error::other(format!("{name}: {e}")))?;
        Ok(Running {
            session,
            name,
            subscribers: Vec::new(),
            queryables: Vec::new(),
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

    /// Hands every sample other sessions put on `key` to `on_sample`, one at a time, until the
    /// endpoint is dropped.
    pub(crate) fn on_remote_sample(
        &mut self,
        key: String,
        on_sample: impl FnMut(Sample) + Send + Sync + 'static,
    ) -> io::Result<()> {
        let subscriber = self
            .session
            .declare_subscriber(key)
            .allowed_origin(Locality::Remote)
            .callback_mut(on_sample)
            .wait()
            .map_err(|e| self.error(e))?;
        self.subscribers.push(subscriber);
        Ok(())
    }

    /// Hands every query on `key` to `on_query` until the endpoint is dropped.
    pub(crate) fn on_query(
        &mut self,
        key: &str,
        on_query: impl Fn(Query) + Send + Sync + 'static,
    ) -> io::Result<()> {
        let queryable = self
            .session
            .declare_queryable(key.to_owned())
            .callback(on_query)
            .wait()
            .map_err(|e| self.error(e))?;
        self.queryables.push(queryable);
        Ok(())
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        for s in self.subscribers.drain(..) {
            let _ = s.undeclare().wait();
        }
        for q in self.queryables.drain(..) {
            let _ = q.undeclare().wait();
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
