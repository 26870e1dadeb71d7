//! The command protocol: COMMAND_LONG and COMMAND_INT, answered by COMMAND_ACK.
//!
//! [`Client`] sends a command and waits for its ACK. Without an answer it sends again after
//! [`Retry::timeout_us`], at most [`Retry::retries`] times, counting COMMAND_LONG's
//! `confirmation` up as the protocol asks. `MAV_RESULT_IN_PROGRESS` stops the retries and
//! stretches the wait ([`ClientConfig::in_progress_timeout_us`], 3 s as MAVSDK) for each further
//! ACK; [`Client::cancel`] sends COMMAND_CANCEL. `MAV_RESULT_COMMAND_LONG_ONLY` and
//! `_INT_ONLY` make the client send the command again in the other form, once.
//!
//! An ACK names only its command id, not the request: a late copy of the ACK for an earlier
//! command of the same id, to the same target, is taken for the current one's. Every
//! implementation shares this limit of the protocol.
//!
//! [`Server`] hands each new command to the application once, and answers a repeat of one it has
//! seen with the same ACK (or `IN_PROGRESS` while it runs) without running it again. A repeat
//! is a COMMAND_LONG with `confirmation` above 0, or the same values again within
//! [`ServerConfig::repeat_window_us`]; a command that was refused changed nothing and is run
//! again. Another command of an id that still runs for that sender
//! is refused with `MAV_RESULT_TEMPORARILY_REJECTED`, since the protocol tells answers apart by
//! command id only.
//!
//! ```
//! use ferrolink_runtime::mavlink::service::command::{Client, ClientConfig, Command, Event};
//! use ferrolink_runtime::mavlink::service::messages::{MavCmd, Message};
//! use ferrolink_runtime::mavlink::service::Address;
//!
//! let mut client: Client<2> = Client::new(ClientConfig::new(Address::new(255, 190)));
//! let vehicle = Address::new(1, 1);
//! client.send(0, vehicle, Command::long(MavCmd::ComponentArmDisarm, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])).unwrap();
//! let Some(Message::CommandLong(sent)) = client.poll_transmit(0) else { panic!() };
//! assert_eq!(sent.param1, 1.0);
//! // Nothing comes back: after 0.5 s it is sent again, confirmation 1.
//! let Some(Message::CommandLong(again)) = client.poll_transmit(500_000) else { panic!() };
//! assert_eq!(again.confirmation, 1);
//! ```

use super::messages::{
    CommandAck, CommandCancel, CommandInt, CommandLong, MavCmd, MavFrame, MavResult, Message,
};
use super::{div_f64, earliest, round_i32, widen, Address, Retry};

/// The two forms a command is sent in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Form {
    /// COMMAND_LONG: seven floats.
    Long,
    /// COMMAND_INT: a frame, four floats, x and y as integers, z as a float.
    Int,
}

/// A command and its seven parameters.
///
/// `x` and `y` (param5 and param6) are kept as `f64`. COMMAND_LONG sends them as floats;
/// COMMAND_INT as integers scaled by the frame: degrees × 10⁷ in global frames, metres × 10⁴ in
/// local ones, unscaled otherwise ([`scale`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// The command id.
    pub command: MavCmd,
    /// param1 to param4.
    pub params: [f32; 4],
    /// param5 (latitude or local x).
    pub x: f64,
    /// param6 (longitude or local y).
    pub y: f64,
    /// param7 (altitude or local z).
    pub z: f32,
    /// The frame of x, y and z (COMMAND_INT only).
    pub frame: MavFrame,
    /// The form to send it in first.
    pub form: Form,
}

impl Command {
    /// A COMMAND_LONG with params 1 to 7.
    pub fn long(command: MavCmd, p: [f32; 7]) -> Self {
        Self {
            command,
            params: [p[0], p[1], p[2], p[3]],
            // f64::from(p[4]), by the bits.
            x: widen(p[4]),
            y: widen(p[5]),
            z: p[6],
            frame: MavFrame::Global,
            form: Form::Long,
        }
    }

    /// A COMMAND_INT in `frame`, params 1 to 4 and x, y, z in the frame's units (degrees in
    /// global frames).
    pub fn int(command: MavCmd, frame: MavFrame, params: [f32; 4], x: f64, y: f64, z: f32) -> Self {
        Self {
            command,
            params,
            x,
            y,
            z,
            frame,
            form: Form::Int,
        }
    }

