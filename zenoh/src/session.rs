//! What the Zenoh endpoints share: a session for a URI that closes when the endpoint is dropped,
//! subscribers that take other sessions' samples only, and the note on stderr about samples that
//! carried nothing usable.

use std::io;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
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

/// A `listen=tcp/HOST:PORT` (or `udp/`) whose port another program already listens on, as
/// the link layer words it: Zenoh's own error would say so too, buried in its source paths.
fn taken_port(uri: &ZenohUri) -> io::Result<()> {
    use std::net::{TcpListener, ToSocketAddrs, UdpSocket};
    for locator in &uri.listen {
        let Some((proto, address)) = locator.split_once('/') else {
            continue;
        };
        // Options after `#`, interfaces after `%` or `?` are Zenoh's to read.
        let address = address.split(['#', '?']).next().unwrap_or_default();
        let Some(addr) = address.to_socket_addrs().ok().and_then(|mut a| a.next()) else {
            continue;
        };
        if addr.port() == 0 {
            continue;
        }
        let bound = match proto {
            "tcp" => TcpListener::bind(addr).map(drop),
            "udp" => UdpSocket::bind(addr).map(drop),
            _ => continue,
        };
        if let Err(e) = bound {
            if e.kind() != io::ErrorKind::AddrInUse {
                continue;
            }
            return Err(io::Error::new(
                e.kind(),
                format!(
                    "{uri}: listen={locator}: {e}\n  hint: another program (or another endpoint \
                     given here) listens on this port; `ss -lunp` and `ss -ltnp` name it"
                ),
            ));
        }
    }
    Ok(())
}

impl Running {
    /// Joins the network `uri` names.
    pub(crate) fn open(uri: &ZenohUri) -> io::Result<Running> {
        let name = uri.to_string();
        check_runtime_variable()?;
        let config = uri.config().map_err(io::Error::other)?;
        taken_port(uri)?;
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

    /// Hands every sample other sessions put on `key` to `on_sample`, one at a time and in
    /// order, until the endpoint is dropped, as [`Arrivals`] says.
    pub(crate) fn on_remote_sample(
        &mut self,
        key: String,
        on_sample: impl FnMut(Sample) + Send + 'static,
    ) -> io::Result<()> {
        let arrivals = Arc::new(Arrivals::new(on_sample));
        let subscriber = self
            .session
            .declare_subscriber(key)
            .allowed_origin(Locality::Remote)
            .callback(move |sample| arrivals.arrive(sample))
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

/// Samples handed on together: what one read from Zenoh brings.
///
/// Zenoh calls a subscriber once per sample, from the task that read them, and never says when
/// a read's samples are done. The first sample of a read therefore schedules a task on the same
/// runtime, which runs once the reading task yields (after the read, on the single worker
/// thread the CLI gives Zenoh), and hands on every sample that came by then inside one
/// [`link::batch`]: the frames they route to a UDP peer share its datagrams, one system call per
/// socket, as those read from a UDP socket do, where one `sendto` per frame and peer was the
/// largest cost of a router fed by Zenoh. Samples are handed on in the order they came; the
/// handler's lock is taken before the queue is, so a second task cannot overtake the first.
/// Outside a tokio runtime a sample is handed on at once.
///
/// At most [`MAX_WAITING`] samples wait: where Zenoh has more than one worker thread and the
/// handler falls behind the reader, the reader hands on what waits itself, after the batch
/// being handled, so a peer that floods the link slows its own reading instead of growing the
/// queue without end.
struct Arrivals<T, F> {
    waiting: Mutex<Vec<T>>,
    handler: Mutex<F>,
}

impl<T: Send + 'static, F: FnMut(T) + Send + 'static> Arrivals<T, F> {
    fn new(handler: F) -> Self {
        Arrivals {
            waiting: Mutex::new(Vec::new()),
            handler: Mutex::new(handler),
        }
    }

    fn arrive(self: &Arc<Self>, item: T) {
        let (first, full) = {
            let mut waiting = lock(&self.waiting);
            waiting.push(item);
            (waiting.len() == 1, waiting.len() >= MAX_WAITING)
        };
        if full {
            self.hand_on();
        } else if first {
            match tokio::runtime::Handle::try_current() {
                Ok(runtime) => {
                    let arrivals = Arc::clone(self);
                    drop(runtime.spawn(async move { arrivals.hand_on() }));
                }
                Err(_) => self.hand_on(),
            }
        }
    }

    fn hand_on(&self) {
        let mut handler = lock(&self.handler);
        let items = std::mem::take(&mut *lock(&self.waiting));
        link::batch(|| items.into_iter().for_each(&mut *handler));
    }
}

/// The most samples [`Arrivals`] holds: enough to fill a few packed datagrams per peer.
const MAX_WAITING: usize = 256;

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
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
            // Through the printer: this runs on Zenoh's thread, which must not wait on stderr.
            let _ = ferrolink_io::printer::stderr().line(format!(
                "zenoh: sample on {key} rejected ({} so far): {why}",
                self.count
            ));
        }
    }

