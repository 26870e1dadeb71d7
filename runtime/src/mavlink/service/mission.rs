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

use super::messages::{
    MavCmd, MavFrame, MavMissionResult, MavMissionType, Message, MissionAck, MissionCount,
    MissionCurrent, MissionItem, MissionItemInt, MissionRequestInt, MissionRequestList,
    MissionState,
};
use super::{command::scale, round_i32, Address, Busy, Retry, Rtt};

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
        let s = scale(self.frame);
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
            x: (f64::from(self.x) / s) as f32,
            y: (f64::from(self.y) / s) as f32,
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
        let s = scale(m.frame);
        Self {
            frame: m.frame,
            command: m.command,
            current: m.current,
            autocontinue: m.autocontinue,
            params: [m.param1, m.param2, m.param3, m.param4],
            x: round_i32(f64::from(m.x) * s),
            y: round_i32(f64::from(m.y) * s),
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

/// What a client's operation came to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// An upload ended: the server's answer, or `None` when it stopped answering.
    Uploaded(Option<MavMissionResult>),
    /// A download ended: its item count, or `None` when the server stopped answering (or the
    /// items did not fit).
    Downloaded(Option<u16>),
    /// A clear ended.
    Cleared(Option<MavMissionResult>),
    /// A set-current ended: the current item the server reports.
    CurrentSet(Option<u16>),
}

/// The client's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// Our own address.
    pub own: Address,
    /// The longest wait for an answer, and how many such waits of silence end an operation:
    /// 1.5 s and 5 retries by default (MAVSDK's). Below the longest wait, the client asks again
    /// after the measured round trip's timeout, doubled for each of the first two unanswered
    /// tries ([`Rtt::backoff_us`]); it gives up only as [`Retry::exhausted`] says.
    pub retry: Retry,
}

impl ClientConfig {
    /// The defaults, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            retry: Retry {
                timeout_us: 1_500_000,
                retries: 5,
            },
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    Idle,
    /// Sending the count, then items as asked; `last_sent` once the last item went out.
    Upload {
        count: u16,
        asked: bool,
        last_sent: bool,
    },
    /// Asking for the count, then item `next`.
    Download {
        count: Option<u16>,
        next: u16,
    },
    Clear,
    SetCurrent {
        seq: u16,
    },
}

/// The mission client for one target: one operation at a time.
#[derive(Debug, Clone)]
pub struct Client {
    config: ClientConfig,
    target: Address,
    kind: MavMissionType,
    op: Op,
    /// An item asked for, to send.
    due_item: Option<u16>,
    tries: u8,
    deadline: Option<u64>,
    /// Since when nothing came from the server (`None` before the first sending).
    silent_since: Option<u64>,
    sent_us: Option<u64>,
    rtt: Rtt,
    event: Option<Event>,
    /// The final ACK of a download, to send.
    ack_due: bool,
}

impl Client {
    /// A client for `target`.
    pub fn new(config: ClientConfig, target: Address) -> Self {
        Self {
            config,
            target,
            kind: MavMissionType::Mission,
            op: Op::Idle,
            due_item: None,
            tries: 0,
            deadline: None,
            silent_since: None,
            sent_us: None,
            rtt: Rtt::default(),
            event: None,
            ack_due: false,
        }
    }

    /// Whether no operation is under way.
    pub fn is_idle(&self) -> bool {
        self.op == Op::Idle
    }

    /// The round-trip estimate.
    pub fn rtt(&self) -> &Rtt {
        &self.rtt
    }

    fn start(&mut self, kind: MavMissionType, op: Op) -> Result<(), Busy> {
        if !self.is_idle() {
            return Err(Busy);
        }
        self.kind = kind;
        self.op = op;
        self.tries = 0;
        self.deadline = None;
        self.silent_since = None;
        self.due_item = None;
        Ok(())
    }

