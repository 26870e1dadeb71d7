//! The mission server over the caller's [`Store`].

// MISSION_ITEM and MISSION_REQUEST are deprecated in common.xml, but ArduPilot and older ground
// stations still send them.
#![allow(deprecated)]

use super::super::messages::{
    MavMissionResult, MavMissionType, Message, MissionAck, MissionCount, MissionCurrent,
    MissionRequestInt, MissionState,
};
use super::super::{Address, Retry, Rtt};
use super::{Item, Store};

/// The server's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServerConfig {
    /// Our own address.
    pub own: Address,
    /// The longest wait for an item asked for, and how many such waits of silence give the
    /// upload up: 1 s and 5 by default. Below the longest wait, the server asks again after the
    /// measured round trip's timeout ([`Rtt::backoff_us`]), and gives up only as
    /// [`Retry::exhausted`] says, counting silence from the client's last item, a copy of one
    /// already taken too (on a bad radio the item due can be lost again and again while the
    /// client answers). A client that answers only with copies is given up after 255 requests
    /// for the item due (18 s or more with the defaults).
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
    /// The last item's arrival, a copy's too (or the count's).
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
                if self
                    .completed
                    .is_some_and(|(_, kind, _, _)| kind == c.mission_type)
                {
                    // The upload just taken is gone: no more copies of its ACK, and the same
                    // count again is a new upload, not a late copy.
                    self.completed = None;
                    self.ack_repeats = 0;
                }
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
        u.heard_us = now_us;
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
            } else if !walking && u.probes > 0 && seq + 1 == u.next {
                // The answer to a probe, from a client in step: the request for the item due
                // was lost, not ignored. Ask again now rather than at the deadline.
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
            // No item came: ask again, or give the upload up (the old mission stays) when the
            // client has gone silent, or when it answers only with copies of items taken.
            if u.tries == u8::MAX
                || self
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
        // where it stands, the fourth unanswered request, and every third after it, asks for an
        // earlier item (a probe), one further back each time; the copy it answers with tells.
        // (Probing after three, not two, and asking again at once when a probe is answered in
        // step, took a simulated 500-item upload at 20 % loss from 20.8 to 15.8 s.) A walk
        // whose step goes unanswered as long steps back the same way: the client may have gone
        // back again on another late copy, and then waits for an item before the step.
        let probe = !u.request_due && !u.walk_now && u.next > 0 && u.tries >= 3 && u.tries % 3 == 0;
        if probe {
            match u.behind.as_mut() {
                Some(behind) => *behind = behind.saturating_sub(1),
                None => u.probes = u.probes.saturating_add(1),
            }
        }
        let seq = match u.behind {
            Some(behind) if u.walk_now || !u.request_due => behind,
            _ if probe => u.next.saturating_sub(u16::from(u.probes)),
            _ => u.next,
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