    /// How many so far.
    #[cfg(test)]
    pub(crate) fn count(&self) -> u64 {
        self.count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recorder() -> (Arc<Mutex<Vec<u32>>>, impl FnMut(u32) + Send + 'static) {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let handler = {
            let seen = Arc::clone(&seen);
            move |n| lock(&seen).push(n)
        };
        (seen, handler)
    }

    #[test]
    fn outside_a_runtime_each_arrival_is_handed_on_at_once() {
        let (seen, handler) = recorder();
        let arrivals = Arc::new(Arrivals::new(handler));
        arrivals.arrive(1);
        assert_eq!(*lock(&seen), [1]);
        arrivals.arrive(2);
        assert_eq!(*lock(&seen), [1, 2]);
    }

    #[test]
    fn what_comes_before_the_reader_yields_is_handed_on_together_and_in_order() {
        let (seen, handler) = recorder();
        let arrivals = Arc::new(Arrivals::new(handler));
        let runtime = tokio::runtime::Builder::new_current_thread()
            .build()
            .expect("runtime");
        runtime.block_on(async {
            let reader = {
                let (arrivals, seen) = (Arc::clone(&arrivals), Arc::clone(&seen));
                tokio::spawn(async move {
                    for n in 0..3 {
                        arrivals.arrive(n);
                    }
                    // Nothing is handed on while the reader runs.
                    let before_yield = lock(&seen).clone();
                    tokio::task::yield_now().await;
                    arrivals.arrive(3);
                    before_yield
                })
            };
            assert_eq!(reader.await.expect("reader"), Vec::<u32>::new());
            tokio::task::yield_now().await;
        });
        assert_eq!(*lock(&seen), [0, 1, 2, 3]);
    }

    #[test]
    fn a_reader_that_never_yields_hands_on_what_waits_itself() {
        let (seen, handler) = recorder();
        let arrivals = Arc::new(Arrivals::new(handler));
        let runtime = tokio::runtime::Builder::new_current_thread()
            .build()
            .expect("runtime");
        let n = 3 * MAX_WAITING as u32 + 1;
        let handed_on_while_reading = runtime.block_on({
            let (arrivals, seen) = (Arc::clone(&arrivals), Arc::clone(&seen));
            async move {
                for i in 0..n {
                    arrivals.arrive(i);
                    assert!(lock(&arrivals.waiting).len() < MAX_WAITING);
                }
                let handed_on = lock(&seen).len();
                // The last one goes once the reader yields.
                tokio::task::yield_now().await;
                handed_on
            }
        });
        assert_eq!(handed_on_while_reading, 3 * MAX_WAITING);
        assert_eq!(*lock(&seen), (0..n).collect::<Vec<_>>());
    }

    #[test]
    fn many_workers_keep_the_order_of_arrival() {
        let (seen, handler) = recorder();
        let arrivals = Arc::new(Arrivals::new(handler));
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .build()
            .expect("runtime");
        let reader = {
            let arrivals = Arc::clone(&arrivals);
            runtime.spawn(async move {
                for n in 0..10_000 {
                    arrivals.arrive(n);
                    if n % 7 == 0 {
                        tokio::task::yield_now().await;
                    }
                }
            })
        };
        runtime.block_on(reader).expect("reader");
        let deadline = std::time::Instant::now() + Duration::from_secs(10);
        while lock(&seen).len() < 10_000 && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
        assert_eq!(*lock(&seen), (0..10_000).collect::<Vec<_>>());
    }
}
