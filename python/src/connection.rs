//! Live connections: a [`SharedConnection`] with one subscription for everything, waited on
//! without the GIL. `ferrolink.mavlink.connect` wraps it with pymavlink's `recv_match` and
//! friends.

use std::sync::Arc;
use std::time::{Duration, Instant};

use ferrolink_io::mavlink::{unix_us, Filter, SharedConnection, Subscription};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use crate::dialect::{self, Loaded};
use crate::{error, message};

/// One connection: our side of a link.
#[pyclass(module = "ferrolink._native")]
#[derive(Debug)]
pub struct NativeConnection {
    dialect: Arc<Loaded>,
    shared: Option<SharedConnection>,
    frames: Subscription,
}

impl NativeConnection {
    fn shared(&self) -> PyResult<&SharedConnection> {
        self.shared
            .as_ref()
            .ok_or_else(|| error::value("the connection is closed"))
    }
}

/// A Python value as JSON, for the encoder: numbers, text, lists; NaN as `null`.
fn json(value: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    use serde_json::Value as Json;
    if value.is_none() {
        return Ok(Json::Null);
    }
    if value.is_instance_of::<PyBool>() {
        return Ok(Json::from(u8::from(value.extract::<bool>()?)));
    }
    if value.is_instance_of::<PyInt>() {
        return match value.extract::<i64>() {
            Ok(v) => Ok(Json::from(v)),
            Err(_) => Ok(Json::from(value.extract::<u64>()?)),
        };
    }
    if value.is_instance_of::<PyFloat>() {
        let v: f64 = value.extract()?;
        return Ok(serde_json::Number::from_f64(v).map_or(Json::Null, Json::Number));
    }
    if value.is_instance_of::<PyString>() {
        return Ok(Json::from(value.extract::<String>()?));
    }
    if let Ok(dict) = value.cast::<PyDict>() {
        let mut object = serde_json::Map::new();
        for (k, v) in dict.iter() {
            object.insert(k.extract::<String>()?, json(&v)?);
        }
        return Ok(Json::Object(object));
    }
    if let Ok(bytes) = value.extract::<Vec<u8>>() {
        if !value.is_instance_of::<PyList>() && !value.is_instance_of::<PyTuple>() {
            // bytes for a char array.
            return Ok(Json::from(String::from_utf8_lossy(&bytes).into_owned()));
        }
    }
    let items = value
        .try_iter()
        .map_err(|_| error::value(format!("cannot send {} as a field value", value.get_type())))?;
    items
        .map(|item| json(&item?))
        .collect::<PyResult<Vec<_>>>()
        .map(Json::Array)
}

#[pymethods]
impl NativeConnection {
    /// Opens `uri`: our URIs and pymavlink's spellings (`udpin:0.0.0.0:14550`, `tcp:HOST:PORT`,
    /// `/dev/ttyACM0,115200`).
    #[new]
    fn new(uri: &str, dialect: &str, source_system: u8, source_component: u8) -> PyResult<Self> {
        let dialect = dialect::load(dialect)?;
        let shared = SharedConnection::open(uri, dialect.table.clone()).map_err(error::io)?;
        shared.set_ids(source_system, source_component);
        // Frames of ids the dialect lacks come through as BAD_DATA, as pymavlink's do.
        shared.set_pass_unknown_ids(true);
        let frames = shared.subscribe(Filter::all());
        Ok(NativeConnection {
            dialect,
            shared: Some(shared),
            frames,
        })
    }

    /// The next message: waits up to `timeout` seconds (`None`: as long as it takes; `0`: only
    /// what is already there). `None` when none came. The GIL is released while it waits, and
    /// Ctrl-C interrupts it.
    #[pyo3(signature = (timeout=None))]
    fn recv(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<Option<Py<PyAny>>> {
        self.shared()?;
        let deadline = timeout.map(|t| Instant::now() + Duration::from_secs_f64(t.max(0.0)));
        let frame = loop {
            let wait = deadline.map_or(Duration::from_millis(100), |d| {
                d.saturating_duration_since(Instant::now())
                    .min(Duration::from_millis(100))
            });
            let got = if wait.is_zero() {
                self.frames.try_recv()
            } else {
                py.detach(|| self.frames.recv(wait))
            }
            .map_err(error::io)?;
            match got {
                Some(frame) => break frame,
                None if deadline.is_some_and(|d| Instant::now() >= d) => return Ok(None),
                None => py.check_signals()?,
            }
        };
        message::from_frame(py, &self.dialect, &frame, unix_us()).map(Some)
    }

    /// Sends a message given as pymavlink's `to_dict()` form: `{"mavpackettype": NAME, ...}`.
    /// Fields left out are zero.
    fn send_dict(&self, dict: &Bound<'_, PyDict>) -> PyResult<()> {
        let shared = self.shared()?;
        let value = json(dict.as_any())?;
        let (id, payload) = self
            .dialect
            .decoder
            .from_dict(&value, &[])
            .map_err(error::value)?;
        let crc_extra = self.dialect.decoder.message(id).map_or(0, |m| m.crc_extra);
        shared.send_raw(id, crc_extra, &payload).map_err(error::io)
    }

    /// The field names of message `name`, in XML order (the order of pymavlink's `*_send`
    /// arguments).
    fn field_names(&self, name: &str) -> PyResult<Vec<String>> {
        let ids = self
            .dialect
            .decoder
            .ids_of(&[name.to_owned()])
            .map_err(error::value)?;
        let message = ids
            .iter()
            .next()
            .and_then(|&id| self.dialect.decoder.message(id));
        Ok(message
            .map(|m| m.fields.iter().map(|f| f.name.wire.clone()).collect())
            .unwrap_or_default())
    }

    /// Frames this connection's reader lost because Python did not read them in time.
    fn dropped(&self) -> u64 {
        self.frames.dropped()
    }

    /// The bound local address (`udpin`, `udpout`, `tcpin`): `(host, port)`.
    fn local_addr(&self) -> PyResult<Option<(String, u16)>> {
        Ok(self
            .shared()?
            .local_addr()
            .map(|a| (a.ip().to_string(), a.port())))
    }

    /// Our system and component ids, as senders.
    fn set_ids(&self, source_system: u8, source_component: u8) -> PyResult<()> {
        self.shared()?.set_ids(source_system, source_component);
        Ok(())
    }

    /// Closes the link. Messages already received can still be read.
    fn close(&mut self) {
        self.shared = None;
    }
}
