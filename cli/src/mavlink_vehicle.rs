//! `ferrolink mavlink telemetry` and `ferrolink mavlink action`: a vehicle's telemetry as JSON
//! lines, and its actions, through the vehicle API (`ferrolink-vehicle`).

use std::io::Write;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Args, Subcommand};
use ferrolink_io::mavlink::{OwnHeartbeat, SharedConnection};
use ferrolink_vehicle::telemetry::{Kind, Update};
use ferrolink_vehicle::{Action, ActionError, ActionResult, Node, System};

use crate::mavlink_services::{table_with, Result, TargetArg};

/// How long the commands wait for the vehicle's first HEARTBEAT.
const DISCOVERY: Duration = Duration::from_secs(10);

/// `ferrolink mavlink telemetry`.
#[derive(Args)]
pub struct TelemetryArgs {
    /// The connection: udpin://, udpout://, tcpin://, tcpout://, serial://.
    uri: String,
    #[command(flatten)]
    target: TargetArg,
    /// Ask the vehicle for this rate of each message printed (MAV_CMD_SET_MESSAGE_INTERVAL).
    #[arg(long, value_name = "HZ")]
    rate: Option<f32>,
    /// Stop after N lines.
    #[arg(long, value_name = "N")]
    count: Option<u64>,
    /// Stop after SECS seconds.
    #[arg(long, value_name = "SECS", value_parser = ferrolink_io::seconds::parse)]
    duration: Option<Duration>,
}

/// `ferrolink mavlink action`.
#[derive(Args)]
pub struct ActionArgs {
    /// The connection.
    uri: String,
    #[command(subcommand)]
    action: ActionCommand,
    /// With `disarm`: disarm in flight too.
    #[arg(long, global = true)]
    force: bool,
    #[command(flatten)]
    target: TargetArg,
    /// How long to wait for the vehicle's first HEARTBEAT [default: 10].
    #[arg(long, value_name = "SECS", value_parser = ferrolink_io::seconds::parse, global = true)]
    timeout: Option<Duration>,
}

#[derive(Subcommand, Clone)]
pub enum ActionCommand {
    /// Arm.
    Arm,
    /// Disarm (`--force`: in flight too).
    Disarm,
    /// Take off to ALT metres above home [default: 10].
    Takeoff {
        /// Metres above home.
        #[arg(default_value_t = 10.0)]
        alt: f32,
    },
    /// Land.
    Land,
    /// Return to launch.
    Rtl,
    /// Hold position.
    Hold,
    /// Fly to LAT LON (degrees) at ALT metres above mean sea level.
    Goto {
        /// Latitude, degrees.
        #[arg(allow_negative_numbers = true)]
        lat: f64,
        /// Longitude, degrees.
        #[arg(allow_negative_numbers = true)]
        lon: f64,
        /// Altitude above mean sea level, metres.
        #[arg(allow_negative_numbers = true)]
        alt: f32,
    },
    /// Switch to a flight mode by its name (the autopilot's own, any case).
    Mode {
        /// The mode.
        name: String,
    },
    /// Reboot the autopilot.
    Reboot,
}

