//! The parameter protocol: PARAM_REQUEST_LIST, PARAM_REQUEST_READ, PARAM_SET, PARAM_VALUE.
//!
//! PARAM_VALUE carries every value in one `f32`. Integers get there in one of two ways
//! ([`Encoding`]): PX4 and most autopilots copy the integer's bytes into the float
//! ("bytewise"), ArduPilot converts the number (a C cast). A client picks the target's way from
//! its HEARTBEAT (`autopilot`), unless told otherwise.
//!
//! [`Client`] fetches the whole list and re-requests by index what the stream left out, until
//! it holds `param_count` values; it reads and sets single parameters with retries. A stream
//! that starts again mid-list, or a count that changes, does not confuse it: it keeps a bitmap
//! of the indices it holds, `32 × W` of them.
//!
//! [`Server`] answers from a [`Store`] the caller implements (a slice of [`Param`] is one).

use super::messages::{
    Heartbeat, MavAutopilot, MavParamType, Message, ParamRequestList, ParamRequestRead, ParamSet,
    ParamValue,
};
use super::{Address, Busy, Retry, Rtt};
use crate::mavlink::CharArray;

/// A parameter name: up to 16 bytes, NUL-padded.
pub type Name = CharArray<16>;

/// How integers travel in PARAM_VALUE's and PARAM_SET's `f32`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// The integer's bytes in the float's (little-endian) bytes, the rest zero: PX4, MAVSDK
    /// and the protocol's own rule.
    Bytewise,
    /// The number converted to `f32`, as a C cast: ArduPilot.
    CCast,
}

impl Encoding {
    /// The encoding an autopilot uses: C cast for ArduPilot, bytewise for every other.
    pub fn for_autopilot(autopilot: MavAutopilot) -> Self {
        match autopilot {
            MavAutopilot::Ardupilotmega => Encoding::CCast,
            _ => Encoding::Bytewise,
        }
    }
}

/// A parameter value of one of the types PARAM_VALUE carries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// MAV_PARAM_TYPE_UINT8.
    U8(u8),
    /// MAV_PARAM_TYPE_INT8.
    I8(i8),
    /// MAV_PARAM_TYPE_UINT16.
    U16(u16),
    /// MAV_PARAM_TYPE_INT16.
    I16(i16),
    /// MAV_PARAM_TYPE_UINT32.
    U32(u32),
    /// MAV_PARAM_TYPE_INT32.
    I32(i32),
    /// MAV_PARAM_TYPE_REAL32.
    F32(f32),
}

impl Value {
    /// The MAV_PARAM_TYPE.
    pub fn param_type(self) -> MavParamType {
        match self {
            Value::U8(_) => MavParamType::Uint8,
            Value::I8(_) => MavParamType::Int8,
            Value::U16(_) => MavParamType::Uint16,
            Value::I16(_) => MavParamType::Int16,
            Value::U32(_) => MavParamType::Uint32,
            Value::I32(_) => MavParamType::Int32,
            Value::F32(_) => MavParamType::Real32,
        }
    }

    /// The value in PARAM_VALUE's `f32`.
    pub fn encode(self, encoding: Encoding) -> f32 {
        match encoding {
            Encoding::Bytewise => f32::from_bits(match self {
                Value::U8(v) => u32::from(v),
                Value::I8(v) => u32::from(v as u8),
                Value::U16(v) => u32::from(v),
                Value::I16(v) => u32::from(v as u16),
                Value::U32(v) => v,
                Value::I32(v) => v as u32,
                Value::F32(v) => return v,
            }),
            Encoding::CCast => match self {
                Value::U8(v) => f32::from(v),
                Value::I8(v) => f32::from(v),
                Value::U16(v) => f32::from(v),
                Value::I16(v) => f32::from(v),
                Value::U32(v) => v as f32,
                Value::I32(v) => v as f32,
                Value::F32(v) => v,
            },
        }
    }

