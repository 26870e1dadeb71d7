//! The leader of a composite module: it configures modules as they appear and routes messages
//! between the upstream network (its parent's) and the robot's own networks.
//!
//! The specification's leader cycle: at power-up the leader learns its subordinates; when its
//! stored configuration has a module that it finds, it sends that module the stored values,
//! publication rates and subscription addresses; then it runs normally, passing publications
//! downstream and to its parent. [`Leader`] does that over a generated [`Robot`] table,
//! allocation-free, with its state in `M` instance slots and `U` unknown-module slots.
//!
//! The application owns the buses. It hands every message it receives to [`Leader::receive`]
//! (or to [`Leader::observe`] and [`Leader::route`]), sends what [`Forward`] names, and calls
//! [`Leader::poll`] until it returns `None`, sending each command on the network it names.
//!
//! # Appearance and configuration
//!
//! - A publication or a piecewise chunk from an MI marks that module present (a command
//!   names the module it is sent *to*, so it marks nothing).
//! - A module of the robot table seen for the first time gets its stored commands
//!   ([`Instance::commands`]: values, then rates, then subscriptions) queued, in that order.
//! - **(project choice)** Modules announce their info text (a piecewise transmission) at
//!   power-up, so a *second* chunk 0 from a module means it restarted and lost what it was
//!   sent: its commands are queued again from the first ([`Config::reconfigure_on_announce`]
//!   turns this off for modules that repeat their text while running). The first chunk 0 is
//!   the power-up announcement itself, which may come after the module's first publications.
//! - A module of the table seen on a network other than its own is counted in
//!   [`LeaderStats::wrong_network`] and not configured: commands would go to the wrong bus.
//! - An MI the table does not have is recorded, per network, in `U` slots (then only counted)
//!   and gets no commands.
//! - The leader's own instance is never configured over a network; its stored commands are
//!   for the application to apply ([`Leader::own_commands`]).
//! - A command counts as sent when [`Leader::poll`] hands it out; ModRob-1 has no
//!   acknowledgement.
//!
//! # Pacing
//!
//! **(project choice)** [`Leader::poll`] hands out one command per call and keeps commands on
//! the same network at least [`Config::spacing_us`] apart, by default
//! [`DEFAULT_SPACING_US`] (500 µs): four CAN-1 frames' time at 1 Mbit/s left for other
//! traffic, and time for the module to check limits and store a value before the next command
//! lands in a receive FIFO only a few frames deep. Spacing 0 hands everything out in one
//! loop. An instance's commands come out in order; instances are served in table order, and
//! different networks do not wait for each other.
//!
//! # Routing
//!
//! [`Leader::route`] decides where a message received on one [`Port`] goes. MIs are taken
//! to be unique across the robot's networks (checked by [`Leader::new`]), which is what makes
//! a cross-network subscription address mean one module. **(project choice)** The policy:
//!
//! - a message is never sent back to the network it came from;
//! - from a robot network:
//!   - a publication goes upstream (the leader publishes new values to its parent), and to
//!     every other robot network with an instance whose stored configuration subscribes to
//!     that (MI, VI);
//!   - a piecewise chunk goes upstream only;
//!   - a command goes to the network of the module it addresses (a table instance or a
//!     module seen there); to the leader itself it is [`Forward::local`]; to a module nobody
//!     knows it goes upstream (the default route);
//! - from upstream:
//!   - a command to a table instance or a seen module goes to that module's network; to the
//!     leader it is local; otherwise it is dropped;
//!   - a publication goes to every robot network with an instance subscribing to that
//!     (MI, VI); one whose MI belongs to a module of this robot is dropped, since it is this
//!     robot's own publication coming back (or an MI collision);
//!   - a piecewise chunk is dropped (info texts travel towards people, upstream);
//! - anything claiming the leader's own MI as its source is dropped: it is an echo;
//! - a publication the leader's own stored configuration subscribes to is also local.
//!
//! Subscriptions are read from the stored configuration only: one set at run time by a
//! command passing through is not learnt. Finding subscribers scans the stored commands,
//! which is cheap for robot-sized tables.
//!
//! # Info texts
//!
//! The leader keeps no text buffers (`CAP` bytes per module add up). An application that wants
//! a module's text feeds its own [`Reassembler`](super::piecewise::Reassembler) the
//! piecewise chunks it receives.
//!
//! ```
//! use ferrolink_runtime::modrob::dictionary::{Instance, Network, Robot, Transport};
//! use ferrolink_runtime::modrob::leader::{Config, Leader, Port};
//! use ferrolink_runtime::modrob::{CommandKind, Message};
//!
//! const NETWORKS: &[Network] = &[Network { name: "body", transport: Transport::Can, bitrate: 1_000_000 }];
//! const DRIVE: &[Message] = &[Message::Command { module: 2, variable: 0, command: CommandKind::SetFrequency(100.0) }];
//! const INSTANCES: &[Instance] = &[
//!     Instance { name: "leader", dictionary: "leader", module: 1, uuid: None, network: 0, commands: &[] },
//!     Instance { name: "drive", dictionary: "drive", module: 2, uuid: None, network: 0, commands: DRIVE },
//! ];
//! static ROBOT: Robot = Robot { name: "cart", networks: NETWORKS, instances: INSTANCES, leader: 0 };
//!
//! let mut leader = Leader::<2>::with_config(&ROBOT, Config { spacing_us: 0, ..Config::default() }).unwrap();
//! let hello = Message::Publication { module: 2, variable: 3, value: 0.0 };
//! let forward = leader.receive(Port::Network(0), &hello);
//! assert!(forward.upstream && forward.networks == 0);
//! let out = leader.poll(0).unwrap();
//! assert_eq!((out.message, out.network), (DRIVE[0], 0));
//! assert!(leader.poll(0).is_none());
//! ```