    /// The command as `form` addressed to `target`, with `confirmation` (COMMAND_LONG only).
    pub fn to_message(&self, form: Form, target: Address, confirmation: u8) -> Message {
        let [param1, param2, param3, param4] = self.params;
        match form {
            Form::Long => Message::CommandLong(CommandLong {
                target_system: target.system,
                target_component: target.component,
                command: self.command,
                confirmation,
                param1,
                param2,
                param3,
                param4,
                param5: self.x as f32,
                param6: self.y as f32,
                param7: self.z,
            }),
            Form::Int => {
                let s = scale(self.frame);
                Message::CommandInt(CommandInt {
                    target_system: target.system,
                    target_component: target.component,
                    frame: self.frame,
                    command: self.command,
                    current: 0,
                    autocontinue: 0,
                    param1,
                    param2,
                    param3,
                    param4,
                    x: round_i32(self.x * s),
                    y: round_i32(self.y * s),
                    z: self.z,
                })
            }
        }
    }

    /// The command in a COMMAND_LONG.
    pub fn from_long(m: &CommandLong) -> Self {
        Self::long(
            m.command,
            [
                m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7,
            ],
        )
    }

    /// The command in a COMMAND_INT.
    pub fn from_int(m: &CommandInt) -> Self {
        let s = scale_int(m.frame);
        Self::int(
            m.command,
            m.frame,
            [m.param1, m.param2, m.param3, m.param4],
            // f64::from(m.x) / scale(m.frame), in integers.
            div_f64(m.x, s),
            div_f64(m.y, s),
            m.z,
        )
    }

    /// Whether two commands carry the same values, bit for bit (a NaN equals itself).
    fn same(&self, other: &Self) -> bool {
        self.command == other.command
            && self.frame == other.frame
            && self.form == other.form
            && self.z.to_bits() == other.z.to_bits()
            && self.x.to_bits() == other.x.to_bits()
            && self.y.to_bits() == other.y.to_bits()
            && self
                .params
                .iter()
                .zip(other.params)
                .all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

/// The factor between COMMAND_INT's integer x and y and the frame's units: 10⁷ for global
/// frames (degrees), 10⁴ for local frames (metres), 1 for the rest (MAV_FRAME_MISSION).
pub fn scale(frame: MavFrame) -> f64 {
    f64::from(scale_int(frame))
}

/// [`scale`] as an integer.
// The superseded `_INT` frames still arrive from older senders.
#[allow(deprecated)]
pub(crate) fn scale_int(frame: MavFrame) -> u32 {
    match frame {
        MavFrame::Global
        | MavFrame::GlobalRelativeAlt
        | MavFrame::GlobalInt
        | MavFrame::GlobalRelativeAltInt
        | MavFrame::GlobalTerrainAlt
        | MavFrame::GlobalTerrainAltInt => 10_000_000,
        MavFrame::LocalNed
        | MavFrame::LocalEnu
        | MavFrame::LocalOffsetNed
        | MavFrame::BodyNed
        | MavFrame::BodyOffsetNed
        | MavFrame::BodyFrd
        | MavFrame::LocalFrd
        | MavFrame::LocalFlu => 10_000,
        _ => 1,
    }
}

/// A COMMAND_ACK's answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ack {
    /// The result.
    pub result: MavResult,
    /// Progress in percent (255: unknown) with `IN_PROGRESS`, or the reason of a refusal.
    pub progress: u8,
    /// Further detail, the command's own.
    pub result_param2: i32,
}

impl Ack {
    /// An answer with `result` and nothing else.
    pub const fn new(result: MavResult) -> Self {
        Self {
            result,
            progress: 0,
            result_param2: 0,
        }
    }
}

/// The client's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// Our own address, the ACK's target.
    pub own: Address,
    /// Retries: 0.5 s and 3 retries by default, as MAVSDK.
    pub retry: Retry,
    /// How long to wait for the next ACK once the target said `IN_PROGRESS`: 3 s.
    pub in_progress_timeout_us: u64,
}

impl ClientConfig {
    /// The defaults, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            retry: Retry {
                timeout_us: 500_000,
                retries: 3,
            },
            in_progress_timeout_us: 3_000_000,
        }
    }
}

/// What happened to a command the client sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// The target is working on it (`IN_PROGRESS`), `progress` percent done (255: unknown).
    Progress {
        /// Where it went.
        target: Address,
        /// Which command.
        command: MavCmd,
        /// Percent done.
        progress: u8,
    },
    /// The final answer.
    Done {
        /// Where it went.
        target: Address,
        /// Which command.
        command: MavCmd,
        /// The answer, or `None` when nothing answered after the retries.
        ack: Option<Ack>,
    },
}

