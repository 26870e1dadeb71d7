//! The halves of a connected TCP stream, for the link layer's clients and servers.

use std::io::{self, Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use crate::{is_timeout, socket_timeout, written, Halves, LinkReader, LinkWriter, WRITE_TIMEOUT};

/// The halves of one connected stream (a client, or one client of a server), set up for small,
/// latency-sensitive frames (`TCP_NODELAY`), writes giving up after [`WRITE_TIMEOUT`]. Reading
/// reports the other side closing as `UnexpectedEof`.
pub(crate) fn stream_halves(stream: TcpStream) -> io::Result<Halves> {
    // Accepted sockets inherit the listener's non-blocking flag on some systems.
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    let reader = TcpReader {
        stream: stream.try_clone()?,
    };
    Ok((Box::new(reader), Box::new(TcpWriter { stream })))
}

#[derive(Debug)]
struct TcpReader {
    stream: TcpStream,
}

impl LinkReader for TcpReader {
    fn woken_at_stop(&self) -> bool {
        true
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        self.stream
            .set_read_timeout(Some(socket_timeout(timeout)))?;
        match self.stream.read(buf) {
            Ok(0) => Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "the other side closed the connection",
            )),
            Ok(n) => Ok(n),
            Err(e) if is_timeout(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }
}

#[derive(Debug)]
struct TcpWriter {
    stream: TcpStream,
}

impl LinkWriter for TcpWriter {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        written(self.stream.write(bytes))
    }

    fn close(&mut self) -> bool {
        self.stream.shutdown(std::net::Shutdown::Both).is_ok()
    }
}
