//! The parameter client: lists, reads and sets.

use super::super::messages::{
    Heartbeat, MavAutopilot, MavParamExtType, Message, ParamAck, ParamExtRequestList,
    ParamExtRequestRead, ParamExtSet, ParamRequestList, ParamRequestRead, ParamSet,
};
use super::super::{Address, Busy, Retry, Rtt};
use super::{Bytes, Encoding, Name, Protocol, Received, Value};

/// What a client's operation came to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// The list is complete (`missing` 0), or still missing `missing` of `count` values after
    /// the retries.
    Listed {
        /// The target's parameter count.
        count: u16,
        /// Values never received.
        missing: u16,
    },
    /// The target's `_HASH_CHECK` equals the hash given to [`Client::list_unless`]: the list
    /// was stopped, the caller's cached copy is current.
    Unchanged {
        /// The target's parameter count.
        count: u16,
        /// The hash.
        hash: u32,
    },
    /// The answer to a read, `None` after the retries.
    Read(Option<Received>),
    /// What the target reports after a set, `None` after the retries. The set took only if
    /// the reported value is exactly the one sent ([`Value::same`]). In [`Protocol::V1`], an
    /// answer with another value is asked for again once (it may be a list stream's, sent
    /// before the set arrived), and the second answer is final. In [`Protocol::Ext`] the
    /// PARAM_EXT_ACK is final: ACCEPTED gives the value it holds, any other result none;
    /// IN_PROGRESS keeps the client waiting, as long as the longest wait each time.
    Set(Option<Received>),
}

/// The client's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// Our own address.
    pub own: Address,
    /// The longest wait for an answer, and how many such waits of silence end an operation:
    /// 1 s and 5 by default. Below the longest wait, the client asks again after the measured
    /// round trip's timeout, doubled for each of the first two unanswered tries; it gives up
    /// only after `timeout_us × (retries + 1)` without a new value, and at least twice as many
    /// sendings ([`Retry::exhausted`]).
    pub retry: Retry,
    /// How many single-index re-requests may be outstanding at once while filling gaps.
    pub window: u16,
    /// The target's encoding; `None`: from its HEARTBEAT (bytewise until one arrives).
    pub encoding: Option<Encoding>,
    /// The messages spoken: PARAM_* ([`Protocol::V1`], the default) or PARAM_EXT_*. A client
    /// takes only its own protocol's answers. `_HASH_CHECK` is V1's.
    pub protocol: Protocol,
}

impl ClientConfig {
    /// The defaults, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            retry: Retry {
                timeout_us: 1_000_000,
                retries: 5,
            },
            window: 16,
            encoding: None,
            protocol: Protocol::V1,
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Op {
    Idle,
    List {
        /// `None` until the first value says how many there are.
        count: Option<u16>,
        /// Re-requesting missing indices, from `cursor` on.
        filling: bool,
        cursor: u16,
        in_flight: u16,
        request_due: bool,
    },
    Read {
        name: Name,
        index: i16,
    },
    Set {
        name: Name,
        value: Value,
    },
    /// A PARAM_EXT CUSTOM value.
    SetCustom {
        name: Name,
        bytes: Bytes,
    },
}

/// The parameter client for one target, holding which of up to `32 × W` indices it has.
#[derive(Debug, Clone)]
pub struct Client<const W: usize> {
    config: ClientConfig,
    target: Address,
    encoding: Encoding,
    op: Op,
    have: [u32; W],
    held: u16,
    /// Sends of the current request so far, or rounds without progress while listing.
    tries: u8,
    /// Since when no new value came (`None` before the first sending).
    silent_since: Option<u64>,
    progress: bool,
    deadline: Option<u64>,
    event: Option<Event>,
    rtt: Rtt,
    /// When the current request went out, if at its first sending (for an RTT sample).
    sent_us: Option<u64>,
    /// Fill re-requests out: (index, when), for RTT samples.
    reads: [Option<(u16, u64)>; 8],
    /// The last stream value's arrival, and the smoothed gap between values (µs).
    last_value_us: Option<u64>,
    gap_us: u64,
    /// The hash of the caller's cached copy, while listing with [`Client::list_unless`].
    cached: Option<u32>,
    /// The target's `_HASH_CHECK` in the current list, if it sent one.
    announced: Option<u32>,
    /// A PARAM_SET `_HASH_CHECK` to send, stopping the target's list.
    stop_due: Option<u32>,
    /// A set's first answer, when it held another value than the one set.
    set_mismatch: Option<Received>,
}

