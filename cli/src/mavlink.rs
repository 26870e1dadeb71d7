//! `ferrolink mavlink`: the router daemon, the log tools, and the microservices' client and
//! software vehicle (in `mavlink_services`).

use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use clap::Subcommand;
use ferrolink_io::uri::Target;

use crate::schemes::{Extra, EXTENSIONS};
use ferrolink_io::link::{OutputQueue, Overflow};
use ferrolink_io::mavlink::config::{self, EndpointConfig, FileConfig};
use ferrolink_io::mavlink::{router, tlog};
use ferrolink_runtime::mavlink::router::LinkConfig;

use ferrolink_traffic::{CsvExport, RowMeta};

use crate::dialect::Dialects;

#[derive(Subcommand)]
pub enum Command {
    /// List the built-in dialects, one JSON line each: its name, and the messages and enums it
    /// has with everything it includes. `--dialect NAME` takes these names.
    Dialects,
    /// Route MAVLink between endpoints: every UDP peer and TCP client is a link of its own.
    Router {
        /// A built-in dialect's name or a dialect XML file, whose messages the router knows
        /// (CRC_EXTRA, targets); repeatable [default: all, every standard dialect].
        #[arg(long, value_name = "NAME|FILE")]
        dialect: Vec<PathBuf>,
        /// Log every frame received (passed its CRC, or an unknown id): to FILE.tlog, appended
        /// to, or into DIR, a new numbered file per run (NNNNN-YYYY-MM-DD_HH-MM-SS.tlog, UTC).
        #[arg(long, value_name = "FILE.tlog|DIR")]
        tlog: Option<PathBuf>,
        /// When the tlog is written: always, or while-armed (a new file each time the vehicle
        /// arms, closed when it disarms: one per flight) [default: always].
        #[arg(long, value_name = "always|while-armed")]
        log_mode: Option<router::LogMode>,
        /// Serve mavlink2rest's REST and WebSocket API and the live inspector page at
        /// http://ADDR:PORT/ (bind 127.0.0.1 unless other hosts should reach it).
        #[arg(long, value_name = "ADDR:PORT")]
        http: Option<std::net::SocketAddr>,
        /// Write statistics as one JSON object per line, every second and at exit.
        #[arg(long, value_name = "FILE")]
        stats_json: Option<PathBuf>,
        /// Print a statistics table every SECS seconds.
        #[arg(long, value_name = "SECS", value_parser = ferrolink_io::seconds::parse)]
        stats: Option<Duration>,
        /// Stop after SECS seconds (SIGINT and SIGTERM stop it too, all with status 0).
        #[arg(long, value_name = "SECS", value_parser = ferrolink_io::seconds::parse)]
        run_for: Option<Duration>,
        /// Forget a UDP peer quiet for SECS seconds [default: 10].
        #[arg(long, value_name = "SECS", value_parser = ferrolink_io::seconds::parse)]
        peer_expiry: Option<Duration>,
        /// The most bytes queued for a TCP, serial or pty peer that reads slower than frames
        /// come for it [default: 65536]; past it, the peer loses frames and no other link waits.
        #[arg(long, value_name = "BYTES")]
        queue_bytes: Option<usize>,
        /// What a full output queue drops [default: oldest].
        #[arg(long, value_name = "oldest|newest")]
        queue_drop: Option<QueueDrop>,
        /// Send each frame to a UDP peer in a datagram of its own, for a peer that reads one
        /// frame a datagram. By default, frames for one UDP peer that leave together share
        /// datagrams of up to 1200 bytes, each frame whole.
        #[arg(long)]
        one_frame_per_datagram: bool,
        /// Drop frames whose exact bytes came within MS milliseconds (redundant links), on the
        /// endpoints given on the command line.
        #[arg(long, value_name = "MS", default_value_t = 0)]
        dedup_ms: u64,
        /// Endpoints, filters and groups from a file: our TOML form (`.toml`) or mavlink-router's
        /// `main.conf` (anything else). Flags add to it and take precedence.
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
        /// udpin://HOST:PORT | udpout://HOST:PORT[?replies=any] | udpbcast://ADDR:PORT |
        /// udpmcast://GROUP:PORT[?iface=NAME] | tcpin://HOST:PORT | tcpout://HOST:PORT |
        /// serial://PATH[:BAUD] | pty://NAME (a pseudo-terminal linked at NAME) |
        /// zenoh://?mode=peer&listen=tcp/HOST:PORT[&connect=tcp/HOST:PORT][&encoding=raw|json][&prefix=ferrolink]
        #[arg(required_unless_present = "config", value_name = "ENDPOINT")]
        endpoints: Vec<String>,
    },
    /// List the routers on a Zenoh network: their links and the systems behind them.
    Fleet {
        /// Wait this long for answers.
        #[arg(long, value_name = "SECS", default_value = "2", value_parser = ferrolink_io::seconds::parse)]
        timeout: Duration,
        /// Print one JSON object per router instead of text.
        #[arg(long)]
        json: bool,
        /// zenoh://?mode=peer&connect=tcp/HOST:PORT[&prefix=ferrolink]
        uri: String,
    },
    /// Print a .tlog (or a raw capture) as JSON lines in pymavlink's to_dict() form.
    Dump {
        /// A built-in dialect's name or a dialect XML file to decode with; repeatable
        /// [default: ardupilotmega].
        #[arg(long, value_name = "NAME|FILE")]
        dialect: Vec<PathBuf>,
        /// The file is raw link bytes, without timestamps.
        #[arg(long)]
        raw: bool,
        /// Also write one CSV file per message type into DIR.
        #[arg(long, value_name = "DIR")]
        csv: Option<PathBuf>,
        /// The log.
        file: PathBuf,
    },
    /// Export logs (or raw captures) as Parquet: one file per message type in DIR, with a `log`
    /// column naming each row's file, for DuckDB, polars, pandas or Spark.
    #[cfg(feature = "parquet")]
    Export {
        /// Write the Parquet files into DIR (created if need be; files there are replaced).
        #[arg(long, value_name = "DIR")]
        parquet: PathBuf,
        /// Only these message types (wire names, comma-separated).
        #[arg(long, value_name = "NAME,...", value_delimiter = ',')]
        types: Option<Vec<String>>,
        /// A built-in dialect's name or a dialect XML file to decode with; repeatable
        /// [default: ardupilotmega].
        #[arg(long, value_name = "NAME|FILE")]
        dialect: Vec<PathBuf>,
        /// The files are raw link bytes, without timestamps.
        #[arg(long)]
        raw: bool,
        /// The logs.
        #[arg(required = true, value_name = "FILE")]
        files: Vec<PathBuf>,
    },
    /// Encode messages: reads JSON lines from stdin, each a message in pymavlink's `to_dict()`
    /// form or the envelope `{"sysid":..,"compid":..,"seq":..,"msg":{..}}` that `dump` prints,
    /// and prints each as an unsigned MAVLink 2 frame in hex.
    Encode {
        /// A built-in dialect's name or a dialect XML file to encode with; repeatable
        /// [default: ardupilotmega].
        #[arg(long, value_name = "NAME|FILE")]
        dialect: Vec<PathBuf>,
    },
    /// Parameters of a vehicle: list, get, set.
    #[command(subcommand)]
    Param(crate::mavlink_services::ParamCommand),
    /// Missions, geofences and rally points of a vehicle: upload, download.
    #[command(subcommand)]
    Mission(crate::mavlink_services::MissionCommand),
    /// Send a command (COMMAND_LONG, or COMMAND_INT with --int), retrying, and print its
    /// answer. Exit 0 on ACCEPTED, 1 on another result, 2 when nothing answered.
    #[command(name = "command")]
    Cmd(crate::mavlink_services::CommandArgs),
    /// Files of a vehicle over MAVLink FTP: ls, get, put.
    #[command(subcommand)]
    Ftp(crate::mavlink_ftp::FtpCommand),
    /// A vehicle's telemetry, one JSON line per update (position, attitude, battery, gps,
    /// state, text). Exit 0 after --count lines or --duration seconds, 2 when no vehicle is
    /// heard within 10 s.
    #[cfg(feature = "vehicle")]
    Telemetry(crate::mavlink_vehicle::TelemetryArgs),
    /// Do an action on a vehicle and print `{"action": .., "result": .., "command": ..}`. Exit 0
    /// when it accepted, 1 when it refused (or the mode has no such name), 2 when nothing
    /// answered.
    #[cfg(feature = "vehicle")]
    Action(crate::mavlink_vehicle::ActionArgs),
    /// A software vehicle: HEARTBEAT, parameters, missions, commands and FTP on every endpoint,
    /// for testing ground software. Prints `ready` once every endpoint is open.
    Vehicle(crate::mavlink_services::VehicleArgs),
    /// Per source: message rates and sequence loss of a .tlog; optionally a plot of message
    /// rates over time.
    Stats {
        /// A built-in dialect's name or a dialect XML file to name messages with; repeatable
        /// [default: ardupilotmega].
        #[arg(long, value_name = "NAME|FILE")]
        dialect: Vec<PathBuf>,
        /// Write a plot: a heat map of the rate of each message type of each source over time
        /// (log colour scale) above each source's sequence loss. FILE.svg, or FILE.png (needs a
        /// TrueType font such as DejaVu Sans).
        #[arg(long, value_name = "FILE.svg|FILE.png")]
        plot: Option<PathBuf>,
        /// The log.
        file: PathBuf,
    },
}

