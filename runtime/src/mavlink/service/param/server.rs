//! The parameter server over the caller's [`Store`].

use super::super::messages::{Message, ParamValue};
use super::super::Address;
use super::{Encoding, Store, Value};

/// The server's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServerConfig {
    /// Our own address: requests for it (or broadcast) are answered.
    pub own: Address,
    /// How integers are put into PARAM_VALUE.
    pub encoding: Encoding,
    /// The least time between two values of a list stream (µs); 0 sends as fast as the caller
    /// polls.
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

/// The parameter server: streams the list, answers reads and sets. `Q` single answers can wait
/// at once (more are dropped, to be asked for again).
#[derive(Debug, Clone)]
pub struct Server<const Q: usize> {
    config: ServerConfig,
    /// The next index of a list stream.
    list_next: Option<u16>,
    list_due_us: u64,
    /// The `_HASH_CHECK` of a list is still to go.
    hash_due: bool,
    queue: [u16; Q],
    queued: usize,
    dropped: usize,
}

impl<const Q: usize> Server<Q> {
    /// A server with nothing to send.
    pub fn new(config: ServerConfig) -> Self {
        Self {
            config,
            list_next: None,
            list_due_us: 0,
            hash_due: false,
            queue: [0; Q],
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

    fn enqueue(&mut self, index: u16) {
        if self.queue[..self.queued].contains(&index) {
            return;
        }
        match self.queue.get_mut(self.queued) {
            Some(slot) => {
                *slot = index;
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
        match msg {
            Message::ParamRequestList(m)
                if own.is_addressed_by(m.target_system, m.target_component) =>
            {
                self.list_next = Some(0);
                self.list_due_us = now_us;
                self.hash_due = self.config.hash_check;
            }
            Message::ParamRequestRead(m)
                if own.is_addressed_by(m.target_system, m.target_component) =>
            {
                let index = match u16::try_from(m.param_index) {
                    Ok(i) if i < store.count() => Some(i),
                    Ok(_) => None,
                    Err(_) => store.index_of(&m.param_id),
                };
                if let Some(i) = index {
                    self.enqueue(i);
                }
            }
            Message::ParamSet(m)
                if self.config.hash_check
                    && own.is_addressed_by(m.target_system, m.target_component)
                    && super::hash::is_hash_check(&m.param_id) =>
            {
                // The client's cache is right: the rest of the list would tell it nothing.
                self.list_next = None;
                self.hash_due = false;
            }
            Message::ParamSet(m) if own.is_addressed_by(m.target_system, m.target_component) => {
                let Some(i) = store.index_of(&m.param_id) else {
                    return;
                };
                let current = store.get(i).map(|p| p.value.param_type());
                let value = Value::decode(m.param_value, m.param_type, self.config.encoding)
                    .zip(current)
                    .and_then(|(v, ty)| v.convert(ty));
                if let Some(v) = value {
                    store.set(i, v);
                }
                // Accepted or not, the answer is the value it holds now.
                self.enqueue(i);
            }
            _ => {}
        }
    }

    /// The next PARAM_VALUE to send: single answers first, then the list stream. Call until
    /// `None`.
    pub fn poll_transmit<S: Store + ?Sized>(&mut self, store: &S, now_us: u64) -> Option<Message> {
        let count = store.count();
        while self.queued > 0 {
            let index = self.queue[0];
            self.queue.copy_within(1..self.queued, 0);
            self.queued -= 1;
            if let Some(m) = self.value_message(store, index, count) {
                return Some(m);
            }
        }
        let next = self.list_next?;
        if now_us < self.list_due_us {
            return None;
        }
        if self.hash_due {
            self.hash_due = false;
            self.list_due_us = now_us.saturating_add(self.config.list_interval_us);
            return Some(super::hash::announce(super::hash::hash(store), count));
        }
        if next >= count {
            self.list_next = None;
            return None;
        }
        self.list_next = Some(next + 1);
        self.list_due_us = now_us.saturating_add(self.config.list_interval_us);
        self.value_message(store, next, count)
    }

    /// When the list stream has its next value due, if one is under way.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.queued > 0 {
            return Some(0);
        }
        self.list_next.map(|_| self.list_due_us)
    }

    fn value_message<S: Store + ?Sized>(
        &self,
        store: &S,
        index: u16,
        count: u16,
    ) -> Option<Message> {
        let p = store.get(index)?;
        Some(Message::ParamValue(ParamValue {
            param_id: p.name,
            param_value: p.value.encode(self.config.encoding),
            param_type: p.value.param_type(),
            param_count: count,
            param_index: index,
        }))
    }
}
