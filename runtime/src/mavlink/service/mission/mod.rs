//! The mission protocol: upload and download of missions, geofences and rally points
//! (MISSION_COUNT, MISSION_REQUEST_INT, MISSION_ITEM_INT, MISSION_ACK), MISSION_CLEAR_ALL and
//! MISSION_SET_CURRENT.
//!
//! Both sides time out and retry. Items come one at a time, each asked for by its sequence
//! number; a duplicate or an item out of turn is ignored and the one due is asked for again.
//!
//! - A lost final MISSION_ACK does not leave either side stuck: a client whose upload got no ACK
//!   sends its last item again, and a server that completed that upload answers with the ACK
//!   again.
//! - A server never holds half a mission: a [`Store`] receives an upload beside the current
//!   mission and takes it only when every item is in.
//! - `MAV_MISSION_INVALID_SEQUENCE` in the middle of an upload (ArduPilot sends it when an item
//!   comes out of turn, then carries on) does not end it.
//! - A server asked with MISSION_REQUEST (not `_INT`) answers with MISSION_ITEM, degrees as
//!   floats, as ArduPilot does.

// MISSION_ITEM, MISSION_REQUEST and MISSION_SET_CURRENT are deprecated in common.xml, but
// ArduPilot and older ground stations still send them: the server answers them.
#![allow(deprecated)]

mod client;
mod server;

pub use client::{Client, ClientConfig, Event};
pub use server::{Server, ServerConfig};

use super::command::scale_int;
use super::messages::{MavCmd, MavFrame, MavMissionType, Message, MissionItem, MissionItemInt};
use super::{div_f32, mul_round, Address};

/// One mission item, as MISSION_ITEM_INT carries it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Item {
    /// The frame of x, y and z.
    pub frame: MavFrame,
    /// The command.
    pub command: MavCmd,
    /// Whether it is the current item (1) or not (0).
    pub current: u8,
    /// Continue to the next item when done (1) or not (0).
    pub autocontinue: u8,
    /// param1 to param4.
    pub params: [f32; 4],
    /// param5: latitude × 10⁷ in global frames, local x × 10⁴ in local ones.
    pub x: i32,
    /// param6: longitude × 10⁷, or local y × 10⁴.
    pub y: i32,
    /// param7: altitude or local z.
    pub z: f32,
}

impl Item {
    fn to_int(self, seq: u16, to: Address, mission_type: MavMissionType) -> Message {
        let [param1, param2, param3, param4] = self.params;
        Message::MissionItemInt(MissionItemInt {
            target_system: to.system,
            target_component: to.component,
            seq,
            frame: self.frame,
            command: self.command,
            current: self.current,
            autocontinue: self.autocontinue,
            param1,
            param2,
            param3,
            param4,
            x: self.x,
            y: self.y,
            z: self.z,
            mission_type,
        })
    }

    /// As MISSION_ITEM: x and y as floats in the frame's units (degrees, metres).
    fn to_float(self, seq: u16, to: Address, mission_type: MavMissionType) -> Message {
        let [param1, param2, param3, param4] = self.params;
        let s = scale_int(self.frame);
        Message::MissionItem(MissionItem {
            target_system: to.system,
            target_component: to.component,
            seq,
            frame: self.frame,
            command: self.command,
            current: self.current,
            autocontinue: self.autocontinue,
            param1,
            param2,
            param3,
            param4,
            // (f64::from(self.x) / scale(self.frame)) as f32, in integers.
            x: div_f32(self.x, s),
            y: div_f32(self.y, s),
            z: self.z,
            mission_type,
        })
    }

    fn from_int(m: &MissionItemInt) -> Self {
        Self {
            frame: m.frame,
            command: m.command,
            current: m.current,
            autocontinue: m.autocontinue,
            params: [m.param1, m.param2, m.param3, m.param4],
            x: m.x,
            y: m.y,
            z: m.z,
        }
    }

    fn from_float(m: &MissionItem) -> Self {
        let s = scale_int(m.frame);
        Self {
            frame: m.frame,
            command: m.command,
            current: m.current,
            autocontinue: m.autocontinue,
            params: [m.param1, m.param2, m.param3, m.param4],
            // round_i32(f64::from(m.x) * scale(m.frame)), in integers.
            x: mul_round(m.x, s),
            y: mul_round(m.y, s),
            z: m.z,
        }
    }

    /// Equal, floats bit for bit.
    pub fn same(&self, other: &Self) -> bool {
        let bits = |i: &Self| {
            (
                i.params.map(f32::to_bits),
                i.z.to_bits(),
                (i.frame, i.command, i.current, i.autocontinue, i.x, i.y),
            )
        };
        bits(self) == bits(other)
    }
}

/// Items as a [`Client`] uploads them or collects a download: the caller's storage.
pub trait Items {
    /// How many there are.
    fn len(&self) -> u16;
    /// Item `seq`.
    fn get(&self, seq: u16) -> Option<Item>;
    /// A download is starting with `count` items; false if they do not fit.
    fn reset(&mut self, count: u16) -> bool;
    /// Item `seq` of a download.
    fn put(&mut self, seq: u16, item: Item);
    /// Whether there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Where a [`Server`] keeps its missions, fences and rally points. An upload is received beside
/// the current one and replaces it only at [`Store::commit`].
pub trait Store {
    /// How many items of `kind` it holds.
    fn count(&self, kind: MavMissionType) -> u16;
    /// Item `seq` of `kind`.
    fn get(&self, kind: MavMissionType, seq: u16) -> Option<Item>;
    /// An upload of `count` items of `kind` begins; false if it cannot take that many (the
    /// server answers `MAV_MISSION_NO_SPACE`).
    fn begin(&mut self, kind: MavMissionType, count: u16) -> bool;
    /// Item `seq` of the upload.
    fn put(&mut self, kind: MavMissionType, seq: u16, item: Item);
    /// Every item of the upload is in: it becomes the current one.
    fn commit(&mut self, kind: MavMissionType);
    /// Forgets every item of `kind` (`All`: of every kind).
    fn clear(&mut self, kind: MavMissionType);
    /// The current mission item.
    fn current(&self) -> u16;
    /// Makes `seq` the current item; false if there is no such item.
    fn set_current(&mut self, seq: u16) -> bool;
}
