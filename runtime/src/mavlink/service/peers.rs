//! Heartbeats and link state: which systems are there, and which were lost.
//!
//! [`Peers`] keeps the last `N` components heard in a HEARTBEAT. One that stays silent for
//! [`Peers::timeout_us`] (3 s, as MAVSDK) is lost. Clients pick their target from it: the first
//! vehicle is the first system whose autopilot is not `MAV_AUTOPILOT_INVALID`.

use super::messages::{MavAutopilot, MavType, Message};
use super::Address;

/// A component heard in a HEARTBEAT.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Peer {
    /// Its system and component.
    pub address: Address,
    /// Its autopilot (`Invalid` for ground stations and most payloads).
    pub autopilot: MavAutopilot,
    /// Its type.
    pub kind: MavType,
    /// When it was first heard (µs), since it was last lost.
    pub since_us: u64,
    /// When its last HEARTBEAT came (µs).
    pub last_us: u64,
}

impl Peer {
    /// Whether it is a vehicle's autopilot rather than a ground station or a payload.
    pub fn is_vehicle(&self) -> bool {
        self.autopilot != MavAutopilot::Invalid
    }
}

/// A change in the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// A component was heard for the first time (or again after it was lost).
    Seen(Peer),
    /// A component stayed silent past the timeout.
    Lost(Peer),
}

/// The components heard, up to `N`; when full, the one silent longest makes room.
#[derive(Debug, Clone)]
pub struct Peers<const N: usize> {
    peers: [Option<Peer>; N],
    /// Silence after which a peer is lost: 3 s by default.
    pub timeout_us: u64,
    events: [Option<Event>; 4],
}

impl<const N: usize> Default for Peers<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Peers<N> {
    /// An empty table.
    pub const fn new() -> Self {
        Self {
            peers: [None; N],
            timeout_us: 3_000_000,
            events: [None; 4],
        }
    }

    fn push(&mut self, event: Event) {
        if let Some(slot) = self.events.iter_mut().find(|e| e.is_none()) {
            *slot = Some(event);
        }
    }

    /// A message from `from`: HEARTBEATs update the table.
    pub fn handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        let Message::Heartbeat(hb) = msg else { return };
        let mut peer = Peer {
            address: from,
            autopilot: hb.autopilot,
            kind: hb.r#type,
            since_us: now_us,
            last_us: now_us,
        };
        if let Some(p) = self.peers.iter_mut().flatten().find(|p| p.address == from) {
            peer.since_us = p.since_us;
            *p = peer;
            return;
        }
        let slot = match self.peers.iter().position(Option::is_none) {
            Some(i) => i,
            None => {
                let Some((i, _)) = self
                    .peers
                    .iter()
                    .enumerate()
                    .min_by_key(|(_, p)| p.map_or(0, |p| p.last_us))
                else {
                    return;
                };
                i
            }
        };
        self.peers[slot] = Some(peer);
        self.push(Event::Seen(peer));
    }

    /// Drops the peers silent since `now_us - timeout_us`, with an event each.
    pub fn expire(&mut self, now_us: u64) {
        for i in 0..N {
            if let Some(p) = self.peers[i] {
                if now_us.saturating_sub(p.last_us) > self.timeout_us {
                    self.peers[i] = None;
                    self.push(Event::Lost(p));
                }
            }
        }
    }

    /// When the next peer would be lost.
    pub fn poll_timeout(&self) -> Option<u64> {
        self.peers
            .iter()
            .flatten()
            .map(|p| p.last_us.saturating_add(self.timeout_us).saturating_add(1))
            .min()
    }

    /// The next change, oldest first.
    pub fn poll_event(&mut self) -> Option<Event> {
        let e = self.events[0].take();
        self.events.rotate_left(1);
        e
    }

    /// Every peer heard and not lost.
    pub fn iter(&self) -> impl Iterator<Item = &Peer> {
        self.peers.iter().flatten()
    }

    /// The peer at `address`.
    pub fn get(&self, address: Address) -> Option<&Peer> {
        self.iter().find(|p| p.address == address)
    }

    /// The target clients take by default: the vehicle heard first (of those not lost),
    /// component 1 of its system.
    pub fn first_vehicle(&self) -> Option<Peer> {
        self.iter()
            .filter(|p| p.is_vehicle())
            .min_by_key(|p| p.since_us)
            .map(|p| Peer {
                address: Address::new(p.address.system, 1),
                ..*p
            })
    }
}

#[cfg(test)]
mod tests {
    use super::super::messages::Heartbeat;
    use super::*;

    fn hb(autopilot: MavAutopilot) -> Message {
        Message::Heartbeat(Heartbeat {
            autopilot,
            ..Default::default()
        })
    }

    #[test]
    fn peers_are_seen_and_lost() {
        let mut peers: Peers<4> = Peers::new();
        let gcs = Address::new(255, 190);
        let vehicle = Address::new(7, 1);
        peers.handle(0, gcs, &hb(MavAutopilot::Invalid));
        assert_eq!(peers.first_vehicle(), None);
        peers.handle(10, vehicle, &hb(MavAutopilot::Px4));
        assert!(matches!(peers.poll_event(), Some(Event::Seen(p)) if p.address == gcs));
        assert!(matches!(peers.poll_event(), Some(Event::Seen(p)) if p.address == vehicle));
        assert_eq!(peers.poll_event(), None);
        assert_eq!(
            peers.first_vehicle().map(|p| p.address),
            Some(Address::new(7, 1))
        );
        peers.handle(2_000_000, vehicle, &hb(MavAutopilot::Px4));
        assert_eq!(peers.poll_timeout(), Some(3_000_001));
        peers.expire(3_000_001);
        assert!(matches!(peers.poll_event(), Some(Event::Lost(p)) if p.address == gcs));
        assert!(peers.get(vehicle).is_some());
        peers.expire(5_000_001);
        assert!(matches!(peers.poll_event(), Some(Event::Lost(p)) if p.address == vehicle));
        assert_eq!(peers.iter().count(), 0);
    }
}