use core::fmt;

use super::dictionary::{Instance, Robot};
use super::message::{CommandKind, Message};

/// The most networks a robot may have: [`Forward::networks`] is a 32-bit mask.
pub const MAX_NETWORKS: usize = 32;

/// The default least time between two commands on one network, in µs.
pub const DEFAULT_SPACING_US: u64 = 500;

/// Where a message was received.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Port {
    /// The parent's network, above this composite module.
    Upstream,
    /// One of the robot's networks, by its index in [`Robot::networks`].
    Network(usize),
}

/// Where a received message goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[must_use = "the message should be sent where this says"]
pub struct Forward {
    /// Send it upstream, to the parent's network.
    pub upstream: bool,
    /// Send it on these robot networks: bit `n` is [`Robot::networks`]`[n]`.
    pub networks: u32,
    /// It concerns the leader itself: a command to its MI, or a publication its stored
    /// configuration subscribes to.
    pub local: bool,
}

impl Forward {
    /// Whether the message goes nowhere and is not for the leader.
    pub fn is_empty(&self) -> bool {
        !self.upstream && self.networks == 0 && !self.local
    }

    /// Whether it goes to robot network `network`.
    pub fn to_network(&self, network: usize) -> bool {
        network < MAX_NETWORKS && self.networks & 1 << network != 0
    }

    /// The robot networks it goes to, ascending.
    pub fn networks(&self) -> impl Iterator<Item = usize> {
        let mask = self.networks;
        (0..MAX_NETWORKS).filter(move |&n| mask & 1 << n != 0)
    }
}

/// A configuration command to send.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outgoing {
    /// The command, as stored.
    pub message: Message,
    /// The network to send it on: its instance's, an index in [`Robot::networks`].
    pub network: usize,
    /// The instance it configures, an index in [`Robot::instances`].
    pub instance: usize,
}

