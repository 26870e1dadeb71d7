//! Messages that behave like pymavlink's: `get_type()`, `to_dict()`, `get_srcSystem()`, ...,
//! `_timestamp`, and the fields as attributes, valued as pymavlink 2.4.50 values them.

use std::sync::Arc;

use ferrolink_dictionary::ir::{Field, Message as IrMessage, Primitive};
use ferrolink_io::mavlink::Frame;
use ferrolink_runtime::mavlink::{v1, v2, AnyFrame, Version};
use ferrolink_traffic::{python_text, wire_value, Value};
use pyo3::exceptions::PyAttributeError;
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict, PyList, PyString};

use crate::dialect::Loaded;

/// One element as pymavlink gives it: an `int`, or a `float` widened exactly.
fn element<'py>(py: Python<'py>, primitive: Primitive, b: &[u8]) -> PyResult<Bound<'py, PyAny>> {
    Ok(match wire_value(primitive, b) {
        Value::Unsigned(v) => v.into_pyobject(py)?.into_any(),
        Value::Signed(v) => v.into_pyobject(py)?.into_any(),
        Value::Float(v) => v.into_pyobject(py)?.into_any(),
        Value::Text(t) => PyString::new(py, &t).into_any(),
    })
}

/// A field's value: a `str` for `char` fields and arrays, a `list` for other arrays.
fn value<'py>(py: Python<'py>, field: &Field, payload: &[u8]) -> PyResult<Bound<'py, PyAny>> {
    let size = field.ty.size();
    let mut zeros = [0u8; 256];
    let bytes = match payload.get(field.offset..field.offset + size) {
        Some(b) => b,
        None => {
            // Past a truncated payload: zero-filled.
            let have = payload.get(field.offset..).unwrap_or_default();
            zeros[..have.len()].copy_from_slice(have);
            &zeros[..size]
        }
    };
    let primitive = field.ty.primitive;
    if primitive == Primitive::Char {
        return Ok(PyString::new(py, &python_text(bytes)).into_any());
    }
    if field.ty.array.is_none() {
        return element(py, primitive, bytes);
    }
    let items = bytes
        .chunks_exact(primitive.size())
        .map(|e| element(py, primitive, e))
        .collect::<PyResult<Vec<_>>>()?;
    Ok(PyList::new(py, items)?.into_any())
}

/// pymavlink's `MAVLink_header`.
#[pyclass(module = "ferrolink.mavlink", name = "MAVLink_header", frozen, get_all)]
#[derive(Debug, Clone)]
#[allow(non_snake_case)]
pub struct Header {
    pub msgId: i64,
    pub incompat_flags: u8,
    pub compat_flags: u8,
    pub mlen: u8,
    pub seq: u8,
    pub srcSystem: u8,
    pub srcComponent: u8,
}

/// A decoded message, as pymavlink hands one out.
#[pyclass(module = "ferrolink.mavlink", name = "MAVLink_message", frozen)]
#[derive(Debug)]
pub struct Message {
    dialect: Arc<Loaded>,
    frame: Box<[u8]>,
    id: u32,
    timestamp: Option<f64>,
}

impl Message {
    /// The dictionary's message (only ids the dialect has become a `Message`).
    fn message(&self) -> PyResult<&IrMessage> {
        self.dialect
            .decoder
            .message(self.id)
            .ok_or_else(|| PyAttributeError::new_err(format!("unknown message id {}", self.id)))
    }

    /// The frame (a parser accepted it, so its length is right).
    fn view(&self) -> AnyFrame<&[u8]> {
        AnyFrame::new_checked(&self.frame[..])
            .unwrap_or_else(|_| AnyFrame::V2(v2::Frame::new_unchecked(&[0; v2::MIN_FRAME_LEN][..])))
    }

    fn payload(&self) -> &[u8] {
        let frame = self.view();
        let head = match frame.version() {
            Version::V1 => v1::HEADER_LEN,
            Version::V2 => v2::HEADER_LEN,
        };
        let len = usize::from(frame.payload_len());
        self.frame.get(head..head + len).unwrap_or_default()
    }

