//! `ferrolink ndlcom ...`: frame encode/decode for checking us against other implementations,
//! and CSV export of logs.

use std::io::{self, BufRead, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Subcommand;
use ferrolink_runtime::ndlcom::{self, parser::Parser, Header};
use serde::{Deserialize, Serialize};

use crate::schemes::{Extra, EXTENSIONS};

#[derive(Subcommand)]
pub enum Command {
    /// Encode frames: reads JSON lines `{"receiver":1,"sender":2,"counter":3,"payload":"<hex>"}`
    /// from stdin and prints each encoded frame as hex.
    Encode,
    /// Decode a hex byte stream from stdin (garbage and broken frames allowed): prints one JSON
    /// line per valid frame, then `{"crc_failures":N,"dropped":M}`.
    Decode {
        /// Drop frames with longer payloads.
        #[arg(long, default_value_t = 255)]
        max_payload: usize,
    },
    /// Run a bridge between interfaces, printing statistics, missed packets, routes and frames.
    ///
    /// Interfaces are URIs: `serial:///dev/ttyUSB0[:baud]`, `udp://host[:in][:out]`,
    /// `tcp://host[:port]`, `tcp-listen://[host]:port`, `pty://name`; a suffix `&id1,id2`
    /// pre-seeds routes. Type `s`, `r`, `m` + Enter for statistics, routes, missed packets;
    /// `a`/`o`/`n` to print all/own/no frames; `q` to quit.
    Bridge {
        #[command(flatten)]
        links: Links,
        /// Own ids: frames to them are delivered here (pings are answered), not forwarded.
        #[arg(short = 'i', long = "id", value_name = "ID")]
        own_ids: Vec<u8>,
        /// Forward cut-through between all interfaces instead of store & forward.
        #[arg(long)]
        cut_through: bool,
        /// Print frames as they pass: all, own (to own ids and broadcasts) or none.
        #[arg(long, value_enum, default_value = "none")]
        print: PrintArg,
        /// Ping this id (from the first own id) every `--ping-every` seconds.
        #[arg(long, value_name = "ID")]
        ping: Option<u8>,
        /// Ping period in seconds.
        #[arg(long, value_name = "SECONDS", default_value = "1", value_parser = ferrolink_io::seconds::parse)]
        ping_every: std::time::Duration,
        /// Also record every frame to this log file.
        #[arg(long, value_name = "FILE")]
        log: Option<PathBuf>,
    },
    /// Record every intact frame arriving on the interfaces, with a timestamp, to a log file
    /// (JSON lines: `t_us`, `interface`, `frame`). Nothing is forwarded.
    Log {
        #[command(flatten)]
        links: Links,
        /// The log file (appended to).
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
    },
    /// Export a log written by `ferrolink ndlcom log` (or a bridge's `--log`) to one CSV file
    /// per message type, decoding payloads with a dictionary.
    Export {
        /// The log file.
        log: PathBuf,
        /// Dictionary files (MAVLink XML) describing the payloads.
        #[arg(long = "dict", required = true)]
        dicts: Vec<PathBuf>,
        /// Output directory.
        #[arg(long)]
        csv: PathBuf,
    },
}

/// Interface and reporting options shared by `bridge` and `log`.
#[derive(clap::Args)]
pub struct Links {
    /// An interface URI (repeat for more): serial://, udp://, tcp://, tcp-listen://, pty://,
    /// or zenoh://?mode=peer&listen=tcp/HOST:PORT[&connect=...][&encoding=raw|json][&prefix=...]
    #[arg(short = 'u', long = "uri", value_name = "URI", required = true, value_parser = parse_uri)]
    uris: Vec<UriArg>,
    /// A mirror interface: it gets every frame and teaches the routing table nothing.
    #[arg(short = 'm', long = "mirror", value_name = "URI")]
    mirrors: Vec<ferrolink_io::ndlcom::Interface>,
    /// Print statistics, routes and missed packets every this many seconds.
    #[arg(long, value_name = "SECONDS", value_parser = ferrolink_io::seconds::parse)]
    stats: Option<std::time::Duration>,
    /// Stop after this many seconds (the final statistics are printed).
    #[arg(long, value_name = "SECONDS", value_parser = ferrolink_io::seconds::parse)]
    run_for: Option<std::time::Duration>,
    /// Print JSON lines instead of text.
    #[arg(long)]
    json: bool,
    /// Do not read commands from stdin.
    #[arg(long)]
    no_commands: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum PrintArg {
    All,
    Own,
    None,
}

/// An interface: one the link layer opens, or a Zenoh one.
#[derive(Clone)]
enum UriArg {
    Link(ferrolink_io::ndlcom::Interface),
    Zenoh(Extra),
}

fn parse_uri(uri: &str) -> Result<UriArg, ferrolink_io::uri::UriError> {
    use ferrolink_io::ndlcom::{Interface, ENDPOINTS};
    use ferrolink_io::uri::Target;
    Ok(match ENDPOINTS.parse_with(uri, EXTENSIONS)? {
        Target::Link(endpoint, routes) => UriArg::Link(Interface { endpoint, routes }),
        Target::Other(uri) => UriArg::Zenoh(uri),
    })
}

impl Links {
    /// The bridge's configuration and its Zenoh interfaces.
    fn config(
        self,
    ) -> Result<
        (
            ferrolink_io::ndlcom::bridge::Config,
            Vec<ferrolink_io::ndlcom::bridge::Attached>,
        ),
        String,
    > {
        let (mut interfaces, mut zenoh) = (Vec::new(), Vec::new());
        for uri in self.uris {
            match uri {
                UriArg::Link(interface) => interfaces.push(interface),
                UriArg::Zenoh(uri) => zenoh.push(uri),
            }
        }
        let dialects = crate::dialect::own()?;
        let names = dialects.names();
        let attached = zenoh_interfaces(zenoh, dialects)?;
        let config = ferrolink_io::ndlcom::bridge::Config {
            interfaces,
            mirrors: self.mirrors,
            stats_every: self.stats,
            run_for: self.run_for,
            json: self.json,
            commands: !self.no_commands,
            names,
            ..Default::default()
        };
        Ok((config, attached))
    }
}

/// The bridge's Zenoh interfaces, their payloads named and written as JSON with `dialects`.
#[cfg(feature = "zenoh")]
fn zenoh_interfaces(
    uris: Vec<Extra>,
    dialects: crate::dialect::Dialects,
) -> Result<Vec<ferrolink_io::ndlcom::bridge::Attached>, String> {
    if uris.is_empty() {
        return Ok(Vec::new());
    }
    // Every interface's threads share the dictionaries.
    let decoder = std::sync::Arc::new(dialects.decoder());
    Ok(uris
        .into_iter()
        .map(|uri| ferrolink_zenoh::ndlcom::attached(uri, decoder.clone()))
        .collect())
}

#[cfg(not(feature = "zenoh"))]
fn zenoh_interfaces(
    uris: Vec<Extra>,
    _: crate::dialect::Dialects,
) -> Result<Vec<ferrolink_io::ndlcom::bridge::Attached>, String> {
    Ok(uris.into_iter().map(|never| match never {}).collect())
}

/// One frame in the JSON form of `encode` and `decode`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FrameJson {
    receiver: u8,
    sender: u8,
    #[serde(default)]
    counter: u8,
    #[serde(default)]
    payload: String,
}

/// One line of a log file.
#[derive(Serialize, Deserialize)]
pub struct LogLine {
    /// Microseconds since the Unix epoch.
    pub t_us: u64,
    /// The interface the frame arrived on.
    pub interface: String,
    /// The frame as on the wire, flags included, in hex.
    pub frame: String,
}

pub fn run(command: Command) -> Result<ExitCode, Box<dyn std::error::Error>> {
    match command {
        Command::Encode => encode(),
        Command::Decode { max_payload } => decode(max_payload),
        Command::Export { log, dicts, csv } => export(&log, &dicts, &csv),
        Command::Bridge {
            links,
            own_ids,
            cut_through,
            print,
            ping,
            ping_every,
            log,
        } => {
            let (config, attached) = links.config()?;
            let config = ferrolink_io::ndlcom::bridge::Config {
                own_ids,
                cut_through,
                print: match print {
                    PrintArg::All => ferrolink_io::ndlcom::bridge::Print::All,
                    PrintArg::Own => ferrolink_io::ndlcom::bridge::Print::Own,
                    PrintArg::None => ferrolink_io::ndlcom::bridge::Print::None,
                },
                ping,
                ping_every,
                log,
                ..config
            };
            ferrolink_io::ndlcom::bridge::run(config, attached)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Log { links, out } => {
            let (config, attached) = links.config()?;
            let config = ferrolink_io::ndlcom::bridge::Config {
                log: Some(out),
                log_only: true,
                ..config
            };
            ferrolink_io::ndlcom::bridge::run(config, attached)?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn encode() -> Result<ExitCode, Box<dyn std::error::Error>> {
    let mut buf = [0u8; ndlcom::MAX_FRAME_LEN];
    crate::encode_lines(|_, line| {
        let f = serde_json::from_str::<FrameJson>(line).map_err(|e| e.to_string())?;
        let payload =
            hex::decode(f.payload.trim()).map_err(|e| format!("payload is not hex: {e}"))?;
        let length = u8::try_from(payload.len())
            .map_err(|_| format!("payload of {} bytes exceeds 255", payload.len()))?;
        let header = Header::new(f.receiver, f.sender, f.counter, length);
        let len = ndlcom::encode(&header, &payload, &mut buf).map_err(|e| e.to_string())?;
        Ok(buf[..len].to_vec())
    })
}

/// Turns hex text into bytes across line breaks; whitespace anywhere is ignored.
#[derive(Default)]
pub(crate) struct HexReader {
    /// A high nibble waiting for its low one.
    pub(crate) high: Option<u8>,
}

impl HexReader {
    /// Appends the bytes of `text` to `out`; an error names the 1-based column.
    pub(crate) fn push(&mut self, text: &str, out: &mut Vec<u8>) -> Result<(), String> {
        for (i, c) in text.char_indices() {
            if c.is_whitespace() {
                continue;
            }
            let digit = c
                .to_digit(16)
                .ok_or_else(|| format!("{}: `{c}` is not a hex digit", i + 1))?
                as u8;
            match self.high.take() {
                Some(high) => out.push(high << 4 | digit),
                None => self.high = Some(digit),
            }
        }
        Ok(())
    }
}

fn decode(max_payload: usize) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let stdout = io::stdout();
    let mut out = io::BufWriter::new(stdout.lock());
    let mut parser = Parser::new([0u8; ndlcom::storage_len(ndlcom::MAX_PAYLOAD_LEN)]);
    parser.set_max_payload(max_payload);
    let mut hex_reader = HexReader::default();
    let mut bytes = Vec::new();
    let mut result = Ok(());
    for (n, line) in io::stdin().lock().lines().enumerate() {
        bytes.clear();
        if let Err(e) = hex_reader.push(&line?, &mut bytes) {
            result = Err(format!("stdin:{}:{e}", n + 1));
            break;
        }
        let mut write = Ok(());
        parser.feed_all(&bytes, |frame| {
            if write.is_ok() {
                write = print_frame(&mut out, &frame);
            }
        });
        write?;
    }
    parser.finish();
    let stats = parser.stats();
    writeln!(
        out,
        "{}",
        serde_json::json!({"crc_failures": stats.crc_failures, "dropped": stats.dropped()})
    )?;
    out.flush()?;
    if hex_reader.high.is_some() && result.is_ok() {
        result = Err("stdin: odd number of hex digits; the last one was ignored".into());
    }
    match result {
        Ok(()) => Ok(ExitCode::SUCCESS),
        Err(e) => {
            eprintln!("{e}");
            Ok(ExitCode::FAILURE)
        }
    }
}

fn print_frame(out: &mut impl Write, frame: &ndlcom::Frame<'_>) -> io::Result<()> {
    let h = frame.header();
    let json = FrameJson {
        receiver: h.receiver,
        sender: h.sender,
        counter: h.counter,
        payload: hex::encode(frame.payload()),
    };
    writeln!(out, "{}", serde_json::to_string(&json)?)
}

fn export(
    log: &std::path::Path,
    dicts: &[PathBuf],
    dir: &std::path::Path,
) -> Result<ExitCode, Box<dyn std::error::Error>> {
    use ferrolink_traffic::{CsvExport, PayloadDecoder, RowMeta};

    let checked =
        match ferrolink_dictionary::load_for(dicts, &[ferrolink_dictionary::Carrier::Ndlcom]) {
            Ok(checked) => checked,
            Err(failed) => {
                eprintln!("{failed}");
                return Ok(ExitCode::FAILURE);
            }
        };
    let decoder = PayloadDecoder::new(checked.ir);
    let mut export = CsvExport::new(dir)?;
    let file = io::BufReader::new(std::fs::File::open(log)?);
    let mut parser = Parser::new([0u8; ndlcom::storage_len(ndlcom::MAX_PAYLOAD_LEN)]);
    let (mut frames, mut bad_lines) = (0u64, 0u64);
    for (n, line) in file.lines().enumerate() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        let entry = serde_json::from_str::<LogLine>(&line)
            .map_err(|e| e.to_string())
            .and_then(|l| {
                hex::decode(&l.frame)
                    .map(|b| (l.t_us, b))
                    .map_err(|e| e.to_string())
            });
        let (t_us, bytes) = match entry {
            Ok(entry) => entry,
            Err(e) => {
                eprintln!("{}:{}: {e}", log.display(), n + 1);
                bad_lines += 1;
                continue;
            }
        };
        let mut result = Ok(());
        let got = parser.feed_all(&bytes, |frame| {
            let h = frame.header();
            let meta = RowMeta {
                t_us,
                sender: h.sender,
                receiver: h.receiver,
                counter: h.counter,
            };
            if result.is_ok() {
                result = export.record(&decoder, &meta, frame.payload()).map(|_| ());
            }
        });
        result?;
        parser.finish();
        if got == 0 {
            eprintln!("{}:{}: no valid frame on this line", log.display(), n + 1);
            bad_lines += 1;
        }
        frames += got as u64;
    }
    for (path, rows) in export.finish()? {
        eprintln!("{}: {rows} row(s)", path.display());
    }
    eprintln!("{frames} frame(s) exported, {bad_lines} bad line(s)");
    Ok(if bad_lines == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