impl<const W: usize> Client<W> {
    /// A client for `target`.
    pub fn new(config: ClientConfig, target: Address) -> Self {
        Self {
            config,
            target,
            encoding: config.encoding.unwrap_or(Encoding::Bytewise),
            op: Op::Idle,
            have: [0; W],
            held: 0,
            tries: 0,
            silent_since: None,
            progress: false,
            deadline: None,
            event: None,
            rtt: Rtt::default(),
            sent_us: None,
            reads: [None; 8],
            last_value_us: None,
            gap_us: 0,
            cached: None,
            announced: None,
            stop_due: None,
            set_mismatch: None,
        }
    }

    /// The round-trip estimate, from requests answered at their first sending.
    pub fn rtt(&self) -> &Rtt {
        &self.rtt
    }

    /// How long to wait for an answer now: the round trip's timeout, doubled for each try
    /// that went unanswered.
    fn timeout_us(&self) -> u64 {
        self.rtt
            .backoff_us(self.config.retry.timeout_us, self.tries)
    }

    /// How long a list stream may pause before what is missing is asked for: four smoothed
    /// gaps between values or a round trip's timeout, whichever is longer, and never more
    /// than the configured timeout.
    fn gap_timeout_us(&self) -> u64 {
        self.timeout_us()
            .max(4 * self.gap_us)
            .min(self.config.retry.timeout_us)
    }

    /// The encoding in use for the target.
    pub fn encoding(&self) -> Encoding {
        self.encoding
    }

    /// Whether no operation is under way.
    pub fn is_idle(&self) -> bool {
        matches!(self.op, Op::Idle)
    }

    fn start(&mut self, op: Op) -> Result<(), Busy> {
        if !self.is_idle() {
            return Err(Busy);
        }
        self.op = op;
        self.tries = 0;
        self.silent_since = None;
        self.deadline = None;
        self.sent_us = None;
        self.reads = [None; 8];
        self.last_value_us = None;
        self.set_mismatch = None;
        Ok(())
    }

    /// Fetches every parameter. Each one arrives through [`Client::handle`]'s return value;
    /// [`Event::Listed`] ends it.
    pub fn list(&mut self) -> Result<(), Busy> {
        self.have = [0; W];
        self.held = 0;
        self.cached = None;
        self.announced = None;
        self.start(Op::List {
            count: None,
            filling: false,
            cursor: 0,
            in_flight: 0,
            request_due: true,
        })
    }

    /// Fetches every parameter unless the target's `_HASH_CHECK` (PX4's, see
    /// [`super::hash`]) is `hash`, the hash of the caller's cached copy: then the target is told
    /// to stop its list and [`Event::Unchanged`] ends the operation. A target without
    /// `_HASH_CHECK`, and a client speaking [`Protocol::Ext`], lists as for [`Client::list`].
    pub fn list_unless(&mut self, hash: u32) -> Result<(), Busy> {
        self.list()?;
        self.cached = Some(hash);
        Ok(())
    }

    /// The `_HASH_CHECK` the target sent in the current or last list, if any.
    pub fn announced_hash(&self) -> Option<u32> {
        self.announced
    }

    /// Reads the parameter called `name`.
    pub fn read(&mut self, name: Name) -> Result<(), Busy> {
        self.start(Op::Read { name, index: -1 })
    }

    /// Reads parameter `index`.
    pub fn read_index(&mut self, index: u16) -> Result<(), Busy> {
        let index = i16::try_from(index).unwrap_or(i16::MAX);
        self.start(Op::Read {
            name: Name::default(),
            index,
        })
    }

    /// Sets the parameter called `name` to `value`, sent with `value`'s type.
    pub fn set(&mut self, name: Name, value: Value) -> Result<(), Busy> {
        self.start(Op::Set { name, value })
    }

