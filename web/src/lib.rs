//! The router's web API: mavlink2rest 1.0.2's REST and WebSocket API, served by the router
//! itself, and a live inspector page.
//!
//! [`endpoint`] makes an [`Attached`] endpoint of the router: a link like any other, except that
//! it is a sniffer ([`LinkConfig::sniffer`]), sent every frame the router takes in. What it is
//! sent goes into a bounded queue (a full queue drops frames, counted, and never holds up
//! routing) and from there, on the API's own threads, into the [`store::Store`] and out to every
//! WebSocket whose filter takes it. What a client posts goes into the router as this link's
//! frames, routed by their targets like any other.
//!
//! | route | |
//! |---|---|
//! | `GET /v1/mavlink[/PATH]` | the tree, or what `PATH` names: `vehicles/SYS/components/COMP/messages/NAME[/message[/FIELD]\|/status[/time[/KEY]]]`; 404 with a JSON error for a path that names nothing |
//! | `POST /v1/mavlink` | `{"header": {"system_id", "component_id", ..}, "message": {"type": NAME, ..}}`: sent from those ids, signed when a key is given; 400 with the reason when it does not decode |
//! | `GET /v1/helper/mavlink?name=NAME` | the message with every field at its default |
//! | `GET /v1/ws/mavlink?filter=REGEX` | every message whose name the regex finds, as `{"header": .., "message": ..}` |
//! | `GET /info` | the service |
//! | `GET /` | the inspector page |
//!
//! The same routes answer without `/v1`, as mavlink2rest's do. JSON is mavlink2rest's (see
//! `ferrolink_traffic`'s REST form), pretty-printed.

use std::collections::HashMap;
use std::io;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Instant, SystemTime};

use ferrolink_io::link::{self, Event, Sender};
use ferrolink_io::mavlink::router::Attached;
use ferrolink_runtime::mavlink::router::LinkConfig;
use ferrolink_runtime::mavlink::signing::{timestamp_from_unix_micros, SecretKey, Signer};
use ferrolink_runtime::mavlink::{v2, AnyFrame, Header};
use ferrolink_traffic::PayloadDecoder;
use tokio::sync::mpsc;

mod api;
mod page;
pub mod store;
mod ws;

/// Frames that may wait between the router and the API before the newest are dropped.
const QUEUE: usize = 8192;
/// Messages that may wait for a WebSocket client before the newest are dropped (its own).
const CLIENT_QUEUE: usize = 1024;
/// The largest body a POST may have.
const MAX_BODY: usize = 64 * 1024;

/// What the web API serves.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where it listens (`127.0.0.1:8088`).
    pub addr: SocketAddr,
    /// The dialect its JSON speaks: the router's.
    pub decoder: PayloadDecoder,
    /// Signs what clients post with this key (link id 0).
    pub signing: Option<SecretKey>,
}

/// A message from the router, as the WebSockets get it.
#[derive(Debug)]
pub(crate) struct Incoming {
    pub header: Header,
    pub id: u32,
    pub payload: Vec<u8>,
    /// Its JSON text, made once for every client that takes it.
    pub text: std::sync::OnceLock<Option<axum::extract::ws::Utf8Bytes>>,
}

/// What the API's tasks share.
pub(crate) struct Shared {
    pub decoder: PayloadDecoder,
    pub store: Mutex<Store>,
    /// The WebSocket clients, each with its filter and queue.
    pub clients: Mutex<Vec<ws::Client>>,
    /// Into the router.
    sink: link::Sink,
    peer: link::PeerId,
    tx: Mutex<Outgoing>,
    pub counts: Counts,
    pub status: link::Status,
    pub started: SystemTime,
}

use store::Store;

/// What posted messages are sent with: a sequence number per sender, and the signer.
struct Outgoing {
    seqs: HashMap<(u8, u8), u8>,
    signer: Option<Signer>,
}

