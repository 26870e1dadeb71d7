//! The vehicle API in Python: a node with our heartbeat, the systems it discovers, and per
//! system its typed telemetry, actions, parameters, missions and files. Every call that waits
//! releases the GIL; `ferrolink.vehicle` adds the asyncio face.

use std::time::Duration;

use ferrolink_io::mavlink::paramfile;
use ferrolink_runtime::mavlink::service::ftp::EntryKind;
use ferrolink_runtime::mavlink::service::messages::{MavCmd, MavFrame, MavMissionType};
use ferrolink_runtime::mavlink::service::mission::Item;
use ferrolink_runtime::mavlink::service::param::Value;
use ferrolink_vehicle::{ActionError, Outcome};
use pyo3::exceptions::PyTimeoutError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use crate::error;

/// A dict of `key: value` pairs.
macro_rules! dict {
    ($py:expr, $($key:literal => $value:expr),* $(,)?) => {{
        let d = PyDict::new($py);
        $(d.set_item($key, $value)?;)*
        Ok::<_, PyErr>(d)
    }};
}

/// The wire name of value `value` of common.xml's enum `name` (`NAME(value)` without one).
fn enum_name(name: &str, value: u64) -> PyResult<String> {
    let common = crate::dialect::load("common")?;
    let entry = common
        .decoder
        .ir()
        .enums
        .iter()
        .filter(|e| e.name.wire == name)
        .flat_map(|e| &e.entries)
        .find(|e| e.value == value);
    Ok(entry.map_or_else(|| format!("{name}({value})"), |e| e.name.wire.clone()))
}

fn seconds(timeout: f64) -> Duration {
    Duration::from_secs_f64(timeout.max(0.0))
}

/// Our node on a link: our heartbeat (a ground station, 255/190), and the systems heard.
#[pyclass(module = "ferrolink._native")]
#[derive(Debug)]
pub struct Node {
    node: ferrolink_vehicle::Node,
}

#[pymethods]
impl Node {
    /// Opens `uri` (our URIs and pymavlink's spellings) as a ground station.
    #[new]
    fn new(uri: &str) -> PyResult<Self> {
        let node = ferrolink_vehicle::Node::connect(uri).map_err(error::io)?;
        Ok(Node { node })
    }

    /// The vehicles heard in the last 5 s.
    fn systems(&self) -> Vec<System> {
        self.node
            .systems()
            .into_iter()
            .map(|system| System { system })
            .collect()
    }

    /// Vehicle `id`, if heard.
    fn system(&self, id: u8) -> Option<System> {
        self.node.system(id).map(|system| System { system })
    }

    /// The first vehicle heard, waiting up to `timeout` seconds; `None` then.
    fn wait_for_system(&self, py: Python<'_>, timeout: f64) -> PyResult<Option<System>> {
        let found = py.detach(|| self.node.wait_for_system(seconds(timeout)));
        Ok(found.map_err(error::io)?.map(|system| System { system }))
    }
}

/// One vehicle.
#[pyclass(module = "ferrolink._native")]
#[derive(Debug)]
pub struct System {
    system: ferrolink_vehicle::System,
}

fn action_error(e: ActionError) -> PyErr {
    match e {
        ActionError::Io(e) => error::io(e),
        other => error::value(other),
    }
}

fn outcome<'py>(py: Python<'py>, o: Outcome) -> PyResult<Bound<'py, PyDict>> {
    let progress = match o.result {
        ferrolink_vehicle::ActionResult::InProgress(p) => Some(p),
        _ => None,
    };
    dict!(py,
        "result" => o.result.name(),
        "accepted" => matches!(o.result, ferrolink_vehicle::ActionResult::Accepted),
        "command" => o.command,
        "in_progress" => progress,
        "progress" => o.progress,
    )
}

/// A parameter's value as Python's: `int` for integer types, `float` for the others.
fn param_value(py: Python<'_>, value: Option<Value>) -> PyResult<Py<PyAny>> {
    Ok(match value {
        None => py.None(),
        Some(Value::F32(v)) => f64::from(v).into_pyobject(py)?.into_any().unbind(),
        Some(Value::F64(v)) => v.into_pyobject(py)?.into_any().unbind(),
        Some(v) => (v.as_f64() as i64).into_pyobject(py)?.into_any().unbind(),
    })
}

fn item_dict<'py>(py: Python<'py>, seq: usize, item: &Item) -> PyResult<Bound<'py, PyDict>> {
    dict!(py,
        "seq" => seq,
        "frame" => item.frame.raw(),
        "command" => item.command.raw(),
        "current" => item.current,
        "autocontinue" => item.autocontinue,
        "param1" => item.params[0],
        "param2" => item.params[1],
        "param3" => item.params[2],
        "param4" => item.params[3],
        "x" => item.x,
        "y" => item.y,
        "z" => item.z,
    )
}

