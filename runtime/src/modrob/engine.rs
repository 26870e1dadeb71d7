//! The module engine: one ModRob-1 module's variables, driven by received messages and a clock.
//!
//! An [`Engine`] is built on the [`Dictionary`] the generator emits for a module. It holds the
//! variables' values, publication rates and subscription addresses, applies the commands
//! addressed to the module ([`Engine::handle`]), follows the publications it subscribes to, and
//! hands out, on [`Engine::poll`], the publications and info chunks that are due. Everything
//! lives in fixed arrays sized by the table (`[_; N]`): no allocation, no panics on any input.
//!
//! ```
//! use ferrolink_runtime::modrob::{CommandKind, Dictionary, Direction, Engine, Handled, Message, Variable};
//!
//! const DRIVE: Dictionary<2> = Dictionary {
//!     name: "drive",
//!     kind: "drive",
//!     module: 0x10,
//!     uuid: None,
//!     info: "drive",
//!     fingerprint: 0x1234_5678,
//!     variables: [
//!         Variable { vi: 0, name: "speed_setpoint", unit: "m/s", direction: Direction::Input,
//!             min: -10.0, max: 10.0, default: 0.0, persist: false, rate: 0.0, description: "" },
//!         Variable { vi: 1, name: "speed", unit: "m/s", direction: Direction::Output,
//!             min: -20.0, max: 20.0, default: 0.0, persist: false, rate: 100.0, description: "" },
//!     ],
//! };
//!
//! let mut drive = Engine::new(&DRIVE);
//! // The first poll starts the clock, publishes every variable with a rate and announces.
//! let mut sent = Vec::new();
//! while let Some(message) = drive.poll(0) {
//!     sent.push(message);
//! }
//! assert_eq!(sent.len(), 2); // speed, then the single info chunk
//! assert_eq!(sent[0], Message::Publication { module: 0x10, variable: 1, value: 0.0 });
//!
//! // A set point from the leader: stored, and the control code is told.
//! let set = Message::Command { module: 0x10, variable: 0, command: CommandKind::SetValue(2.5) };
//! assert!(matches!(drive.handle(&set), Handled::Applied { variable: 0, .. }));
//! assert_eq!(drive.take_changed(), Some(0));
//! assert_eq!(drive.value(0), Some(2.5));
//!
//! // The control code writes a reading; it goes out with the next publication, 10 ms later.
//! drive.set(1, 1.9).unwrap();
//! assert_eq!(drive.next_deadline(), Some(10_000));
//! assert_eq!(drive.poll(10_000), Some(Message::Publication { module: 0x10, variable: 1, value: 1.9 }));
//! assert_eq!(drive.poll(10_000), None);
//! ```
//!
//! # Commands
//!
//! [`Engine::handle`] takes every message seen on the network and says what it did
//! ([`Handled`]). Commands for another MI and piecewise chunks are [`Handled::Ignored`].
//! A command for this MI is counted in [`Counters::commands`]; one for a VI the table lacks is
//! counted in [`Counters::unknown_variable`] and otherwise ignored.
//!
//! - **Set value.** The variable's limits apply ([`Variable::accepts`]): a value out of limits,
//!   or NaN, leaves the variable unchanged, is counted in [`Counters::rejected`] and is reported
//!   as [`Handled::Rejected`]. An accepted value on an **input** is stored and raises the
//!   variable's *changed* flag, which the control code collects with
//!   [`Engine::take_changed`] (a 256-bit mask keyed by VI, lowest VI first). The flag is raised
//!   even when the new value equals the old one: the command itself is news. An accepted value
//!   on an **output** is stored, so it goes out in the next publication, but raises no flag: the
//!   specification says setting an output from outside changes no state, and the control code
//!   overwrites it with its next reading.
//! - **Set publication frequency.** Any finite rate from 0 to [`MAX_RATE_HZ`] Hz is accepted;
//!   0 stops publishing. A negative, NaN or infinite rate, or one above the maximum, is rejected
//!   and counted like a value out of limits. An accepted rate, even the current one, restarts
//!   the variable's schedule: the first publication is due at the next [`Engine::poll`], then
//!   one every period.
//! - **Set subscription address.** The (MI, VI) is stored as the source of the commanded
//!   variable; any address is accepted. Subscribing a variable to **its own address** (this
//!   module's current MI and the same VI) clears its subscription, since a variable following
//!   itself means nothing.
//!
//! # Subscriptions
//!
//! A publication whose (MI, VI) is the source of one or more variables sets each of them as a
//! "set value" command would: limits apply, inputs raise their changed flag, outputs do not.
//! Each accepted value is counted in [`Counters::subscription_updates`]; each refused one in
//! [`Counters::subscription_rejected`] (kept apart from [`Counters::rejected`], which counts
//! commands only). Several variables may follow the same source. A publication nobody follows
//! is [`Handled::Ignored`].
//!
//! # Values set by the module
//!
//! The module's control code sets variables with [`Engine::set`] (limits apply; a refused value
//! is an error and leaves the variable unchanged), rates with [`Engine::set_rate`] or
//! [`Engine::set_rate_mhz`], and subscriptions with [`Engine::set_subscription`]. None of these
//! is counted or raises a changed flag.
//!
//! # Scheduling
//!
//! Times are microseconds of any monotonic clock, given to [`Engine::poll`], which returns one
//! due message per call: call it until it returns `None`, then sleep until
//! [`Engine::next_deadline`] or until a message arrives. The clock starts at the first poll:
//! every variable with a rate publishes then, and the module announces itself (see below).
//!
//! Rates are held as integer **millihertz**: a rate in Hz is rounded to the nearest mHz, and a
//! positive rate below 0.5 mHz becomes 1 mHz (one publication every 11.6 days) rather than
//! silently stopping. [`Engine::rate`] reports the rate in use (`mHz / 1000`). Publication `k`
//! of a schedule started at `start` is due at exactly `start + floor(k * 10^9 / mHz)` µs,
//! computed in 128-bit integers from `start` and `k`, never by adding periods, so no rounding
//! accumulates however long it runs. [`MAX_RATE_HZ`] is 10 kHz (a 100 µs period): above it a
//! microsecond clock has no resolution left, and no ModRob network carries more (CAN-1 at
//! 1 Mbit/s moves about 5500 publications a second).
//!
//! A late poll publishes once and skips the publications it missed, counting them in
//! [`Counters::missed`]; it never bursts to catch up. The schedule keeps its phase: the next
//! publication is the first one of the original grid after the poll.
//!
//! All variables whose schedules started at the same poll with the same rate are due at the
//! same instants; a poll hands them out in table order (VI order).
//!
//! # Info text
//!
//! [`Engine::announce`] starts sending the dictionary's info text in piecewise chunks (again
//! from chunk 0 if a transmission is under way). A new engine announces itself at its first
//! poll, so a leader learns of it even when it publishes nothing. Chunks are paced: one per
//! [`Engine::info_interval`] (default [`DEFAULT_INFO_INTERVAL_US`], 1 ms; 0 sends them all at
//! once), and a poll hands out due publications before a due chunk, so a long text never delays
//! the control data.
//!
//! # Persistence
//!
//! [`Engine::save`] writes the values of the persistent variables and every variable's rate and
//! subscription into a caller's buffer of [`Engine::IMAGE_LEN`] bytes; [`Engine::load`] checks
//! a whole image before applying any of it. The byte layout is in [`persist`]. A load restarts
//! every schedule (as a rate command would) and raises no changed flags: it happens at power-up,
//! before the control code reads its variables.
//!
//! [`Variable::accepts`]: super::dictionary::Variable::accepts

