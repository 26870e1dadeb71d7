//! ModRob.Ethernet-1 over UDP: one [`link`] endpoint per module, packets batched per flush.
//!
//! Ethernet is a shared medium; on UDP each node stands for it by sending every datagram to each
//! of its peers (unicast fan-out, which also works on loopback, where broadcast does not). A
//! node queues messages with [`EthernetNode::queue`]; [`EthernetNode::flush`] packs them into as
//! few packets as fit [`MAX_DATAGRAM_LEN`] each, every packet with a fresh ULID from a monotonic
//! generator and the node's UUID. [`EthernetNode::receive`] drains what arrived without
//! blocking and counts packets that do not parse.

use std::io;
use std::net::SocketAddr;

use ferrolink_runtime::modrob::ethernet::{Packet, PacketBuilder, MAX_DATAGRAM_LEN};
use ferrolink_runtime::modrob::Message;

use crate::framed::{Datagrams, Framed};
use crate::link::{Endpoint, Sender};

/// Traffic counters of one node.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Packets sent (each counted once, not per peer).
    pub packets_sent: u64,
    /// Messages sent.
    pub messages_sent: u64,
    /// Bytes sent per peer (UDP payload).
    pub bytes_sent: u64,
    /// Packets received.
    pub packets_received: u64,
    /// Messages received.
    pub messages_received: u64,
    /// Datagrams that were not Ethernet-1 packets, and messages in them that did not decode.
    pub malformed: u64,
}

/// One module's Ethernet-1 endpoint.
pub struct EthernetNode {
    /// Every datagram that arrives, from any sender, through the one read loop.
    framed: Framed<Datagrams>,
    peers: Vec<(SocketAddr, Sender)>,
    uuid: [u8; 16],
    ulids: ulid::Generator,
    pending: Vec<Message>,
    stats: Stats,
}

impl std::fmt::Debug for EthernetNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EthernetNode")
            .field("local", &self.framed.local_addr())
            .field(
                "peers",
                &self.peers.iter().map(|(a, _)| a).collect::<Vec<_>>(),
            )
            .field("pending", &self.pending.len())
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl EthernetNode {
    /// Binds `local` for the module with UUID `uuid`, sending to `peers`.
    pub fn bind(local: SocketAddr, uuid: [u8; 16], peers: Vec<SocketAddr>) -> io::Result<Self> {
        let framed = Framed::open(
            &Endpoint::UdpIn(local.ip().to_string(), local.port()),
            Datagrams::default,
        )?;
        let mut node = Self {
            framed,
            peers: Vec::new(),
            uuid,
            ulids: ulid::Generator::new(),
            pending: Vec::new(),
            stats: Stats::default(),
        };
        node.set_peers(peers);
        Ok(node)
    }

    /// The bound address.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.framed
            .local_addr()
            .ok_or_else(|| io::Error::from(io::ErrorKind::AddrNotAvailable))
    }

    /// Replaces the peers.
    pub fn set_peers(&mut self, peers: Vec<SocketAddr>) {
        let framed = &self.framed;
        self.peers = peers
            .into_iter()
            .filter_map(|a| Some((a, framed.sender_to(a)?)))
            .collect();
    }

    /// The counters.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Queues a message for the next [`EthernetNode::flush`].
    pub fn queue(&mut self, message: Message) {
        self.pending.push(message);
    }

    /// Sends every queued message, batched into packets; returns how many packets.
    pub fn flush(&mut self) -> io::Result<usize> {
        let mut packets = 0;
        let mut buf = [0u8; MAX_DATAGRAM_LEN];
        let mut rest = &self.pending[..];
        while !rest.is_empty() {
            let id = self
                .ulids
                .generate()
                .map_err(|e| io::Error::other(e.to_string()))?;
            let mut builder = PacketBuilder::new(&mut buf, id.to_bytes(), self.uuid)
                .map_err(|e| io::Error::other(e.to_string()))?;
            let mut taken = 0;
            for m in rest {
                if builder.push(m).is_err() {
                    break;
                }
                taken += 1;
            }
            let count = builder.count();
            let bytes = builder.finish();
            for (_, peer) in &self.peers {
                match peer.send(bytes) {
                    Ok(_) => {}
                    // A peer that is not up yet is not an error on a shared medium.
                    Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {}
                    Err(e) => return Err(e),
                }
            }
            self.stats.packets_sent += 1;
            self.stats.messages_sent += u64::from(count);
            self.stats.bytes_sent += bytes.len() as u64;
            packets += 1;
            rest = &rest[taken.max(1)..];
        }
        self.pending.clear();
        Ok(packets)
    }

    /// Hands every message that arrived to `on_message(sender UUID, message)`, without
    /// blocking; returns how many messages.
    pub fn receive(&mut self, mut on_message: impl FnMut([u8; 16], Message)) -> io::Result<usize> {
        let mut n = 0;
        let stats = &mut self.stats;
        self.framed.poll(|_, datagram| {
            let Ok(packet) = Packet::new_checked(datagram) else {
                stats.malformed += 1;
                return;
            };
            stats.packets_received += 1;
            let sender = packet.module_id();
            for message in packet.messages() {
                match message {
                    Ok(m) => {
                        stats.messages_received += 1;
                        n += 1;
                        on_message(sender, m);
                    }
                    Err(_) => stats.malformed += 1,
                }
            }
        })?;
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_and_fans_out() -> io::Result<()> {
        let any = "127.0.0.1:0".parse().expect("addr");
        let mut a = EthernetNode::bind(any, [1; 16], Vec::new())?;
        let mut b = EthernetNode::bind(any, [2; 16], Vec::new())?;
        let mut c = EthernetNode::bind(any, [3; 16], Vec::new())?;
        a.set_peers(vec![b.local_addr()?, c.local_addr()?]);
        for v in 0..150u8 {
            a.queue(Message::Publication {
                module: 7,
                variable: v,
                value: f32::from(v),
            });
        }
        assert_eq!(a.flush()?, 2, "119 + 31 messages");
        for node in [&mut b, &mut c] {
            let mut got = Vec::new();
            let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
            while got.len() < 150 && std::time::Instant::now() < deadline {
                node.receive(|uuid, m| got.push((uuid, m)))?;
            }
            assert_eq!(got.len(), 150);
            assert!(got.iter().all(|(uuid, _)| *uuid == [1; 16]));
            assert_eq!(
                got[149].1,
                Message::Publication {
                    module: 7,
                    variable: 149,
                    value: 149.0
                }
            );
        }
        Ok(())
    }
}
