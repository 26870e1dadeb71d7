//! UDP endpoints' readers: `udpin`, `udpbcast` and `udpmcast`, whose every sender is a peer of
//! its own, and the one-peer `udpout` and NDLCom `udp://` pair. Each takes every datagram that
//! has arrived with one `recvmmsg` and waits without a timeout (see [`super::Handle`]'s drop).
//! The multicast sockets are made here too.

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr};

use super::*;

/// How a reader with a peer per sender answers each, and what it ignores.
pub(super) struct Sources {
    /// The socket answers go out of: the reader's own, or a multicast endpoint's sending one.
    pub socket: Arc<UdpSocket>,
    /// Where answers go: the sender itself (`None`), or a multicast group.
    pub to: Option<SocketAddr>,
    /// The endpoint's peer whose sends reach every sender too (a broadcast address or a
    /// group), for [`Sender::reached_through`].
    pub through: Option<PeerId>,
    /// Our own datagrams, looped back: sent from this port, from one of these addresses.
    pub own: Option<(u16, Vec<IpAddr>)>,
}

impl Sources {
    /// A `udpin` socket's: answered from the socket, each sender directly.
    pub fn direct(socket: &Arc<UdpSocket>) -> Sources {
        Sources {
            socket: socket.clone(),
            to: None,
            through: None,
            own: None,
        }
    }

    fn is_own(&self, from: SocketAddr) -> bool {
        self.own
            .as_ref()
            .is_some_and(|(port, ips)| from.port() == *port && ips.contains(&from.ip()))
    }
}

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
    sources: &Sources,
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
                let Some(from) = from.filter(|from| !sources.is_own(*from)) else {
                    continue;
                };
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
                            sender: Sender::udp(
                                Arc::clone(&sources.socket),
                                sources.to.unwrap_or(from),
                                options.pack_up_to,
                            )
                            .through(sources.through),
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

/// A multicast endpoint's sockets.
pub(super) struct Multicast {
    /// Bound to the group's port, member of the group on the interface.
    pub receive: UdpSocket,
    /// Sends to the group from an ephemeral port, on the interface; nothing else reads it.
    pub send: UdpSocket,
    /// The group and port.
    pub group: SocketAddr,
    /// The interface's addresses (every address of this host without one): where our own
    /// datagrams come back from.
    pub local: Vec<IpAddr>,
}

/// Joins `group` on `iface` (by name; the system's choice without one) and makes the sending
/// socket. The receiving socket may share the port with other programs (`SO_REUSEADDR`), as
/// pymavlink's `mcast:` and ArduPilot's SITL do.
pub(super) fn multicast(group: &str, port: u16, iface: Option<&str>) -> io::Result<Multicast> {
    use socket2::{Domain, Protocol, Socket, Type};
    let group = resolve(group, port)?;
    if !group.ip().is_multicast() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{} is not a multicast group\n  hint: IPv4 groups are 224.0.0.0 to \
                 239.255.255.255 (ArduPilot uses 239.255.145.50), IPv6 groups start with ff",
                group.ip()
            ),
        ));
    }
    let (index, addresses) = interface(iface, group.is_ipv4())?;
    // A link-local group (ff02::...) is only meaningful on an interface.
    let group = match group {
        SocketAddr::V6(mut v6) if v6.scope_id() == 0 => {
            v6.set_scope_id(index);
            SocketAddr::V6(v6)
        }
        other => other,
    };
    let domain = Domain::for_address(group);
    let receive = Socket::new(domain, Type::DGRAM, Some(Protocol::UDP))?;
    receive.set_reuse_address(true)?;
    // Bound to the group itself where the system allows, so that only the group's datagrams
    // arrive, not those sent to the port directly.
    let bind = if cfg!(unix) {
        group
    } else {
        SocketAddr::new(unspecified(group), port)
    };
    receive.bind(&bind.into())?;
    let send = Socket::new(domain, Type::DGRAM, Some(Protocol::UDP))?;
    match group.ip() {
        IpAddr::V4(ip) => {
            let on = addresses
                .iter()
                .find_map(|a| match a {
                    IpAddr::V4(a) => Some(*a),
                    IpAddr::V6(_) => None,
                })
                .filter(|_| iface.is_some())
                .unwrap_or(Ipv4Addr::UNSPECIFIED);
            receive.join_multicast_v4(&ip, &on).map_err(|e| {
                with_hint(e, "no route for multicast; name the interface: ?iface=eth0")
            })?;
            send.set_multicast_if_v4(&on)?;
        }
        IpAddr::V6(ip) => {
            receive.join_multicast_v6(&ip, index).map_err(|e| {
                with_hint(e, "no route for multicast; name the interface: ?iface=eth0")
            })?;
            send.set_multicast_if_v6(index)?;
        }
    }
    send.bind(&SocketAddr::new(unspecified(group), 0).into())?;
    // Where our own datagrams cannot be told by their address, they are not looped back (and
    // other programs of this host in the group do not get them).
    #[cfg(not(unix))]
    {
        let _ = send.set_multicast_loop_v4(false);
        let _ = send.set_multicast_loop_v6(false);
    }
    let local = match iface {
        Some(_) => addresses,
        None => interface(None, group.is_ipv4())?.1,
    };
    Ok(Multicast {
        receive: receive.into(),
        send: send.into(),
        group,
        local,
    })
}

pub(super) fn unspecified(like: SocketAddr) -> IpAddr {
    match like {
        SocketAddr::V4(_) => Ipv4Addr::UNSPECIFIED.into(),
        SocketAddr::V6(_) => Ipv6Addr::UNSPECIFIED.into(),
    }
}

fn with_hint(e: io::Error, hint: &str) -> io::Error {
    io::Error::new(e.kind(), format!("{e}\n  hint: {hint}"))
}

/// The index and addresses (of the family asked for) of the interface named, or 0 and every
/// address of this host without a name.
#[cfg(unix)]
fn interface(name: Option<&str>, v4: bool) -> io::Result<(u32, Vec<IpAddr>)> {
    let index = match name {
        Some(name) => nix::net::if_::if_nametoindex(name).map_err(|_| {
            io::Error::new(
                io::ErrorKind::NotFound,
                format!("no network interface {name:?}\n  hint: `ip link` lists them"),
            )
        })?,
        None => 0,
    };
    let addresses = nix::ifaddrs::getifaddrs()
        .map_err(io::Error::from)?
        .filter(|a| name.is_none_or(|n| a.interface_name == n))
        .filter_map(|a| {
            let address = a.address?;
            match (address.as_sockaddr_in(), address.as_sockaddr_in6()) {
                (Some(v4_addr), _) if v4 => Some(IpAddr::V4(v4_addr.ip())),
                (_, Some(v6_addr)) if !v4 => Some(IpAddr::V6(v6_addr.ip())),
                _ => None,
            }
        })
        .collect();
    Ok((index, addresses))
}

#[cfg(not(unix))]
fn interface(name: Option<&str>, _v4: bool) -> io::Result<(u32, Vec<IpAddr>)> {
    match name {
        Some(name) => Err(io::Error::new(
            io::ErrorKind::Unsupported,
            format!("?iface={name}: naming the interface needs a Unix system"),
        )),
        None => Ok((0, Vec::new())),
    }
}
