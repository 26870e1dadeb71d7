//! The `ferrolink._native` extension module: what the `ferrolink` Python package is built on.
//!
//! - [`dialect`]: dialects by built-in name or XML file, loaded once per process;
//! - [`message`]: messages that behave like pymavlink's objects;
//! - [`log`]: logs read message by message, as Arrow tables, and into Parquet;
//! - [`connection`]: live connections over the link layer, waited on without the GIL;
//! - [`vehicle`]: the vehicle API (telemetry, actions, parameters, missions, files).
//!
//! Nothing here panics across the boundary: every failure is a Python exception
//! (`FileNotFoundError`, `ValueError`, `OSError`).

use pyo3::prelude::*;

mod connection;
mod dialect;
mod log;
mod message;
mod vehicle;

/// Errors of this crate as Python exceptions.
pub(crate) mod error {
    use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
    use pyo3::PyErr;

    /// An I/O error: `FileNotFoundError` for a missing file, else `OSError`.
    pub fn io(e: std::io::Error) -> PyErr {
        match e.kind() {
            std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(e.to_string()),
            std::io::ErrorKind::InvalidInput => PyValueError::new_err(e.to_string()),
            _ => PyOSError::new_err(e.to_string()),
        }
    }

    /// A bad argument: `ValueError`.
    pub fn value(e: impl std::fmt::Display) -> PyErr {
        PyValueError::new_err(e.to_string())
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(dialect::dialects, m)?)?;
    m.add_class::<message::Message>()?;
    m.add_class::<message::Unknown>()?;
    m.add_class::<message::Header>()?;
    m.add_class::<log::LogIter>()?;
    m.add_class::<log::ArrowTable>()?;
    m.add_function(wrap_pyfunction!(log::load_tables, m)?)?;
    m.add_function(wrap_pyfunction!(log::save_parquet, m)?)?;
    m.add_class::<connection::NativeConnection>()?;
    m.add_class::<vehicle::Node>()?;
    m.add_class::<vehicle::System>()?;
    Ok(())
}