use core::fmt;

use super::dictionary::{Dictionary, Direction};
use super::message::{CommandKind, Message};
use super::persist::{self, PersistError, Settings};
pub use super::persist::{rate_to_mhz, MAX_RATE_HZ, MAX_RATE_MHZ};
use super::piecewise::Sender;

/// The default spacing of info chunks, in µs.
pub const DEFAULT_INFO_INTERVAL_US: u64 = 1_000;

/// Microseconds times millihertz in one cycle: a period is `10^9 / mHz` µs.
const PERIOD_SCALE: u128 = 1_000_000_000;

/// A rate in millihertz as Hz.
pub fn mhz_to_hz(mhz: u32) -> f32 {
    (f64::from(mhz) / 1000.0) as f32
}

/// When publication `k` of a schedule started at `anchor` with `mhz` is due.
fn due_at(anchor: u64, k: u64, mhz: u32) -> u64 {
    let offset = u128::from(k) * PERIOD_SCALE / u128::from(mhz.max(1));
    u64::try_from(offset).map_or(u64::MAX, |offset| anchor.saturating_add(offset))
}

/// The first publication of a schedule started at `anchor` with `mhz` due after `now`: the
/// smallest `k` with `anchor + floor(k * 10^9 / mhz) > now`, i.e. `k * 10^9 >= (now - anchor
/// + 1) * mhz`.
fn first_after(anchor: u64, now: u64, mhz: u32) -> u64 {
    let elapsed = u128::from(now.saturating_sub(anchor)) + 1;
    let k = (elapsed * u128::from(mhz)).div_ceil(PERIOD_SCALE);
    u64::try_from(k).unwrap_or(u64::MAX)
}

