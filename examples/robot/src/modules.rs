//! The robot's modules: a module engine on each generated dictionary, plus the little control
//! code each module kind runs (a first-order motor, odometry, made-up sensor readings).

use ferrolink_generated::modrob::{
    bumper, distance_sensor, drive, motion_control, planar_obstacle_search, sensor_processing,
    spatial_obstacle_search,
};
use ferrolink_runtime::modrob::engine::{Counters, Engine, Handled};
use ferrolink_runtime::modrob::{Instance, Message};

/// One module of the robot, whatever its dictionary.
pub trait Module: Send {
    /// Its instance in the robot file.
    fn instance(&self) -> &'static Instance;
    /// A message seen on its network.
    fn handle(&mut self, message: &Message) -> Handled;
    /// Runs the control code up to `now_us`, then returns the next message due (call until
    /// `None`).
    fn poll(&mut self, now_us: u64) -> Option<Message>;
    /// When it next has something to send.
    fn next_deadline(&self) -> Option<u64>;
    /// Its engine's counters.
    fn counters(&self) -> &Counters;
    /// The value of variable `vi`.
    fn value(&self, vi: u8) -> Option<f32>;
    /// The publication rate of variable `vi`, Hz.
    fn rate(&self, vi: u8) -> Option<f32>;
}

/// The control code of a module kind.
pub trait Behaviour<const N: usize>: Send {
    /// Reads inputs and writes outputs through the engine, at `now_us`.
    fn step(&mut self, engine: &mut Engine<'static, N>, now_us: u64);
}

/// A module engine and its control code.
#[derive(Debug)]
pub struct Node<const N: usize, B> {
    instance: &'static Instance,
    engine: Engine<'static, N>,
    behaviour: B,
    stepped_us: Option<u64>,
}

/// Control code runs every millisecond of module time.
const STEP_US: u64 = 1_000;

impl<const N: usize, B: Behaviour<N> + 'static> Node<N, B> {
    fn boxed(
        instance: &'static Instance,
        mut engine: Engine<'static, N>,
        behaviour: B,
    ) -> Box<dyn Module> {
        engine.set_module(instance.module);
        Box::new(Self {
            instance,
            engine,
            behaviour,
            stepped_us: None,
        })
    }
}

impl<const N: usize, B: Behaviour<N>> Module for Node<N, B> {
    fn instance(&self) -> &'static Instance {
        self.instance
    }

    fn handle(&mut self, message: &Message) -> Handled {
        self.engine.handle(message)
    }

    fn poll(&mut self, now_us: u64) -> Option<Message> {
        let due = self.stepped_us.map_or(0, |t| t + STEP_US);
        if now_us >= due {
            self.behaviour.step(&mut self.engine, now_us);
            self.stepped_us = Some(now_us - (now_us - due) % STEP_US);
        }
        self.engine.poll(now_us)
    }

    fn next_deadline(&self) -> Option<u64> {
        let step = self.stepped_us.map_or(0, |t| t + STEP_US);
        Some(self.engine.next_deadline().map_or(step, |d| d.min(step)))
    }

    fn counters(&self) -> &Counters {
        self.engine.counters()
    }

    fn value(&self, vi: u8) -> Option<f32> {
        self.engine.value(vi)
    }

    fn rate(&self, vi: u8) -> Option<f32> {
        self.engine.rate(vi)
    }
}

fn seconds(now_us: u64) -> f32 {
    now_us as f32 / 1e6
}

/// Sets an output the control code computed; outputs have no limits here, so this only fails
/// on a value the dictionary would refuse, which then keeps the old one.
fn write<const N: usize>(engine: &mut Engine<'static, N>, vi: u8, value: f32) {
    let _ = engine.set(vi, value);
}

/// A wheel drive: speed follows the set point with a 50 ms time constant while in speed mode.
#[derive(Debug, Default)]
struct Drive {
    last_us: Option<u64>,
}

impl Behaviour<{ drive::VARIABLES }> for Drive {
    fn step(&mut self, e: &mut drive::Engine, now_us: u64) {
        let dt = self.last_us.map_or(0.0, |t| (now_us - t) as f32 / 1e6);
        self.last_us = Some(now_us);
        let v = drive::Vars::from_values(e.values());
        let target = if v.mode == 1.0 { v.speed_setpoint } else { 0.0 };
        let speed = v.speed + (target - v.speed) * (dt / 0.05).min(1.0);
        let current = ((speed - v.speed).abs() / dt.max(1e-3) * 0.02 + 0.4).min(v.max_current);
        write(e, drive::Var::Speed.vi(), speed);
        write(e, drive::Var::Position.vi(), v.position + speed * dt);
        write(e, drive::Var::Current.vi(), current);
    }
}

/// A distance sensor looking at something that comes and goes.
#[derive(Debug)]
struct Distance {
    phase: f32,
}

impl Behaviour<{ distance_sensor::VARIABLES }> for Distance {
    fn step(&mut self, e: &mut distance_sensor::Engine, now_us: u64) {
        let d = 2.0 + 1.5 * (seconds(now_us) * 0.7 + self.phase).sin();
        let v = distance_sensor::Vars::from_values(e.values());
        write(e, distance_sensor::Var::Distance.vi(), d);
        let collision = if d < v.warning_distance { 1.0 } else { 0.0 };
        write(e, distance_sensor::Var::Collision.vi(), collision);
    }
}

/// A bumper that is never hit.
#[derive(Debug)]
struct Bumper;