/// The router's `zenoh://` endpoints.
#[cfg(feature = "zenoh")]
fn zenoh_endpoints(
    uris: Vec<(Extra, LinkConfig)>,
    dialects: Dialects,
) -> Result<Vec<router::Attached>, Box<dyn std::error::Error>> {
    use ferrolink_zenoh::mavlink;
    if uris.is_empty() {
        return Ok(Vec::new());
    }
    // Every endpoint's threads share the dictionaries.
    let dictionaries = mavlink::Dictionaries {
        decoder: std::sync::Arc::new(dialects.decoder()),
        table: dialects.table,
    };
    Ok(uris
        .into_iter()
        .map(|(uri, link)| mavlink::attached(uri, link, dictionaries.clone()))
        .collect())
}

#[cfg(not(feature = "zenoh"))]
fn zenoh_endpoints(
    uris: Vec<(Extra, LinkConfig)>,
    _: Dialects,
) -> Result<Vec<router::Attached>, Box<dyn std::error::Error>> {
    Ok(uris.into_iter().map(|(never, _)| match never {}).collect())
}

/// The router's web API (`--http`).
#[cfg(feature = "http")]
fn web_endpoint(
    addr: std::net::SocketAddr,
    dialects: &Dialects,
    signing: Option<ferrolink_runtime::mavlink::signing::SecretKey>,
) -> Result<router::Attached, Box<dyn std::error::Error>> {
    Ok(ferrolink_web::endpoint(ferrolink_web::Config {
        addr,
        decoder: dialects.decoder(),
        signing,
    }))
}