/// Where a variable's publications stand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Schedule {
    /// Rate 0: nothing to publish.
    Off,
    /// A rate, and the schedule starts at the next poll.
    Pending,
    /// Publication `k` is due at `due`, on the grid started at `anchor`.
    Running { anchor: u64, k: u64, due: u64 },
}

impl Schedule {
    fn for_rate(mhz: u32) -> Self {
        if mhz == 0 {
            Schedule::Off
        } else {
            Schedule::Pending
        }
    }
}

/// Counters since the engine was made. They wrap around.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Commands addressed to this module's MI, whatever became of them.
    pub commands: u32,
    /// Commands for a known variable that were refused: a value out of limits or NaN, an
    /// invalid rate.
    pub rejected: u32,
    /// Commands for a VI this module does not have.
    pub unknown_variable: u32,
    /// Variables set from a publication they subscribe to.
    pub subscription_updates: u32,
    /// Published values a subscribed variable refused (out of its limits, or NaN).
    pub subscription_rejected: u32,
    /// Publications handed out by [`Engine::poll`].
    pub publications: u32,
    /// Info chunks handed out by [`Engine::poll`].
    pub chunks: u32,
    /// Publications skipped because the engine was polled late.
    pub missed: u32,
}

/// What [`Engine::handle`] did with a message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Handled {
    /// Not for this module: a command to another MI, a piecewise chunk, or a publication no
    /// variable here subscribes to.
    Ignored,
    /// A command applied: a value stored, a rate or a subscription set.
    Applied {
        /// The commanded VI.
        variable: u8,
        /// The command.
        command: CommandKind,
    },
    /// A command refused: a value out of limits or NaN, or an invalid rate. Nothing changed.
    Rejected {
        /// The commanded VI.
        variable: u8,
        /// The command.
        command: CommandKind,
    },
    /// A command for a VI this module does not have. Nothing changed.
    UnknownVariable {
        /// The commanded VI.
        variable: u8,
    },
    /// A publication some variables subscribe to.
    Subscriptions {
        /// How many of them took the value.
        applied: u16,
        /// How many refused it (out of their limits, or NaN).
        rejected: u16,
    },
}

impl Handled {
    /// Whether the message concerned this module.
    pub fn is_for_us(&self) -> bool {
        !matches!(self, Handled::Ignored)
    }
}

/// Why the module's own code could not set a variable, a rate or a subscription.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SetError {
    /// The table has no variable with this VI.
    UnknownVariable,
    /// The value is outside the variable's limits, or NaN.
    OutOfLimits,
    /// The rate is negative, NaN, infinite or above [`MAX_RATE_HZ`].
    InvalidRate,
}

impl fmt::Display for SetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SetError::UnknownVariable => "the module has no variable with this VI",
            SetError::OutOfLimits => "the value is outside the variable's limits",
            SetError::InvalidRate => "the rate is negative, not finite or above 10 kHz",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for SetError {}

/// One ModRob-1 module: its variables' values, rates and subscriptions, its publication
/// schedule and its info text. See the [module documentation](self) for its behaviour.
///
/// `46 N + 152` bytes on a 64-bit target, a little less on a 32-bit one.
#[derive(Debug, Clone)]
pub struct Engine<'d, const N: usize> {
    dictionary: &'d Dictionary<N>,
    module: u16,
    settings: Settings<N>,
    schedules: [Schedule; N],
    /// Changed flags of input variables, bit `vi % 32` of word `vi / 32`.
    changed: [u32; 8],
    info: Sender<'d>,
    /// When the next info chunk may go out.
    info_at: u64,
    info_interval: u64,
    started: bool,
    /// The first variable not yet looked at by the polls at `scan_now`: a variable published
    /// at a time is not due again at that time, so a poll loop looks at each one once.
    scan: usize,
    scan_now: u64,
    counters: Counters,
}