/// Why [`Client::send`] refused a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SendError {
    /// The same command to the same target is still waiting for its answer.
    AlreadyPending,
    /// Every slot holds a command waiting for its answer.
    Full,
}

impl core::fmt::Display for SendError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            SendError::AlreadyPending => "this command is already waiting for its answer",
            SendError::Full => "every command slot is waiting for an answer",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for SendError {}

#[derive(Debug, Clone, Copy)]
struct Pending {
    target: Address,
    command: Command,
    form: Form,
    /// Transmissions so far.
    sent: u8,
    /// When to give up waiting for the current transmission; `None` until it is sent.
    deadline: Option<u64>,
    in_progress: bool,
    /// The form was switched on `_LONG_ONLY` / `_INT_ONLY`.
    switched: bool,
    cancel_due: bool,
    /// An event not yet polled.
    progress: Option<u8>,
    done: Option<Option<Ack>>,
}

/// The command client: up to `N` commands waiting for their answers at once.
#[derive(Debug, Clone)]
pub struct Client<const N: usize> {
    config: ClientConfig,
    slots: [Option<Pending>; N],
}

impl<const N: usize> Client<N> {
    /// A client with no commands pending.
    pub fn new(config: ClientConfig) -> Self {
        Self {
            config,
            slots: [None; N],
        }
    }

    /// The settings.
    pub fn config(&self) -> &ClientConfig {
        &self.config
    }

    /// Queues `command` for `target`; it goes out at the next [`Client::poll_transmit`].
    pub fn send(
        &mut self,
        _now_us: u64,
        target: Address,
        command: Command,
    ) -> Result<(), SendError> {
        if self.find(target, command.command).is_some() {
            return Err(SendError::AlreadyPending);
        }
        let slot = self
            .slots
            .iter_mut()
            .find(|s| s.is_none())
            .ok_or(SendError::Full)?;
        *slot = Some(Pending {
            target,
            command,
            form: command.form,
            sent: 0,
            deadline: None,
            in_progress: false,
            switched: false,
            cancel_due: false,
            progress: None,
            done: None,
        });
        Ok(())
    }

    /// Asks the target to cancel `command` (COMMAND_CANCEL). The command stays pending until its
    /// final ACK (`MAV_RESULT_CANCELLED` if the target could cancel it) or its timeout. Returns
    /// whether such a command was pending.
    pub fn cancel(&mut self, target: Address, command: MavCmd) -> bool {
        match self.find(target, command) {
            Some(i) => {
                if let Some(p) = &mut self.slots[i] {
                    p.cancel_due = true;
                }
                true
            }
            None => false,
        }
    }

    /// Whether any command is waiting for its answer (or for its event to be polled).
    pub fn is_idle(&self) -> bool {
        self.slots.iter().all(Option::is_none)
    }

    fn find(&self, target: Address, command: MavCmd) -> Option<usize> {
        self.slots.iter().position(|s| {
            s.as_ref().is_some_and(|p| {
                p.target == target && p.command.command == command && p.done.is_none()
            })
        })
    }