/// What [`Leader::observe`] learnt from a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Observed {
    /// A table instance seen for the first time; its commands are queued.
    New {
        /// Its index in [`Robot::instances`].
        instance: usize,
    },
    /// A present table instance announced itself again (piecewise chunk 0): it restarted and
    /// its commands are queued again.
    Restarted {
        /// Its index in [`Robot::instances`].
        instance: usize,
    },
    /// A table instance already known.
    Known {
        /// Its index in [`Robot::instances`].
        instance: usize,
    },
    /// A table instance's MI seen on another network than its own; nothing is queued.
    WrongNetwork {
        /// Its index in [`Robot::instances`].
        instance: usize,
    },
    /// An MI the table does not have.
    Unknown {
        /// The MI.
        module: u16,
        /// Whether this is the first message from it on this network.
        first: bool,
    },
    /// A message from the leader's own MI: an echo, ignored.
    Own,
    /// Nothing to learn: a command, or a network the robot does not have.
    Ignored,
}

/// How a [`Leader`] paces and reconfigures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Config {
    /// The least time between two commands on one network, in µs; 0 for none.
    pub spacing_us: u64,
    /// Whether piecewise chunk 0 from a present module means it restarted, so its
    /// configuration is sent again.
    pub reconfigure_on_announce: bool,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            spacing_us: DEFAULT_SPACING_US,
            reconfigure_on_announce: true,
        }
    }
}

/// Why a robot table cannot be led.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum LeaderError {
    /// More instances than the leader has slots (`M`).
    TooManyInstances {
        /// Instances in the table.
        instances: usize,
        /// Slots.
        capacity: usize,
    },
    /// More networks than [`MAX_NETWORKS`].
    TooManyNetworks {
        /// Networks in the table.
        networks: usize,
    },
    /// [`Robot::leader`] is not an instance.
    NoLeader {
        /// The index.
        leader: usize,
    },
    /// An instance's network is not in [`Robot::networks`].
    NoSuchNetwork {
        /// The instance's index.
        instance: usize,
        /// Its network index.
        network: usize,
    },
    /// Two instances share an MI.
    DuplicateModule {
        /// The MI.
        module: u16,
    },
}

impl fmt::Display for LeaderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            LeaderError::TooManyInstances {
                instances,
                capacity,
            } => write!(
                f,
                "{instances} instances, more than the leader's {capacity} slots"
            ),
            LeaderError::TooManyNetworks { networks } => {
                write!(f, "{networks} networks, more than {MAX_NETWORKS}")
            }
            LeaderError::NoLeader { leader } => write!(f, "leader index {leader} is no instance"),
            LeaderError::NoSuchNetwork { instance, network } => {
                write!(
                    f,
                    "instance {instance} is on network {network}, which does not exist"
                )
            }
            LeaderError::DuplicateModule { module } => {
                write!(f, "MI {module} is used by two instances")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for LeaderError {}

/// Where the leader stands with one instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct InstanceStatus {
    /// It has been seen on its network (the leader itself always is).
    pub present: bool,
    /// It is present and every stored command has been sent since it appeared or restarted.
    pub configured: bool,
    /// Stored commands still to send.
    pub pending: usize,
    /// Times its whole configuration was sent.
    pub configurations: u32,
}

/// Message counts of [`Leader::route`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct RouteStats {
    /// Messages from upstream sent to at least one robot network.
    pub downstream: u64,
    /// Messages from a robot network sent upstream.
    pub upstream: u64,
    /// Messages from a robot network sent to at least one other robot network.
    pub across: u64,
    /// Messages for the leader itself.
    pub local: u64,
    /// Messages from upstream that went nowhere.
    pub dropped_from_upstream: u64,
    /// Messages from a robot network that went nowhere.
    pub dropped_from_downstream: u64,
}

/// The leader's counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct LeaderStats {
    /// Table instances seen for the first time.
    pub appeared: u32,
    /// Present instances that announced themselves again and are reconfigured.
    pub restarted: u32,
    /// Whole configurations sent (instances without commands count when they appear).
    pub configured: u32,
    /// Commands handed out by [`Leader::poll`].
    pub commands_sent: u64,
    /// Distinct unknown modules recorded.
    pub unknown_modules: u32,
    /// Messages from unknown modules that found no free slot to be recorded in.
    pub unknown_unrecorded: u64,
    /// Messages from a table instance's MI on another network than its own.
    pub wrong_network: u64,
    /// Routing counts.
    pub route: RouteStats,
}