impl<'d, const N: usize> Engine<'d, N> {
    /// The bytes [`Engine::save`] writes: [`persist::image_len`] of `N`.
    pub const IMAGE_LEN: usize = persist::image_len(N);

    /// An engine at the dictionary's defaults: its MI, default values and rates, no
    /// subscriptions, no changed flags. Its clock starts at the first [`Engine::poll`], which
    /// also announces the info text. A default rate that is not valid (see [`rate_to_mhz`])
    /// counts as 0.
    pub fn new(dictionary: &'d Dictionary<N>) -> Self {
        let settings = Settings::defaults(dictionary);
        let schedules = core::array::from_fn(|i| Schedule::for_rate(settings.rates[i]));
        Self {
            dictionary,
            module: dictionary.module,
            settings,
            schedules,
            changed: [0; 8],
            info: Sender::new(dictionary.module, dictionary.info.as_bytes()),
            info_at: 0,
            info_interval: DEFAULT_INFO_INTERVAL_US,
            started: false,
            scan: 0,
            scan_now: 0,
            counters: Counters::default(),
        }
    }

    /// The module's table.
    pub fn dictionary(&self) -> &'d Dictionary<N> {
        self.dictionary
    }

    /// The module's MI.
    pub fn module(&self) -> u16 {
        self.module
    }

    /// Changes the module's MI: commands to the new MI are handled from now on, and
    /// publications and info chunks not sent yet carry it. It does not announce again; call
    /// [`Engine::announce`] for that.
    pub fn set_module(&mut self, module: u16) {
        self.module = module;
        self.info.set_module(module);
    }

    /// The value of variable `vi`.
    pub fn value(&self, vi: u8) -> Option<f32> {
        self.dictionary
            .index_of(vi)
            .map(|i| self.settings.values[i])
    }

    /// Every variable's value, in table (VI) order.
    pub fn values(&self) -> &[f32; N] {
        &self.settings.values
    }

    /// The publication rate of variable `vi` in use, in Hz (0: not published).
    pub fn rate(&self, vi: u8) -> Option<f32> {
        self.rate_mhz(vi).map(mhz_to_hz)
    }

    /// The publication rate of variable `vi`, in millihertz.
    pub fn rate_mhz(&self, vi: u8) -> Option<u32> {
        self.dictionary.index_of(vi).map(|i| self.settings.rates[i])
    }

    /// The (MI, VI) variable `vi` follows; `None` if it follows nothing or does not exist.
    pub fn subscription(&self, vi: u8) -> Option<(u16, u8)> {
        self.dictionary
            .index_of(vi)
            .and_then(|i| self.settings.subscriptions[i])
    }

    /// Values, rates and subscriptions together: what [`Engine::save`] stores.
    pub fn settings(&self) -> &Settings<N> {
        &self.settings
    }

    /// The counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The module's own code sets variable `vi`. Limits apply: a refused value leaves the
    /// variable unchanged. Not counted, and raises no changed flag.
    pub fn set(&mut self, vi: u8, value: f32) -> Result<(), SetError> {
        let i = self.index(vi)?;
        if !self.dictionary.variables[i].accepts(value) {
            return Err(SetError::OutOfLimits);
        }
        self.settings.values[i] = value;
        Ok(())
    }

    /// The module's own code sets the publication rate of variable `vi`, in Hz, as a "set
    /// publication frequency" command would: the schedule restarts at the next poll.
    pub fn set_rate(&mut self, vi: u8, hz: f32) -> Result<(), SetError> {
        let mhz = rate_to_mhz(hz).ok_or(SetError::InvalidRate)?;
        self.set_rate_mhz(vi, mhz)
    }

    /// [`Engine::set_rate`] in millihertz (at most [`MAX_RATE_MHZ`]).
    pub fn set_rate_mhz(&mut self, vi: u8, mhz: u32) -> Result<(), SetError> {
        let i = self.index(vi)?;
        if mhz > MAX_RATE_MHZ {
            return Err(SetError::InvalidRate);
        }
        self.apply_rate(i, mhz);
        Ok(())
    }

    /// The module's own code makes variable `vi` follow the publications of `source` (MI, VI),
    /// or nothing.
    pub fn set_subscription(&mut self, vi: u8, source: Option<(u16, u8)>) -> Result<(), SetError> {
        let i = self.index(vi)?;
        self.settings.subscriptions[i] = source;
        Ok(())
    }

    /// Takes one raised changed flag: the lowest VI of an input variable set from outside
    /// since its flag was last taken.
    pub fn take_changed(&mut self) -> Option<u8> {
        for (word_index, word) in self.changed.iter_mut().enumerate() {
            if *word != 0 {
                let bit = word.trailing_zeros();
                *word &= !(1 << bit);
                return Some((word_index * 32) as u8 + bit as u8);
            }
        }
        None
    }

    /// Whether variable `vi`'s changed flag is raised (without taking it).
    pub fn is_changed(&self, vi: u8) -> bool {
        self.changed[usize::from(vi / 32)] & 1 << (vi % 32) != 0
    }

    /// Sends the info text (again) from its first chunk.
    pub fn announce(&mut self) {
        self.info.restart();
        self.info_at = 0;
    }

    /// Whether info chunks remain to be sent.
    pub fn is_announcing(&self) -> bool {
        !self.info.is_done()
    }

    /// The spacing of info chunks, in µs.
    pub fn info_interval(&self) -> u64 {
        self.info_interval
    }

    /// Sets the spacing of info chunks, in µs; 0 sends every chunk at the same poll.
    pub fn set_info_interval(&mut self, interval_us: u64) {
        self.info_interval = interval_us;
    }

    /// Handles a message from the network. See the [module documentation](self).
    pub fn handle(&mut self, message: &Message) -> Handled {
        match *message {
            Message::Command {
                module,
                variable,
                command,
            } if module == self.module => self.command(variable, command),
            Message::Publication {
                module,
                variable,
                value,
            } => self.publication(module, variable, value),
            _ => Handled::Ignored,
        }
    }

    /// The next message due at `now_us`: a publication, else an info chunk. Call again until
    /// `None`. The first call starts the clock and the announcement.
    pub fn poll(&mut self, now_us: u64) -> Option<Message> {
        if !self.started {
            self.started = true;
            self.announce();
        }
        if now_us != self.scan_now {
            self.scan = 0;
            self.scan_now = now_us;
        }
        while self.scan < N {
            let i = self.scan;
            self.scan += 1;
            if let Some(message) = self.publish_if_due(i, now_us) {
                return Some(message);
            }
        }
        if !self.info.is_done() && now_us >= self.info_at {
            if let Some(chunk) = self.info.next_chunk() {
                self.info_at = now_us.saturating_add(self.info_interval);
                self.counters.chunks = self.counters.chunks.wrapping_add(1);
                return Some(chunk);
            }
        }
        None
    }

    /// When [`Engine::poll`] next has something to hand out, if no message arrives before:
    /// 0 means at once (not started yet, a schedule restarted, an announcement starting);
    /// `None` means nothing is scheduled.
    pub fn next_deadline(&self) -> Option<u64> {
        if !self.started {
            return Some(0);
        }
        let publications = self.schedules.iter().filter_map(|s| match *s {
            Schedule::Off => None,
            Schedule::Pending => Some(0),
            Schedule::Running { due, .. } => Some(due),
        });
        let info = (!self.info.is_done()).then_some(self.info_at);
        publications.chain(info).min()
    }

    /// Writes the persistent values and every rate and subscription into `buf` (at least
    /// [`Engine::IMAGE_LEN`] bytes); returns the image's length.
    pub fn save(&self, buf: &mut [u8]) -> Result<usize, PersistError> {
        persist::save(self.dictionary, &self.settings, buf)
    }

    /// Applies an image made by [`Engine::save`] for the same table. The whole image is
    /// checked first: on any error nothing changes. Restarts every schedule; raises no changed
    /// flags.
    pub fn load(&mut self, image: &[u8]) -> Result<(), PersistError> {
        persist::load(self.dictionary, image, &mut self.settings)?;
        for (schedule, &mhz) in self.schedules.iter_mut().zip(&self.settings.rates) {
            *schedule = Schedule::for_rate(mhz);
        }
        self.scan = 0;
        Ok(())
    }

    fn index(&self, vi: u8) -> Result<usize, SetError> {
        self.dictionary
            .index_of(vi)
            .ok_or(SetError::UnknownVariable)
    }

    fn apply_rate(&mut self, i: usize, mhz: u32) {
        self.settings.rates[i] = mhz;
        self.schedules[i] = Schedule::for_rate(mhz);
        self.scan = 0;
    }

    /// Stores `value` into variable `i` if its limits accept it; an input raises its flag.
    fn accept(&mut self, i: usize, value: f32) -> bool {
        let variable = &self.dictionary.variables[i];
        if !variable.accepts(value) {
            return false;
        }
        self.settings.values[i] = value;
        if variable.direction == Direction::Input {
            self.changed[usize::from(variable.vi / 32)] |= 1 << (variable.vi % 32);
        }
        true
    }

    fn command(&mut self, variable: u8, command: CommandKind) -> Handled {
        self.counters.commands = self.counters.commands.wrapping_add(1);
        let Some(i) = self.dictionary.index_of(variable) else {
            self.counters.unknown_variable = self.counters.unknown_variable.wrapping_add(1);
            return Handled::UnknownVariable { variable };
        };
        let applied = match command {
            CommandKind::SetValue(value) => self.accept(i, value),
            CommandKind::SetFrequency(hz) => match rate_to_mhz(hz) {
                Some(mhz) => {
                    self.apply_rate(i, mhz);
                    true
                }
                None => false,
            },
            CommandKind::SetSubscription {
                module,
                variable: source,
            } => {
                self.settings.subscriptions[i] =
                    (module != self.module || source != variable).then_some((module, source));
                true
            }
        };
        if applied {
            Handled::Applied { variable, command }
        } else {
            self.counters.rejected = self.counters.rejected.wrapping_add(1);
            Handled::Rejected { variable, command }
        }
    }

    fn publication(&mut self, module: u16, variable: u8, value: f32) -> Handled {
        let (mut applied, mut rejected) = (0u16, 0u16);
        for i in 0..N {
            if self.settings.subscriptions[i] != Some((module, variable)) {
                continue;
            }
            if self.accept(i, value) {
                applied = applied.wrapping_add(1);
                self.counters.subscription_updates =
                    self.counters.subscription_updates.wrapping_add(1);
            } else {
                rejected = rejected.wrapping_add(1);
                self.counters.subscription_rejected =
                    self.counters.subscription_rejected.wrapping_add(1);
            }
        }
        if applied == 0 && rejected == 0 {
            Handled::Ignored
        } else {
            Handled::Subscriptions { applied, rejected }
        }
    }

    /// Publishes variable `i` if it is due at `now`, and moves its schedule to the first
    /// publication after `now`, counting the skipped ones.
    fn publish_if_due(&mut self, i: usize, now: u64) -> Option<Message> {
        let mhz = self.settings.rates[i];
        if self.schedules[i] == Schedule::Pending {
            self.schedules[i] = Schedule::Running {
                anchor: now,
                k: 0,
                due: now,
            };
        }
        let Schedule::Running { anchor, k, due } = self.schedules[i] else {
            return None;
        };
        if mhz == 0 || due > now {
            return None;
        }
        let next = first_after(anchor, now, mhz).max(k.saturating_add(1));
        let missed = next - k - 1;
        self.counters.missed = self
            .counters
            .missed
            .wrapping_add(u32::try_from(missed).unwrap_or(u32::MAX));
        self.schedules[i] = Schedule::Running {
            anchor,
            k: next,
            due: due_at(anchor, next, mhz),
        };
        self.counters.publications = self.counters.publications.wrapping_add(1);
        Some(Message::Publication {
            module: self.module,
            variable: self.dictionary.variables[i].vi,
            value: self.settings.values[i],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modrob::dictionary::Variable;

    const fn var(vi: u8, direction: Direction, rate: f32) -> Variable {
        Variable {
            vi,
            name: "v",
            unit: "1",
            direction,
            min: -1.0,
            max: 1.0,
            default: 0.0,
            persist: false,
            rate,
            description: "",
        }
    }

    const TABLE: Dictionary<3> = Dictionary {
        name: "t",
        kind: "t",
        module: 5,
        uuid: None,
        info: "",
        fingerprint: 1,
        variables: [
            var(1, Direction::Input, 0.0),
            var(40, Direction::Input, 3.0),
            var(200, Direction::Output, 0.0),
        ],
    };

    #[test]
    fn rate_rounding() {
        assert_eq!(rate_to_mhz(MAX_RATE_HZ), Some(MAX_RATE_MHZ));
        assert_eq!(rate_to_mhz(10_000.001), None);
        assert_eq!(rate_to_mhz(f32::INFINITY), None);
        assert_eq!(rate_to_mhz(-0.0), Some(0));
        assert_eq!(rate_to_mhz(0.0004), Some(1));
        assert_eq!(rate_to_mhz(0.0015), Some(2));
        assert_eq!(rate_to_mhz(2.0 / 3.0), Some(667));
        assert_eq!(mhz_to_hz(2500), 2.5);
    }

    #[test]
    fn grid_math() {
        // 3 Hz: 333333.33 µs periods, floored per publication, never accumulated.
        assert_eq!(due_at(0, 1, 3000), 333_333);
        assert_eq!(due_at(0, 3, 3000), 1_000_000);
        assert_eq!(due_at(7, 10_800, 3000), 3_600_000_007);
        assert_eq!(first_after(0, 0, 3000), 1);
        assert_eq!(first_after(0, 333_332, 3000), 1);
        assert_eq!(first_after(0, 333_333, 3000), 2);
        assert_eq!(first_after(0, 999_999, 3000), 3);
        assert_eq!(first_after(0, 1_000_000, 3000), 4);
        // Far times saturate instead of overflowing.
        assert_eq!(due_at(u64::MAX - 1, u64::MAX, 1), u64::MAX);
        assert!(first_after(0, u64::MAX, MAX_RATE_MHZ) > 0);
    }

    #[test]
    fn changed_flags_by_vi() {
        let mut e = Engine::new(&TABLE);
        for vi in [200, 40, 1] {
            let m = Message::Command {
                module: 5,
                variable: vi,
                command: CommandKind::SetValue(0.5),
            };
            assert!(e.handle(&m).is_for_us());
        }
        // The output took the value but raised nothing.
        assert_eq!(e.value(200), Some(0.5));
        assert!(e.is_changed(40) && !e.is_changed(200));
        assert_eq!(e.take_changed(), Some(1));
        assert_eq!(e.take_changed(), Some(40));
        assert_eq!(e.take_changed(), None);
    }

    #[test]
    fn own_address_clears_a_subscription() {
        let mut e = Engine::new(&TABLE);
        let sub = |module, variable| Message::Command {
            module: 5,
            variable: 1,
            command: CommandKind::SetSubscription { module, variable },
        };
        e.handle(&sub(9, 40));
        assert_eq!(e.subscription(1), Some((9, 40)));
        // Another variable of this module is a valid source.
        e.handle(&sub(5, 40));
        assert_eq!(e.subscription(1), Some((5, 40)));
        e.handle(&sub(5, 1));
        assert_eq!(e.subscription(1), None);
        assert_eq!(e.counters().commands, 3);
    }

    #[test]
    fn deadlines() {
        let mut e = Engine::new(&TABLE);
        assert_eq!(e.next_deadline(), Some(0));
        assert_eq!(
            e.poll(100),
            Some(Message::Publication {
                module: 5,
                variable: 40,
                value: 0.0
            })
        );
        // The info text (empty: one zero chunk) follows at the same time.
        assert!(matches!(
            e.poll(100),
            Some(Message::Piecewise { chunk: 0, .. })
        ));
        assert_eq!(e.poll(100), None);
        assert_eq!(e.next_deadline(), Some(100 + 333_333));
        e.set_rate(40, 0.0).unwrap();
        assert_eq!(e.next_deadline(), None);
        e.set_rate(40, 2.0).unwrap();
        assert_eq!(e.next_deadline(), Some(0));
        assert!(e.poll(200).is_some());
        assert_eq!(e.next_deadline(), Some(200 + 500_000));
    }
}