#[cfg(not(feature = "http"))]
fn web_endpoint(
    addr: std::net::SocketAddr,
    _: &Dialects,
    _: Option<ferrolink_runtime::mavlink::signing::SecretKey>,
) -> Result<router::Attached, Box<dyn std::error::Error>> {
    Err(format!(
        "--http {addr}: this ferrolink was built without the web API\n  hint: build it with \
         the `http` feature (on by default)"
    )
    .into())
}

/// `ferrolink mavlink fleet`.
#[cfg(feature = "zenoh")]
fn fleet(uri: &str, timeout: Duration, json: bool) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let uri: ferrolink_zenoh::ZenohUri = uri.parse()?;
    let routers = ferrolink_zenoh::fleet::list(&uri, timeout)?;
    let mut out = io::stdout().lock();
    for r in &routers {
        if json {
            writeln!(out, "{r}")?;
            continue;
        }
        let text = |v: &serde_json::Value| v.as_str().unwrap_or("?").to_owned();
        writeln!(
            out,
            "router {} ({})",
            text(&r["router"]),
            text(&r["endpoint"])
        )?;
        for link in r["links"].as_array().into_iter().flatten() {
            writeln!(out, "  link   {}", text(link))?;
        }
        for s in r["systems"].as_array().into_iter().flatten() {
            writeln!(
                out,
                "  system {}/{} on {}",
                s["sysid"],
                s["compid"],
                text(&s["link"])
            )?;
        }
    }
    if routers.is_empty() {
        eprintln!(
            "no router answered under {}/ within {timeout:?}",
            uri.fleet_root()
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(not(feature = "zenoh"))]
fn fleet(uri: &str, _: Duration, _: bool) -> Result<ExitCode, Box<dyn std::error::Error>> {
    Err(crate::schemes::without_zenoh(uri).into())
}

/// What a full output queue drops.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum QueueDrop {
    /// The oldest queued frames, so a peer that catches up gets the newest.
    Oldest,
    /// The frame being sent.
    Newest,
}