impl Behaviour<{ bumper::VARIABLES }> for Bumper {
    fn step(&mut self, _: &mut bumper::Engine, _: u64) {}
}

/// Skid-steer kinematics: the velocity command becomes four wheel speed set points; the pose
/// integrates the command.
#[derive(Debug, Default)]
struct Motion {
    last_us: Option<u64>,
}

impl Behaviour<{ motion_control::VARIABLES }> for Motion {
    fn step(&mut self, e: &mut motion_control::Engine, now_us: u64) {
        use motion_control::Var;
        let dt = self.last_us.map_or(0.0, |t| (now_us - t) as f32 / 1e6);
        self.last_us = Some(now_us);
        let v = motion_control::Vars::from_values(e.values());
        let half = v.angular_velocity * v.track_width / 2.0;
        let left = (v.linear_velocity - half) / v.wheel_radius;
        let right = (v.linear_velocity + half) / v.wheel_radius;
        for (var, speed) in [
            (Var::WheelFl, left),
            (Var::WheelRl, left),
            (Var::WheelFr, right),
            (Var::WheelRr, right),
        ] {
            write(e, var.vi(), speed);
        }
        let yaw = v.yaw + v.angular_velocity * dt;
        write(e, Var::X.vi(), v.x + v.linear_velocity * yaw.cos() * dt);
        write(e, Var::Y.vi(), v.y + v.linear_velocity * yaw.sin() * dt);
        write(e, Var::Yaw.vi(), yaw);
    }
}

/// A planar obstacle search seeing a few walls.
#[derive(Debug)]
struct Planar {
    side: f32,
}

impl Behaviour<{ planar_obstacle_search::VARIABLES }> for Planar {
    fn step(&mut self, e: &mut planar_obstacle_search::Engine, now_us: u64) {
        let mut v = planar_obstacle_search::Vars::from_values(e.values());
        let n = 12;
        v.segment_count = n as f32;
        let t = seconds(now_us);
        for i in 0..n {
            let a = i as f32 * 0.5 + t * 0.1;
            v.x0[i] = self.side * (3.0 + a.cos());
            v.y0[i] = a.sin() * 2.0;
            v.x1[i] = v.x0[i] + 0.5;
            v.y1[i] = v.y0[i] + 0.2;
        }
        for (vi, value) in (0u8..).zip(v.to_values()) {
            write(e, vi, value);
        }
    }
}

/// A spatial obstacle search tracking a few moving boxes.
#[derive(Debug)]
struct Spatial;

impl Behaviour<{ spatial_obstacle_search::VARIABLES }> for Spatial {
    fn step(&mut self, e: &mut spatial_obstacle_search::Engine, now_us: u64) {
        let mut v = spatial_obstacle_search::Vars::from_values(e.values());
        let n = 5;
        v.obstacle_count = n as f32;
        let t = seconds(now_us);
        for i in 0..n {
            let k = i as f32;
            v.center_x[i] = 4.0 + k + 0.2 * t.sin();
            v.center_y[i] = k - 2.0;
            v.size_x[i] = 0.5;
            v.size_y[i] = 0.5;
            v.size_z[i] = 1.7;
            v.velocity_x[i] = 0.2 * t.cos();
        }
        for (vi, value) in (0u8..).zip(v.to_values()) {
            write(e, vi, value);
        }
    }
}

/// Sensor processing: a made-up nearest obstacle.
#[derive(Debug)]
struct Processing;

impl Behaviour<{ sensor_processing::VARIABLES }> for Processing {
    fn step(&mut self, e: &mut sensor_processing::Engine, now_us: u64) {
        let t = seconds(now_us);
        write(
            e,
            sensor_processing::Var::NearestDistance.vi(),
            1.2 + 0.3 * t.sin(),
        );
        write(
            e,
            sensor_processing::Var::NearestBearing.vi(),
            0.4 * t.cos(),
        );
    }
}

/// The module of `instance`, by its dictionary.
/// The name of variable `vi` in dictionary `dictionary`, from the generated tables.
pub fn variable_name(dictionary: &str, vi: u8) -> Option<&'static str> {
    macro_rules! find {
        ($($dict:ident),*) => {
            match dictionary {
                $(stringify!($dict) => $dict::DICTIONARY.variables.iter().find(|v| v.vi == vi).map(|v| v.name),)*
                _ => None,
            }
        };
    }
    find!(
        drive,
        distance_sensor,
        bumper,
        motion_control,
        planar_obstacle_search,
        spatial_obstacle_search,
        sensor_processing
    )
}

pub fn build(instance: &'static Instance, index: usize) -> Box<dyn Module> {
    let phase = index as f32;
    match instance.dictionary {
        "drive" => Node::boxed(instance, drive::engine(), Drive::default()),
        "distance_sensor" => Node::boxed(instance, distance_sensor::engine(), Distance { phase }),
        "bumper" => Node::boxed(instance, bumper::engine(), Bumper),
        "motion_control" => Node::boxed(instance, motion_control::engine(), Motion::default()),
        "planar_obstacle_search" => {
            let side = if index.is_multiple_of(2) { 1.0 } else { -1.0 };
            Node::boxed(instance, planar_obstacle_search::engine(), Planar { side })
        }
        "spatial_obstacle_search" => {
            Node::boxed(instance, spatial_obstacle_search::engine(), Spatial)
        }
        "sensor_processing" => Node::boxed(instance, sensor_processing::engine(), Processing),
        other => panic!("the example has no module for dictionary `{other}`"),
    }
}