    /// Uploads `count` items of `kind` (taken from the [`Items`] given to `handle` and
    /// `poll_transmit`). Zero items clears that kind on the server.
    pub fn upload(&mut self, kind: MavMissionType, count: u16) -> Result<(), Busy> {
        self.start(
            kind,
            Op::Upload {
                count,
                asked: false,
                last_sent: false,
            },
        )
    }

    /// Downloads the items of `kind` into the [`Items`] given to `handle`.
    pub fn download(&mut self, kind: MavMissionType) -> Result<(), Busy> {
        self.start(
            kind,
            Op::Download {
                count: None,
                next: 0,
            },
        )
    }

    /// Clears every item of `kind` (`All`: every kind) on the server.
    pub fn clear(&mut self, kind: MavMissionType) -> Result<(), Busy> {
        self.start(kind, Op::Clear)
    }

    /// Makes `seq` the server's current mission item.
    pub fn set_current(&mut self, seq: u16) -> Result<(), Busy> {
        self.start(MavMissionType::Mission, Op::SetCurrent { seq })
    }

    fn finish(&mut self, event: Event) {
        self.op = Op::Idle;
        self.deadline = None;
        self.due_item = None;
        self.event = Some(event);
    }

    fn timeout_us(&self) -> u64 {
        self.rtt
            .backoff_us(self.config.retry.timeout_us, self.tries)
    }

    /// An answer came: the next wait starts afresh.
    fn answered(&mut self, now_us: u64) {
        if let Some(sent) = self.sent_us.take() {
            self.rtt.sample(now_us.saturating_sub(sent));
        }
        self.tries = 0;
        self.deadline = None;
        self.silent_since = Some(now_us);
    }

    fn is_target(&self, from: Address) -> bool {
        from.system == self.target.system
            && (self.target.component == 0 || from.component == self.target.component)
    }

