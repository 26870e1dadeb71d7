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
//! Items are kept as [`Slot`]s, an [`Item`] with its enums as their wire numbers: a `const`
//! empty store is then all zero bytes and starts in `.bss`, with no initial image in flash. A
//! slot is 36 bytes on thumbv7em: the two banks take 7200 B, the fence and rally arrays 864 B.

use ferrolink_runtime::mavlink::service::messages::{MavCmd, MavFrame, MavMissionType};
use ferrolink_runtime::mavlink::service::mission::{Item, Store};

/// The most mission items.
pub const MISSION_ITEMS: usize = 100;
/// The most geofence items (polygon vertices and circles).
pub const FENCE_ITEMS: usize = 16;
/// The most rally points.
pub const RALLY_ITEMS: usize = 8;

const _: () = assert!(FENCE_ITEMS <= MISSION_ITEMS && RALLY_ITEMS <= MISSION_ITEMS);

/// An [`Item`] as kept: the same fields, the frame and the command as their wire numbers.
#[derive(Debug, Clone, Copy)]
struct Slot {
    params: [f32; 4],
    x: i32,
    y: i32,
    z: f32,
    command: u16,
    frame: u8,
    current: u8,
    autocontinue: u8,
}

impl Slot {
    /// All zero bytes.
    const EMPTY: Slot = Slot {
        params: [0.0; 4],
        x: 0,
        y: 0,
        z: 0.0,
        command: 0,
        frame: 0,
        current: 0,
        autocontinue: 0,
    };

    fn from_item(item: Item) -> Self {
        Self {
            params: item.params,
            x: item.x,
            y: item.y,
            z: item.z,
            command: item.command.raw(),
            frame: item.frame.raw(),
            current: item.current,
            autocontinue: item.autocontinue,
        }
    }

    fn to_item(self) -> Item {
        Item {
            frame: MavFrame::from_raw(self.frame),
            command: MavCmd::from_raw(self.command),
            current: self.current,
            autocontinue: self.autocontinue,
            params: self.params,
            x: self.x,
            y: self.y,
            z: self.z,
        }
    }
}

/// The kinds, as the index of [`Missions::len`] and the upload's kind (0: none).
const MISSION: u8 = 1;
const FENCE: u8 = 2;
const RALLY: u8 = 3;

/// The kind's number; 0 for `All` and unknown kinds, which hold nothing.
fn kind_index(kind: MavMissionType) -> u8 {
    match kind {
        MavMissionType::Mission => MISSION,
        MavMissionType::Fence => FENCE,
        MavMissionType::Rally => RALLY,
        _ => 0,
    }
}

/// The mission (in one of two banks), the geofence and the rally points. Every field is an
/// integer or a float, so that [`Missions::new`] is all zero bytes.
#[derive(Debug)]
pub struct Missions {
    banks: [[Slot; MISSION_ITEMS]; 2],
    fence: [Slot; FENCE_ITEMS],
    rally: [Slot; RALLY_ITEMS],
    /// Items held, by kind number (index 0 unused).
    len: [u16; 4],
    /// The bank that holds the mission; the other receives uploads.
    held: u8,
    /// The upload under way: its kind number (0: none) and its count.
    upload_kind: u8,
    upload_count: u16,
    current: u16,
}

impl Missions {
    /// Nothing held.
    pub const fn new() -> Self {
        Self {
            banks: [[Slot::EMPTY; MISSION_ITEMS]; 2],
            fence: [Slot::EMPTY; FENCE_ITEMS],
            rally: [Slot::EMPTY; RALLY_ITEMS],
            len: [0; 4],
            held: 0,
            upload_kind: 0,
            upload_count: 0,
            current: 0,
        }
    }

    fn held_bank(&self) -> usize {
        usize::from(self.held & 1)
    }

    fn spare_bank(&self) -> usize {
        1 - self.held_bank()
    }

    /// The items held of kind number `k`.
    fn items(&self, k: u8) -> &[Slot] {
        let items: &[Slot] = match k {
            MISSION => &self.banks[self.held_bank()],
            FENCE => &self.fence,
            RALLY => &self.rally,
            _ => &[],
        };
        let len = self.len.get(usize::from(k)).copied().unwrap_or(0);
        items.get(..usize::from(len)).unwrap_or_default()
    }
}

impl Store for Missions {
    fn count(&self, kind: MavMissionType) -> u16 {
        self.items(kind_index(kind)).len() as u16
    }

    fn get(&self, kind: MavMissionType, seq: u16) -> Option<Item> {
        self.items(kind_index(kind))
            .get(usize::from(seq))
            .map(|s| s.to_item())
    }

    fn begin(&mut self, kind: MavMissionType, count: u16) -> bool {
        let k = kind_index(kind);
        let capacity = match k {
            MISSION => MISSION_ITEMS,
            FENCE => FENCE_ITEMS,
            RALLY => RALLY_ITEMS,
            _ => 0,
        };
        let fits = usize::from(count) <= capacity;
        self.upload_kind = if fits { k } else { 0 };
        self.upload_count = count;
        fits
    }

    fn put(&mut self, kind: MavMissionType, seq: u16, item: Item) {
        if kind_index(kind) != self.upload_kind || seq >= self.upload_count {
            return;
        }
        let spare = self.spare_bank();
        if let Some(slot) = self.banks[spare].get_mut(usize::from(seq)) {
            *slot = Slot::from_item(item);
        }
    }

    fn commit(&mut self, kind: MavMissionType) {
        let k = kind_index(kind);
        if k == 0 || k != self.upload_kind {
            return;
        }
        self.upload_kind = 0;
        let spare = self.spare_bank();
        let n = usize::from(self.upload_count);
        let held = match k {
            // The spare bank becomes the mission; the old one receives the next upload.
            MISSION => {
                self.held = spare as u8;
                self.current = 0;
                None
            }
            FENCE => Some(&mut self.fence[..]),
            _ => Some(&mut self.rally[..]),
        };
        if let Some(items) = held {
            // `begin` made sure that the upload fits.
            let n = n.min(items.len());
            items[..n].copy_from_slice(&self.banks[spare][..n]);
        }
        self.len[usize::from(k)] = self.upload_count;
    }

    fn clear(&mut self, kind: MavMissionType) {
        match kind {
            MavMissionType::All => self.len = [0; 4],
            _ => self.len[usize::from(kind_index(kind))] = 0,
        }
        if matches!(kind, MavMissionType::Mission | MavMissionType::All) {
            self.current = 0;
        }
    }

    fn current(&self) -> u16 {
        self.current
    }

    fn set_current(&mut self, seq: u16) -> bool {
        let ok = seq < self.len[usize::from(MISSION)];
        if ok {
            self.current = seq;
        }
        ok
    }
}