/// A node on `uri`, checking frames with the `--dialect` ones, as a ground station, and the
/// target system on it; `None` when no vehicle came within `timeout`.
fn find(uri: &str, target: &TargetArg, timeout: Duration) -> Result<Option<System>> {
    let link = SharedConnection::open(uri, table_with(&target.dialect)?)
        .map_err(|e| format!("{uri}: {e}"))?;
    link.start_heartbeat(OwnHeartbeat::default());
    let node = Node::on(link);
    let Some(address) = target.target else {
        return Ok(node.wait_for_system(timeout)?);
    };
    let until = Instant::now() + timeout;
    loop {
        if let Some(system) = node.system(address.system) {
            return Ok(Some(system.with_component(address.component)));
        }
        if Instant::now() >= until {
            return Ok(None);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A JSON number for `x`, as short as reads back the same; `null` for NaN and infinities.
fn num(x: impl Into<f64> + std::fmt::Display + Copy) -> String {
    if x.into().is_finite() {
        x.to_string()
    } else {
        "null".into()
    }
}

/// The line `update` prints as, after `t` seconds; `None` for kinds the contract does not print.
fn line(t: f64, update: &Update) -> Option<String> {
    let body = match update {
        Update::Position(p) => format!(
            r#""kind": "position", "lat": {}, "lon": {}, "alt_amsl": {}, "alt_rel": {}"#,
            num(p.lat),
            num(p.lon),
            num(p.alt_amsl),
            num(p.alt_rel)
        ),
        Update::Attitude(a) => format!(
            r#""kind": "attitude", "roll": {}, "pitch": {}, "yaw": {}"#,
            num(a.roll),
            num(a.pitch),
            num(a.yaw)
        ),
        Update::Battery(b) => format!(
            r#""kind": "battery", "voltage": {}, "remaining": {}"#,
            num(b.voltage),
            b.remaining.map_or_else(|| "null".into(), num)
        ),
        Update::Gps(g) => format!(
            r#""kind": "gps", "fix": "{}", "satellites": {}"#,
            g.fix.name(),
            g.satellites
                .map_or_else(|| "null".into(), |n| n.to_string())
        ),
        Update::State(s) => format!(
            r#""kind": "state", "armed": {}, "mode": {}, "landed": "{}""#,
            s.armed,
            serde_json::to_string(&s.mode).ok()?,
            s.landed.name()
        ),
        Update::Text(t) => format!(
            r#""kind": "text", "severity": "{}", "text": {}"#,
            severity(t.severity),
            serde_json::to_string(&t.text).ok()?
        ),
        _ => return None,
    };
    Some(format!(r#"{{"t": {t:.3}, {body}}}"#))
}

/// MAV_SEVERITY's name without its prefix: `EMERGENCY` to `DEBUG`.
fn severity(s: ferrolink_vehicle::dialects::common::MavSeverity) -> &'static str {
    const NAMES: [&str; 8] = [
        "EMERGENCY",
        "ALERT",
        "CRITICAL",
        "ERROR",
        "WARNING",
        "NOTICE",
        "INFO",
        "DEBUG",
    ];
    NAMES
        .get(usize::from(s.raw()))
        .copied()
        .unwrap_or("UNKNOWN")
}

/// The messages each printed kind comes from, for `--rate`.
const PRINTED: &[u32] = &[33, 30, 147, 1, 24, 245, 0];

pub fn telemetry(args: TelemetryArgs) -> Result<ExitCode> {
    let start = Instant::now();
    let Some(system) = find(&args.uri, &args.target, DISCOVERY)? else {
        eprintln!(
            "no vehicle's HEARTBEAT on {} within {} s",
            args.uri,
            DISCOVERY.as_secs()
        );
        return Ok(ExitCode::from(2));
    };
    let kinds = [
        Kind::Position,
        Kind::Attitude,
        Kind::Battery,
        Kind::Gps,
        Kind::State,
        Kind::Text,
    ];
    let updates = system.telemetry().subscribe(&kinds);
    if let Some(hz) = args.rate {
        for &id in PRINTED.iter().filter(|&&id| id != 0) {
            let outcome = system.set_rate(id, hz)?;
            if outcome.result != ActionResult::Accepted {
                eprintln!("message {id} at {hz} Hz: {}", outcome.result.name());
            }
        }
    }
    let end = args.duration.map(|d| start + d);
    let mut printed = 0u64;
    let mut out = std::io::stdout().lock();
    while args.count.is_none_or(|n| printed < n) {
        let wait = end.map_or(Duration::from_secs(3600), |e| {
            e.saturating_duration_since(Instant::now())
        });
        if end.is_some_and(|e| Instant::now() >= e) {
            break;
        }
        let Some(update) = updates.recv(wait) else {
            continue;
        };
        if let Some(text) = line(start.elapsed().as_secs_f64(), &update) {
            writeln!(out, "{text}")?;
            out.flush()?;
            printed += 1;
        }
    }
    Ok(ExitCode::SUCCESS)
}

pub fn action(args: ActionArgs) -> Result<ExitCode> {
    let action = match args.action.clone() {
        ActionCommand::Arm => Action::Arm,
        ActionCommand::Disarm if args.force => Action::ForceDisarm,
        ActionCommand::Disarm => Action::Disarm,
        ActionCommand::Takeoff { alt } => Action::Takeoff { alt },
        ActionCommand::Land => Action::Land,
        ActionCommand::Rtl => Action::ReturnToLaunch,
        ActionCommand::Hold => Action::Hold,
        ActionCommand::Goto { lat, lon, alt } => Action::Goto {
            lat,
            lon,
            alt_amsl: alt,
        },
        ActionCommand::Mode { name } => Action::SetMode(name),
        ActionCommand::Reboot => Action::Reboot,
    };
    let timeout = args.timeout.unwrap_or(DISCOVERY);
    let Some(system) = find(&args.uri, &args.target, timeout)? else {
        eprintln!(
            "no vehicle's HEARTBEAT on {} within {} s",
            args.uri,
            timeout.as_secs()
        );
        return Ok(ExitCode::from(2));
    };
    let outcome = match system.act(&action, |_| {}) {
        Ok(outcome) => outcome,
        Err(e @ ActionError::UnknownMode { .. }) => {
            eprintln!("{e}");
            return Ok(ExitCode::FAILURE);
        }
        Err(e) => return Err(e.into()),
    };
    println!(
        r#"{{"action": "{}", "result": "{}", "command": {}}}"#,
        action.name(),
        outcome.result.name(),
        outcome.command
    );
    Ok(match outcome.result {
        ActionResult::Accepted => ExitCode::SUCCESS,
        ActionResult::NoAnswer => ExitCode::from(2),
        _ => ExitCode::FAILURE,
    })
}
