//! The whole robot in one process over a simulated CAN bus carrying real CAN-1 frames, on a
//! virtual clock.
//!
//! Every module is a node of the bus; the motion controller's node also runs the leader, which
//! configures the modules as their first messages appear and forwards between the bus and the
//! host upstream. The host sends the motion controller a velocity command every 100 ms.

use ferrolink_generated::modrob::{motion_control, robot};
use ferrolink_io::modrob::can_sim::{Bus, Stats as BusStats};
use ferrolink_runtime::modrob::leader::{Leader, LeaderStats, Port};
use ferrolink_runtime::modrob::{CommandKind, Message};

use crate::modules::{build, Module};

/// Time between two rounds of polling the modules, µs.
pub const TICK_US: u64 = 100;

/// The robot on its bus.
pub struct CanRobot {
    bus: Bus,
    modules: Vec<Box<dyn Module>>,
    leader: Leader<'static, 16>,
    leader_node: usize,
    now_us: u64,
    next_command_us: u64,
    upstream: u64,
}

impl std::fmt::Debug for CanRobot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CanRobot")
            .field("now_us", &self.now_us)
            .field("bus", &self.bus.stats())
            .finish_non_exhaustive()
    }
}

/// The host's velocity command at `t` seconds: forward at 0.5 m/s, weaving.
pub fn command_at(t: f32) -> (f32, f32) {
    (0.5, 0.6 * (t * 0.5).sin())
}

impl CanRobot {
    /// The example robot at power-up.
    pub fn new() -> Self {
        let r = &robot::ROBOT;
        let modules: Vec<Box<dyn Module>> = r
            .instances
            .iter()
            .enumerate()
            .map(|(i, inst)| build(inst, i))
            .collect();
        let leader = Leader::new(r).expect("the generated robot is valid");
        let bitrate = r.networks[0].bitrate;
        Self {
            bus: Bus::new(bitrate, modules.len()),
            modules,
            leader,
            leader_node: r.leader,
            now_us: 0,
            next_command_us: 0,
            upstream: 0,
        }
    }

    /// Simulated time, µs.
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// The modules, in robot order.
    pub fn modules(&self) -> &[Box<dyn Module>] {
        &self.modules
    }

    /// What the bus carried.
    pub fn bus(&self) -> &BusStats {
        self.bus.stats()
    }

    /// The leader's counters.
    pub fn leader(&self) -> &LeaderStats {
        self.leader.stats()
    }

    /// Whether the leader has configured instance `i`.
    pub fn configured(&self, i: usize) -> bool {
        self.leader.status(i).is_some_and(|s| s.configured)
    }

    /// Messages the leader forwarded upstream to the host.
    pub fn upstream(&self) -> u64 {
        self.upstream
    }

    /// Runs the robot up to `until_us`.
    pub fn run_until(&mut self, until_us: u64) {
        while self.now_us < until_us {
            let now = self.now_us;
            if now >= self.next_command_us {
                self.host_command(now);
                self.next_command_us += 100_000;
            }
            for (i, module) in self.modules.iter_mut().enumerate() {
                while let Some(m) = module.poll(now) {
                    self.bus.send(i, m.to_can(), now * 1_000);
                    if i == self.leader_node {
                        // The leader's own module publishes to the parent too.
                        self.upstream += 1;
                    }
                }
            }
            while let Some(out) = self.leader.poll(now) {
                self.bus
                    .send(self.leader_node, out.message.to_can(), now * 1_000);
            }
            let next = (now + TICK_US).min(until_us);
            let mut delivered = Vec::new();
            self.bus
                .run_until(next * 1_000, |node, frame| delivered.push((node, *frame)));
            for (node, frame) in delivered {
                let Ok(message) = Message::from_can(frame.id, frame.data()) else {
                    continue;
                };
                let _ = self.modules[node].handle(&message);
                if node == self.leader_node {
                    let forward = self.leader.receive(Port::Network(0), &message);
                    if forward.upstream {
                        self.upstream += 1;
                    }
                }
            }
            self.now_us = next;
        }
    }

    /// The host's command, through the leader: to the motion controller, which is the
    /// leader's own module (local) — the leader also puts it on the bus if it were elsewhere.
    fn host_command(&mut self, now: u64) {
        let (linear, angular) = command_at(now as f32 / 1e6);
        for (var, value) in [
            (motion_control::Var::LinearVelocity, linear),
            (motion_control::Var::AngularVelocity, angular),
        ] {
            let command = Message::Command {
                module: robot::MOTION,
                variable: var.vi(),
                command: CommandKind::SetValue(value),
            };
            let forward = self.leader.receive(Port::Upstream, &command);
            if forward.local {
                let _ = self.modules[self.leader_node].handle(&command);
            }
            for _ in forward.networks() {
                self.bus
                    .send(self.leader_node, command.to_can(), now * 1_000);
            }
        }
    }
}

impl Default for CanRobot {
    fn default() -> Self {
        Self::new()
    }
}