#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    present: bool,
    /// Chunk 0 of its info text has been seen since it appeared.
    announced: bool,
    /// The next stored command to send.
    next: usize,
    configurations: u32,
}

#[derive(Debug, Clone, Copy, Default)]
struct Seen {
    module: u16,
    network: u8,
}

/// The leader engine over a robot table; `M` instance slots, `U` slots for unknown modules.
#[derive(Debug, Clone)]
pub struct Leader<'r, const M: usize, const U: usize = 16> {
    robot: &'r Robot,
    config: Config,
    slots: [Slot; M],
    unknown: [Seen; U],
    unknown_len: usize,
    /// When each network last got a command; valid where `sent` has its bit.
    last_sent: [u64; MAX_NETWORKS],
    sent: u32,
    stats: LeaderStats,
}

impl<'r, const M: usize, const U: usize> Leader<'r, M, U> {
    /// A leader of `robot` with the default [`Config`]; nothing seen yet.
    pub fn new(robot: &'r Robot) -> Result<Self, LeaderError> {
        Self::with_config(robot, Config::default())
    }

    /// A leader of `robot`; checks the table (slots, networks, leader index, unique MIs).
    pub fn with_config(robot: &'r Robot, config: Config) -> Result<Self, LeaderError> {
        let instances = robot.instances;
        if instances.len() > M {
            return Err(LeaderError::TooManyInstances {
                instances: instances.len(),
                capacity: M,
            });
        }
        if robot.networks.len() > MAX_NETWORKS {
            return Err(LeaderError::TooManyNetworks {
                networks: robot.networks.len(),
            });
        }
        let Some(own) = instances.get(robot.leader) else {
            return Err(LeaderError::NoLeader {
                leader: robot.leader,
            });
        };
        for (index, instance) in instances.iter().enumerate() {
            if instance.network >= robot.networks.len() {
                return Err(LeaderError::NoSuchNetwork {
                    instance: index,
                    network: instance.network,
                });
            }
            if instances[..index]
                .iter()
                .any(|i| i.module == instance.module)
            {
                return Err(LeaderError::DuplicateModule {
                    module: instance.module,
                });
            }
        }
        let mut slots = [Slot::default(); M];
        slots[robot.leader] = Slot {
            present: true,
            announced: true,
            next: own.commands.len(),
            configurations: 0,
        };
        Ok(Leader {
            robot,
            config,
            slots,
            unknown: [Seen::default(); U],
            unknown_len: 0,
            last_sent: [0; MAX_NETWORKS],
            sent: 0,
            stats: LeaderStats::default(),
        })
    }

