//! `udp://HOST[:IN_PORT][:OUT_PORT]`: one datagram per write, one per read.

use std::io;
use std::net::{Ipv4Addr, Ipv6Addr, SocketAddr, UdpSocket};
use std::time::Duration;

use crate::{is_timeout, resolve, socket_timeout, Halves, LinkReader, LinkWriter};

/// Binds `in_port` on the unspecified address of the peer's family and sends to
/// `host:out_port` (the first address `host` resolves to, IPv4 preferred).
pub(crate) fn open(host: &str, in_port: u16, out_port: u16) -> io::Result<Halves> {
    let peer = resolve(host, out_port)?[0];
    let local = match peer {
        SocketAddr::V4(_) => SocketAddr::from((Ipv4Addr::UNSPECIFIED, in_port)),
        SocketAddr::V6(_) => SocketAddr::from((Ipv6Addr::UNSPECIFIED, in_port)),
    };
    let socket = UdpSocket::bind(local)?;
    let reader = UdpReader {
        socket: socket.try_clone()?,
    };
    Ok((Box::new(reader), Box::new(UdpWriter { socket, peer })))
}

#[derive(Debug)]
struct UdpReader {
    socket: UdpSocket,
}

impl LinkReader for UdpReader {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        self.socket
            .set_read_timeout(Some(socket_timeout(timeout)))?;
        match self.socket.recv_from(buf) {
            Ok((n, _from)) => Ok(n),
            Err(e) if is_timeout(&e) => Ok(0),
            // Some systems report an ICMP "port unreachable" for an earlier datagram on the
            // next receive. The peer not running (yet) is no reason to give up on the link.
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::ConnectionRefused | io::ErrorKind::ConnectionReset
                ) =>
            {
                Ok(0)
            }
            Err(e) => Err(e),
        }
    }
}

#[derive(Debug)]
struct UdpWriter {
    socket: UdpSocket,
    peer: SocketAddr,
}

impl LinkWriter for UdpWriter {
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        let sent = self.socket.send_to(bytes, self.peer)?;
        if sent != bytes.len() {
            return Err(io::Error::new(
                io::ErrorKind::WriteZero,
                format!(
                    "sent {sent} of {} bytes in a datagram to {}",
                    bytes.len(),
                    self.peer
                ),
            ));
        }
        Ok(())
    }
}