    /// A message from `from`; `items` is what an upload sends from or a download fills.
    pub fn handle<I: Items + ?Sized>(
        &mut self,
        items: &mut I,
        now_us: u64,
        from: Address,
        msg: &Message,
    ) {
        if !self.is_target(from) {
            return;
        }
        let own = self.config.own;
        let kind = self.kind;
        // A request for an item, with or without _INT (a server that asks without it gets
        // MISSION_ITEM_INT all the same: MAVLink 2 servers take it, and it keeps positions
        // exact). Answered whatever its seq, a late copy of an earlier request too. Once the
        // last item went out, it stays the one to send again while the ACK is awaited.
        let request = match msg {
            Message::MissionRequestInt(r) => {
                Some((r.seq, r.mission_type, r.target_system, r.target_component))
            }
            Message::MissionRequest(r) => {
                Some((r.seq, r.mission_type, r.target_system, r.target_component))
            }
            _ => None,
        };
        if let (
            Op::Upload {
                count, last_sent, ..
            },
            Some((seq, mission_type, ts, tc)),
        ) = (self.op, request)
        {
            if mission_type == kind && own.is_addressed_by(ts, tc) && seq < count {
                self.answered(now_us);
                self.due_item = Some(seq);
                self.op = Op::Upload {
                    count,
                    asked: true,
                    last_sent,
                };
            }
            return;
        }
        match (self.op, msg) {
            // MAV_MISSION_INVALID_SEQUENCE is no end: ArduPilot answers an item out of turn
            // so, and carries on.
            (Op::Upload { .. }, Message::MissionAck(a))
                if a.mission_type == kind
                    && own.is_addressed_by(a.target_system, a.target_component)
                    && a.r#type != MavMissionResult::MavMissionInvalidSequence =>
            {
                self.answered(now_us);
                self.finish(Event::Uploaded(Some(a.r#type)));
            }
            (Op::Download { count: None, .. }, Message::MissionCount(c))
                if c.mission_type == kind
                    && own.is_addressed_by(c.target_system, c.target_component) =>
            {
                self.answered(now_us);
                if !items.reset(c.count) {
                    self.finish(Event::Downloaded(None));
                    return;
                }
                if c.count == 0 {
                    self.ack_due = true;
                    self.finish(Event::Downloaded(Some(0)));
                    return;
                }
                self.op = Op::Download {
                    count: Some(c.count),
                    next: 0,
                };
            }
            (
                Op::Download {
                    count: Some(count),
                    next,
                },
                Message::MissionItemInt(m),
            ) if m.mission_type == kind && m.seq == next => {
                self.answered(now_us);
                items.put(next, Item::from_int(m));
                self.download_next(count, next);
            }
            (
                Op::Download {
                    count: Some(count),
                    next,
                },
                Message::MissionItem(m),
            ) if m.mission_type == kind && m.seq == next => {
                self.answered(now_us);
                items.put(next, Item::from_float(m));
                self.download_next(count, next);
            }
            (Op::Clear, Message::MissionAck(a))
                if own.is_addressed_by(a.target_system, a.target_component) =>
            {
                self.answered(now_us);
                self.finish(Event::Cleared(Some(a.r#type)));
            }
            (Op::SetCurrent { seq }, Message::MissionCurrent(c)) if c.seq == seq => {
                self.answered(now_us);
                self.finish(Event::CurrentSet(Some(c.seq)));
            }
            _ => {}
        }
    }

    fn download_next(&mut self, count: u16, next: u16) {
        if next + 1 >= count {
            self.ack_due = true;
            self.finish(Event::Downloaded(Some(count)));
        } else {
            self.op = Op::Download {
                count: Some(count),
                next: next + 1,
            };
        }
    }

    /// The next message to send. Call until `None`.
    pub fn poll_transmit<I: Items + ?Sized>(&mut self, items: &I, now_us: u64) -> Option<Message> {
        let to = self.target;
        let kind = self.kind;
        if self.ack_due {
            self.ack_due = false;
            return Some(Message::MissionAck(MissionAck {
                target_system: to.system,
                target_component: to.component,
                r#type: MavMissionResult::MavMissionAccepted,
                mission_type: kind,
            }));
        }
        if let (Op::Upload { count, .. }, Some(seq)) = (self.op, self.due_item.take()) {
            let item = items.get(seq).unwrap_or_default();
            // The last item waits for the ACK; a lost ACK gets the last item sent again.
            if seq + 1 == count {
                self.op = Op::Upload {
                    count,
                    asked: true,
                    last_sent: true,
                };
            }
            // Not timed: the next request may be the server's own retry, late by its timeout.
            self.sent_us = None;
            self.deadline = Some(now_us.saturating_add(self.timeout_us()));
            return Some(item.to_int(seq, to, kind));
        }
        if self.op == Op::Idle || self.deadline.is_some_and(|d| now_us < d) {
            return None;
        }
        let timeout_us = self.config.retry.timeout_us;
        let silent_since = *self.silent_since.get_or_insert(now_us);
        if self
            .config
            .retry
            .exhausted(now_us.saturating_sub(silent_since), self.tries)
        {
            let event = match self.op {
                Op::Upload { .. } => Event::Uploaded(None),
                Op::Download { .. } => Event::Downloaded(None),
                Op::Clear => Event::Cleared(None),
                _ => Event::CurrentSet(None),
            };
            self.finish(event);
            return None;
        }
        let msg = match self.op {
            Op::Idle => return None,
            // Nothing asked for yet: the count again. The last item went out: it again, for
            // a lost ACK. In between, the server's own retries drive the transfer.
            Op::Upload {
                count,
                asked,
                last_sent,
            } => {
                if !asked {
                    Message::MissionCount(MissionCount {
                        target_system: to.system,
                        target_component: to.component,
                        count,
                        mission_type: kind,
                    })
                } else if last_sent {
                    items
                        .get(count - 1)
                        .unwrap_or_default()
                        .to_int(count - 1, to, kind)
                } else {
                    // The server drives the transfer and retries on its own: wait for its next
                    // request, as long as its own retries could take.
                    self.deadline = Some(now_us.saturating_add(timeout_us));
                    return None;
                }
            }
            Op::Download { count: None, .. } => Message::MissionRequestList(MissionRequestList {
                target_system: to.system,
                target_component: to.component,
                mission_type: kind,
            }),
            Op::Download { next, .. } => Message::MissionRequestInt(MissionRequestInt {
                target_system: to.system,
                target_component: to.component,
                seq: next,
                mission_type: kind,
            }),
            Op::Clear => Message::MissionClearAll(super::messages::MissionClearAll {
                target_system: to.system,
                target_component: to.component,
                mission_type: kind,
            }),
            Op::SetCurrent { seq } => {
                Message::MissionSetCurrent(super::messages::MissionSetCurrent {
                    target_system: to.system,
                    target_component: to.component,
                    seq,
                })
            }
        };
        self.sent_us = self.rtt.time_sending(now_us, self.tries == 0);
        self.deadline = Some(now_us.saturating_add(self.timeout_us()));
        self.tries = self.tries.saturating_add(1);
        Some(msg)
    }

    /// When [`Client::poll_transmit`] has something to do next, if nothing arrives first.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.ack_due || self.due_item.is_some() {
            return Some(0);
        }
        if self.op == Op::Idle {
            return None;
        }
        self.deadline.or(Some(0))
    }

    /// The end of the current operation, once.
    pub fn poll_event(&mut self) -> Option<Event> {
        self.event.take()
    }
}

/// The server's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServerConfig {
    /// Our own address.
    pub own: Address,
    /// The longest wait for an item asked for, and how many such waits of silence give the
    /// upload up: 1 s and 5 by default. Below the longest wait, the server asks again after the
    /// measured round trip's timeout ([`Rtt::backoff_us`]), and gives up only as
    /// [`Retry::exhausted`] says.
    pub retry: Retry,
}

impl ServerConfig {
    /// The defaults, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            retry: Retry {
                timeout_us: 1_000_000,
                retries: 5,
            },
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Upload {
    from: Address,
    kind: MavMissionType,
    count: u16,
    next: u16,
    tries: u8,
    deadline: u64,
    request_due: bool,
    sent_us: Option<u64>,
    /// The last item's arrival (or the count's).
    heard_us: u64,
    /// Where the client seems to stand, when it is behind: the item after the last copy of an
    /// old item it sent. Requests walk it forward from there (see [`Server::poll_transmit`]).
    behind: Option<u16>,
    /// Ask for `behind` at once (a copy just came while walking).
    walk_now: bool,
    /// Probes since the last new item: each reaches one further back.
    probes: u8,
}

/// An answer the server owes.
#[derive(Debug, Clone, Copy)]
enum Reply {
    Ack(Address, MavMissionType, MavMissionResult),
    Count(Address, MavMissionType, u16),
    Item {
        to: Address,
        kind: MavMissionType,
        seq: u16,
        float: bool,
    },
    Current,
}

/// The mission server over a [`Store`]: one upload at a time; downloads, clears and
/// set-current answered as they come.
#[derive(Debug, Clone)]
pub struct Server {
    config: ServerConfig,
    upload: Option<Upload>,
    /// The last completed upload: (from, kind, count, when), to answer a repeat of its last
    /// item and to tell a late copy of its count from a new upload.
    completed: Option<(Address, MavMissionType, u16, u64)>,
    replies: [Option<Reply>; 4],
    /// Copies of the last upload's final ACK still to send, and when the next goes.
    ack_repeats: u8,
    ack_at: u64,
    rtt: Rtt,
    dropped: usize,
}

impl Server {
    /// A server with nothing under way.
    pub fn new(config: ServerConfig) -> Self {
        Self {
            config,
            upload: None,
            completed: None,
            replies: [None; 4],
            ack_repeats: 0,
            ack_at: 0,
            rtt: Rtt::default(),
            dropped: 0,
        }
    }

    /// Answers that did not fit the queue (the client asks again).
    pub fn dropped(&self) -> usize {
        self.dropped
    }

    fn reply(&mut self, r: Reply) {
        match self.replies.iter_mut().find(|s| s.is_none()) {
            Some(slot) => *slot = Some(r),
            None => crate::bump(&mut self.dropped, 1),
        }
    }

    /// A message from `from`, applied to `store` (an upload is committed there once complete).
    pub fn handle<S: Store + ?Sized>(
        &mut self,
        store: &mut S,
        now_us: u64,
        from: Address,
        msg: &Message,
    ) {
        let own = self.config.own;
        match msg {
            Message::MissionCount(c)
                if own.is_addressed_by(c.target_system, c.target_component) =>
            {
                if let Some(u) = self.upload {
                    if u.from != from {
                        // Someone else's upload is under way.
                        self.reply(Reply::Ack(
                            from,
                            c.mission_type,
                            MavMissionResult::MavMissionDenied,
                        ));
                        return;
                    }
                    if u.kind == c.mission_type && u.count == c.count && u.next == 0 {
                        // A repeated count: ask for the first item again.
                        self.upload = Some(Upload {
                            request_due: true,
                            ..u
                        });
                        return;
                    }
                    // Otherwise the sender started afresh: its old upload is dropped.
                }
                if let Some((f, k, n, at)) = self.completed {
                    // A late copy of the count of the upload just taken: not a new upload. (A
                    // real one of the same size is asked again by its client, and taken once
                    // the window has passed.)
                    let window = self.rtt.timeout_us(self.config.retry.timeout_us) * 4;
                    if (f, k, n) == (from, c.mission_type, c.count)
                        && now_us.saturating_sub(at) < window
                    {
                        return;
                    }
                }
                self.completed = None;
                self.ack_repeats = 0;
                if c.count == 0 {
                    store.clear(c.mission_type);
                    self.upload = None;
                    self.reply(Reply::Ack(
                        from,
                        c.mission_type,
                        MavMissionResult::MavMissionAccepted,
                    ));
                    return;
                }
                if !store.begin(c.mission_type, c.count) {
                    self.upload = None;
                    self.reply(Reply::Ack(
                        from,
                        c.mission_type,
                        MavMissionResult::MavMissionNoSpace,
                    ));
                    return;
                }
                self.upload = Some(Upload {
                    from,
                    kind: c.mission_type,
                    count: c.count,
                    next: 0,
                    tries: 0,
                    deadline: now_us,
                    request_due: true,
                    sent_us: None,
                    heard_us: now_us,
                    behind: None,
                    walk_now: false,
                    probes: 0,
                });
            }
            Message::MissionItemInt(m)
                if own.is_addressed_by(m.target_system, m.target_component) =>
            {
                self.item(
                    store,
                    now_us,
                    from,
                    m.seq,
                    m.mission_type,
                    Item::from_int(m),
                );
            }
            Message::MissionItem(m) if own.is_addressed_by(m.target_system, m.target_component) => {
                self.item(
                    store,
                    now_us,
                    from,
                    m.seq,
                    m.mission_type,
                    Item::from_float(m),
                );
            }
            Message::MissionRequestList(r)
                if own.is_addressed_by(r.target_system, r.target_component) =>
            {
                let count = store.count(r.mission_type);
                self.reply(Reply::Count(from, r.mission_type, count));
            }
            Message::MissionRequestInt(r)
                if own.is_addressed_by(r.target_system, r.target_component) =>
            {
                self.request(store, from, r.mission_type, r.seq, false);
            }
            Message::MissionRequest(r)
                if own.is_addressed_by(r.target_system, r.target_component) =>
            {
                self.request(store, from, r.mission_type, r.seq, true);
            }
            Message::MissionClearAll(c)
                if own.is_addressed_by(c.target_system, c.target_component) =>
            {
                store.clear(c.mission_type);
                self.reply(Reply::Ack(
                    from,
                    c.mission_type,
                    MavMissionResult::MavMissionAccepted,
                ));
            }
            Message::MissionSetCurrent(s)
                if own.is_addressed_by(s.target_system, s.target_component) =>
            {
                // Answered with MISSION_CURRENT either way: the current item, set or not.
                store.set_current(s.seq);
                self.reply(Reply::Current);
            }
            _ => {}
        }
    }

    fn request<S: Store + ?Sized>(
        &mut self,
        store: &S,
        to: Address,
        kind: MavMissionType,
        seq: u16,
        float: bool,
    ) {
        if seq < store.count(kind) {
            self.reply(Reply::Item {
                to,
                kind,
                seq,
                float,
            });
        } else {
            self.reply(Reply::Ack(
                to,
                kind,
                MavMissionResult::MavMissionInvalidSequence,
            ));
        }
    }

    fn item<S: Store + ?Sized>(
        &mut self,
        store: &mut S,
        now_us: u64,
        from: Address,
        seq: u16,
        kind: MavMissionType,
        item: Item,
    ) {
        let Some(mut u) = self.upload.filter(|u| u.from == from && u.kind == kind) else {
            // The last item of an upload already taken: its ACK was lost.
            if self
                .completed
                .is_some_and(|(f, k, count, _)| f == from && k == kind && seq + 1 == count)
            {
                self.reply(Reply::Ack(from, kind, MavMissionResult::MavMissionAccepted));
            }
            return;
        };
        if seq < u.next {
            // A copy of an item already taken: a repeated frame, or the answer to a late copy
            // of an old request. Nothing to do at once (asking again here would keep every
            // later item doubled), but it tells where the client stands, should its answers
            // stop: one that went back on that old request (MAVSDK 4.1's does) now ignores
            // requests for anything but the item after it. While already walking it forward,
            // the next step goes at once.
            let walking = u.behind.is_some();
            u.behind = (seq + 1 < u.next).then_some(seq + 1);
            u.walk_now = walking;
            if walking && u.behind.is_none() {
                u.request_due = true;
            }
            self.upload = Some(u);
            return;
        }
        if seq > u.next {
            // Out of turn: ask for the one due again, now.
            u.request_due = true;
            self.upload = Some(u);
            return;
        }
        if let Some(sent) = u.sent_us.take() {
            self.rtt.sample(now_us.saturating_sub(sent));
        }
        store.put(kind, seq, item);
        u.next += 1;
        u.tries = 0;
        u.probes = 0;
        u.behind = None;
        u.walk_now = false;
        u.heard_us = now_us;
        if u.next == u.count {
            store.commit(kind);
            self.upload = None;
            self.completed = Some((from, kind, u.count, now_us));
            self.reply(Reply::Ack(from, kind, MavMissionResult::MavMissionAccepted));
            // The final ACK goes twice more, a round trip apart: a client that does not send
            // its last item again when the ACK is lost (MAVSDK's) would report a failure for an
            // upload that was taken.
            self.ack_repeats = 2;
            self.ack_at = now_us.saturating_add(self.rtt.timeout_us(self.config.retry.timeout_us));
            return;
        }
        u.request_due = true;
        self.upload = Some(u);
    }

    /// The next message to send. Call until `None`.
    pub fn poll_transmit<S: Store + ?Sized>(&mut self, store: &S, now_us: u64) -> Option<Message> {
        if let Some(r) = self.replies[0].take() {
            self.replies.rotate_left(1);
            return Some(self.render(store, r));
        }
        if self.ack_repeats > 0 && now_us >= self.ack_at {
            if let Some((to, kind, _, _)) = self.completed {
                self.ack_repeats -= 1;
                self.ack_at =
                    now_us.saturating_add(self.rtt.timeout_us(self.config.retry.timeout_us));
                return Some(self.render(
                    store,
                    Reply::Ack(to, kind, MavMissionResult::MavMissionAccepted),
                ));
            }
            self.ack_repeats = 0;
        }
        let mut u = self.upload?;
        if !u.request_due && !u.walk_now && now_us < u.deadline {
            return None;
        }
        let timeout_us = self.config.retry.timeout_us;
        if !u.request_due {
            // No item came: ask again, or give the upload up (the old mission stays).
            if self
                .config
                .retry
                .exhausted(now_us.saturating_sub(u.heard_us), u.tries)
            {
                self.upload = None;
                return Some(Message::MissionAck(MissionAck {
                    target_system: u.from.system,
                    target_component: u.from.component,
                    r#type: MavMissionResult::MavMissionOperationCancelled,
                    mission_type: u.kind,
                }));
            }
        }
        // Which item to ask for: the one due, or, when the client seems behind, the item it
        // waits to be asked for, walking it forward one answer at a time. When nothing tells
        // where it stands, every third unanswered request asks for an earlier item (a probe),
        // one further back each time; the copy it answers with tells.
        let seq = if let (Some(behind), true) = (u.behind, u.walk_now || !u.request_due) {
            behind
        } else if !u.request_due && u.next > 0 && u.tries >= 2 && u.tries % 3 == 2 {
            u.probes = u.probes.saturating_add(1);
            u.next.saturating_sub(u16::from(u.probes))
        } else {
            u.next
        };
        if u.walk_now {
            // A step of the walk: no retry, the deadline stands.
            u.walk_now = false;
            self.upload = Some(u);
            return Some(Message::MissionRequestInt(MissionRequestInt {
                target_system: u.from.system,
                target_component: u.from.component,
                seq,
                mission_type: u.kind,
            }));
        }
        u.sent_us = self.rtt.time_sending(now_us, u.tries == 0);
        u.request_due = false;
        u.deadline = now_us.saturating_add(self.rtt.backoff_us(timeout_us, u.tries));
        u.tries = u.tries.saturating_add(1);
        self.upload = Some(u);
        Some(Message::MissionRequestInt(MissionRequestInt {
            target_system: u.from.system,
            target_component: u.from.component,
            seq,
            mission_type: u.kind,
        }))
    }

    fn render<S: Store + ?Sized>(&self, store: &S, r: Reply) -> Message {
        match r {
            Reply::Ack(to, kind, result) => Message::MissionAck(MissionAck {
                target_system: to.system,
                target_component: to.component,
                r#type: result,
                mission_type: kind,
            }),
            Reply::Count(to, kind, count) => Message::MissionCount(MissionCount {
                target_system: to.system,
                target_component: to.component,
                count,
                mission_type: kind,
            }),
            Reply::Item {
                to,
                kind,
                seq,
                float,
            } => {
                let item = store.get(kind, seq).unwrap_or_default();
                if float {
                    item.to_float(seq, to, kind)
                } else {
                    item.to_int(seq, to, kind)
                }
            }
            Reply::Current => {
                let total = store.count(MavMissionType::Mission);
                Message::MissionCurrent(MissionCurrent {
                    seq: store.current(),
                    total,
                    mission_state: if total == 0 {
                        MissionState::NoMission
                    } else {
                        MissionState::NotStarted
                    },
                    mission_mode: 0,
                })
            }
        }
    }

    /// When [`Server::poll_transmit`] has something to do next.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.replies[0].is_some() {
            return Some(0);
        }
        if self.ack_repeats > 0 {
            return Some(self.ack_at);
        }
        self.upload.map(|u| {
            if u.request_due || u.walk_now {
                0
            } else {
                u.deadline
            }
        })
    }
}
