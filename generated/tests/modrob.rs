//! The checked-in ModRob-1 bindings (`definitions/modrob/`): variable tables against the
//! dictionaries, the `Var` enums and `Vars` structs, engines built on them, and the example
//! robot's stored configuration.

use ferrolink_generated::modrob::{
    drive, motion_control, planar_obstacle_search, robot, spatial_obstacle_search,
};
use ferrolink_runtime::modrob::{CommandKind, Direction, Handled, Message, Transport};

#[test]
fn tables_are_sorted_and_match_the_var_enum() {
    fn check<const N: usize>(
        d: &ferrolink_runtime::modrob::Dictionary<N>,
        from_vi: fn(u8) -> bool,
    ) {
        assert!(
            d.variables.windows(2).all(|w| w[0].vi < w[1].vi),
            "{}",
            d.name
        );
        for (i, v) in d.variables.iter().enumerate() {
            assert_eq!(d.index_of(v.vi), Some(i));
            assert!(from_vi(v.vi), "{} VI {}", d.name, v.vi);
            assert!(v.accepts(v.default), "{}.{}", d.name, v.name);
        }
        let known = (0..=255u8).filter(|&vi| from_vi(vi)).count();
        assert_eq!(known, N, "{}", d.name);
    }
    check(&drive::DICTIONARY, |vi| drive::Var::from_vi(vi).is_some());
    check(&motion_control::DICTIONARY, |vi| {
        motion_control::Var::from_vi(vi).is_some()
    });
    check(&planar_obstacle_search::DICTIONARY, |vi| {
        planar_obstacle_search::Var::from_vi(vi).is_some()
    });
    check(&spatial_obstacle_search::DICTIONARY, |vi| {
        spatial_obstacle_search::Var::from_vi(vi).is_some()
    });
}

#[test]
fn drive_table_is_the_dictionary() {
    let d = &drive::DICTIONARY;
    assert_eq!((d.name, d.kind, d.module), ("drive", "drive", 0x0110));
    assert_eq!(drive::VARIABLES, 7);
    let setpoint = d.variable(drive::Var::SpeedSetpoint.vi()).expect("VI 0");
    assert_eq!(
        (
            setpoint.name,
            setpoint.unit,
            setpoint.direction,
            setpoint.min,
            setpoint.max
        ),
        ("speed_setpoint", "rad/s", Direction::Input, -50.0, 50.0)
    );
    let speed = d.variable(drive::Var::Speed as u8).expect("VI 1");
    assert_eq!((speed.direction, speed.rate), (Direction::Output, 100.0));
    let gain = d.variable(5).expect("VI 5");
    assert_eq!(
        (gain.name, gain.default, gain.persist),
        ("speed_gain", 1.5, true)
    );
    assert!(drive::INFO.starts_with("ModRob-1 drive module."));
}

#[test]
fn array_variables_take_consecutive_vis() {
    use planar_obstacle_search::{Var, Vars, DICTIONARY, VARIABLES};
    assert_eq!(VARIABLES, 201);
    assert_eq!(Var::X0_0 as u8, 1);
    assert_eq!(Var::X0_49 as u8, 50);
    assert_eq!(Var::Y1_49 as u8, 200);
    assert_eq!(DICTIONARY.variable(51).map(|v| v.name), Some("y0[0]"));
    let mut values = [0.0f32; VARIABLES];
    for (i, v) in values.iter_mut().enumerate() {
        *v = i as f32;
    }
    let vars = Vars::from_values(&values);
    assert_eq!(vars.segment_count, 0.0);
    assert_eq!(vars.x0[0], 1.0);
    assert_eq!(vars.y0[49], 100.0);
    assert_eq!(vars.y1[49], 200.0);
    assert_eq!(vars.to_values(), values);
    assert_eq!(Vars::default().to_values(), [0.0; VARIABLES]);
}

#[test]
fn an_engine_on_the_generated_table() {
    let mut e = drive::engine();
    assert_eq!(e.module(), drive::MODULE);
    e.set_module(robot::DRIVE_FL);
    let set = |value| Message::Command {
        module: robot::DRIVE_FL,
        variable: drive::Var::SpeedSetpoint.vi(),
        command: CommandKind::SetValue(value),
    };
    assert!(matches!(e.handle(&set(60.0)), Handled::Rejected { .. }));
    assert!(matches!(e.handle(&set(12.5)), Handled::Applied { .. }));
    let vars = drive::Vars::from_values(e.values());
    assert_eq!(vars.speed_setpoint, 12.5);
    assert_eq!(vars.max_current, 10.0);
    assert_eq!(e.counters().rejected, 1);
}

#[test]
fn the_robot_configuration() {
    let r = &robot::ROBOT;
    assert_eq!(r.instances.len(), 14);
    assert_eq!(r.instances[r.leader].name, "motion");
    assert_eq!(r.networks[0].transport, Transport::Can);
    assert_eq!(r.networks[0].bitrate, 1_000_000);
    let count = |dict: &str| r.instances.iter().filter(|i| i.dictionary == dict).count();
    assert_eq!(
        [
            count("drive"),
            count("distance_sensor"),
            count("bumper"),
            count("motion_control"),
            count("planar_obstacle_search"),
            count("spatial_obstacle_search"),
            count("sensor_processing"),
        ],
        [4, 4, 1, 1, 2, 1, 1]
    );
    let fl = r.instance(robot::DRIVE_FL).expect("drive_fl");
    assert!(fl.uuid.is_some());
    assert_eq!(
        fl.commands,
        [
            Message::Command {
                module: robot::DRIVE_FL,
                variable: drive::Var::Mode.vi(),
                command: CommandKind::SetValue(1.0),
            },
            Message::Command {
                module: robot::DRIVE_FL,
                variable: drive::Var::Current.vi(),
                command: CommandKind::SetFrequency(10.0),
            },
            Message::Command {
                module: robot::DRIVE_FL,
                variable: drive::Var::SpeedSetpoint.vi(),
                command: CommandKind::SetSubscription {
                    module: robot::MOTION,
                    variable: motion_control::Var::WheelFl.vi(),
                },
            },
        ]
    );
    let mut mis: Vec<u16> = r.instances.iter().map(|i| i.module).collect();
    mis.sort_unstable();
    mis.dedup();
    assert_eq!(mis.len(), 14);
}
