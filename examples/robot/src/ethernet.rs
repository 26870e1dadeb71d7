//! The same robot over ModRob.Ethernet-1: every module in its own thread with its own UDP socket
//! on loopback, batching what it sends into Ethernet-1 packets with its UUID and a ULID per
//! packet. The leader, in the motion controller's thread, has a second socket upstream, to the
//! host (the caller's thread), which sends velocity commands and counts what comes up.
//!
//! Ports: module `i` at `base + i`, the leader's upstream socket at `base + n`, the host at
//! `base + n + 1` (n modules).
//!
//! With the `zenoh` feature, the leader's upstream port can be a Zenoh network instead
//! (`ferrolink_zenoh::modrob`): what goes up is put on `<prefix>/modrob/robot/<instance>/
//! <variable>`, and commands come down from whoever puts on `.../<variable>/set`; the host
//! thread then only reports.

use std::io;
use std::net::{Ipv4Addr, SocketAddr};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use ferrolink_generated::modrob::{motion_control, robot};
use ferrolink_io::modrob::udp::EthernetNode;
use ferrolink_runtime::modrob::leader::{Leader, Port};
use ferrolink_runtime::modrob::{CommandKind, Message};

use crate::can::command_at;
use crate::modules::{build, Module};

/// Counters shared by the threads.
#[derive(Debug, Default)]
pub struct Shared {
    /// Messages sent, by type: command, publication, piecewise.
    pub sent: [AtomicU64; 3],
    /// Packets sent.
    pub packets: AtomicU64,
    /// UDP payload bytes sent (once per packet, not per peer).
    pub bytes: AtomicU64,
    /// Messages the host received from the leader.
    pub upstream: AtomicU64,
    /// Per module: subscription updates applied.
    pub subscription_updates: Vec<AtomicU64>,
    /// Per module: whether the leader has configured it.
    pub configured: Vec<AtomicBool>,
}

fn addr(port: u16) -> SocketAddr {
    SocketAddr::from((Ipv4Addr::LOCALHOST, port))
}

fn kind(m: &Message) -> usize {
    match m {
        Message::Command { .. } => 0,
        Message::Publication { .. } => 1,
        Message::Piecewise { .. } => 2,
    }
}

/// Where the leader's upstream port goes.
#[derive(Debug)]
pub enum Upstream {
    /// The host thread, over Ethernet-1 on UDP.
    Host,
    /// A Zenoh network, named by a `zenoh://` URI.
    #[cfg(feature = "zenoh")]
    Zenoh(ferrolink_zenoh::ZenohUri),
}

/// The leader's upstream port, open.
enum UpPort {
    Host(Box<EthernetNode>),
    #[cfg(feature = "zenoh")]
    Zenoh(Box<ferrolink_zenoh::modrob::Upstream>),
}

impl UpPort {
    /// Takes what came down.
    fn receive(&mut self, on_message: impl FnMut(Message)) -> io::Result<()> {
        let mut on_message = on_message;
        match self {
            UpPort::Host(node) => node.receive(|_, m| on_message(m)).map(|_| ()),
            #[cfg(feature = "zenoh")]
            UpPort::Zenoh(up) => {
                up.receive(on_message);
                Ok(())
            }
        }
    }

    /// Sends what goes up; returns how many messages.
    fn send(&mut self, messages: Vec<Message>) -> io::Result<u64> {
        let n = messages.len() as u64;
        match self {
            UpPort::Host(node) => {
                for m in messages {
                    node.queue(m);
                }
                node.flush()?;
            }
            #[cfg(feature = "zenoh")]
            UpPort::Zenoh(up) => {
                for m in &messages {
                    up.publish(m)?;
                }
            }
        }
        Ok(n)
    }
}