/// The output queue from the flags, over the file's, over the router's default.
fn output_queue(
    file: Option<OutputQueue>,
    bytes: Option<usize>,
    drop: Option<QueueDrop>,
) -> Result<OutputQueue, String> {
    let mut queue = file.unwrap_or(ferrolink_io::link::DAEMON_QUEUE);
    if let Some(bytes) = bytes {
        ferrolink_io::mavlink::config::queue_fits(bytes, "--queue-bytes ")?;
        queue.bytes = bytes;
    }
    match drop {
        Some(QueueDrop::Oldest) => queue.overflow = Overflow::DropOldest,
        Some(QueueDrop::Newest) => queue.overflow = Overflow::DropNewest,
        None => {}
    }
    Ok(queue)
}

/// The default `--peer-expiry`.
const DEFAULT_PEER_EXPIRY: Duration = Duration::from_secs(10);

pub fn run(command: Command) -> Result<ExitCode, Box<dyn std::error::Error>> {
    match command {
        Command::Router {
            dialect,
            tlog,
            log_mode,
            http,
            stats_json,
            stats,
            run_for,
            peer_expiry,
            queue_bytes,
            queue_drop,
            one_frame_per_datagram,
            dedup_ms,
            config,
            endpoints,
        } => {
            let config_path = config.clone();
            let file = match &config {
                Some(path) => read_config(path)?,
                None => FileConfig::default(),
            };
            let mut given = Vec::new();
            let mut zenoh = file.extra.clone();
            for uri in &endpoints {
                match ferrolink_io::mavlink::ENDPOINTS.parse_with(uri, EXTENSIONS)? {
                    Target::Link(endpoint, _) => {
                        let mut endpoint = EndpointConfig::new(endpoint);
                        endpoint.link.dedup_window_us = dedup_ms.saturating_mul(1000);
                        given.push(endpoint);
                    }
                    Target::Other(uri) => {
                        let link = LinkConfig {
                            dedup_window_us: dedup_ms.saturating_mul(1000),
                            ..LinkConfig::default()
                        };
                        zenoh.push((uri, link));
                    }
                }
            }
            let all = [file.endpoints.clone(), given.clone()].concat();
            let dialects = crate::dialect::load(
                &[file.dialects, dialect].concat(),
                crate::dialect::ROUTER_DEFAULT,
            )?;
            let table = dialects.table.clone();
            let http = http.or(file.http);
            // What the API sends is signed with the first key the endpoints require.
            let signing = all.iter().find_map(|e| e.link.require_signing.clone());
            let web = http
                .map(|addr| web_endpoint(addr, &dialects, signing))
                .transpose()?;
            let mut attached = zenoh_endpoints(zenoh, dialects)?;
            attached.extend(web);
            let config = router::Config {
                endpoints: all,
                table,
                tlog: tlog.or(file.tlog),
                retention: file.retention,
                log_mode: log_mode.or(file.log_mode).unwrap_or_default(),
                log_system_id: file.log_system_id,
                stats_json: stats_json.or(file.stats_json),
                stats_every: stats.or(file.stats_every),
                run_for,
                peer_expiry: Some(
                    peer_expiry
                        .or(file.peer_expiry)
                        .unwrap_or(DEFAULT_PEER_EXPIRY),
                ),
                queue: Some(output_queue(file.queue, queue_bytes, queue_drop)?),
                one_frame_per_datagram: one_frame_per_datagram
                    || file.one_frame_per_datagram.unwrap_or(false),
            };
            let (stop, reload) = signals(config_path, given, file.extra)?;
            router::run_reloading(&config, attached, &stop, reload)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Fleet { timeout, json, uri } => fleet(&uri, timeout, json),
        Command::Dialects => dialects(),
        Command::Dump {
            dialect,
            raw,
            csv,
            file,
        } => dump(&dialect, raw, csv.as_deref(), &file),
        #[cfg(feature = "parquet")]
        Command::Export {
            parquet,
            types,
            dialect,
            raw,
            files,
        } => crate::mavlink_export::run(&dialect, types.as_deref(), raw, &parquet, &files),
        Command::Encode { dialect } => encode(&dialect),
        Command::Stats {
            dialect,
            plot,
            file,
        } => crate::mavlink_stats::run(&dialect, plot.as_deref(), &file),
        Command::Param(command) => crate::mavlink_services::param(command),
        Command::Mission(command) => crate::mavlink_services::mission(command),
        Command::Cmd(args) => crate::mavlink_services::command(args),
        Command::Ftp(command) => crate::mavlink_ftp::ftp(command),
        Command::Vehicle(args) => crate::mavlink_services::vehicle(args),
        #[cfg(feature = "vehicle")]
        Command::Telemetry(args) => crate::mavlink_vehicle::telemetry(args),
        #[cfg(feature = "vehicle")]
        Command::Action(args) => crate::mavlink_vehicle::action(args),
    }
}

/// The router's signals, as daemons take them: SIGINT and SIGTERM stop it; SIGHUP reloads the
/// endpoints of the configuration file (those given as arguments stay), or is logged and
/// otherwise ignored without one. A SIGHUP ignored when the router started (under `nohup`)
/// stays ignored.
fn signals(
    config: Option<PathBuf>,
    given: Vec<EndpointConfig>,
    extra: Vec<(Extra, LinkConfig)>,
) -> io::Result<(Arc<AtomicBool>, Option<router::Reload>)> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    use std::sync::atomic::Ordering;
    let stop = Arc::new(AtomicBool::new(false));
    let requested = Arc::new(AtomicBool::new(false));
    let hup = !ignored(SIGHUP);
    let mut taken = vec![SIGINT, SIGTERM];
    if hup {
        taken.push(SIGHUP);
    }
    // A thread of its own waits for the signals (no wake-ups in between) and wakes the router.
    let mut signals = signal_hook::iterator::Signals::new(&taken)?;
    let (wake, woken) = std::sync::mpsc::channel();
    {
        let (stop, requested) = (stop.clone(), requested.clone());
        std::thread::Builder::new()
            .name("signals".into())
            .spawn(move || {
                for signal in signals.forever() {
                    match signal {
                        SIGHUP => requested.store(true, Ordering::Relaxed),
                        _ => stop.store(true, Ordering::Relaxed),
                    }
                    if wake.send(()).is_err() {
                        return;
                    }
                }
            })?;
    }
    let endpoints: Box<dyn Fn() -> Result<Vec<EndpointConfig>, String> + Send> = match config {
        Some(path) => Box::new(move || {
            eprintln!("SIGHUP: reloading {}", path.display());
            let file = read_config(&path)?;
            if file.extra != extra {
                eprintln!(
                    "reload: {}: its zenoh:// endpoints changed, and they are opened once, at \
                     start: the running ones are kept\n  hint: restart the router to change them",
                    path.display()
                );
            }
            Ok([file.endpoints, given.clone()].concat())
        }),
        None => Box::new(|| Err("SIGHUP, but there is no configuration file to reload".into())),
    };
    Ok((
        stop,
        Some(router::Reload {
            requested,
            endpoints,
            wake: Some(woken),
        }),
    ))
}

