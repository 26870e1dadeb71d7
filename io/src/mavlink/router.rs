//! The MAVLink router daemon: the runtime's [`Router`] between endpoints on a PC.
//!
//! Every peer of every endpoint (each UDP sender on a `udpin` port, each client of a `tcpin`
//! server, the one peer of `udpout`, `tcpout` and `serial`) is its own link, with its own parser
//! and counters. One thread routes; each endpoint has reader threads that feed it.
//! `ferrolink mavlink router` is a thin wrapper around [`run`].

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use ferrolink_runtime::mavlink::router::{LinkCounters, Router, MAX_LINKS};
use ferrolink_runtime::mavlink::MessageMeta;
use serde_json::json;

use super::config::EndpointConfig;
use super::{tlog, unix_us};
use crate::peers::{self, Event, PeerId, Sender};

/// Route and source table sizes of the daemon.
type Daemon = Router<MAX_LINKS, 1024, 256, 1024>;

/// What the router daemon does.
#[derive(Debug, Clone, Default)]
pub struct Config {
    /// The endpoints, each with the configuration of its links.
    pub endpoints: Vec<EndpointConfig>,
    /// The messages it knows (CRC_EXTRA, target offsets), sorted by id.
    pub table: &'static [MessageMeta],
    /// Log every frame received here.
    pub tlog: Option<PathBuf>,
    /// Append a JSON object of statistics here every second and at exit.
    pub stats_json: Option<PathBuf>,
    /// Print a statistics table this often.
    pub stats_every: Option<Duration>,
    /// Stop after this long.
    pub run_for: Option<Duration>,
    /// How long a quiet `udpin` peer keeps its link (default 10 s).
    pub peer_expiry: Option<Duration>,
}

struct Link {
    slot: usize,
    name: String,
    sender: Sender,
    tx_errors: u64,
}