/// Runs the robot for `duration` from ports `base..`; `report` is called with the counters
/// about once a second from the caller's thread, which is also the host (when the leader's
/// upstream goes there).
pub fn run(
    base: u16,
    duration: Duration,
    upstream: Upstream,
    mut report: impl FnMut(Duration, &Shared),
) -> io::Result<Arc<Shared>> {
    let r = &robot::ROBOT;
    let n = r.instances.len();
    let port = |i: usize| -> io::Result<u16> {
        base.checked_add(i as u16)
            .ok_or_else(|| io::Error::other("base port too high"))
    };
    let shared = Arc::new(Shared {
        subscription_updates: (0..n).map(|_| AtomicU64::new(0)).collect(),
        configured: (0..n).map(|_| AtomicBool::new(false)).collect(),
        ..Shared::default()
    });
    let stop = Arc::new(AtomicBool::new(false));
    let start = Instant::now();
    let mut host = EthernetNode::bind(addr(port(n + 1)?), [0xEE; 16], vec![addr(port(n)?)])?;
    let mut threads = Vec::new();
    for (i, inst) in r.instances.iter().enumerate() {
        let peers = (0..n)
            .filter(|&j| j != i)
            .map(|j| port(j).map(addr))
            .collect::<io::Result<Vec<_>>>()?;
        let node = EthernetNode::bind(addr(port(i)?), inst.uuid.unwrap_or_default(), peers)?;
        let upstream = match (i == r.leader, &upstream) {
            (false, _) => None,
            (true, Upstream::Host) => Some(UpPort::Host(Box::new(EthernetNode::bind(
                addr(port(n)?),
                inst.uuid.unwrap_or_default(),
                vec![addr(port(n + 1)?)],
            )?))),
            #[cfg(feature = "zenoh")]
            (true, Upstream::Zenoh(uri)) => Some(UpPort::Zenoh(Box::new(
                ferrolink_zenoh::modrob::Upstream::open(
                    uri,
                    &robot::ROBOT,
                    crate::modules::variable_name,
                )?,
            ))),
        };
        let module = build(inst, i);
        let (shared, stop) = (shared.clone(), stop.clone());
        threads.push(thread::spawn(move || {
            run_module(i, module, node, upstream, start, &shared, &stop)
        }));
    }
    let mut next_report = Duration::from_secs(1);
    let mut next_command = Duration::ZERO;
    while start.elapsed() < duration {
        let now = start.elapsed();
        if now >= next_command && matches!(upstream, Upstream::Host) {
            let (linear, angular) = command_at(now.as_secs_f32());
            for (var, value) in [
                (motion_control::Var::LinearVelocity, linear),
                (motion_control::Var::AngularVelocity, angular),
            ] {
                host.queue(Message::Command {
                    module: robot::MOTION,
                    variable: var.vi(),
                    command: CommandKind::SetValue(value),
                });
            }
            host.flush()?;
            next_command += Duration::from_millis(100);
        }
        let got = host.receive(|_, _| {})?;
        shared.upstream.fetch_add(got as u64, Ordering::Relaxed);
        if now >= next_report {
            report(now, &shared);
            next_report += Duration::from_secs(1);
        }
        thread::sleep(Duration::from_millis(2));
    }
    stop.store(true, Ordering::Relaxed);
    for t in threads {
        t.join()
            .map_err(|_| io::Error::other("a module thread panicked"))??;
    }
    Ok(shared)
}

fn run_module(
    i: usize,
    mut module: Box<dyn Module>,
    mut node: EthernetNode,
    mut upstream: Option<UpPort>,
    start: Instant,
    shared: &Shared,
    stop: &AtomicBool,
) -> io::Result<()> {
    let mut leader = match upstream {
        Some(_) => Some(Leader::<'static, 16>::new(&robot::ROBOT).map_err(io::Error::other)?),
        None => None,
    };
    while !stop.load(Ordering::Relaxed) {
        let now = start.elapsed().as_micros() as u64;
        let mut to_parent = Vec::new();
        let mut received = Vec::new();
        node.receive(|_, m| received.push(m))?;
        for m in &received {
            let _ = module.handle(m);
            if let Some(leader) = leader.as_mut() {
                if leader.receive(Port::Network(0), m).upstream {
                    to_parent.push(*m);
                }
            }
        }
        if let (Some(up), Some(leader)) = (upstream.as_mut(), leader.as_mut()) {
            let mut commands = Vec::new();
            up.receive(|m| commands.push(m))?;
            for m in commands {
                let forward = leader.receive(Port::Upstream, &m);
                if forward.local {
                    let _ = module.handle(&m);
                }
                if forward.networks != 0 {
                    node.queue(m);
                }
            }
        }
        while let Some(m) = module.poll(now) {
            shared.sent[kind(&m)].fetch_add(1, Ordering::Relaxed);
            if leader.is_some() {
                to_parent.push(m);
            }
            node.queue(m);
        }
        if let Some(leader) = leader.as_mut() {
            while let Some(out) = leader.poll(now) {
                shared.sent[0].fetch_add(1, Ordering::Relaxed);
                node.queue(out.message);
            }
            for (j, flag) in shared.configured.iter().enumerate() {
                if leader.status(j).is_some_and(|s| s.configured) {
                    flag.store(true, Ordering::Relaxed);
                }
            }
        }
        let before = node.stats().bytes_sent;
        let packets = node.flush()?;
        shared.packets.fetch_add(packets as u64, Ordering::Relaxed);
        shared
            .bytes
            .fetch_add(node.stats().bytes_sent - before, Ordering::Relaxed);
        if let Some(up) = upstream.as_mut() {
            let sent = up.send(to_parent)?;
            // The host counts what it receives; what goes up to Zenoh is counted here.
            if !matches!(up, UpPort::Host(_)) {
                shared.upstream.fetch_add(sent, Ordering::Relaxed);
            }
        }
        shared.subscription_updates[i].store(
            module.counters().subscription_updates.into(),
            Ordering::Relaxed,
        );
        let next = module.next_deadline().unwrap_or(now + 1_000);
        let wait = next
            .saturating_sub(start.elapsed().as_micros() as u64)
            .clamp(100, 1_000);
        thread::sleep(Duration::from_micros(wait));
    }
    Ok(())
}
