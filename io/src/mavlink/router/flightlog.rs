//! The router's telemetry log: written all the time, or one file per flight, opened when the
//! vehicle arms and closed when it disarms, as mavlink-router's `LogMode = while-armed`.
//!
//! The vehicle is the system named (`LogSystemId`), or else the first one whose checked
//! HEARTBEAT comes from an autopilot (any `autopilot` but `MAV_AUTOPILOT_INVALID`, which ground
//! stations and companions send). Its `base_mode` armed flag decides; a frame that failed its
//! checksum never does. A flight's file is opened and old ones deleted by the log's own thread,
//! at its first record, so arming never holds up routing.

use std::io::Write;
use std::path::{Path, PathBuf};

use ferrolink_runtime::mavlink::parser::ParsedFrame;

use super::output::say;
use super::tlog::{self, Retention, Spool};
use super::*;

/// When the router writes its log.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LogMode {
    /// From start to end.
    #[default]
    Always,
    /// While the vehicle is armed: a new file (or, for a `.tlog` file, a new stretch of it)
    /// per flight.
    WhileArmed,
}

impl std::str::FromStr for LogMode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "always" => Ok(LogMode::Always),
            "while-armed" => Ok(LogMode::WhileArmed),
            other => Err(format!("{other:?}: expected always or while-armed")),
        }
    }
}

/// `MAV_AUTOPILOT_INVALID`: a HEARTBEAT from something that is not a vehicle.
const AUTOPILOT_INVALID: u8 = 8;
/// `MAV_MODE_FLAG_SAFETY_ARMED` in HEARTBEAT's `base_mode`.
const SAFETY_ARMED: u8 = 128;

/// The log the router writes every routed frame to.
pub(super) struct FlightLog {
    /// As configured: a directory or a `.tlog` file.
    path: PathBuf,
    retention: Retention,
    mode: LogMode,
    /// The vehicle whose arming decides, once known.
    vehicle: Option<u8>,
    armed: bool,
    spool: Option<Spool>,
    /// What the logs of flights that ended took and dropped.
    closed_records: u64,
    closed_dropped: u64,
    /// The file being written, when known at start (always); else the configured path.
    shown: PathBuf,
}

impl FlightLog {
    /// Opens the log (`Always`), or checks that a flight's log can be opened there
    /// (`WhileArmed`), so that a wrong path is an error at start either way.
    pub fn open(
        path: &Path,
        retention: Retention,
        mode: LogMode,
        vehicle: Option<u8>,
    ) -> io::Result<FlightLog> {
        let named = |e: io::Error| io::Error::new(e.kind(), format!("tlog {e}"));
        let (spool, shown) = match mode {
            LogMode::Always => {
                let opened = tlog::files::open(path, retention).map_err(named)?;
                let shown = opened.path.clone();
                (Some(Spool::new(announce(opened))), shown)
            }
            LogMode::WhileArmed => {
                tlog::files::check(path).map_err(named)?;
                say(format!(
                    "tlog: a new log in {} each time the vehicle arms",
                    path.display()
                ));
                (None, path.to_path_buf())
            }
        };
        Ok(FlightLog {
            path: path.to_path_buf(),
            retention,
            mode,
            vehicle,
            armed: false,
            spool,
            closed_records: 0,
            closed_dropped: 0,
            shown,
        })
    }

    /// Logs a frame received at `rx_us`; with `WhileArmed`, a flight's file opens with the
    /// HEARTBEAT that arms and closes after the one that disarms.
    pub fn write(&mut self, rx_us: u64, frame: &ParsedFrame<'_>, bytes: &[u8]) {
        let arming = match self.mode {
            LogMode::WhileArmed => self.arming(frame),
            LogMode::Always => None,
        };
        if arming == Some(true) {
            say(format!(
                "tlog: system {} armed: a new flight's log",
                frame.header().sysid
            ));
            self.spool = Some(Spool::new(Deferred::Path(
                self.path.clone(),
                self.retention,
            )));
        }
        if let Some(spool) = &mut self.spool {
            spool.write(rx_us, bytes);
        }
        if arming == Some(false) {
            if let Some(mut spool) = self.spool.take() {
                // Its thread writes what it was handed, and closes the file.
                spool.hand_over();
                self.closed_records += spool.records();
                self.closed_dropped += spool.dropped();
                say(format!(
                    "tlog: system {} disarmed: its flight's log closed ({} records)",
                    frame.header().sysid,
                    spool.records()
                ));
            }
        }
    }

    /// Whether `frame` arms (`Some(true)`) or disarms (`Some(false)`) the vehicle.
    fn arming(&mut self, frame: &ParsedFrame<'_>) -> Option<bool> {
        if frame.msg_id() != 0 || !frame.is_checked() {
            return None;
        }
        // MAVLink 2 drops a payload's trailing zeros.
        let payload = frame.payload();
        let byte = |i: usize| payload.get(i).copied().unwrap_or(0);
        let (autopilot, base_mode) = (byte(5), byte(6));
        let sysid = frame.header().sysid;
        match self.vehicle {
            Some(vehicle) if vehicle != sysid => return None,
            Some(_) => {}
            None if autopilot == AUTOPILOT_INVALID => return None,
            None => self.vehicle = Some(sysid),
        }
        let armed = base_mode & SAFETY_ARMED != 0;
        (armed != std::mem::replace(&mut self.armed, armed)).then_some(armed)
    }

    /// Hands the records gathered so far to the log's thread (see [`Spool::hand_over`]).
    pub fn hand_over(&mut self) {
        if let Some(spool) = &mut self.spool {
            spool.hand_over();
        }
    }

    /// What made the open log fail, if it has.
    pub fn failure(&self) -> Option<io::Error> {
        self.spool.as_ref().and_then(Spool::failure)
    }

    /// Records taken, in every flight.
    pub fn records(&self) -> u64 {
        self.closed_records + self.spool.as_ref().map_or(0, Spool::records)
    }

    /// Records dropped, in every flight.
    pub fn dropped(&self) -> u64 {
        self.closed_dropped + self.spool.as_ref().map_or(0, Spool::dropped)
    }

    /// Waits, up to `deadline`, for the open log's records to be written and flushed.
    pub fn flush_until(&mut self, deadline: std::time::Instant) -> io::Result<()> {
        match &mut self.spool {
            Some(spool) => spool.flush_until(deadline),
            None => Ok(()),
        }
    }

    /// What messages about the log name it by: the file (always), or the configured path.
    pub fn shown(&self) -> &Path {
        &self.shown
    }
}

/// Says which file a log was opened as, and which old logs made room for it.
fn announce(opened: tlog::files::Opened) -> std::fs::File {
    for old in &opened.deleted {
        say(format!(
            "tlog: deleted {} to keep the log directory within its limits",
            old.display()
        ));
    }
    say(format!("tlog: writing {}", opened.path.display()));
    opened.file
}

/// A flight's file, opened by the spool's thread at its first write.
enum Deferred {
    Path(PathBuf, Retention),
    Open(std::fs::File),
}

impl Write for Deferred {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if let Deferred::Path(path, retention) = self {
            let opened = tlog::files::open(path, *retention)?;
            *self = Deferred::Open(announce(opened));
        }
        match self {
            Deferred::Open(file) => file.write(buf),
            Deferred::Path(..) => Ok(0),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Deferred::Open(file) => file.flush(),
            Deferred::Path(..) => Ok(()),
        }
    }
}