    /// Sets the PARAM_EXT CUSTOM parameter called `name` to `bytes` (128 bytes of the
    /// target's own meaning; a camera's text, NUL-padded). [`Event::Set`] ends it with the
    /// bytes the target acknowledged in [`Received::custom`]. Only in [`Protocol::Ext`]: in
    /// V1, which has no such type, it ends at once with `Event::Set(None)`.
    pub fn set_custom(&mut self, name: Name, bytes: Bytes) -> Result<(), Busy> {
        self.start(Op::SetCustom { name, bytes })?;
        if self.config.protocol != Protocol::Ext {
            self.finish(Event::Set(None));
        }
        Ok(())
    }

    /// Whether index `i` has been received during the current list.
    pub fn has(&self, i: u16) -> bool {
        let (w, b) = (usize::from(i / 32), i % 32);
        self.have.get(w).is_some_and(|word| word & (1 << b) != 0)
    }

    fn mark(&mut self, i: u16) -> bool {
        let (w, b) = (usize::from(i / 32), i % 32);
        match self.have.get_mut(w) {
            Some(word) if *word & (1 << b) == 0 => {
                *word |= 1 << b;
                self.held += 1;
                true
            }
            _ => false,
        }
    }

    /// A message from `from`: returns a PARAM_VALUE from the target, decoded; HEARTBEATs from
    /// the target set the encoding (unless it was given).
    pub fn handle(&mut self, now_us: u64, from: Address, msg: &Message) -> Option<Received> {
        let from_target = from.system == self.target.system
            && (self.target.component == 0 || from.component == self.target.component);
        if !from_target {
            return None;
        }
        let ext = self.config.protocol == Protocol::Ext;
        let received = match msg {
            Message::Heartbeat(Heartbeat { autopilot, .. }) => {
                if self.config.encoding.is_none() && *autopilot != MavAutopilot::Invalid {
                    self.encoding = Encoding::for_autopilot(*autopilot);
                }
                return None;
            }
            Message::ParamValue(v) if !ext => {
                if super::hash::is_hash_check(&v.param_id) {
                    self.hash_announced(v.param_value.to_bits(), v.param_count);
                    return None;
                }
                Received {
                    name: v.param_id,
                    index: v.param_index,
                    count: v.param_count,
                    value: Value::decode(v.param_value, v.param_type, self.encoding),
                    custom: None,
                }
            }
            Message::ParamExtValue(v) if ext => Received {
                name: v.param_id,
                index: v.param_index,
                count: v.param_count,
                value: Value::from_ext(&v.param_value, v.param_type),
                custom: (v.param_type == MavParamExtType::Custom).then_some(v.param_value),
            },
            Message::ParamExtAck(a) if ext => {
                let (Op::Set { name, .. } | Op::SetCustom { name, .. }) = self.op else {
                    return None;
                };
                if a.param_id != name {
                    return None;
                }
                let accepted = a.param_result == ParamAck::Accepted;
                if let Some(sent) = self.sent_us.take() {
                    self.rtt.sample(now_us.saturating_sub(sent));
                }
                let received = Received {
                    name: a.param_id,
                    index: u16::MAX,
                    count: 0,
                    value: accepted
                        .then(|| Value::from_ext(&a.param_value, a.param_type))
                        .flatten(),
                    custom: (accepted && a.param_type == MavParamExtType::Custom)
                        .then_some(a.param_value),
                };
                if a.param_result == ParamAck::InProgress {
                    // Alive and working on it: wait as long as the longest wait, from now.
                    self.silent_since = Some(now_us);
                    self.tries = 0;
                    self.deadline = Some(now_us.saturating_add(self.config.retry.timeout_us));
                } else {
                    self.finish(Event::Set(Some(received)));
                }
                return Some(received);
            }
            _ => return None,
        };
        if let Some(sent) = self.sent_us.take() {
            self.rtt.sample(now_us.saturating_sub(sent));
        }
        match self.op {
            // A CUSTOM set is answered by PARAM_EXT_ACK alone.
            Op::Idle | Op::SetCustom { .. } => {}
            Op::List { count, .. } => {
                if received.index < received.count {
                    if let Some(slot) = self
                        .reads
                        .iter_mut()
                        .find(|r| r.is_some_and(|(i, _)| i == received.index))
                    {
                        if let Some((_, sent)) = slot.take() {
                            self.rtt.sample(now_us.saturating_sub(sent));
                        }
                    }
                    if let Some(last) = self.last_value_us {
                        let gap = now_us.saturating_sub(last);
                        self.gap_us = (7 * self.gap_us + gap) / 8;
                    }
                    self.last_value_us = Some(now_us);
                    if count != Some(received.count) {
                        // The first value, or the target's list changed: start counting again.
                        self.have = [0; W];
                        self.held = 0;
                        if let Op::List { count, .. } = &mut self.op {
                            *count = Some(received.count);
                        }
                    }
                    if self.mark(received.index) {
                        self.progress = true;
                        self.silent_since = Some(now_us);
                        if let Op::List { in_flight, .. } = &mut self.op {
                            *in_flight = in_flight.saturating_sub(1);
                        }
                    }
                    // The stream's last index: what is missing now is lost, ask for it after a
                    // round trip's wait rather than a pause's.
                    let wait = if received.index + 1 == received.count {
                        self.timeout_us()
                    } else {
                        self.gap_timeout_us()
                    };
                    self.deadline = Some(now_us.saturating_add(wait));
                    self.finish_list_if_complete();
                }
            }
            Op::Read { name, index } => {
                let hit = if index >= 0 {
                    i32::from(received.index) == i32::from(index)
                } else {
                    received.name == name
                };
                if hit {
                    self.finish(Event::Read(Some(received)));
                }
            }
            Op::Set { name, value } => {
                // PARAM_EXT_SET is answered by PARAM_EXT_ACK alone.
                if received.name == name && !ext {
                    let took = received.value.is_some_and(|v| v.same(value));
                    if took || self.set_mismatch.is_some() {
                        self.finish(Event::Set(Some(received)));
                    } else {
                        // Another value: a refusal, or a list stream's value sent before the
                        // set arrived. Ask once more at once; a second answer is final.
                        self.set_mismatch = Some(received);
                        self.deadline = Some(now_us);
                    }
                }
            }
        }
        Some(received)
    }

