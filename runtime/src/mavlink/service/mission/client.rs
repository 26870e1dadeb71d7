//! The mission client: uploads, downloads, clears and sets the current item.

// MISSION_REQUEST and MISSION_SET_CURRENT are deprecated in common.xml, but ArduPilot still
// uses them.
#![allow(deprecated)]

use super::super::messages::{
    MavMissionResult, MavMissionType, Message, MissionAck, MissionClearAll, MissionCount,
    MissionRequestInt, MissionRequestList, MissionSetCurrent,
};
use super::super::{Address, Busy, Retry, Rtt};
use super::{Item, Items};

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
    /// An upload's progress: the highest item the server asked for, since when, and how many
    /// requests came since without a higher one.
    progress: Option<Progress>,
}

/// How far a server has taken an upload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Progress {
    highest: u16,
    since_us: u64,
    requests: u8,
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
            progress: None,
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
        self.progress = None;
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

    /// Whether a request for `seq` ends an upload the server no longer takes forward: one that
    /// asks again and again without ever asking past the highest item yet, for as long and as
    /// many times as silence would take to give up ([`Retry::exhausted`]). Each request
    /// answers, so without this a server stuck on one item would hold the upload forever.
    fn stalled(&mut self, seq: u16, now_us: u64) -> bool {
        match &mut self.progress {
            Some(p) if seq <= p.highest => {
                p.requests = p.requests.saturating_add(1);
                self.config
                    .retry
                    .exhausted(now_us.saturating_sub(p.since_us), p.requests)
            }
            _ => {
                self.progress = Some(Progress {
                    highest: seq,
                    since_us: now_us,
                    requests: 0,
                });
                false
            }
        }
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
                if self.stalled(seq, now_us) {
                    self.finish(Event::Uploaded(None));
                    return;
                }
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
            // so, and carries on. MAV_MISSION_ACCEPTED before the last item went out is no end
            // either: it is a late copy of an earlier upload's ACK (servers repeat the final
            // one), and taking it would report a mission the vehicle never got.
            (
                Op::Upload {
                    count, last_sent, ..
                },
                Message::MissionAck(a),
            ) if a.mission_type == kind
                && own.is_addressed_by(a.target_system, a.target_component)
                && a.r#type != MavMissionResult::MavMissionInvalidSequence
                && (a.r#type != MavMissionResult::MavMissionAccepted
                    || last_sent
                    || count == 0) =>
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
                } else if self
                    .config
                    .retry
                    .outlasted(now_us.saturating_sub(silent_since))
                {
                    // Silent since its last request for as long as silence takes to give up:
                    // the server dropped the transfer (its own retries ran out, or its ACK
                    // saying so was lost).
                    self.finish(Event::Uploaded(None));
                    return None;
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
            Op::Clear => Message::MissionClearAll(MissionClearAll {
                target_system: to.system,
                target_component: to.component,
                mission_type: kind,
            }),
            Op::SetCurrent { seq } => Message::MissionSetCurrent(MissionSetCurrent {
                target_system: to.system,
                target_component: to.component,
                seq,
            }),
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
