//! The parameter server over the caller's [`Store`], in both protocols.

use super::super::messages::{Message, ParamAck, ParamExtAck, ParamExtValue, ParamValue};
use super::super::Address;
use super::{Encoding, Param, Store, Value};

/// The most list values a paced stream sends at once after a late poll.
pub const LIST_BURST: u64 = 8;

/// What a queued answer is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Answer {
    /// PARAM_VALUE.
    Value,
    /// PARAM_EXT_VALUE.
    ExtValue,
    /// PARAM_EXT_ACK with this result.
    ExtAck(ParamAck),
}

/// The server's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServerConfig {
    /// Our own address: requests for it (or broadcast) are answered.
    pub own: Address,
    /// How integers are put into PARAM_VALUE.
    pub encoding: Encoding,
    /// The time between two values of a list stream (µs), on average: a caller that polls
    /// late gets what fell due meanwhile, up to [`LIST_BURST`] values at once, so the stream
    /// keeps its rate whatever the caller's timer does. 0 sends as fast as the caller polls.
    pub list_interval_us: u64,
    /// Sends PX4's `_HASH_CHECK` first in every list, and stops the list when a client answers
    /// that its cache has that hash ([`super::hash`]). Off by default.
    pub hash_check: bool,
}

impl ServerConfig {
    /// Bytewise encoding, no pacing, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            encoding: Encoding::Bytewise,
            list_interval_us: 0,
            hash_check: false,
        }
    }
}

/// The parameter server: streams the list, answers reads and sets, in the protocol each request
/// came in. `Q` single answers can wait at once (more are dropped, to be asked for again).
///
/// A set is converted to the parameter's type if the number is exactly representable there,
/// and refused otherwise. PARAM_SET is answered with PARAM_VALUE, the value held, accepted or
/// not; PARAM_EXT_SET with PARAM_EXT_ACK: ACCEPTED and the new value, VALUE_UNSUPPORTED (no
/// such number in the parameter's type) or FAILED (the store refused) and the value held. A
/// set of a name the store does not have goes unanswered in both, as a read of one does.
#[derive(Debug, Clone)]
pub struct Server<const Q: usize> {
    config: ServerConfig,
    /// The next index of a list stream.
    list_next: Option<u16>,
    /// The list stream is PARAM_EXT_VALUE's.
    list_ext: bool,
    list_due_us: u64,
    /// The `_HASH_CHECK` of a list is still to go.
    hash_due: bool,
    queue: [(u16, Answer); Q],
    queued: usize,
    dropped: usize,
}

impl<const Q: usize> Server<Q> {
    /// A server with nothing to send.
    pub fn new(config: ServerConfig) -> Self {
        Self {
            config,
            list_next: None,
            list_ext: false,
            list_due_us: 0,
            hash_due: false,
            queue: [(0, Answer::Value); Q],
            queued: 0,
            dropped: 0,
        }
    }

    /// The settings.
    pub fn config(&self) -> &ServerConfig {
        &self.config
    }

    /// Answers that did not fit the queue.
    pub fn dropped(&self) -> usize {
        self.dropped
    }

    fn enqueue(&mut self, index: u16, answer: Answer) {
        if self.queue[..self.queued].contains(&(index, answer)) {
            return;
        }
        match self.queue.get_mut(self.queued) {
            Some(slot) => {
                *slot = (index, answer);
                self.queued += 1;
            }
            None => crate::bump(&mut self.dropped, 1),
        }
    }

    /// A message from `from`. A set is applied to `store` at once; its answer, like every
    /// other, goes out through [`Server::poll_transmit`].
    pub fn handle<S: Store + ?Sized>(
        &mut self,
        store: &mut S,
        now_us: u64,
        _from: Address,
        msg: &Message,
    ) {
        let own = self.config.own;
        let addressed = |system: u8, component: u8| own.is_addressed_by(system, component);
        match msg {
            Message::ParamRequestList(m) if addressed(m.target_system, m.target_component) => {
                self.start_list(now_us, false);
                self.hash_due = self.config.hash_check;
            }
            Message::ParamExtRequestList(m)
                if S::EXTENDED && addressed(m.target_system, m.target_component) =>
            {
                self.start_list(now_us, true);
            }
            Message::ParamRequestRead(m) if addressed(m.target_system, m.target_component) => {
                if let Some(i) = lookup(store, m.param_index, &m.param_id) {
                    self.enqueue(i, Answer::Value);
                }
            }
            Message::ParamExtRequestRead(m)
                if S::EXTENDED && addressed(m.target_system, m.target_component) =>
            {
                if let Some(i) = lookup(store, m.param_index, &m.param_id) {
                    self.enqueue(i, Answer::ExtValue);
                }
            }
            Message::ParamSet(m)
                if self.config.hash_check
                    && addressed(m.target_system, m.target_component)
                    && super::hash::is_hash_check(&m.param_id) =>
            {
                // The client's cache is right: the rest of the list would tell it nothing.
                self.list_next = None;
                self.hash_due = false;
            }
            Message::ParamSet(m) if addressed(m.target_system, m.target_component) => {
                let value = Value::decode(m.param_value, m.param_type, self.config.encoding);
                if let Some((i, _)) = set(store, &m.param_id, value) {
                    // Accepted or not, the answer is the value it holds now.
                    self.enqueue(i, Answer::Value);
                }
            }
            Message::ParamExtSet(m)
                if S::EXTENDED && addressed(m.target_system, m.target_component) =>
            {
                let value = Value::from_ext(&m.param_value, m.param_type);
                if let Some((i, result)) = set(store, &m.param_id, value) {
                    self.enqueue(i, Answer::ExtAck(result));
                }
            }
            _ => {}
        }
    }