fn item_from(d: &Bound<'_, PyDict>) -> PyResult<Item> {
    let get = |key: &str| -> PyResult<Option<Bound<'_, PyAny>>> { d.get_item(key) };
    let f32_of = |key: &str| -> PyResult<f32> { get(key)?.map_or(Ok(0.0), |v| v.extract::<f32>()) };
    let command: u16 = get("command")?
        .ok_or_else(|| error::value("a mission item needs a \"command\""))?
        .extract()?;
    Ok(Item {
        frame: MavFrame::from_raw(get("frame")?.map_or(Ok(3), |v| v.extract::<u8>())?),
        command: MavCmd::from_raw(command),
        current: get("current")?.map_or(Ok(0), |v| v.extract::<u8>())?,
        autocontinue: get("autocontinue")?.map_or(Ok(1), |v| v.extract::<u8>())?,
        params: [
            f32_of("param1")?,
            f32_of("param2")?,
            f32_of("param3")?,
            f32_of("param4")?,
        ],
        x: get("x")?.map_or(Ok(0), |v| v.extract::<i32>())?,
        y: get("y")?.map_or(Ok(0), |v| v.extract::<i32>())?,
        z: f32_of("z")?,
    })
}

fn mission_type(kind: &str) -> PyResult<MavMissionType> {
    match kind {
        "mission" => Ok(MavMissionType::Mission),
        "fence" => Ok(MavMissionType::Fence),
        "rally" => Ok(MavMissionType::Rally),
        other => Err(error::value(format!(
            "mission type {other:?}: expected \"mission\", \"fence\" or \"rally\""
        ))),
    }
}

fn no_answer(what: &str) -> PyErr {
    PyTimeoutError::new_err(format!("{what}: the vehicle stopped answering"))
}

#[pymethods]
impl System {
    /// Its system id.
    #[getter]
    fn id(&self) -> u8 {
        self.system.id()
    }

    /// Its autopilot: `MAV_AUTOPILOT_ARDUPILOTMEGA`, `MAV_AUTOPILOT_PX4`, ...
    #[getter]
    fn autopilot(&self) -> PyResult<String> {
        enum_name("MAV_AUTOPILOT", u64::from(self.system.autopilot().raw()))
    }

    /// Its type: `MAV_TYPE_QUADROTOR`, ...
    #[getter]
    fn kind(&self) -> PyResult<String> {
        enum_name("MAV_TYPE", u64::from(self.system.kind().raw()))
    }

    /// Its components heard.
    #[getter]
    fn components(&self) -> Vec<u8> {
        self.system.components()
    }