    /// The robot table.
    #[inline]
    pub fn robot(&self) -> &'r Robot {
        self.robot
    }

    /// The configuration.
    #[inline]
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The counters.
    #[inline]
    pub fn stats(&self) -> &LeaderStats {
        &self.stats
    }

    /// The leader's own MI.
    pub fn module(&self) -> u16 {
        self.own().module
    }

    /// The leader's own stored commands, for the application to apply to itself.
    pub fn own_commands(&self) -> &'r [Message] {
        self.own().commands
    }

    /// The index in [`Robot::instances`] of the instance with MI `module`.
    pub fn instance_index(&self, module: u16) -> Option<usize> {
        self.robot.instances.iter().position(|i| i.module == module)
    }

    /// The status of instance `instance` (an index in [`Robot::instances`]).
    pub fn status(&self, instance: usize) -> Option<InstanceStatus> {
        let commands = self.robot.instances.get(instance)?.commands.len();
        let slot = self.slots.get(instance)?;
        let pending = if slot.present {
            commands.saturating_sub(slot.next)
        } else {
            0
        };
        Some(InstanceStatus {
            present: slot.present,
            configured: slot.present && pending == 0,
            pending,
            configurations: slot.configurations,
        })
    }

    /// The unknown modules recorded, as (MI, network index).
    pub fn unknown_modules(&self) -> impl Iterator<Item = (u16, usize)> + '_ {
        self.unknown[..self.unknown_len]
            .iter()
            .map(|seen| (seen.module, usize::from(seen.network)))
    }

    /// Stored commands still to send, over all instances.
    pub fn pending(&self) -> usize {
        (0..self.robot.instances.len())
            .filter_map(|i| self.status(i))
            .map(|s| s.pending)
            .sum()
    }

    /// Queues instance `instance`'s whole configuration again, if it is present; returns
    /// whether it was.
    pub fn reconfigure(&mut self, instance: usize) -> bool {
        if instance == self.robot.leader {
            return false;
        }
        match self.slots.get_mut(instance) {
            Some(slot) if slot.present => {
                slot.next = 0;
                true
            }
            _ => false,
        }
    }

    /// Learns from a message received on robot network `network`: which module is there,
    /// and whether it appeared or restarted (then its configuration is queued).
    pub fn observe(&mut self, network: usize, message: &Message) -> Observed {
        let (module, announce) = match *message {
            Message::Command { .. } => return Observed::Ignored,
            Message::Publication { module, .. } => (module, false),
            Message::Piecewise { module, chunk, .. } => (module, chunk == 0),
        };
        if network >= self.robot.networks.len() {
            return Observed::Ignored;
        }
        if module == self.module() {
            return Observed::Own;
        }
        let Some(instance) = self.instance_index(module) else {
            return self.observe_unknown(network, module);
        };
        let commands = self.robot.instances[instance].commands.len();
        if self.robot.instances[instance].network != network {
            self.stats.wrong_network += 1;
            return Observed::WrongNetwork { instance };
        }
        let slot = &mut self.slots[instance];
        let announced = slot.announced;
        slot.announced |= announce;
        let observed = if !slot.present {
            slot.present = true;
            self.stats.appeared += 1;
            Observed::New { instance }
        } else if announce && announced && self.config.reconfigure_on_announce {
            self.stats.restarted += 1;
            Observed::Restarted { instance }
        } else {
            return Observed::Known { instance };
        };
        slot.next = 0;
        if commands == 0 {
            slot.configurations += 1;
            self.stats.configured += 1;
        }
        observed
    }

    fn observe_unknown(&mut self, network: usize, module: u16) -> Observed {
        let recorded = self.unknown[..self.unknown_len]
            .iter()
            .any(|seen| seen.module == module && usize::from(seen.network) == network);
        if recorded {
            return Observed::Unknown {
                module,
                first: false,
            };
        }
        match self.unknown.get_mut(self.unknown_len) {
            Some(seen) => {
                *seen = Seen {
                    module,
                    network: network as u8,
                };
                self.unknown_len += 1;
                self.stats.unknown_modules += 1;
                Observed::Unknown {
                    module,
                    first: true,
                }
            }
            None => {
                self.stats.unknown_unrecorded += 1;
                Observed::Unknown {
                    module,
                    first: false,
                }
            }
        }
    }

    /// The next configuration command to send, with its network, or `None` when nothing is
    /// queued or every network with queued commands must wait (see the pacing rules). Call
    /// it until it returns `None`; `now_us` is a monotonic time in µs (a clock that went
    /// backwards does not hold commands back).
    pub fn poll(&mut self, now_us: u64) -> Option<Outgoing> {
        let robot = self.robot;
        for (index, instance) in robot.instances.iter().enumerate() {
            let Some(slot) = self.slots.get_mut(index) else {
                break;
            };
            let Some(&message) = instance.commands.get(slot.next) else {
                continue;
            };
            let network = instance.network;
            let free = self.sent & 1 << network == 0
                || now_us.wrapping_sub(self.last_sent[network]) >= self.config.spacing_us;
            if !slot.present || !free {
                continue;
            }
            slot.next += 1;
            if slot.next == instance.commands.len() {
                slot.configurations += 1;
                self.stats.configured += 1;
            }
            self.stats.commands_sent += 1;
            self.last_sent[network] = now_us;
            self.sent |= 1 << network;
            return Some(Outgoing {
                message,
                network,
                instance: index,
            });
        }
        None
    }

    /// Observes (when it comes from a robot network) and routes a received message.
    pub fn receive(&mut self, from: Port, message: &Message) -> Forward {
        if let Port::Network(network) = from {
            let _ = self.observe(network, message);
        }
        self.route(from, message)
    }

    /// Where a message received on `from` goes; see the routing rules in the
    /// [module documentation](self). Learns nothing (see [`Leader::observe`]).
    pub fn route(&mut self, from: Port, message: &Message) -> Forward {
        let source = match from {
            Port::Upstream => None,
            Port::Network(n) if n < self.robot.networks.len() => Some(n),
            Port::Network(_) => {
                self.stats.route.dropped_from_downstream += 1;
                return Forward::default();
            }
        };
        let own = self.module();
        let mut forward = Forward::default();
        match *message {
            Message::Command { module, .. } => {
                if module == own {
                    forward.local = true;
                } else {
                    forward.networks = self.home(module);
                    forward.upstream = forward.networks == 0 && source.is_some();
                    if let Some(n) = source {
                        if forward.networks & 1 << n != 0 {
                            // Already on its network: delivered there.
                            forward.upstream = false;
                        }
                    }
                }
            }
            Message::Publication {
                module, variable, ..
            } => {
                let echo = module == own || (source.is_none() && self.home(module) != 0);
                if !echo {
                    forward.upstream = source.is_some();
                    (forward.networks, forward.local) = self.subscribers(module, variable);
                }
            }
            Message::Piecewise { module, .. } => {
                forward.upstream = source.is_some() && module != own;
            }
        }
        if let Some(n) = source {
            forward.networks &= !(1 << n);
        }
        let stats = &mut self.stats.route;
        if forward.local {
            stats.local += 1;
        }
        match source {
            None if forward.networks != 0 => stats.downstream += 1,
            None if !forward.local => stats.dropped_from_upstream += 1,
            Some(_) => {
                if forward.upstream {
                    stats.upstream += 1;
                }
                if forward.networks != 0 {
                    stats.across += 1;
                }
                if forward.is_empty() {
                    stats.dropped_from_downstream += 1;
                }
            }
            None => {}
        }
        forward
    }

    /// The networks where module `module` lives: its table instance's, else those it was
    /// seen on.
    fn home(&self, module: u16) -> u32 {
        if let Some(instance) = self.robot.instance(module) {
            return 1 << instance.network;
        }
        self.unknown[..self.unknown_len]
            .iter()
            .filter(|seen| seen.module == module)
            .fold(0, |mask, seen| mask | 1 << seen.network)
    }

    /// The networks with an instance subscribing to (`module`, `variable`) in its stored
    /// configuration, and whether the leader itself does.
    fn subscribers(&self, module: u16, variable: u8) -> (u32, bool) {
        let mut networks = 0u32;
        let mut local = false;
        for (index, instance) in self.robot.instances.iter().enumerate() {
            let is_leader = index == self.robot.leader;
            if (is_leader && local) || (!is_leader && networks & 1 << instance.network != 0) {
                continue;
            }
            if subscribes(instance, module, variable) {
                if is_leader {
                    local = true;
                } else {
                    networks |= 1 << instance.network;
                }
            }
        }
        (networks, local)
    }

    fn own(&self) -> &'r Instance {
        &self.robot.instances[self.robot.leader]
    }
}