    fn start_list(&mut self, now_us: u64, ext: bool) {
        self.list_next = Some(0);
        self.list_ext = ext;
        self.list_due_us = now_us;
        self.hash_due = false;
    }

    /// The next PARAM_VALUE to send: single answers first, then the list stream. Call until
    /// `None`.
    pub fn poll_transmit<S: Store + ?Sized>(&mut self, store: &S, now_us: u64) -> Option<Message> {
        let count = store.count();
        while self.queued > 0 {
            let (index, answer) = self.queue[0];
            self.queue.copy_within(1..self.queued, 0);
            self.queued -= 1;
            if let Some(m) = self.answer(store, index, count, answer) {
                return Some(m);
            }
        }
        let next = self.list_next?;
        if now_us < self.list_due_us {
            return None;
        }
        // The next is due one interval after this one was; after a late poll, what fell due
        // meanwhile goes at once, at most LIST_BURST values.
        let interval = self.config.list_interval_us;
        let late = now_us.saturating_sub(interval.saturating_mul(LIST_BURST - 1));
        self.list_due_us = self.list_due_us.max(late).saturating_add(interval);
        if self.hash_due {
            self.hash_due = false;
            return Some(super::hash::announce(super::hash::hash(store), count));
        }
        if next >= count {
            self.list_next = None;
            return None;
        }
        self.list_next = Some(next + 1);
        let answer = if self.list_ext {
            Answer::ExtValue
        } else {
            Answer::Value
        };
        self.answer(store, next, count, answer)
    }

    /// When the list stream has its next value due, if one is under way.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.queued > 0 {
            return Some(0);
        }
        self.list_next.map(|_| self.list_due_us)
    }

    fn answer<S: Store + ?Sized>(
        &self,
        store: &S,
        index: u16,
        count: u16,
        answer: Answer,
    ) -> Option<Message> {
        let Param { name, value } = store.get(index)?;
        let encoding = self.config.encoding;
        Some(match answer {
            Answer::Value => Message::ParamValue(ParamValue {
                param_id: name,
                param_value: match S::EXTENDED {
                    true => value.encode(encoding),
                    // A store of 32-bit values only: their code alone.
                    false => value.encode_narrow(encoding)?,
                },
                param_type: value.param_type(),
                param_count: count,
                param_index: index,
            }),
            _ if !S::EXTENDED => return None,
            Answer::ExtValue => Message::ParamExtValue(ParamExtValue {
                param_id: name,
                param_value: value.to_ext(),
                param_type: value.ext_type(),
                param_count: count,
                param_index: index,
            }),
            Answer::ExtAck(result) => Message::ParamExtAck(ParamExtAck {
                param_id: name,
                param_value: value.to_ext(),
                param_type: value.ext_type(),
                param_result: result,
            }),
        })
    }
}

/// The parameter a read asks for: by index if it is one of the store's, by name if the index
/// is negative.
fn lookup<S: Store + ?Sized>(store: &S, index: i16, name: &super::Name) -> Option<u16> {
    match u16::try_from(index) {
        Ok(i) => (i < store.count()).then_some(i),
        Err(_) => store.index_of(name),
    }
}

/// Applies a set of `name` to `value` (`None`: not a number the request's type carries), as
/// the parameter's type: its index and how it went, or `None` for a name the store lacks.
fn set<S: Store + ?Sized>(
    store: &mut S,
    name: &super::Name,
    value: Option<Value>,
) -> Option<(u16, ParamAck)> {
    let i = store.index_of(name)?;
    let ty = store.get(i)?.value.param_type();
    let converted = match S::EXTENDED {
        true => value.and_then(|v| v.convert(ty)),
        false => value.and_then(|v| v.convert_narrow(ty)),
    };
    let result = match converted {
        None => ParamAck::ValueUnsupported,
        Some(v) => match store.set(i, v) {
            Some(_) => ParamAck::Accepted,
            None => ParamAck::Failed,
        },
    };
    Some((i, result))
}