/// What the API counted.
#[derive(Debug, Default)]
pub(crate) struct Counts {
    /// Frames the router sent it.
    pub frames: AtomicU64,
    /// Frames dropped because the API did not keep up.
    pub dropped: AtomicU64,
    /// Messages WebSocket clients lost because they did not keep up.
    pub ws_dropped: AtomicU64,
    /// WebSocket clients connected now.
    pub ws_clients: AtomicU64,
    /// Messages clients posted.
    pub posted: AtomicU64,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Shared {
    /// Sends message `id` from `(sysid, compid)` into the router and keeps it in the store, as
    /// mavlink2rest does; returns the frame's length.
    pub fn send(&self, sysid: u8, compid: u8, id: u32, payload: &[u8]) -> Result<usize, String> {
        let crc_extra = self
            .decoder
            .message(id)
            .map(|m| m.crc_extra)
            .ok_or("unknown message")?;
        let mut out = [0u8; v2::MAX_FRAME_LEN];
        let n = {
            let mut tx = lock(&self.tx);
            let Outgoing { seqs, signer } = &mut *tx;
            let seq = seqs.entry((sysid, compid)).or_insert(0);
            let header = Header::new(*seq, sysid, compid);
            *seq = seq.wrapping_add(1);
            let now = timestamp_from_unix_micros(ferrolink_io::mavlink::unix_us());
            match signer {
                Some(signer) => signer.encode_raw(now, header, id, crc_extra, payload, &mut out),
                None => v2::encode_raw(header, id, crc_extra, payload, &mut out),
            }
            .map_err(|e| format!("{e:?}"))?
        };
        (self.sink)(Event::Rx {
            peer: self.peer,
            bytes: &out[..n],
            at: Instant::now(),
        });
        lock(&self.store).update(sysid, compid, id, payload, SystemTime::now());
        self.counts.posted.fetch_add(1, Ordering::Relaxed);
        Ok(n)
    }
}

/// The web API as an endpoint of the router, listening on `config.addr` once the router opens
/// it (an address in use fails the router's start).
pub fn endpoint(config: Config) -> Attached {
    Attached {
        link: LinkConfig {
            sniffer: true,
            datagrams: true,
            ..LinkConfig::default()
        },
        open: Box::new(move |index, sink, status| open(index, sink, status, config)),
    }
}

/// Stops the API when dropped.
struct Running {
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

fn open(
    index: usize,
    sink: link::Sink,
    status: link::Status,
    config: Config,
) -> io::Result<Box<dyn Send>> {
    let named = |e: io::Error| io::Error::new(e.kind(), format!("--http {}: {e}", config.addr));
    raise_file_limit();
    let listener = std::net::TcpListener::bind(config.addr).map_err(named)?;
    listener.set_nonblocking(true).map_err(named)?;
    let addr = listener.local_addr().map_err(named)?;
    let (frames_tx, frames_rx) = mpsc::channel::<Vec<u8>>(QUEUE);
    let peer = link::next_peer();
    let shared = Arc::new(Shared {
        decoder: config.decoder,
        store: Mutex::new(Store::default()),
        clients: Mutex::new(Vec::new()),
        sink: sink.clone(),
        peer,
        tx: Mutex::new(Outgoing {
            seqs: HashMap::new(),
            signer: config.signing.map(|k| Signer::new(k, 0)),
        }),
        counts: Counts::default(),
        status,
        started: SystemTime::now(),
    });
    let sender = {
        let shared = shared.clone();
        Sender::from_fn(move |bytes| {
            shared.counts.frames.fetch_add(1, Ordering::Relaxed);
            match frames_tx.try_send(bytes.to_vec()) {
                Ok(()) => Ok(()),
                Err(mpsc::error::TrySendError::Full(_)) => {
                    shared.counts.dropped.fetch_add(1, Ordering::Relaxed);
                    Ok(())
                }
                Err(mpsc::error::TrySendError::Closed(_)) => {
                    Err(io::Error::from(io::ErrorKind::BrokenPipe))
                }
            }
        })
    };
    let up = Event::Up {
        endpoint: index,
        peer,
        name: format!("http://{addr}"),
        sender,
    };
    if !sink(up) {
        return Err(io::Error::other("the router is not listening"));
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name("http")
        .enable_all()
        .build()?;
    let (stop, stopped) = tokio::sync::oneshot::channel();
    let thread = std::thread::Builder::new()
        .name("http".into())
        .spawn(move || {
            runtime.block_on(async move {
                let listener = match tokio::net::TcpListener::from_std(listener) {
                    Ok(l) => l,
                    Err(e) => {
                        eprintln!("--http {addr}: {e}");
                        return;
                    }
                };
                tokio::spawn(ingest(shared.clone(), frames_rx));
                let app = api::router(shared);
                tokio::select! {
                    served = axum::serve(listener, app) => {
                        if let Err(e) = served {
                            eprintln!("--http {addr}: {e}");
                        }
                    }
                    _ = stopped => {}
                }
            });
            // WebSockets still open are cut, not waited for.
            runtime.shutdown_background();
        })?;
    Ok(Box::new(Running {
        stop: Some(stop),
        thread: Some(thread),
    }))
}

/// Every client holds a descriptor: a thousand of them must not meet the usual soft limit of
/// 1024 open files, so it is raised to the hard limit.
fn raise_file_limit() {
    #[cfg(unix)]
    {
        use nix::sys::resource::{getrlimit, setrlimit, Resource};
        if let Ok((soft, hard)) = getrlimit(Resource::RLIMIT_NOFILE) {
            if soft < hard {
                let _ = setrlimit(Resource::RLIMIT_NOFILE, hard, hard);
            }
        }
    }
}

/// How long the API lets the router's frames gather before it takes them in: it wakes at most
/// this often, not once per frame, whatever the rate.
const INGEST_TICK: std::time::Duration = std::time::Duration::from_millis(5);

/// Takes the router's frames into the store and out to the WebSockets, a tick's worth at a
/// time.
async fn ingest(shared: Arc<Shared>, mut frames: mpsc::Receiver<Vec<u8>>) {
    while let Some(first) = frames.recv().await {
        tokio::time::sleep(INGEST_TICK).await;
        let now = SystemTime::now();
        let mut store = lock(&shared.store);
        let mut taken = Vec::new();
        for bytes in std::iter::once(first).chain(std::iter::from_fn(|| frames.try_recv().ok())) {
            let Ok(frame) = AnyFrame::new_checked(&bytes[..]) else {
                continue;
            };
            let (header, id) = (frame.header(), frame.msg_id());
            if shared.decoder.message(id).is_none() {
                continue;
            }
            store.update(header.sysid, header.compid, id, frame.payload(), now);
            taken.push((header, id, bytes));
        }
        drop(store);
        for (header, id, bytes) in taken {
            if let Ok(frame) = AnyFrame::new_checked(&bytes[..]) {
                ws::fan_out(&shared, header, id, frame.payload());
            }
        }
    }
}
