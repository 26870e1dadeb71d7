//! UDP endpoints' readers: `udpin`, whose every sender is a peer of its own, and the one-peer
//! `udpout` and NDLCom `udp://` pair. Each takes every datagram that has arrived with one
//! `recvmmsg` and waits without a timeout (see [`super::Handle`]'s drop).

use super::*;

/// ICMP "port unreachable" answers to earlier datagrams: no reason to give up on a socket.
fn is_icmp_noise(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::ConnectionRefused | io::ErrorKind::ConnectionReset
    )
}

/// Up to how many peers a UDP reader keeps its sweep's time exact (it looks at each peer after
/// every batch for it).
const EXACT_SWEEP_PEERS: usize = 16;

pub(super) fn udp_in(
    index: usize,
    name: &str,
    socket: &Arc<UdpSocket>,
    options: Options,
    stop: &Stop,
    events: &Sink,
) {
    let expiry = options.peer_expiry;
    let mut peers: HashMap<SocketAddr, (PeerId, Instant)> = HashMap::new();
    // When the quietest peer would expire: the only reason to wake without a datagram. With
    // a few peers it is kept exact after every batch, so that the reader wakes only for a peer
    // that has gone quiet; with more, it may come early, and the sweep then sets it anew.
    let mut sweep_at: Option<Instant> = None;
    // A sweep may come up to a sixteenth of the expiry late.
    let mut inbox = batch::Inbox::new(expiry / 16);
    while !stop.is_set() {
        let received = inbox.receive(socket, sweep_at);
        if stop.is_set() {
            return;
        }
        let now = Instant::now();
        if sweep_at.is_some_and(|t| now >= t) {
            let mut gone = Vec::new();
            peers.retain(|addr, (peer, last)| {
                let keep = now.duration_since(*last) <= expiry;
                if !keep {
                    gone.push((*peer, *addr));
                }
                keep
            });
            sweep_at = peers.values().map(|(_, last)| *last + expiry).min();
            for (peer, addr) in gone {
                let why = format!("{addr} quiet for {} s", expiry.as_secs_f64());
                if !events(Event::Down { peer, why }) {
                    return;
                }
            }
        }
        match received {
            Ok(_) => {}
            Err(e) if is_timeout(&e) || is_icmp_noise(&e) => continue,
            Err(_) => {
                thread::sleep(POLL);
                continue;
            }
        }
        let listening = batch::batch(|| {
            for (bytes, from) in inbox.datagrams() {
                let Some(from) = from else { continue };
                let peer = match peers.get_mut(&from) {
                    Some((peer, last)) => {
                        *last = now;
                        *peer
                    }
                    None => {
                        let peer = next_peer();
                        peers.insert(from, (peer, now));
                        sweep_at = Some(sweep_at.map_or(now + expiry, |t| t.min(now + expiry)));
                        let up = Event::Up {
                            endpoint: index,
                            peer,
                            name: format!("{name} <- {from}"),
                            sender: Sender::udp(Arc::clone(socket), from, options.pack_up_to),
                        };
                        if !events(up) {
                            return false;
                        }
                        peer
                    }
                };
                if !events(Event::Rx {
                    peer,
                    bytes,
                    at: now,
                }) {
                    return false;
                }
            }
            true
        });
        if !listening {
            return;
        }
        if peers.len() <= EXACT_SWEEP_PEERS {
            sweep_at = peers.values().map(|(_, last)| *last + expiry).min();
        }
    }
}

/// Reads a UDP socket with one peer: every datagram, or (`udpout`) only those from `only_from`
/// (anything else reaching an ephemeral port is ignored).
pub(super) fn udp_one_peer(
    peer: PeerId,
    socket: &UdpSocket,
    only_from: Option<SocketAddr>,
    stop: &Stop,
    events: &Sink,
) {
    let mut inbox = batch::Inbox::new(Duration::ZERO);
    while !stop.is_set() {
        let received = inbox.receive(socket, None);
        if stop.is_set() {
            return;
        }
        match received {
            Ok(_) => {}
            Err(e) if is_timeout(&e) || is_icmp_noise(&e) => continue,
            Err(_) => {
                thread::sleep(POLL);
                continue;
            }
        }
        let at = Instant::now();
        let listening = batch::batch(|| {
            inbox
                .datagrams()
                .filter(|(_, from)| only_from.is_none_or(|to| Some(to) == *from))
                .all(|(bytes, _)| events(Event::Rx { peer, bytes, at }))
        });
        if !listening {
            return;
        }
    }
}