    /// A message from `from`. Only COMMAND_ACKs from a pending command's target, for its
    /// command and for us (or for everyone), count.
    pub fn handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        let Message::CommandAck(ack) = msg else {
            return;
        };
        if !self
            .config
            .own
            .is_addressed_by(ack.target_system, ack.target_component)
        {
            return;
        }
        let Some(i) = self.slots.iter().position(|s| {
            s.as_ref().is_some_and(|p| {
                p.done.is_none()
                    && p.command.command == ack.command
                    && from.system == p.target.system
                    && (p.target.component == 0 || from.component == p.target.component)
            })
        }) else {
            return;
        };
        let Some(p) = &mut self.slots[i] else { return };
        let answer = Ack {
            result: ack.result,
            progress: ack.progress,
            result_param2: ack.result_param2,
        };
        match ack.result {
            MavResult::InProgress => {
                p.in_progress = true;
                p.progress = Some(ack.progress);
                p.deadline = Some(now_us.saturating_add(self.config.in_progress_timeout_us));
            }
            MavResult::CommandLongOnly if p.form == Form::Int && !p.switched => {
                p.switch(Form::Long)
            }
            MavResult::CommandIntOnly if p.form == Form::Long && !p.switched => p.switch(Form::Int),
            _ => p.done = Some(Some(answer)),
        }
    }

    /// The next message to send at `now_us`: a command due for its first transmission or a
    /// retry, or a COMMAND_CANCEL. Call until `None`.
    pub fn poll_transmit(&mut self, now_us: u64) -> Option<Message> {
        let retry = self.config.retry;
        for p in self.slots.iter_mut().flatten() {
            if p.done.is_some() {
                continue;
            }
            if p.cancel_due {
                p.cancel_due = false;
                return Some(Message::CommandCancel(CommandCancel {
                    target_system: p.target.system,
                    target_component: p.target.component,
                    command: p.command.command,
                }));
            }
            let due = p.deadline.is_none_or(|d| now_us >= d);
            if !due {
                continue;
            }
            if p.in_progress || p.sent > retry.retries {
                p.done = Some(None);
                continue;
            }
            let confirmation = p.sent;
            p.sent = p.sent.saturating_add(1);
            p.deadline = Some(now_us.saturating_add(retry.timeout_us));
            return Some(p.command.to_message(p.form, p.target, confirmation));
        }
        None
    }

    /// When [`Client::poll_transmit`] has something to do next, if no answer comes first.
    pub fn poll_timeout(&self) -> Option<u64> {
        self.slots
            .iter()
            .flatten()
            .filter(|p| p.done.is_none())
            .fold(None, |t, p| earliest(t, Some(p.deadline.unwrap_or(0))))
    }

    /// The next event: progress, or a command's end (which frees its slot).
    pub fn poll_event(&mut self) -> Option<Event> {
        for slot in &mut self.slots {
            let Some(p) = slot else { continue };
            let (target, command) = (p.target, p.command.command);
            if let Some(progress) = p.progress.take() {
                return Some(Event::Progress {
                    target,
                    command,
                    progress,
                });
            }
            if let Some(ack) = p.done {
                *slot = None;
                return Some(Event::Done {
                    target,
                    command,
                    ack,
                });
            }
        }
        None
    }
}

impl Pending {
    fn switch(&mut self, form: Form) {
        self.form = form;
        self.switched = true;
        self.sent = 0;
        self.deadline = None;
    }
}

/// What the server asks of the application.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Request {
    /// Run this command and answer it with [`Server::respond`].
    Run {
        /// Who sent it, the ACK's target.
        from: Address,
        /// The command, in the form it came in.
        command: Command,
    },
    /// `from` asks to cancel its running `command`: answer it with `MAV_RESULT_CANCELLED`
    /// through [`Server::respond`], or with its real result if it cannot be stopped.
    Cancel {
        /// Who sent it.
        from: Address,
        /// Which command.
        command: MavCmd,
    },
}

#[derive(Debug, Clone, Copy)]
struct Seen {
    from: Address,
    command: Command,
    /// The latest answer; `IN_PROGRESS` (or nothing yet) while it runs.
    answer: Option<Ack>,
    last_us: u64,
    ack_due: bool,
}

impl Seen {
    fn running(&self) -> bool {
        self.answer
            .is_none_or(|a| a.result == MavResult::InProgress)
    }

    /// Whether it was refused (or failed): it changed nothing, so running it again is safe,
    /// and right when what made it fail has changed since.
    fn refused(&self) -> bool {
        self.answer
            .is_some_and(|a| !matches!(a.result, MavResult::Accepted | MavResult::InProgress))
    }
}

/// The server's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServerConfig {
    /// Our own address: commands for it (or broadcast) are taken.
    pub own: Address,
    /// A command with the same values as one answered within this time (µs) is a repeat, not
    /// a new command: a retry of COMMAND_INT (which has no `confirmation` to tell) or a copy
    /// the link repeated. 2 s by default, a whole MAVSDK retry cycle; make it cover the retry
    /// span of the clients you expect. A COMMAND_LONG with `confirmation` above 0 is a repeat
    /// at any time. A command that was refused or failed is run again whenever it comes: it
    /// changed nothing, and its answer may differ now (take off, refused while disarmed; arm;
    /// take off).
    pub repeat_window_us: u64,
}

impl ServerConfig {
    /// The defaults, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            repeat_window_us: 2_000_000,
        }
    }
}

/// The command server: remembers the last `N` commands it answered, so that retries get the
/// same answer and nothing runs twice.
#[derive(Debug, Clone)]
pub struct Server<const N: usize> {
    config: ServerConfig,
    seen: [Option<Seen>; N],
    /// A refusal for a command that found every slot running.
    busy: Option<(Address, MavCmd)>,
}