    /// A `_HASH_CHECK` of a list: ends the list if it is the cached copy's.
    fn hash_announced(&mut self, hash: u32, count: u16) {
        if let Op::List { .. } = self.op {
            self.announced = Some(hash);
            if self.cached == Some(hash) {
                self.stop_due = Some(hash);
                self.finish(Event::Unchanged { count, hash });
            }
        }
    }

    fn finish(&mut self, event: Event) {
        self.op = Op::Idle;
        self.deadline = None;
        self.event = Some(event);
    }

    fn finish_list_if_complete(&mut self) {
        if let Op::List { count: Some(c), .. } = self.op {
            if self.held >= c || (usize::from(c) > 32 * W && usize::from(self.held) >= 32 * W) {
                self.finish(Event::Listed {
                    count: c,
                    missing: c.saturating_sub(self.held),
                });
            }
        }
    }

    /// The next request to send. Call until `None`.
    pub fn poll_transmit(&mut self, now_us: u64) -> Option<Message> {
        if let Some(hash) = self.stop_due.take() {
            return Some(super::hash::stop(self.target, hash));
        }
        let timeout_us = self.timeout_us();
        let due = self.deadline.is_none_or(|d| now_us >= d);
        let silent_us = now_us.saturating_sub(*self.silent_since.get_or_insert(now_us));
        let exhausted = self.config.retry.exhausted(silent_us, self.tries);
        let target = self.target;
        let msg = match self.op {
            Op::Idle => return None,
            Op::List { .. } => return self.poll_list(now_us),
            _ if !due => return None,
            Op::Read { .. } if exhausted => {
                self.finish(Event::Read(None));
                return None;
            }
            Op::Set { .. } | Op::SetCustom { .. } if exhausted => {
                self.finish(Event::Set(self.set_mismatch));
                return None;
            }
            Op::Read { name, index } => self.read_message(&name, index),
            Op::Set { name, value } => match self.config.protocol {
                Protocol::V1 => Message::ParamSet(ParamSet {
                    target_system: target.system,
                    target_component: target.component,
                    param_id: name,
                    param_value: value.encode(self.encoding),
                    param_type: value.param_type(),
                }),
                Protocol::Ext => Message::ParamExtSet(ParamExtSet {
                    target_system: target.system,
                    target_component: target.component,
                    param_id: name,
                    param_value: value.to_ext(),
                    param_type: value.ext_type(),
                }),
            },
            Op::SetCustom { name, bytes } => Message::ParamExtSet(ParamExtSet {
                target_system: target.system,
                target_component: target.component,
                param_id: name,
                param_value: bytes,
                param_type: MavParamExtType::Custom,
            }),
        };
        self.sent_us = self.rtt.time_sending(now_us, self.tries == 0);
        self.tries = self.tries.saturating_add(1);
        self.deadline = Some(now_us.saturating_add(timeout_us));
        Some(msg)
    }