    /// The value of type `ty` in PARAM_VALUE's `raw`; `None` for the 64-bit types and unknown
    /// ones, which a 4-byte float cannot carry.
    pub fn decode(raw: f32, ty: MavParamType, encoding: Encoding) -> Option<Self> {
        let bits = raw.to_bits();
        Some(match (encoding, ty) {
            (_, MavParamType::Real32) => Value::F32(raw),
            (Encoding::Bytewise, MavParamType::Uint8) => Value::U8(bits as u8),
            (Encoding::Bytewise, MavParamType::Int8) => Value::I8(bits as u8 as i8),
            (Encoding::Bytewise, MavParamType::Uint16) => Value::U16(bits as u16),
            (Encoding::Bytewise, MavParamType::Int16) => Value::I16(bits as u16 as i16),
            (Encoding::Bytewise, MavParamType::Uint32) => Value::U32(bits),
            (Encoding::Bytewise, MavParamType::Int32) => Value::I32(bits as i32),
            // `as` from a float truncates toward zero and saturates, as the C cast's defined cases.
            (Encoding::CCast, MavParamType::Uint8) => Value::U8(raw as u8),
            (Encoding::CCast, MavParamType::Int8) => Value::I8(raw as i8),
            (Encoding::CCast, MavParamType::Uint16) => Value::U16(raw as u16),
            (Encoding::CCast, MavParamType::Int16) => Value::I16(raw as i16),
            (Encoding::CCast, MavParamType::Uint32) => Value::U32(raw as u32),
            (Encoding::CCast, MavParamType::Int32) => Value::I32(raw as i32),
            _ => return None,
        })
    }

    /// The value as a number.
    pub fn as_f64(self) -> f64 {
        match self {
            Value::U8(v) => f64::from(v),
            Value::I8(v) => f64::from(v),
            Value::U16(v) => f64::from(v),
            Value::I16(v) => f64::from(v),
            Value::U32(v) => f64::from(v),
            Value::I32(v) => f64::from(v),
            Value::F32(v) => f64::from(v),
        }
    }

    /// `v` as type `ty`, if it is exactly representable there (an integer in range for the
    /// integer types; any number for REAL32, rounded to the nearest `f32`).
    pub fn from_f64(ty: MavParamType, v: f64) -> Option<Self> {
        fn int<T: TryFrom<i64>>(v: f64) -> Option<T> {
            // Integral and well inside i64: the cast is exact.
            if v.is_finite() && v == (v as i64) as f64 && v.abs() < 9.0e15 {
                T::try_from(v as i64).ok()
            } else {
                None
            }
        }
        Some(match ty {
            MavParamType::Uint8 => Value::U8(int(v)?),
            MavParamType::Int8 => Value::I8(int(v)?),
            MavParamType::Uint16 => Value::U16(int(v)?),
            MavParamType::Int16 => Value::I16(int(v)?),
            MavParamType::Uint32 => Value::U32(int(v)?),
            MavParamType::Int32 => Value::I32(int(v)?),
            MavParamType::Real32 => Value::F32(v as f32),
            _ => return None,
        })
    }

    /// This value as type `ty`, if the number is exactly representable there.
    pub fn convert(self, ty: MavParamType) -> Option<Self> {
        if self.param_type() == ty {
            return Some(self);
        }
        Self::from_f64(ty, self.as_f64())
    }

    /// Equal type and bits (a NaN equals itself, 0.0 differs from -0.0).
    pub fn same(self, other: Self) -> bool {
        match (self, other) {
            (Value::F32(a), Value::F32(b)) => a.to_bits() == b.to_bits(),
            (a, b) => a == b,
        }
    }
}

/// One parameter: its name and value. A slice of them is a [`Store`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    /// The name.
    pub name: Name,
    /// The value, whose type is the parameter's.
    pub value: Value,
}

