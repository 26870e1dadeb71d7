//! `serial://PATH[:BAUD]` and `pty://NAME`: both are tty devices driven through `serialport`.
//! A reader waits for its device and its endpoint's [`Bell`] at once, so that an idle link sleeps
//! until bytes come or the endpoint stops.

use std::io::{self, Read, Write};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

#[cfg(windows)]
use serialport::COMPort as Port;
#[cfg(unix)]
use serialport::TTYPort as Port;
use serialport::{DataBits, FlowControl, Parity, SerialPort, StopBits};

use crate::link::Bell;
use crate::{is_timeout, written, Halves, LinkReader, LinkWriter, WRITE_TIMEOUT};

/// Opens a serial device at `baud`, 8N1, no flow control, in exclusive mode (`TIOCEXCL` and
/// `flock`; `serialport` clears `TIOCEXCL` again when the port is closed). Its reader returns
/// when `bell` rings.
pub(crate) fn open_serial(path: &str, baud: u32, bell: Option<Arc<Bell>>) -> io::Result<Halves> {
    let port = serialport::new(path, baud)
        .data_bits(DataBits::Eight)
        .parity(Parity::None)
        .stop_bits(StopBits::One)
        .flow_control(FlowControl::None)
        .timeout(WRITE_TIMEOUT)
        .open_native()?;
    halves(port, None, bell)
}

/// Splits `port` into a reader, which returns when `bell` rings, and a writer; both hold on to
/// `keep`.
fn halves(port: Port, keep: Option<Arc<PtyKeep>>, bell: Option<Arc<Bell>>) -> io::Result<Halves> {
    let reader = TtyReader {
        port: port.try_clone_native()?,
        bell,
        _keep: keep.clone(),
    };
    Ok((Box::new(reader), Box::new(TtyWriter { port, _keep: keep })))
}

/// What a `pty://` link keeps until both halves are dropped: the slave side, held open so
/// reading the master never fails with EIO while nobody is attached, and the symlink that
/// points to it, removed at the end.
#[derive(Debug)]
#[cfg_attr(not(unix), allow(dead_code))]
struct PtyKeep {
    _slave: Port,
    link: PathBuf,
    target: PathBuf,
}

impl Drop for PtyKeep {
    fn drop(&mut self) {
        // Only remove the link if it is still ours: a later run may have taken the name.
        if std::fs::read_link(&self.link).is_ok_and(|t| t == self.target) {
            let _ = std::fs::remove_file(&self.link);
        }
    }
}

#[derive(Debug)]
struct TtyReader {
    port: Port,
    bell: Option<Arc<Bell>>,
    _keep: Option<Arc<PtyKeep>>,
}

/// The port's descriptor, for a wait beside the bell.
#[cfg(unix)]
#[allow(unsafe_code)]
fn descriptor(port: &Port) -> std::os::fd::BorrowedFd<'_> {
    use std::os::fd::AsRawFd;
    // SAFETY: the port owns the descriptor and closes it only when it is dropped, which the
    // borrow of `port` rules out while the result lives. (`serialport` gives no `AsFd`.)
    unsafe { std::os::fd::BorrowedFd::borrow_raw(port.as_raw_fd()) }
}

impl LinkReader for TtyReader {
    fn woken_at_stop(&self) -> bool {
        cfg!(unix) && self.bell.is_some()
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        #[cfg(unix)]
        if let Some(bell) = &self.bell {
            // Bytes, a hang-up or an error: the read below takes it at once.
            if bell.wait(Some(descriptor(&self.port)), timeout)? != crate::link::Rang::Device {
                return Ok(0);
            }
        }
        self.port.set_timeout(timeout)?;
        match self.port.read(buf) {
            // The device said "readable" and then had nothing: it hung up (a USB adapter
            // unplugged, say). Reporting Ok(0) would have the caller spin on it.
            Ok(0) => Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "the serial device hung up",
            )),
            Ok(n) => Ok(n),
            Err(e) if is_timeout(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }
}

#[derive(Debug)]
struct TtyWriter {
    port: Port,
    _keep: Option<Arc<PtyKeep>>,
}

impl LinkWriter for TtyWriter {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        written(self.port.write(bytes))
    }
}

/// Creates a pseudo-terminal pair, links `name` to its slave device and talks through the
/// master. Both ends stay open for the lifetime of the link.
#[cfg(unix)]
pub(crate) fn open_pty(name: &str, bell: Option<Arc<Bell>>) -> io::Result<Halves> {
    use crate::WRITE_TIMEOUT;
    use std::path::Path;

    // `TTYPort::pair` puts the slave in raw mode (`cfmakeraw`: no echo, no line editing, no
    // CR/LF translation, 8-bit clean). The settings are shared with the master.
    let (mut master, slave) = serialport::TTYPort::pair()?;
    let target = PathBuf::from(
        slave
            .name()
            .ok_or_else(|| io::Error::other("the pty slave has no device path"))?,
    );
    let link = Path::new(name);
    match std::fs::symlink_metadata(link) {
        Ok(meta) if meta.file_type().is_symlink() => std::fs::remove_file(link)?,
        Ok(_) => {
            return Err(io::Error::new(
                io::ErrorKind::AlreadyExists,
                format!(
                    "{} exists and is not a symlink; refusing to replace it",
                    link.display()
                ),
            ))
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
        Err(e) => return Err(e),
    }
    std::os::unix::fs::symlink(&target, link)?;
    let keep = Arc::new(PtyKeep {
        _slave: slave,
        link: link.to_owned(),
        target,
    });
    master.set_timeout(WRITE_TIMEOUT)?;
    halves(master, Some(keep), bell)
}

#[cfg(not(unix))]
pub(crate) fn open_pty(_name: &str, _bell: Option<Arc<Bell>>) -> io::Result<Halves> {
    Err(io::Error::new(
        io::ErrorKind::Unsupported,
        "pty:// links need a Unix system",
    ))
}