    fn header_fields(&self) -> Header {
        let frame = self.view();
        let flags = frame
            .as_v2()
            .map_or((0, 0), |f| (f.incompat_flags(), f.compat_flags()));
        Header {
            msgId: i64::from(self.id),
            incompat_flags: flags.0,
            compat_flags: flags.1,
            mlen: frame.payload_len(),
            seq: frame.seq(),
            srcSystem: frame.sysid(),
            srcComponent: frame.compid(),
        }
    }
}

/// What a frame becomes: a [`Message`], or [`Unknown`] for an id the dialect lacks.
pub fn to_python(
    py: Python<'_>,
    dialect: &Arc<Loaded>,
    frame: Box<[u8]>,
    id: u32,
    t_us: Option<u64>,
) -> PyResult<Py<PyAny>> {
    let timestamp = t_us.map(|t| t as f64 * 1e-6);
    if dialect.decoder.message(id).is_none() {
        let unknown = Unknown {
            data: frame,
            id,
            timestamp,
        };
        return Ok(Py::new(py, unknown)?.into_any());
    }
    let message = Message {
        dialect: Arc::clone(dialect),
        frame,
        id,
        timestamp,
    };
    Ok(Py::new(py, message)?.into_any())
}

/// A received [`Frame`] as a message.
pub fn from_frame(
    py: Python<'_>,
    dialect: &Arc<Loaded>,
    frame: &Frame,
    t_us: u64,
) -> PyResult<Py<PyAny>> {
    to_python(
        py,
        dialect,
        frame.as_bytes().into(),
        frame.msg_id(),
        Some(t_us),
    )
}

#[pymethods]
impl Message {
    /// The message's name: `"ATTITUDE"`.
    fn get_type(&self, py: Python<'_>) -> PyResult<Py<PyString>> {
        let names = self.dialect.names(py, self.id, self.message()?);
        Ok(names.message.clone_ref(py))
    }

    /// Its id.
    #[allow(non_snake_case)]
    fn get_msgId(&self) -> u32 {
        self.id
    }

    /// The sender's system id.
    #[allow(non_snake_case)]
    fn get_srcSystem(&self) -> u8 {
        self.header_fields().srcSystem
    }

    /// The sender's component id.
    #[allow(non_snake_case)]
    fn get_srcComponent(&self) -> u8 {
        self.header_fields().srcComponent
    }

    /// The sequence number.
    fn get_seq(&self) -> u8 {
        self.header_fields().seq
    }

    /// The frame's header, as pymavlink's `MAVLink_header`.
    fn get_header(&self) -> Header {
        self.header_fields()
    }

    /// Whether the frame carried a MAVLink 2 signature.
    fn get_signed(&self) -> bool {
        self.view().is_signed()
    }

    /// The whole frame as received.
    fn get_msgbuf<'py>(&self, py: Python<'py>) -> Bound<'py, PyByteArray> {
        PyByteArray::new(py, &self.frame)
    }

    /// The payload as received (MAVLink 2 truncation kept).
    fn get_payload<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, self.payload())
    }

    /// The field names, in XML order.
    fn get_fieldnames(&self) -> PyResult<Vec<&str>> {
        Ok(self
            .message()?
            .fields
            .iter()
            .map(|f| f.name.wire.as_str())
            .collect())
    }

    /// The field names, as pymavlink's `fieldnames` attribute.
    #[getter(fieldnames)]
    fn names_attribute(&self) -> PyResult<Vec<&str>> {
        self.get_fieldnames()
    }

    /// The `.tlog` timestamp in seconds since the Unix epoch (`None` in a raw capture); for a
    /// live message, when it was received.
    #[getter(_timestamp)]
    fn timestamp(&self) -> Option<f64> {
        self.timestamp
    }

    /// `{"mavpackettype": NAME, field: value, ...}`, as pymavlink's `to_dict()`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let message = self.message()?;
        let names = self.dialect.names(py, self.id, message);
        let dict = PyDict::new(py);
        dict.set_item(intern!(py, "mavpackettype"), names.message.bind(py))?;
        let payload = self.payload();
        for (field, name) in message.fields.iter().zip(&names.fields) {
            dict.set_item(name.bind(py), value(py, field, payload)?)?;
        }
        Ok(dict)
    }

    fn __getattr__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let message = self.message()?;
        match message.fields.iter().find(|f| f.name.wire == name) {
            Some(field) => value(py, field, self.payload()),
            None => Err(PyAttributeError::new_err(format!(
                "'{}' message has no attribute '{name}'",
                message.name.wire
            ))),
        }
    }

    fn __dir__(&self) -> PyResult<Vec<String>> {
        let mut names: Vec<String> = self
            .get_fieldnames()?
            .into_iter()
            .map(String::from)
            .collect();
        names.extend(
            [
                "get_type",
                "get_msgId",
                "get_srcSystem",
                "get_srcComponent",
                "get_seq",
                "get_header",
                "get_signed",
                "get_msgbuf",
                "get_payload",
                "get_fieldnames",
                "fieldnames",
                "to_dict",
                "_timestamp",
            ]
            .map(String::from),
        );
        Ok(names)
    }

    /// `NAME {field : value, ...}`, as pymavlink prints a message.
    fn __str__(&self, py: Python<'_>) -> PyResult<String> {
        let message = self.message()?;
        let payload = self.payload();
        let mut parts = Vec::with_capacity(message.fields.len());
        for field in &message.fields {
            let v = value(py, field, payload)?;
            parts.push(format!("{} : {}", field.name.wire, v.str()?));
        }
        Ok(format!("{} {{{}}}", message.name.wire, parts.join(", ")))
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        self.__str__(py)
    }
}

