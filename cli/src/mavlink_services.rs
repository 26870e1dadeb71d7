//! `ferrolink mavlink param|mission|command|vehicle`: the microservices from the command line,
//! and the software vehicle that serves them.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use clap::{Args, Subcommand, ValueEnum};
use ferrolink_io::mavlink::services::{self, Peer, Remote};
use ferrolink_io::mavlink::{missionfile, paramfile};
use ferrolink_io::mavlink::{vehicle, Connection};
use ferrolink_runtime::mavlink::service::command::Command as MavCommand;
use ferrolink_runtime::mavlink::service::messages::{
    MavAutopilot, MavCmd, MavFrame, MavMissionResult, MavMissionType, MavParamType, MavResult,
    MavType,
};
use ferrolink_runtime::mavlink::service::param::{self, Protocol, Received, Value};
use ferrolink_runtime::mavlink::service::Address;

/// How long a client waits for the vehicle's first HEARTBEAT.
const DISCOVERY: Duration = Duration::from_secs(10);

/// The target, as `--target SYS/COMP`, and the dialect the connection checks frames with.
#[derive(Args, Clone)]
pub struct TargetArg {
    /// The target system and component [default: the first vehicle heard, component 1].
    #[arg(long, value_name = "SYS/COMP", value_parser = parse_target)]
    pub(crate) target: Option<Address>,
    /// A built-in dialect's name or a dialect XML file, whose messages the connection checks
    /// and whose MAV_CMD names it knows; repeatable [default: ardupilotmega].
    #[arg(long, value_name = "NAME|FILE")]
    pub(crate) dialect: Vec<PathBuf>,
}

fn parse_home(s: &str) -> std::result::Result<ferrolink_io::mavlink::flight::Point, String> {
    let parts: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            format!("`{s}`: write the home as LAT,LON,ALT, e.g. 47.397742,8.545594,488")
        })?;
    match parts[..] {
        [lat, lon, alt] if lat.abs() <= 90.0 && lon.abs() <= 180.0 && alt.is_finite() => {
            Ok(ferrolink_io::mavlink::flight::Point { lat, lon, alt })
        }
        _ => Err(format!(
            "`{s}`: LAT within ±90, LON within ±180 and ALT in metres, e.g. 47.397742,8.545594,488"
        )),
    }
}

fn parse_target(s: &str) -> std::result::Result<Address, String> {
    let (sys, comp) = s
        .split_once('/')
        .ok_or_else(|| format!("`{s}`: write the target as SYS/COMP, e.g. 1/1"))?;
    let id = |v: &str| {
        v.trim()
            .parse::<u8>()
            .map_err(|_| format!("`{v}` in `{s}` is not an id from 0 to 255"))
    };
    Ok(Address::new(id(sys)?, id(comp)?))
}

#[derive(Subcommand)]
pub enum ParamCommand {
    /// Fetch every parameter; print one JSON line each, in index order. Exit 0 once all are in,
    /// 1 if some are still missing at the timeout.
    List {
        /// The connection: udpin://, udpout://, tcpin://, tcpout://, serial://.
        uri: String,
        #[command(flatten)]
        target: TargetArg,
        /// Give up after SECS seconds.
        #[arg(long, value_name = "SECS", default_value = "60", value_parser = ferrolink_io::seconds::parse)]
        timeout: Duration,
        /// Speak PARAM_EXT_* (cameras' and gimbals' protocol, 64-bit values whole) instead of
        /// PARAM_*.
        #[arg(long)]
        ext: bool,
    },
    /// Read one parameter and print it as a JSON line.
    Get {
        /// The connection.
        uri: String,
        /// The parameter's name.
        name: String,
        #[command(flatten)]
        target: TargetArg,
        /// Speak PARAM_EXT_* (cameras' and gimbals' protocol, 64-bit values whole) instead of
        /// PARAM_*.
        #[arg(long)]
        ext: bool,
    },
    /// Set one parameter and print what the vehicle reports; exit 0 only when it confirms
    /// exactly the value set.
    Set {
        /// The connection.
        uri: String,
        /// The parameter's name.
        name: String,
        /// The value.
        #[arg(allow_negative_numbers = true)]
        value: String,
        /// UINT8, INT8, UINT16, INT16, UINT32, INT32 or REAL32, and with --ext UINT64, INT64,
        /// REAL64 or CUSTOM (VALUE's bytes) [default: the parameter's type, read first].
        #[arg(long = "type", value_name = "TYPE")]
        ty: Option<String>,
        #[command(flatten)]
        target: TargetArg,
        /// Speak PARAM_EXT_* (cameras' and gimbals' protocol, 64-bit values whole) instead of
        /// PARAM_*.
        #[arg(long)]
        ext: bool,
    },
}

