//! Where the mission, the geofence and the rally points are kept: the mission server's
//! [`Store`].
//!
//! The server takes an upload beside what is held and commits it only once every item is in,
//! so a failed upload leaves the old one. It runs one upload at a time, so one spare bank of
//! [`MISSION_ITEMS`] receives an upload of any kind:
//!
//! - the mission lives in one of two banks; a mission upload fills the other, and the commit
//!   swaps them (nothing is copied);
//! - the geofence ([`FENCE_ITEMS`]) and the rally points ([`RALLY_ITEMS`]) have their own
//!   arrays; their uploads also fill the spare bank and are copied over at the commit.
//!
//! On thumbv7em an [`Item`] is 36 bytes: the two banks take 7200 B, the fence and rally arrays
//! 864 B.

use ferrolink_runtime::mavlink::service::messages::{MavCmd, MavFrame, MavMissionType};
use ferrolink_runtime::mavlink::service::mission::{Item, Store};

/// The most mission items.
pub const MISSION_ITEMS: usize = 100;
/// The most geofence items (polygon vertices and circles).
pub const FENCE_ITEMS: usize = 16;
/// The most rally points.
pub const RALLY_ITEMS: usize = 8;

const _: () = assert!(FENCE_ITEMS <= MISSION_ITEMS && RALLY_ITEMS <= MISSION_ITEMS);

/// An item of zero bytes, so that the stores start in `.bss`.
const EMPTY: Item = Item {
    frame: MavFrame::Global,
    command: MavCmd::NavWaypoint,
    current: 0,
    autocontinue: 0,
    params: [0.0; 4],
    x: 0,
    y: 0,
    z: 0.0,
};

/// An upload under way: its kind and its count.
#[derive(Debug, Clone, Copy)]
struct Upload {
    kind: MavMissionType,
    count: u16,
}

/// The mission (in one of two banks), the geofence and the rally points.
#[derive(Debug)]
pub struct Missions {
    banks: [[Item; MISSION_ITEMS]; 2],
    /// The bank that holds the mission; the other receives uploads.
    held: usize,
    mission_len: u16,
    fence: [Item; FENCE_ITEMS],
    fence_len: u16,
    rally: [Item; RALLY_ITEMS],
    rally_len: u16,
    current: u16,
    upload: Option<Upload>,
}

impl Missions {
    /// Nothing held.
    pub const fn new() -> Self {
        Self {
            banks: [[EMPTY; MISSION_ITEMS]; 2],
            held: 0,
            mission_len: 0,
            fence: [EMPTY; FENCE_ITEMS],
            fence_len: 0,
            rally: [EMPTY; RALLY_ITEMS],
            rally_len: 0,
            current: 0,
            upload: None,
        }
    }

    /// The items held of `kind` (`All` and unknown kinds: none).
    fn held(&self, kind: MavMissionType) -> &[Item] {
        let (items, len) = match kind {
            MavMissionType::Mission => (&self.banks[self.held][..], self.mission_len),
            MavMissionType::Fence => (&self.fence[..], self.fence_len),
            MavMissionType::Rally => (&self.rally[..], self.rally_len),
            _ => return &[],
        };
        items.get(..usize::from(len)).unwrap_or_default()
    }

    /// How many items of `kind` fit.
    fn capacity(kind: MavMissionType) -> usize {
        match kind {
            MavMissionType::Mission => MISSION_ITEMS,
            MavMissionType::Fence => FENCE_ITEMS,
            MavMissionType::Rally => RALLY_ITEMS,
            _ => 0,
        }
    }
}

impl Store for Missions {
    fn count(&self, kind: MavMissionType) -> u16 {
        self.held(kind).len() as u16
    }

    fn get(&self, kind: MavMissionType, seq: u16) -> Option<Item> {
        self.held(kind).get(usize::from(seq)).copied()
    }

    fn begin(&mut self, kind: MavMissionType, count: u16) -> bool {
        let fits = usize::from(count) <= Self::capacity(kind);
        self.upload = fits.then_some(Upload { kind, count });
        fits
    }

    fn put(&mut self, kind: MavMissionType, seq: u16, item: Item) {
        if !self.upload.is_some_and(|u| u.kind == kind && seq < u.count) {
            return;
        }
        if let Some(slot) = self.banks[1 - self.held].get_mut(usize::from(seq)) {
            *slot = item;
        }
    }

    fn commit(&mut self, kind: MavMissionType) {
        let Some(upload) = self.upload.take().filter(|u| u.kind == kind) else {
            return;
        };
        let spare = 1 - self.held;
        let (items, len) = match kind {
            MavMissionType::Mission => {
                self.held = spare;
                self.mission_len = upload.count;
                self.current = 0;
                return;
            }
            MavMissionType::Fence => (&mut self.fence[..], &mut self.fence_len),
            MavMissionType::Rally => (&mut self.rally[..], &mut self.rally_len),
            _ => return,
        };
        // `begin` made sure that the upload fits.
        let n = usize::from(upload.count).min(items.len());
        items[..n].copy_from_slice(&self.banks[spare][..n]);
        *len = n as u16;
    }

    fn clear(&mut self, kind: MavMissionType) {
        match kind {
            MavMissionType::Mission => self.mission_len = 0,
            MavMissionType::Fence => self.fence_len = 0,
            MavMissionType::Rally => self.rally_len = 0,
            MavMissionType::All => {
                self.mission_len = 0;
                self.fence_len = 0;
                self.rally_len = 0;
            }
            _ => return,
        }
        if matches!(kind, MavMissionType::Mission | MavMissionType::All) {
            self.current = 0;
        }
    }

    fn current(&self) -> u16 {
        self.current
    }

    fn set_current(&mut self, seq: u16) -> bool {
        let ok = seq < self.mission_len;
        if ok {
            self.current = seq;
        }
        ok
    }
}