/// Runs the router until `run_for` elapses or `stop` is set. Prints `ready` on stdout once
/// every endpoint is bound and listening.
pub fn run(config: &Config, stop: &Arc<AtomicBool>) -> io::Result<()> {
    let (tx, rx) = mpsc::channel();
    let options = peers::Options {
        peer_expiry: config.peer_expiry.unwrap_or(peers::DEFAULT_PEER_EXPIRY),
    };
    let mut handles = Vec::new();
    for (i, endpoint) in config.endpoints.iter().enumerate() {
        handles.push(peers::open(i, &endpoint.endpoint, options, tx.clone())?);
    }
    drop(tx);
    let mut tlog = match &config.tlog {
        Some(path) => Some(tlog::Writer::new(BufWriter::new(File::create(path)?))),
        None => None,
    };
    let mut stats_json = match &config.stats_json {
        Some(path) => Some(BufWriter::new(File::create(path)?)),
        None => None,
    };
    let mut router: Box<Daemon> = Box::new(Router::new(config.table));
    let mut links: HashMap<PeerId, Link> = HashMap::new();
    let mut by_slot: Vec<Option<PeerId>> = vec![None; MAX_LINKS];
    let mut refused = 0u64;
    let start = Instant::now();
    let deadline = config.run_for.map(|d| start + d);
    let mut next_json = start + Duration::from_secs(1);
    let mut next_table = config.stats_every.map(|d| start + d);
    {
        let mut out = io::stdout().lock();
        writeln!(
            out,
            "ready: routing {} endpoint(s), {} message(s) known",
            config.endpoints.len(),
            config.table.len()
        )?;
        out.flush()?;
    }
    loop {
        let now = Instant::now();
        if stop.load(Ordering::Relaxed) || deadline.is_some_and(|d| now >= d) {
            break;
        }
        let mut wake = now + Duration::from_millis(200);
        for t in [Some(next_json), next_table, deadline]
            .into_iter()
            .flatten()
        {
            wake = wake.min(t);
        }
        match rx.recv_timeout(wake.saturating_duration_since(now)) {
            Ok(Event::Up {
                endpoint,
                peer,
                name,
                sender,
            }) => {
                let link = config
                    .endpoints
                    .get(endpoint)
                    .map(|e| e.link.clone())
                    .unwrap_or_default();
                match router.open_link(link) {
                    Some(slot) => {
                        by_slot[slot] = Some(peer);
                        eprintln!("link up: {name}");
                        links.insert(
                            peer,
                            Link {
                                slot,
                                name,
                                sender,
                                tx_errors: 0,
                            },
                        );
                    }
                    None => {
                        refused += 1;
                        eprintln!("link refused: {name}: all {MAX_LINKS} links in use");
                    }
                }
            }
            Ok(Event::Rx { peer, bytes, at }) => {
                let Some(from) = links.get(&peer).map(|l| l.slot) else {
                    continue;
                };
                let now_us = unix_us();
                let rx_us = now_us.saturating_sub(at.elapsed().as_micros() as u64);
                let mut log_error = None;
                router.receive(from, &bytes, rx_us, now_us, |routed| {
                    if let Some(log) = &mut tlog {
                        if let Err(e) = log.write(rx_us, routed.bytes) {
                            log_error = Some(e);
                        }
                    }
                    let mut to = routed.to;
                    while to != 0 {
                        let slot = to.trailing_zeros() as usize;
                        to &= to - 1;
                        let link = by_slot
                            .get(slot)
                            .copied()
                            .flatten()
                            .and_then(|p| links.get_mut(&p));
                        if let Some(link) = link {
                            if link.sender.send(routed.bytes).is_err() {
                                link.tx_errors += 1;
                            }
                        }
                    }
                });
                if let Some(e) = log_error {
                    return Err(io::Error::new(e.kind(), format!("writing the tlog: {e}")));
                }
            }
            Ok(Event::Down { peer, why }) => {
                if let Some(link) = links.remove(&peer) {
                    router.close_link(link.slot);
                    by_slot[link.slot] = None;
                    eprintln!("link down: {}: {why}", link.name);
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
        let now = Instant::now();
        if now >= next_json {
            if let Some(out) = &mut stats_json {
                write_json(out, &router, &links, refused)?;
            }
            next_json += Duration::from_secs(1);
        }
        if let (Some(every), Some(at)) = (config.stats_every, next_table) {
            if now >= at {
                print_table(&router, &links)?;
                next_table = Some(at + every);
            }
        }
    }
    if let Some(out) = &mut stats_json {
        write_json(out, &router, &links, refused)?;
        out.flush()?;
    }
    if let Some(log) = &mut tlog {
        log.flush()?;
    }
    drop(handles);
    Ok(())
}

fn counters_json(c: &LinkCounters) -> serde_json::Value {
    let d = &c.drops;
    json!({
        "rx_frames": c.rx_frames, "rx_bytes": c.rx_bytes,
        "tx_frames": c.tx_frames, "tx_bytes": c.tx_bytes,
        "unchecked": c.unchecked, "crc_failures": c.crc_failures,
        "garbage_bytes": c.garbage_bytes,
        "drops": {
            "unsigned": d.unsigned, "bad_signature": d.bad_signature,
            "duplicate": d.duplicate, "filtered_in": d.filtered_in,
            "no_route": d.no_route, "filtered_out": d.filtered_out, "late": d.late,
        },
    })
}

fn sorted_links(links: &HashMap<PeerId, Link>) -> Vec<&Link> {
    let mut sorted: Vec<&Link> = links.values().collect();
    sorted.sort_by_key(|l| l.slot);
    sorted
}

fn write_json(
    out: &mut impl Write,
    router: &Daemon,
    links: &HashMap<PeerId, Link>,
    refused: u64,
) -> io::Result<()> {
    let links_json: Vec<_> = sorted_links(links)
        .into_iter()
        .filter_map(|l| {
            let mut c = counters_json(router.link_counters(l.slot)?);
            c["link"] = l.name.clone().into();
            c["tx_errors"] = l.tx_errors.into();
            Some(c)
        })
        .collect();
    let sources: Vec<_> = router
        .sources()
        .map(|s| {
            json!({"sysid": s.sysid, "compid": s.compid, "rx_frames": s.rx_frames,
                   "rx_bytes": s.rx_bytes, "tx_frames": s.tx_frames, "lost": s.lost})
        })
        .collect();
    let r = router.counters();
    let line = json!({
        "t_us": unix_us(),
        "links": links_json,
        "sources": sources,
        "routes": router.routes().count(),
        "routes_evicted": r.routes_evicted,
        "sources_evicted": r.sources_evicted,
        "links_refused": refused,
    });
    writeln!(out, "{line}")?;
    out.flush()
}

fn print_table(router: &Daemon, links: &HashMap<PeerId, Link>) -> io::Result<()> {
    let mut out = io::stdout().lock();
    writeln!(
        out,
        "{:<44} {:>9} {:>9} {:>6} {:>8} {:>8}",
        "link", "rx", "tx", "crc", "dropped", "tx err"
    )?;
    for l in sorted_links(links) {
        let Some(c) = router.link_counters(l.slot) else {
            continue;
        };
        writeln!(
            out,
            "{:<44} {:>9} {:>9} {:>6} {:>8} {:>8}",
            l.name,
            c.rx_frames,
            c.tx_frames,
            c.crc_failures,
            c.drops.inbound(),
            l.tx_errors
        )?;
    }
    writeln!(
        out,
        "{:<12} {:>9} {:>9} {:>6}",
        "source", "rx", "tx", "lost"
    )?;
    for s in router.sources() {
        writeln!(
            out,
            "{:<12} {:>9} {:>9} {:>6}",
            format!("{}/{}", s.sysid, s.compid),
            s.rx_frames,
            s.tx_frames,
            s.lost
        )?;
    }
    out.flush()
}