/// The mission types, as `--type` names them.
#[derive(Clone, Copy, ValueEnum)]
pub enum MissionKind {
    Mission,
    Fence,
    Rally,
}

impl MissionKind {
    fn mav(self) -> MavMissionType {
        match self {
            MissionKind::Mission => MavMissionType::Mission,
            MissionKind::Fence => MavMissionType::Fence,
            MissionKind::Rally => MavMissionType::Rally,
        }
    }
}

#[derive(Subcommand)]
pub enum MissionCommand {
    /// Upload a mission, geofence or rally points from a QGC WPL 110 file, or a QGroundControl
    /// .plan (FILE ending so). Exit 0 once the vehicle accepts it.
    Upload {
        /// The connection.
        uri: String,
        /// The file.
        file: PathBuf,
        /// What to upload.
        #[arg(long = "type", value_enum, default_value = "mission")]
        kind: MissionKind,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Clear the mission, geofence or rally points on the vehicle. Exit 0 once it accepts, 1 when
    /// it refuses or does not answer.
    Clear {
        /// The connection.
        uri: String,
        /// What to clear.
        #[arg(long = "type", value_enum, default_value = "mission")]
        kind: MissionKind,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Make item SEQ the vehicle's current mission item. Exit 0 once it reports SEQ current, 1
    /// otherwise.
    SetCurrent {
        /// The connection.
        uri: String,
        /// The item's sequence number.
        seq: u16,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Download a mission, geofence or rally points as QGC WPL 110 (or .plan when --out ends
    /// so), to --out or stdout.
    Download {
        /// The connection.
        uri: String,
        /// What to download.
        #[arg(long = "type", value_enum, default_value = "mission")]
        kind: MissionKind,
        /// Write it here instead of stdout.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
        #[command(flatten)]
        target: TargetArg,
    },
}

/// `ferrolink mavlink command`.
#[derive(Args)]
pub struct CommandArgs {
    /// The connection.
    uri: String,
    /// A MAV_CMD name (with or without the prefix) or number.
    command: String,
    /// param1 to param7 (with --int: param1 to param4, then x and y in degrees, then z).
    #[arg(value_name = "P", num_args = 0..=7, allow_negative_numbers = true)]
    params: Vec<f64>,
    /// Send COMMAND_INT (frame MAV_FRAME_GLOBAL) instead of COMMAND_LONG.
    #[arg(long)]
    int: bool,
    #[command(flatten)]
    target: TargetArg,
}

/// The autopilots a software vehicle can claim.
#[derive(Clone, Copy, ValueEnum)]
pub enum Autopilot {
    Generic,
    Px4,
    Ardupilotmega,
}

/// `ferrolink mavlink vehicle`.
#[derive(Args)]
pub struct VehicleArgs {
    /// A built-in dialect's name or a dialect XML file, whose other messages its connections
    /// check and ignore; repeatable [default: ardupilotmega].
    #[arg(long, value_name = "NAME|FILE")]
    dialect: Vec<PathBuf>,
    /// Its system id.
    #[arg(long, default_value_t = 1)]
    sysid: u8,
    /// Its component id.
    #[arg(long, default_value_t = 1)]
    compid: u8,
    /// The autopilot its HEARTBEAT names, which also sets how it encodes integer parameters.
    #[arg(long, value_enum, default_value = "generic")]
    autopilot: Autopilot,
    /// Its parameters: QGroundControl's .params, or MAVProxy's .parm (anything else).
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// The directory it serves over MAVLink FTP (read and written; nothing outside it).
    #[arg(long, value_name = "DIR")]
    ftp_root: Option<PathBuf>,
    /// Where it stands at first and comes home to: degrees, degrees, metres above sea level
    /// [default: 47.397742,8.545594,488.0, PX4's SITL home].
    #[arg(long, value_name = "LAT,LON,ALT", value_parser = parse_home, allow_hyphen_values = true)]
    home: Option<ferrolink_io::mavlink::flight::Point>,
    /// Stop after SECS seconds (SIGINT and SIGTERM stop it too).
    #[arg(long, value_name = "SECS", value_parser = ferrolink_io::seconds::parse)]
    run_for: Option<Duration>,
    /// udpin://HOST:PORT | udpout://HOST:PORT | tcpin://HOST:PORT | tcpout://HOST:PORT |
    /// serial://PATH[:BAUD] | pty://NAME
    #[arg(required = true, value_name = "ENDPOINT")]
    endpoints: Vec<String>,
}

pub(crate) type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Opens `uri`, checking frames with the services' messages and the `--dialect` ones.
pub(crate) fn open(uri: &str, target: &TargetArg) -> Result<Connection> {
    let table = table_with(&target.dialect)?;
    Connection::open(uri, table).map_err(|e| format!("{uri}: {e}").into())
}

/// The services' messages, then those of `dialect` (or the default dialect) that they lack.
pub(crate) fn table_with(
    dialect: &[PathBuf],
) -> Result<Vec<ferrolink_runtime::mavlink::MessageMeta>> {
    let mut table = services::TABLE.to_vec();
    for m in crate::dialect::load(dialect, crate::dialect::DEFAULT)?
        .table
        .iter()
    {
        if !table.iter().any(|t| t.id == m.id) {
            table.push(*m);
        }
    }
    table.sort_by_key(|m| m.id);
    Ok(table)
}

/// Opens `uri` and finds the target on it.
pub(crate) fn connect(uri: &str, target: &TargetArg) -> Result<(Connection, Peer)> {
    let mut link = open(uri, target)?;
    let peer = find_target(&mut link, uri, target)?;
    Ok((link, peer))
}

/// The target: the one given (its autopilot from its HEARTBEAT if one comes), or the first
/// vehicle heard.
pub(crate) fn find_target(link: &mut Connection, uri: &str, target: &TargetArg) -> Result<Peer> {
    let Some(address) = target.target else {
        return services::wait_for_vehicle(link, DISCOVERY)?.ok_or_else(|| {
            format!(
                "no vehicle's HEARTBEAT on {uri} within {} s",
                DISCOVERY.as_secs()
            )
            .into()
        });
    };
    // Its autopilot (for the parameter encoding) from its HEARTBEAT, if one comes soon.
    let heard = services::wait_for_system(link, address.system, Duration::from_secs(3))?;
    Ok(Peer {
        address,
        autopilot: heard.map_or(MavAutopilot::Generic, |p| p.autopilot),
        kind: heard.map_or(MavType::Generic, |p| p.kind),
        since_us: 0,
        last_us: 0,
    })
}

/// A received value as the contract's JSON line: `{"name": "...", "value": V, "type": "INT32",
/// "index": I}`, integers as JSON integers.
fn value_line(r: &Received) -> String {
    let value = match (r.value, r.custom) {
        // Integers whole; floats as the shortest text that reads back as the same value.
        (Some(Value::F32(v)), _) if !v.is_finite() => "null".into(),
        (Some(Value::F64(v)), _) if !v.is_finite() => "null".into(),
        (Some(v), _) => v.to_string(),
        // A CUSTOM value: its text, up to the first NUL.
        (None, Some(bytes)) => {
            serde_json::json!(String::from_utf8_lossy(bytes.text_bytes())).to_string()
        }
        (None, None) => "null".into(),
    };
    let ty = match (r.value, r.custom) {
        (Some(v), _) => paramfile::type_name(v.param_type()),
        (None, Some(_)) => "CUSTOM",
        (None, None) => "UNKNOWN",
    };
    format!(
        "{{\"name\": {}, \"value\": {value}, \"type\": \"{ty}\", \"index\": {}}}",
        serde_json::json!(r.name.as_str()),
        r.index
    )
}

/// The contract's line for a command's answer: `{"command": ID, "result": "MAV_RESULT_...",
/// "progress": [..]}` (`null` result when nothing answered).
fn command_line(id: u16, result: Option<&str>, progress: &[u8]) -> String {
    let progress: Vec<String> = progress.iter().map(u8::to_string).collect();
    format!(
        "{{\"command\": {id}, \"result\": {}, \"progress\": [{}]}}",
        serde_json::json!(result),
        progress.join(", ")
    )
}

pub fn param(command: ParamCommand) -> Result<ExitCode> {
    match command {
        ParamCommand::List {
            uri,
            target,
            timeout,
            ext,
        } => {
            let (mut link, peer) = connect(&uri, &target)?;
            let mut remote = param_remote(&mut link, peer, ext);
            let list = remote.fetch_params(timeout, |_| {})?;
            let mut out = std::io::stdout().lock();
            for r in list.values.iter().flatten() {
                if writeln!(out, "{}", value_line(r)).is_err() {
                    break;
                }
            }
            let missing = list.missing();
            if list.count == 0 && list.values.is_empty() {
                eprintln!(
                    "no parameter arrived from {}/{} within {} s",
                    peer.address.system,
                    peer.address.component,
                    timeout.as_secs_f64()
                );
                return Ok(ExitCode::FAILURE);
            }
            if missing > 0 {
                eprintln!(
                    "{missing} of {} parameters still missing after {} s",
                    list.count,
                    timeout.as_secs_f64()
                );
                return Ok(ExitCode::FAILURE);
            }
            Ok(ExitCode::SUCCESS)
        }
        ParamCommand::Get {
            uri,
            name,
            target,
            ext,
        } => {
            check_name(&name)?;
            let (mut link, peer) = connect(&uri, &target)?;
            let mut remote = param_remote(&mut link, peer, ext);
            match remote.read_param(&name)? {
                Some(r) => {
                    println!("{}", value_line(&r));
                    Ok(ExitCode::SUCCESS)
                }
                None => Err(unknown(&name, peer)),
            }
        }
        ParamCommand::Set {
            uri,
            name,
            value,
            ty,
            target,
            ext,
        } => {
            check_name(&name)?;
            let ty = ty.map(|t| parse_type(&t, ext)).transpose()?;
            let (mut link, peer) = connect(&uri, &target)?;
            let mut remote = param_remote(&mut link, peer, ext);
            // The type, if not given, and for PARAM_EXT_ACK (which has none) the index.
            let read = match (ty, ext) {
                (Some(_), false) => None,
                _ => match remote.read_param(&name)? {
                    Some(r) if r.value.is_some() || r.custom.is_some() => Some(r),
                    _ => return Err(unknown(&name, peer)),
                },
            };
            let ty = match ty {
                Some(ty) => ty,
                None => match read.and_then(|r| r.value) {
                    Some(v) => SetType::Value(v.param_type()),
                    None => SetType::Custom,
                },
            };
            let (answer, sent) = match ty {
                SetType::Value(ty) => {
                    let v = paramfile::parse_value(ty, &value).ok_or_else(|| {
                        format!(
                            "`{value}` is not a value of type {}",
                            paramfile::type_name(ty)
                        )
                    })?;
                    (remote.set_param(&name, v)?, Sent::Value(v))
                }
                SetType::Custom => {
                    if value.len() > 128 {
                        return Err(format!(
                            "a CUSTOM value has at most 128 bytes, not {}",
                            value.len()
                        )
                        .into());
                    }
                    let bytes = value.as_bytes();
                    let sent = Sent::Custom(param::Bytes::from_bytes(bytes));
                    (remote.set_param_custom(&name, bytes)?, sent)
                }
            };
            let Some(mut r) = answer else {
                return Err(unknown(&name, peer));
            };
            if let (u16::MAX, Some(read)) = (r.index, read) {
                r.index = read.index;
            }
            println!("{}", value_line(&r));
            let took = match sent {
                Sent::Value(v) => r.value.map(|held| held.same(v)),
                Sent::Custom(bytes) => r.custom.map(|held| held == bytes),
            };
            match took {
                Some(true) => Ok(ExitCode::SUCCESS),
                Some(false) => {
                    eprintln!("the vehicle holds another value than the one set");
                    Ok(ExitCode::FAILURE)
                }
                None => {
                    eprintln!("the vehicle refused the value");
                    Ok(ExitCode::FAILURE)
                }
            }
        }
    }
}

/// What `param set` sets: a value of a type, or (PARAM_EXT only) CUSTOM bytes.
#[derive(Clone, Copy)]
enum SetType {
    Value(MavParamType),
    Custom,
}

/// What `param set` sent, to compare with the answer.
enum Sent {
    Value(Value),
    Custom(param::Bytes),
}

/// `--type TYPE`: the types of PARAM_VALUE, and with `ext` the 64-bit ones and CUSTOM.
fn parse_type(t: &str, ext: bool) -> Result<SetType> {
    let upper = t.to_ascii_uppercase();
    if ext && upper.strip_prefix("MAV_PARAM_EXT_TYPE_").unwrap_or(&upper) == "CUSTOM" {
        return Ok(SetType::Custom);
    }
    paramfile::param_type(t)
        .filter(|t| ext || !param::is_wide(*t))
        .map(SetType::Value)
        .ok_or_else(|| {
            let more = if ext {
                ", UINT64, INT64, REAL64 or CUSTOM"
            } else {
                " (and with --ext UINT64, INT64, REAL64 or CUSTOM)"
            };
            format!("--type {t}: use UINT8, INT8, UINT16, INT16, UINT32, INT32 or REAL32{more}")
                .into()
        })
}

/// A client of `peer`'s parameters, speaking PARAM_EXT_* when `ext`.
fn param_remote(link: &mut Connection, peer: Peer, ext: bool) -> Remote<'_> {
    let mut remote = Remote::new(link, peer);
    if ext {
        remote.param_config.protocol = Protocol::Ext;
    }
    remote
}

fn check_name(name: &str) -> Result<()> {
    if name.is_empty() || name.len() > 16 {
        return Err(format!("`{name}`: parameter names are 1 to 16 bytes").into());
    }
    Ok(())
}

fn unknown(name: &str, peer: Peer) -> Box<dyn std::error::Error> {
    format!(
        "no answer about `{name}` from {}/{}: the vehicle has no such parameter, or does not answer",
        peer.address.system, peer.address.component
    )
    .into()
}

/// A progress bar on stderr when it is a terminal (hidden otherwise).
pub(crate) fn progress_bar(what: &'static str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(0);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what);
    bar
}

fn is_plan(path: &std::path::Path) -> bool {
    path.extension().is_some_and(|e| e == "plan")
}

pub fn mission(command: MissionCommand) -> Result<ExitCode> {
    match command {
        MissionCommand::Upload {
            uri,
            file,
            kind,
            target,
        } => {
            let text = std::fs::read_to_string(&file)
                .map_err(|e| format!("{}: cannot read it: {e}", file.display()))?;
            let parsed = if is_plan(&file) {
                missionfile::parse_plan(&text, kind.mav())
            } else {
                missionfile::parse_wpl(&text)
            };
            let items = parsed.map_err(|errors| {
                errors
                    .iter()
                    .map(|e| format!("{}: {e}", file.display()))
                    .collect::<Vec<_>>()
                    .join("\n")
            })?;
            let (mut link, peer) = connect(&uri, &target)?;
            let mut remote = Remote::new(&mut link, peer);
            let bar = progress_bar("upload");
            bar.set_length(items.len() as u64);
            let result = remote.upload_mission(kind.mav(), &items, |done, _| {
                bar.set_position(u64::from(done));
            })?;
            bar.finish_and_clear();
            match result {
                Some(MavMissionResult::MavMissionAccepted) => {
                    eprintln!("{} items accepted", items.len());
                    Ok(ExitCode::SUCCESS)
                }
                Some(other) => {
                    eprintln!("the vehicle refused the upload: {other:?}");
                    Ok(ExitCode::FAILURE)
                }
                None => {
                    eprintln!("the vehicle stopped answering; it keeps its old items");
                    Ok(ExitCode::FAILURE)
                }
            }
        }
        MissionCommand::Clear { uri, kind, target } => {
            let (mut link, peer) = connect(&uri, &target)?;
            match Remote::new(&mut link, peer).clear_mission(kind.mav())? {
                Some(MavMissionResult::MavMissionAccepted) => Ok(ExitCode::SUCCESS),
                Some(other) => {
                    eprintln!("the vehicle refused to clear: {other:?}");
                    Ok(ExitCode::FAILURE)
                }
                None => {
                    eprintln!("the vehicle did not answer the clear");
                    Ok(ExitCode::FAILURE)
                }
            }
        }
        MissionCommand::SetCurrent { uri, seq, target } => {
            let (mut link, peer) = connect(&uri, &target)?;
            match Remote::new(&mut link, peer).set_current_mission_item(seq)? {
                Some(current) if current == seq => Ok(ExitCode::SUCCESS),
                Some(current) => {
                    eprintln!("the vehicle's current item is {current}, not {seq}");
                    Ok(ExitCode::FAILURE)
                }
                None => {
                    eprintln!("the vehicle did not answer");
                    Ok(ExitCode::FAILURE)
                }
            }
        }
        MissionCommand::Download {
            uri,
            kind,
            out,
            target,
        } => {
            let (mut link, peer) = connect(&uri, &target)?;
            let mut remote = Remote::new(&mut link, peer);
            let bar = progress_bar("download");
            let items = remote.download_mission(kind.mav(), |done, all| {
                bar.set_length(u64::from(all));
                bar.set_position(u64::from(done));
            })?;
            bar.finish_and_clear();
            let Some(items) = items else {
                eprintln!("the vehicle stopped answering");
                return Ok(ExitCode::FAILURE);
            };
            let text = match &out {
                Some(path) if is_plan(path) => missionfile::write_plan(&items, kind.mav()),
                _ => missionfile::write_wpl(&items),
            };
            match &out {
                Some(path) => std::fs::write(path, text)
                    .map_err(|e| format!("{}: cannot write it: {e}", path.display()))?,
                None => {
                    let mut stdout = std::io::stdout().lock();
                    if let Err(e) = stdout.write_all(text.as_bytes()) {
                        if e.kind() != std::io::ErrorKind::BrokenPipe {
                            return Err(e.into());
                        }
                    }
                }
            }
            eprintln!("{} items", items.len());
            Ok(ExitCode::SUCCESS)
        }
    }
}

pub fn command(args: CommandArgs) -> Result<ExitCode> {
    // MAV_CMD and MAV_RESULT names: the dialect's, else the services' own.
    let (names, own) = (
        crate::dialect::load(&args.target.dialect, crate::dialect::DEFAULT)?,
        crate::dialect::services()?,
    );
    let id = match args.command.parse::<u16>() {
        Ok(id) => id,
        Err(_) => names
            .entry_value("MAV_CMD", &args.command)
            .or_else(|| own.entry_value("MAV_CMD", &args.command))
            .and_then(|v| u16::try_from(v).ok())
            .ok_or_else(|| {
                format!(
                    "`{}` is not a MAV_CMD name or number (e.g. COMPONENT_ARM_DISARM or 400)",
                    args.command
                )
            })?,
    };
    let mut p = [0.0f64; 7];
    p[..args.params.len()].copy_from_slice(&args.params);
    let first = [p[0] as f32, p[1] as f32, p[2] as f32, p[3] as f32];
    let command = if args.int {
        MavCommand::int(
            MavCmd::from_raw(id),
            MavFrame::Global,
            first,
            p[4],
            p[5],
            p[6] as f32,
        )
    } else {
        let mut c = MavCommand::long(MavCmd::from_raw(id), [0.0; 7]);
        c.params = first;
        (c.x, c.y, c.z) = (p[4], p[5], p[6] as f32);
        c
    };
    let mut link = open(&args.uri, &args.target)?;
    let peer = match find_target(&mut link, &args.uri, &args.target) {
        Ok(peer) => peer,
        Err(e) => {
            eprintln!("{e}");
            return Ok(ExitCode::from(2));
        }
    };
    let mut remote = Remote::new(&mut link, peer);
    let mut progress = Vec::new();
    let ack = remote.command(command, |p| progress.push(p))?;
    let Some(ack) = ack else {
        println!("{}", command_line(id, None, &progress));
        eprintln!(
            "no answer from {}/{} after {} tries",
            peer.address.system,
            peer.address.component,
            remote.command_config.retry.retries + 1
        );
        return Ok(ExitCode::from(2));
    };
    let raw = u64::from(ack.result.raw());
    let result = names
        .entry_name("MAV_RESULT", raw)
        .or_else(|| own.entry_name("MAV_RESULT", raw))
        .map_or_else(|| ack.result.raw().to_string(), str::to_string);
    println!("{}", command_line(id, Some(&result), &progress));
    Ok(if ack.result == MavResult::Accepted {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

pub fn vehicle(args: VehicleArgs) -> Result<ExitCode> {
    let params = match &args.params {
        Some(path) => paramfile::read(path).map_err(|errors| {
            errors
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join("\n")
        })?,
        None => Vec::new(),
    };
    if params.len() > usize::from(u16::MAX - 1) {
        return Err(format!(
            "{} parameters: PARAM_VALUE counts at most 65534",
            params.len()
        )
        .into());
    }
    let table = table_with(&args.dialect)?;
    let config = vehicle::Config {
        address: Address::new(args.sysid, args.compid),
        autopilot: match args.autopilot {
            Autopilot::Generic => MavAutopilot::Generic,
            Autopilot::Px4 => MavAutopilot::Px4,
            Autopilot::Ardupilotmega => MavAutopilot::Ardupilotmega,
        },
        kind: MavType::Quadrotor,
        params,
        table: table.into(),
        ftp_root: args.ftp_root,
        home: args.home.unwrap_or(vehicle::HOME),
    };
    let run_for = args.run_for;
    for uri in &args.endpoints {
        ferrolink_io::mavlink::ENDPOINTS.endpoint(uri)?;
    }
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, stop.clone())?;
    }
    vehicle::run(&config, &args.endpoints, run_for, &stop, || {
        println!(
            "ready: vehicle {}/{} with {} parameters on {}",
            args.sysid,
            args.compid,
            config.params.len(),
            args.endpoints.join(", ")
        );
        let _ = std::io::stdout().flush();
    })?;
    Ok(ExitCode::SUCCESS)
}