    /// The flight modes its autopilot has, by name.
    fn mode_names(&self) -> Vec<&'static str> {
        self.system.mode_names()
    }

    // Telemetry: the latest of each kind, in SI units and degrees, `None` before the first.

    /// `{"lat", "lon", "alt_amsl", "alt_rel"}` (GLOBAL_POSITION_INT).
    fn position<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system.telemetry().position().map(|p| {
            dict!(py, "lat" => p.lat, "lon" => p.lon, "alt_amsl" => p.alt_amsl, "alt_rel" => p.alt_rel)
        }).transpose()
    }

    /// Home, as `position()` (HOME_POSITION).
    fn home<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system.telemetry().home().map(|p| {
            dict!(py, "lat" => p.lat, "lon" => p.lon, "alt_amsl" => p.alt_amsl, "alt_rel" => p.alt_rel)
        }).transpose()
    }

    /// `{"roll", "pitch", "yaw"}`, degrees (ATTITUDE).
    fn attitude<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system
            .telemetry()
            .attitude()
            .map(|a| dict!(py, "roll" => a.roll, "pitch" => a.pitch, "yaw" => a.yaw))
            .transpose()
    }

    /// `{"w", "x", "y", "z"}` (ATTITUDE_QUATERNION).
    fn quaternion<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system
            .telemetry()
            .quaternion()
            .map(|q| dict!(py, "w" => q.w, "x" => q.x, "y" => q.y, "z" => q.z))
            .transpose()
    }

    /// `{"north", "east", "down"}`, m/s (GLOBAL_POSITION_INT).
    fn velocity<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system
            .telemetry()
            .velocity()
            .map(|v| dict!(py, "north" => v.north, "east" => v.east, "down" => v.down))
            .transpose()
    }

    /// `{"fix", "satellites"}` (GPS_RAW_INT).
    fn gps<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system
            .telemetry()
            .gps()
            .map(|g| dict!(py, "fix" => g.fix.name(), "satellites" => g.satellites))
            .transpose()
    }

    /// `{"voltage", "remaining"}` (BATTERY_STATUS, or SYS_STATUS).
    fn battery<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system
            .telemetry()
            .battery()
            .map(|b| dict!(py, "voltage" => b.voltage, "remaining" => b.remaining))
            .transpose()
    }

    /// `{"gyro", "accel", "mag", "baro", "gps", "rc", "battery"}`: `True`, `False`, or `None`
    /// where the sensor is absent (SYS_STATUS).
    fn health<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system
            .telemetry()
            .health()
            .map(|h| {
                dict!(py, "gyro" => h.gyro, "accel" => h.accel, "mag" => h.mag, "baro" => h.baro,
                "gps" => h.gps, "rc" => h.rc, "battery" => h.battery)
            })
            .transpose()
    }

    /// `{"armed", "mode", "custom_mode", "landed"}` (HEARTBEAT, EXTENDED_SYS_STATE).
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system
            .telemetry()
            .state()
            .map(|s| {
                dict!(py, "armed" => s.armed, "mode" => s.mode, "custom_mode" => s.custom_mode,
                "landed" => s.landed.name())
            })
            .transpose()
    }

    /// `{"severity", "text"}`, the last status text, chunks joined (STATUSTEXT).
    fn text<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.system
            .telemetry()
            .text()
            .map(|t| dict!(py, "severity" => t.severity.raw(), "text" => t.text))
            .transpose()
    }

    /// The first position, waiting up to `timeout` seconds; `None` then.
    fn wait_position<'py>(
        &self,
        py: Python<'py>,
        timeout: f64,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let telemetry = self.system.telemetry();
        match py.detach(|| telemetry.wait_position(seconds(timeout))) {
            Some(_) => self.position(py),
            None => Ok(None),
        }
    }

    // Actions: each returns {"result", "accepted", "command", "in_progress", "progress"}.

    /// Arms.
    fn arm<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        outcome(py, py.detach(|| self.system.arm()).map_err(action_error)?)
    }

    /// Disarms (`force`: in flight too).
    #[pyo3(signature = (force=false))]
    fn disarm<'py>(&self, py: Python<'py>, force: bool) -> PyResult<Bound<'py, PyDict>> {
        outcome(
            py,
            py.detach(|| self.system.disarm(force))
                .map_err(action_error)?,
        )
    }

    /// Takes off to `alt` metres above home.
    fn takeoff<'py>(&self, py: Python<'py>, alt: f32) -> PyResult<Bound<'py, PyDict>> {
        outcome(
            py,
            py.detach(|| self.system.takeoff(alt))
                .map_err(action_error)?,
        )
    }

    /// Lands.
    fn land<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        outcome(py, py.detach(|| self.system.land()).map_err(action_error)?)
    }

    /// Returns to launch.
    fn return_to_launch<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        outcome(
            py,
            py.detach(|| self.system.return_to_launch())
                .map_err(action_error)?,
        )
    }

    /// Holds position.
    fn hold<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        outcome(py, py.detach(|| self.system.hold()).map_err(action_error)?)
    }

    /// Flies to a point (degrees, metres above mean sea level).
    fn goto<'py>(
        &self,
        py: Python<'py>,
        lat: f64,
        lon: f64,
        alt_amsl: f32,
    ) -> PyResult<Bound<'py, PyDict>> {
        outcome(
            py,
            py.detach(|| self.system.goto(lat, lon, alt_amsl))
                .map_err(action_error)?,
        )
    }

    /// Sets the flight mode by its name (any case); an unknown name is a `ValueError` listing
    /// the vehicle's, before anything is sent.
    fn set_mode<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        outcome(
            py,
            py.detach(|| self.system.set_mode(name))
                .map_err(action_error)?,
        )
    }

    /// Reboots the autopilot.
    fn reboot<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        outcome(
            py,
            py.detach(|| self.system.reboot()).map_err(action_error)?,
        )
    }

    /// Asks for message `id` at `hz` (MAV_CMD_SET_MESSAGE_INTERVAL).
    fn set_rate<'py>(&self, py: Python<'py>, id: u32, hz: f32) -> PyResult<Bound<'py, PyDict>> {
        outcome(
            py,
            py.detach(|| self.system.set_rate(id, hz))
                .map_err(error::io)?,
        )
    }

    // Parameters.

    /// Every parameter, `{name: value}` (ints for integer types), fetched in up to `timeout`
    /// seconds; what never came is missing.
    #[pyo3(signature = (timeout=30.0))]
    fn params<'py>(&self, py: Python<'py>, timeout: f64) -> PyResult<Bound<'py, PyDict>> {
        let list = py
            .detach(|| self.system.remote().fetch_params(seconds(timeout), |_| {}))
            .map_err(error::io)?;
        let out = PyDict::new(py);
        for r in list.iter() {
            out.set_item(r.name.as_str(), param_value(py, r.value)?)?;
        }
        Ok(out)
    }

    /// One parameter's value; `KeyError` for a name the vehicle does not have.
    fn param(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        let got = py
            .detach(|| self.system.remote().read_param(name))
            .map_err(error::io)?;
        match got {
            Some(r) if r.value.is_some() => param_value(py, r.value),
            _ => Err(pyo3::exceptions::PyKeyError::new_err(name.to_owned())),
        }
    }

    /// Sets a parameter, in its own type (read first), and returns the value the vehicle kept.
    fn set_param(&self, py: Python<'_>, name: &str, value: f64) -> PyResult<Py<PyAny>> {
        let set = py.detach(|| -> PyResult<_> {
            let mut remote = self.system.remote();
            let current = remote.read_param(name).map_err(error::io)?;
            let Some(ty) = current.and_then(|r| r.value).map(|v| v.param_type()) else {
                return Err(pyo3::exceptions::PyKeyError::new_err(name.to_owned()));
            };
            let text = if value.fract() == 0.0 {
                format!("{}", value as i64)
            } else {
                value.to_string()
            };
            let v = paramfile::parse_value(ty, &text).ok_or_else(|| {
                error::value(format!(
                    "{value} is not a value of {name}'s type {}",
                    paramfile::type_name(ty)
                ))
            })?;
            remote.set_param(name, v).map_err(error::io)
        })?;
        match set {
            Some(r) => param_value(py, r.value),
            None => Err(no_answer(&format!("setting {name}"))),
        }
    }

    // Missions.

    /// Downloads the vehicle's `kind` ("mission", "fence" or "rally"): a list of dicts with
    /// MISSION_ITEM_INT's fields.
    #[pyo3(signature = (kind="mission"))]
    fn download_mission<'py>(
        &self,
        py: Python<'py>,
        kind: &str,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let kind = mission_type(kind)?;
        let items = py
            .detach(|| self.system.remote().download_mission(kind, |_, _| {}))
            .map_err(error::io)?
            .ok_or_else(|| no_answer("downloading the mission"))?;
        items
            .iter()
            .enumerate()
            .map(|(i, item)| item_dict(py, i, item))
            .collect()
    }

    /// Uploads `items` (dicts with MISSION_ITEM_INT's fields; left out: frame 3, autocontinue
    /// 1, the rest 0) as the vehicle's `kind`. Returns the vehicle's answer:
    /// `MAV_MISSION_ACCEPTED`, ...
    #[pyo3(signature = (items, kind="mission"))]
    fn upload_mission(
        &self,
        py: Python<'_>,
        items: Vec<Bound<'_, PyDict>>,
        kind: &str,
    ) -> PyResult<String> {
        let kind = mission_type(kind)?;
        let items = items.iter().map(item_from).collect::<PyResult<Vec<_>>>()?;
        let answer = py
            .detach(|| self.system.remote().upload_mission(kind, &items, |_, _| {}))
            .map_err(error::io)?
            .ok_or_else(|| no_answer("uploading the mission"))?;
        enum_name("MAV_MISSION_RESULT", u64::from(answer.raw()))
    }

    // Files (MAVLink FTP).

    /// A directory's entries: `[{"name", "dir", "size"}]`.
    fn ftp_list<'py>(&self, py: Python<'py>, path: &str) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let entries = py
            .detach(|| self.system.remote().ftp_list(path))
            .map_err(error::io)?;
        entries
            .into_iter()
            .map(|e| dict!(py, "name" => e.name, "dir" => matches!(e.kind, EntryKind::Dir), "size" => e.size))
            .collect()
    }

    /// A file's bytes.
    fn ftp_get<'py>(&self, py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyBytes>> {
        let data = py
            .detach(|| self.system.remote().ftp_get(path, |_, _| {}))
            .map_err(error::io)?;
        Ok(PyBytes::new(py, &data))
    }

    fn __repr__(&self) -> PyResult<String> {
        Ok(format!(
            "System(id={}, autopilot={})",
            self.system.id(),
            self.autopilot()?
        ))
    }
}