impl<const N: usize> Server<N> {
    /// A server that has seen nothing.
    pub fn new(config: ServerConfig) -> Self {
        Self {
            config,
            seen: [None; N],
            busy: None,
        }
    }

    /// A message from `from`: returns what the application must do, if anything. A repeat of a
    /// command already seen returns nothing and queues its answer again.
    pub fn handle(&mut self, now_us: u64, from: Address, msg: &Message) -> Option<Request> {
        let (command, confirmation) = match msg {
            Message::CommandLong(m)
                if self
                    .config
                    .own
                    .is_addressed_by(m.target_system, m.target_component) =>
            {
                (Command::from_long(m), Some(m.confirmation))
            }
            Message::CommandInt(m)
                if self
                    .config
                    .own
                    .is_addressed_by(m.target_system, m.target_component) =>
            {
                (Command::from_int(m), None)
            }
            Message::CommandCancel(m)
                if self
                    .config
                    .own
                    .is_addressed_by(m.target_system, m.target_component) =>
            {
                return self
                    .seen
                    .iter()
                    .flatten()
                    .any(|s| s.from == from && s.command.command == m.command && s.running())
                    .then_some(Request::Cancel {
                        from,
                        command: m.command,
                    });
            }
            _ => return None,
        };
        let window = self.config.repeat_window_us;
        // While a command of that id runs for the sender, the same values again are a retry
        // and anything else is refused for now: an answer to another command of that id would
        // be taken for this one's.
        if let Some(s) = self
            .seen
            .iter_mut()
            .flatten()
            .find(|s| s.from == from && s.command.command == command.command && s.running())
        {
            if s.command.same(&command) {
                s.last_us = now_us;
                s.ack_due = true;
                s.answer.get_or_insert(Ack {
                    result: MavResult::InProgress,
                    progress: u8::MAX,
                    result_param2: 0,
                });
            } else {
                self.busy = Some((from, command.command));
            }
            return None;
        }
        // A retry (confirmation counted up) or a copy the link repeated (the same values within
        // the window) of a command it answered: the same answer again.
        if let Some(s) = self.seen.iter_mut().flatten().find(|s| {
            s.from == from
                && s.command.same(&command)
                && !s.refused()
                && (confirmation.is_some_and(|c| c > 0)
                    || now_us.saturating_sub(s.last_us) <= window)
        }) {
            s.last_us = now_us;
            s.ack_due = true;
            return None;
        }
        let entry = Seen {
            from,
            command,
            answer: None,
            last_us: now_us,
            ack_due: false,
        };
        // A free slot, or the one answered longest ago.
        let slot = self.seen.iter().position(Option::is_none).or_else(|| {
            self.seen
                .iter()
                .enumerate()
                .filter(|(_, s)| s.is_some_and(|s| !s.running() && !s.ack_due))
                .min_by_key(|(_, s)| s.map_or(0, |s| s.last_us))
                .map(|(i, _)| i)
        });
        match slot {
            Some(i) => {
                self.seen[i] = Some(entry);
                Some(Request::Run { from, command })
            }
            None => {
                self.busy = Some((from, command.command));
                None
            }
        }
    }

    /// Answers `from`'s running `command`: `IN_PROGRESS` with progress while it runs, then its
    /// final result. The answer is kept for retries. Returns whether such a command was
    /// running.
    pub fn respond(&mut self, now_us: u64, from: Address, command: MavCmd, ack: Ack) -> bool {
        let Some(s) = self
            .seen
            .iter_mut()
            .flatten()
            .find(|s| s.from == from && s.command.command == command && s.running())
        else {
            return false;
        };
        s.answer = Some(ack);
        s.ack_due = true;
        s.last_us = now_us;
        true
    }

    /// The next COMMAND_ACK to send. Call until `None`.
    pub fn poll_transmit(&mut self, _now_us: u64) -> Option<Message> {
        if let Some((from, command)) = self.busy.take() {
            return Some(ack_message(
                from,
                command,
                Ack::new(MavResult::TemporarilyRejected),
            ));
        }
        let s = self.seen.iter_mut().flatten().find(|s| s.ack_due)?;
        s.ack_due = false;
        let answer = s.answer?;
        Some(ack_message(s.from, s.command.command, answer))
    }
}

fn ack_message(to: Address, command: MavCmd, ack: Ack) -> Message {
    Message::CommandAck(CommandAck {
        command,
        result: ack.result,
        progress: ack.progress,
        result_param2: ack.result_param2,
        target_system: to.system,
        target_component: to.component,
    })
}