/// Whether `signal` was ignored when the process started (`SigIgn` in /proc/self/status, on
/// Linux; elsewhere, never).
fn ignored(signal: i32) -> bool {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return false;
    };
    status
        .lines()
        .find_map(|l| l.strip_prefix("SigIgn:"))
        .and_then(|mask| u64::from_str_radix(mask.trim(), 16).ok())
        .is_some_and(|mask| mask >> (signal - 1) & 1 == 1)
}

/// Reads a router configuration file, printing its warnings. A TOML file may have `zenoh://`
/// endpoints too.
fn read_config(path: &Path) -> Result<FileConfig<Extra>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let parsed = if path.extension().is_some_and(|e| e == "toml") {
        config::from_toml_with(&text, path.parent().unwrap_or(Path::new(".")), EXTENSIONS)
    } else {
        config::from_main_conf(&text).map(FileConfig::with_extra)
    };
    let file = parsed.map_err(|e| e.in_file(path))?;
    for w in &file.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(file)
}

/// `ferrolink mavlink encode`: JSON lines in, unsigned MAVLink 2 frames in hex out, sent as
/// system 255, component 190, the line number as the sequence, unless the envelope says otherwise.
/// `ferrolink mavlink dialects`.
fn dialects() -> Result<ExitCode, Box<dyn std::error::Error>> {
    let mut out = io::stdout().lock();
    for name in crate::dialect::names() {
        let loaded = crate::dialect::load(&[], name)?;
        let messages: usize = loaded.ir.modules.iter().map(|m| m.messages.len()).sum();
        let (name, enums) = (serde_json::to_string(name)?, loaded.ir.enums.len());
        writeln!(
            out,
            r#"{{"name": {name}, "messages": {messages}, "enums": {enums}}}"#
        )?;
    }
    Ok(ExitCode::SUCCESS)
}