/// A frame of an id the dialect lacks, as pymavlink's `MAVLink_unknown`: its type is
/// `UNKNOWN_<id>`, its `data` the whole frame, its header empty (message id -2), as pymavlink
/// 2.4.50 leaves it.
#[pyclass(module = "ferrolink.mavlink", name = "MAVLink_unknown", frozen)]
#[derive(Debug)]
pub struct Unknown {
    data: Box<[u8]>,
    id: u32,
    timestamp: Option<f64>,
}

/// pymavlink's `MAVLINK_MSG_ID_UNKNOWN`.
const UNKNOWN_ID: i64 = -2;

#[pymethods]
impl Unknown {
    /// `"UNKNOWN_<id>"`.
    fn get_type(&self) -> String {
        format!("UNKNOWN_{}", self.id)
    }

    /// -2, as pymavlink's.
    #[allow(non_snake_case)]
    fn get_msgId(&self) -> i64 {
        UNKNOWN_ID
    }

    /// 0, as pymavlink's (it leaves the header empty).
    #[allow(non_snake_case)]
    fn get_srcSystem(&self) -> u8 {
        0
    }

    /// 0, as pymavlink's.
    #[allow(non_snake_case)]
    fn get_srcComponent(&self) -> u8 {
        0
    }

    /// 0, as pymavlink's.
    fn get_seq(&self) -> u8 {
        0
    }

    /// An empty header with message id -2, as pymavlink's.
    fn get_header(&self) -> Header {
        Header {
            msgId: UNKNOWN_ID,
            incompat_flags: 0,
            compat_flags: 0,
            mlen: 0,
            seq: 0,
            srcSystem: 0,
            srcComponent: 0,
        }
    }

    /// The whole frame.
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> Bound<'py, PyByteArray> {
        PyByteArray::new(py, &self.data)
    }

    /// The whole frame.
    fn get_msgbuf<'py>(&self, py: Python<'py>) -> Bound<'py, PyByteArray> {
        PyByteArray::new(py, &self.data)
    }

    /// `["data"]`.
    fn get_fieldnames(&self) -> Vec<&'static str> {
        vec!["data"]
    }

    /// The `.tlog` timestamp, as [`Message`]'s.
    #[getter(_timestamp)]
    fn timestamp(&self) -> Option<f64> {
        self.timestamp
    }

    /// `{"mavpackettype": "UNKNOWN_<id>", "data": bytearray(frame)}`, as pymavlink's.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        dict.set_item("mavpackettype", self.get_type())?;
        dict.set_item("data", self.data(py))?;
        Ok(dict)
    }

    /// pymavlink's form: `UNKNOWN_<id> {data:['fd', '9', ...]}`.
    fn __str__(&self) -> String {
        let hex: Vec<String> = self.data.iter().map(|b| format!("'{b:x}'")).collect();
        format!("{} {{data:[{}]}}", self.get_type(), hex.join(", "))
    }
}