    fn poll_list(&mut self, now_us: u64) -> Option<Message> {
        let Op::List {
            count,
            mut filling,
            mut cursor,
            mut in_flight,
            mut request_due,
        } = self.op
        else {
            return None;
        };
        let timeout_us = self.timeout_us();
        let silent_since = *self.silent_since.get_or_insert(now_us);
        if self.deadline.is_some_and(|d| now_us >= d) && !request_due {
            // The stream went quiet, or re-requests went unanswered.
            if self.progress {
                self.tries = 0;
            } else {
                self.tries = self.tries.saturating_add(1);
            }
            self.progress = false;
            if self
                .config
                .retry
                .exhausted(now_us.saturating_sub(silent_since), self.tries)
            {
                let c = count.unwrap_or(0);
                let missing = c.saturating_sub(self.held);
                self.finish(Event::Listed { count: c, missing });
                return None;
            }
            match count {
                None => request_due = true,
                Some(_) => {
                    filling = true;
                    cursor = 0;
                    in_flight = 0;
                    // Answers to the last round's reads no longer time anything.
                    self.reads = [None; 8];
                }
            }
            self.deadline = Some(now_us.saturating_add(timeout_us));
        }
        let mut msg = None;
        if request_due {
            request_due = false;
            // The first request is timed; a repeat is not (Karn).
            self.sent_us = count
                .is_none()
                .then(|| self.rtt.time_sending(now_us, self.tries == 0))
                .flatten();
            self.deadline = Some(now_us.saturating_add(timeout_us));
            let (target_system, target_component) = (self.target.system, self.target.component);
            msg = Some(match self.config.protocol {
                Protocol::V1 => Message::ParamRequestList(ParamRequestList {
                    target_system,
                    target_component,
                }),
                Protocol::Ext => Message::ParamExtRequestList(ParamExtRequestList {
                    target_system,
                    target_component,
                }),
            });
        } else if let (Some(c), true) = (count, filling && in_flight < self.config.window) {
            let limit = c.min(u16::try_from(32 * W).unwrap_or(u16::MAX));
            let mut i = cursor;
            while i < limit && self.has(i) {
                i += 1;
            }
            if i < limit {
                cursor = i + 1;
                in_flight += 1;
                self.deadline = Some(now_us.saturating_add(timeout_us));
                if let Some(slot) = self.reads.iter_mut().find(|r| r.is_none()) {
                    *slot = Some((i, now_us));
                }
                msg = Some(self.read_message(&Name::default(), i16::try_from(i).unwrap_or(-1)));
            } else {
                cursor = limit;
            }
        }
        self.op = Op::List {
            count,
            filling,
            cursor,
            in_flight,
            request_due,
        };
        msg
    }

    /// A read of `index`, or of `name` if `index` is negative.
    fn read_message(&self, name: &Name, index: i16) -> Message {
        let (target_system, target_component) = (self.target.system, self.target.component);
        match self.config.protocol {
            Protocol::V1 => Message::ParamRequestRead(ParamRequestRead {
                target_system,
                target_component,
                param_id: *name,
                param_index: index,
            }),
            Protocol::Ext => Message::ParamExtRequestRead(ParamExtRequestRead {
                target_system,
                target_component,
                param_id: *name,
                param_index: index,
            }),
        }
    }

    /// When [`Client::poll_transmit`] has something to do next, if nothing arrives first.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.stop_due.is_some() {
            return Some(0);
        }
        match self.op {
            Op::Idle => None,
            Op::List {
                request_due: true, ..
            } => Some(0),
            Op::List {
                count: Some(c),
                filling: true,
                cursor,
                in_flight,
                ..
            } if in_flight < self.config.window && cursor < c => Some(0),
            _ => self.deadline.or(Some(0)),
        }
    }

    /// The end of the current operation, once.
    pub fn poll_event(&mut self) -> Option<Event> {
        self.event.take()
    }
}