/// Whether `instance`'s stored configuration subscribes it to (`module`, `variable`).
fn subscribes(instance: &Instance, module: u16, variable: u8) -> bool {
    instance.commands.iter().any(|command| {
        matches!(
            command,
            Message::Command {
                command: CommandKind::SetSubscription { module: m, variable: v },
                ..
            } if *m == module && *v == variable
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modrob::dictionary::{Network, Transport};

    const NETWORKS: &[Network] = &[
        Network {
            name: "a",
            transport: Transport::Can,
            bitrate: 1_000_000,
        },
        Network {
            name: "b",
            transport: Transport::Uart,
            bitrate: 115_200,
        },
    ];
    const SUB: &[Message] = &[
        Message::Command {
            module: 20,
            variable: 1,
            command: CommandKind::SetValue(2.0),
        },
        Message::Command {
            module: 20,
            variable: 1,
            command: CommandKind::SetSubscription {
                module: 10,
                variable: 4,
            },
        },
    ];
    const INSTANCES: &[Instance] = &[
        Instance {
            name: "leader",
            dictionary: "leader",
            module: 1,
            uuid: None,
            network: 0,
            commands: &[Message::Command {
                module: 1,
                variable: 0,
                command: CommandKind::SetSubscription {
                    module: 10,
                    variable: 5,
                },
            }],
        },
        Instance {
            name: "pub",
            dictionary: "x",
            module: 10,
            uuid: None,
            network: 0,
            commands: &[],
        },
        Instance {
            name: "sub",
            dictionary: "y",
            module: 20,
            uuid: None,
            network: 1,
            commands: SUB,
        },
    ];
    static ROBOT: Robot = Robot {
        name: "r",
        networks: NETWORKS,
        instances: INSTANCES,
        leader: 0,
    };

    fn publication(module: u16, variable: u8) -> Message {
        Message::Publication {
            module,
            variable,
            value: 1.0,
        }
    }

    #[test]
    fn table_checks() {
        assert_eq!(
            Leader::<2>::new(&ROBOT).err(),
            Some(LeaderError::TooManyInstances {
                instances: 3,
                capacity: 2
            })
        );
        static BAD: Robot = Robot {
            name: "bad",
            networks: NETWORKS,
            instances: INSTANCES,
            leader: 3,
        };
        assert_eq!(
            Leader::<3>::new(&BAD).err(),
            Some(LeaderError::NoLeader { leader: 3 })
        );
        const TWICE: &[Instance] = &[INSTANCES[0], INSTANCES[1], INSTANCES[1]];
        static DUP: Robot = Robot {
            name: "dup",
            networks: NETWORKS,
            instances: TWICE,
            leader: 0,
        };
        assert_eq!(
            Leader::<3>::new(&DUP).err(),
            Some(LeaderError::DuplicateModule { module: 10 })
        );
    }

    #[test]
    fn spacing_per_network() {
        let mut leader = Leader::<3>::new(&ROBOT).unwrap();
        assert_eq!(
            leader.observe(1, &publication(20, 0)),
            Observed::New { instance: 2 }
        );
        assert_eq!(leader.poll(1_000).unwrap().message, SUB[0]);
        assert!(leader.poll(1_499).is_none());
        assert_eq!(leader.poll(1_500).unwrap().message, SUB[1]);
        assert!(leader.poll(10_000).is_none());
        assert_eq!(leader.stats().configured, 1);
        assert!(leader.status(2).unwrap().configured);
        // A clock that went backwards does not block.
        assert!(leader.reconfigure(2));
        assert!(leader.poll(0).is_some());
    }

    #[test]
    fn leader_subscription_is_local() {
        let mut leader = Leader::<3>::new(&ROBOT).unwrap();
        let f = leader.route(Port::Network(0), &publication(10, 5));
        assert!(f.local && f.upstream && f.networks == 0);
        let f = leader.route(Port::Network(0), &publication(10, 4));
        assert!(!f.local && f.upstream && f.to_network(1) && !f.to_network(0));
        assert_eq!(f.networks().collect::<std::vec::Vec<_>>(), [1]);
        assert_eq!(leader.own_commands().len(), 1);
        assert_eq!(leader.observe(0, &publication(1, 0)), Observed::Own);
    }
}