fn encode(dialect: &[PathBuf]) -> Result<ExitCode, Box<dyn std::error::Error>> {
    use ferrolink_traffic::FrameDefaults;
    let dialects = crate::dialect::load(dialect, crate::dialect::DEFAULT)?;
    let decoder = dialects.decoder();
    crate::encode_lines(|n, line| {
        let value = serde_json::from_str(line).map_err(|e| e.to_string())?;
        let defaults = FrameDefaults {
            sysid: 255,
            compid: 190,
            seq: n as u8,
            target: None,
        };
        decoder.frame_from_json(&value, defaults)
    })
}

fn dump(
    dialect: &[PathBuf],
    raw: bool,
    csv: Option<&Path>,
    file: &Path,
) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let dialects = crate::dialect::load(dialect, crate::dialect::DEFAULT)?;
    let decoder = dialects.decoder();
    let unreadable = |e: io::Error| format!("{}: {e}", file.display());
    let mut reader = tlog::LogReader::open(file, &dialects.table[..], raw)?;
    let mut out = BufWriter::new(io::stdout().lock());
    let mut export = csv.map(CsvExport::new_mavlink).transpose()?;
    let mut decoded = 0u64;
    let mut unknown = 0u64;
    let mut failed: Option<io::Error> = None;
    let mut print = |record: tlog::Record<'_>| {
        let frame = &record.frame;
        let header = frame.header();
        if let Some(export) = &mut export {
            let meta = RowMeta {
                t_us: record.t_us.unwrap_or(0),
                sender: header.sysid,
                receiver: header.compid,
                counter: header.seq,
            };
            let written = match decoder.decode(frame.msg_id(), frame.payload()) {
                Some(message) => export.write(&meta, &message),
                None => export.write_unknown_id(&meta, Some(frame.msg_id()), frame.payload()),
            };
            if let Err(e) = written {
                failed.get_or_insert(e);
            }
        }
        let t_us = record
            .t_us
            .map_or_else(|| "null".to_owned(), |t| t.to_string());
        let (members, known) = decoder.frame_json_members(
            header.sysid,
            header.compid,
            header.seq,
            frame.msg_id(),
            frame.payload(),
        );
        if known {
            decoded += 1;
        } else {
            unknown += 1;
        }
        let line = format!("{{\"t_us\":{t_us},{members}}}");
        if failed.is_none() {
            if let Err(e) = writeln!(out, "{line}") {
                failed = Some(e);
            }
        }
    };
    let stats = reader.read_all(&mut print).map_err(unreadable)?;
    if let Some(e) = failed {
        if e.kind() == io::ErrorKind::BrokenPipe {
            return Ok(ExitCode::SUCCESS);
        }
        return Err(e.into());
    }
    if let Some(export) = export {
        for (path, rows) in export.finish()? {
            eprintln!("{}: {rows} rows", path.display());
        }
    }
    writeln!(
        out,
        "{}",
        serde_json::json!({"summary": {
            "frames": stats.frames, "decoded": decoded, "unknown": unknown,
            "unchecked": stats.unchecked, "recovered_after_damage": stats.resynced,
            "bad_crc": stats.bad_crc, "skipped_bytes": stats.skipped_bytes,
            "truncated_bytes": stats.truncated_bytes,
        }})
    )?;
    out.flush()?;
    Ok(ExitCode::SUCCESS)
}