/// Where a [`Server`] keeps its parameters. Indices are `0..count()`.
pub trait Store {
    /// How many parameters there are.
    fn count(&self) -> u16;
    /// Parameter `index`.
    fn get(&self, index: u16) -> Option<Param>;
    /// The index of the parameter called `name`.
    fn index_of(&self, name: &Name) -> Option<u16>;
    /// Sets parameter `index` to `value` (already of the parameter's type) and returns the
    /// value it now holds; `None` if it refused (read-only, out of limits).
    fn set(&mut self, index: u16, value: Value) -> Option<Value>;
}

impl Store for [Param] {
    fn count(&self) -> u16 {
        self.len().min(usize::from(u16::MAX)) as u16
    }

    fn get(&self, index: u16) -> Option<Param> {
        self.get(usize::from(index)).copied()
    }

    fn index_of(&self, name: &Name) -> Option<u16> {
        self.iter()
            .position(|p| p.name == *name)
            .and_then(|i| u16::try_from(i).ok())
    }

    fn set(&mut self, index: u16, value: Value) -> Option<Value> {
        let p = self.get_mut(usize::from(index))?;
        p.value = value;
        Some(value)
    }
}

/// A PARAM_VALUE as a client understood it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Received {
    /// The name.
    pub name: Name,
    /// The index (`u16::MAX` for values outside the list, such as PX4's `_HASH_CHECK`).
    pub index: u16,
    /// How many parameters the sender has.
    pub count: u16,
    /// The value, decoded with the sender's encoding; `None` for a type a float cannot carry.
    pub value: Option<Value>,
}

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
    /// The answer to a read, `None` after the retries.
    Read(Option<Received>),
    /// What the target reports after a set, `None` after the retries. The set took only if
    /// the reported value is exactly the one sent ([`Value::same`]).
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
        Ok(())
    }

    /// Fetches every parameter. Each one arrives through [`Client::handle`]'s return value;
    /// [`Event::Listed`] ends it.
    pub fn list(&mut self) -> Result<(), Busy> {
        self.have = [0; W];
        self.held = 0;
        self.start(Op::List {
            count: None,
            filling: false,
            cursor: 0,
            in_flight: 0,
            request_due: true,
        })
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
        let v = match msg {
            Message::Heartbeat(Heartbeat { autopilot, .. }) => {
                if self.config.encoding.is_none() && *autopilot != MavAutopilot::Invalid {
                    self.encoding = Encoding::for_autopilot(*autopilot);
                }
                return None;
            }
            Message::ParamValue(v) => v,
            _ => return None,
        };
        let received = Received {
            name: v.param_id,
            index: v.param_index,
            count: v.param_count,
            value: Value::decode(v.param_value, v.param_type, self.encoding),
        };
        if let Some(sent) = self.sent_us.take() {
            self.rtt.sample(now_us.saturating_sub(sent));
        }
        match self.op {
            Op::Idle => {}
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
            Op::Set { name, .. } => {
                if received.name == name {
                    self.finish(Event::Set(Some(received)));
                }
            }
        }
        Some(received)
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
            Op::Set { .. } if exhausted => {
                self.finish(Event::Set(None));
                return None;
            }
            Op::Read { name, index } => read_message(target, &name, index),
            Op::Set { name, value } => Message::ParamSet(ParamSet {
                target_system: target.system,
                target_component: target.component,
                param_id: name,
                param_value: value.encode(self.encoding),
                param_type: value.param_type(),
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
            msg = Some(Message::ParamRequestList(ParamRequestList {
                target_system: self.target.system,
                target_component: self.target.component,
            }));
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
                msg = Some(read_message(
                    self.target,
                    &Name::default(),
                    i16::try_from(i).unwrap_or(-1),
                ));
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

    /// When [`Client::poll_transmit`] has something to do next, if nothing arrives first.
    pub fn poll_timeout(&self) -> Option<u64> {
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

fn read_message(target: Address, name: &Name, index: i16) -> Message {
    Message::ParamRequestRead(ParamRequestRead {
        target_system: target.system,
        target_component: target.component,
        param_id: *name,
        param_index: index,
    })
}

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
}

impl ServerConfig {
    /// Bytewise encoding, no pacing, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            encoding: Encoding::Bytewise,
            list_interval_us: 0,
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
