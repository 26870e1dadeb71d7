//! The example robot for 10 simulated seconds on its CAN bus: the leader configures every
//! module, and every stored subscription delivers values at its source's rate.

use ferrolink_example_robot::can::CanRobot;
use ferrolink_generated::modrob::{drive, motion_control, robot};
use ferrolink_runtime::modrob::{CommandKind, Message};

/// Every (target instance, source instance, source VI) of the stored configuration.
fn subscriptions() -> Vec<(usize, usize, u8)> {
    let r = &robot::ROBOT;
    let mut subs = Vec::new();
    for (t, inst) in r.instances.iter().enumerate() {
        for c in inst.commands {
            if let Message::Command {
                command: CommandKind::SetSubscription { module, variable },
                ..
            } = c
            {
                let s = r
                    .instances
                    .iter()
                    .position(|i| i.module == *module)
                    .expect("source");
                subs.push((t, s, *variable));
            }
        }
    }
    subs
}

#[test]
fn ten_seconds_on_the_can_bus() {
    let mut sim = CanRobot::new();
    sim.run_until(1_000_000);
    let n = robot::INSTANCES.len();
    for i in (0..n).filter(|&i| i != robot::ROBOT.leader) {
        assert!(
            sim.configured(i),
            "{} not configured after 1 s",
            robot::INSTANCES[i].name
        );
    }
    let subs = subscriptions();
    assert_eq!(subs.len(), 4, "the four wheel set points");
    let before: Vec<u32> = sim
        .modules()
        .iter()
        .map(|m| m.counters().subscription_updates)
        .collect();
    sim.run_until(10_000_000);
    for &(target, source, vi) in &subs {
        let rate = sim.modules()[source].rate(vi).expect("source variable");
        let expected = rate * 9.0;
        let got = (sim.modules()[target].counters().subscription_updates - before[target]) as f32;
        assert!(
            (got - expected).abs() <= expected * 0.01,
            "{} got {got} updates in 9 s, expected {expected}",
            robot::INSTANCES[target].name
        );
        // The set point is the last published wheel speed: at most one period behind.
        let target_value = sim.modules()[target]
            .value(drive::Var::SpeedSetpoint.vi())
            .unwrap();
        let source_value = sim.modules()[source].value(vi).unwrap();
        assert!(
            (target_value - source_value).abs() < 0.05,
            "{target_value} vs {source_value}"
        );
    }
    // Stored values and rates arrived: speed control on, currents at 10 Hz.
    for (i, inst) in robot::INSTANCES.iter().enumerate() {
        if inst.dictionary == "drive" {
            let m = &sim.modules()[i];
            assert_eq!(m.value(drive::Var::Mode.vi()), Some(1.0), "{}", inst.name);
            assert_eq!(
                m.rate(drive::Var::Current.vi()),
                Some(10.0),
                "{}",
                inst.name
            );
            // The wheels turn: the drive tracks its set point.
            let speed = m.value(drive::Var::Speed.vi()).unwrap();
            assert!(speed.abs() > 1.0, "{} speed {speed}", inst.name);
        }
    }
    let motion = &sim.modules()[robot::ROBOT.leader];
    let x = motion.value(motion_control::Var::X.vi()).unwrap();
    let y = motion.value(motion_control::Var::Y.vi()).unwrap();
    assert!(x.hypot(y) > 1.0, "the robot drove: ({x}, {y})");
    // Nothing was refused, nothing lost, and the bus kept up.
    for (i, m) in sim.modules().iter().enumerate() {
        let c = m.counters();
        assert_eq!(
            (c.rejected, c.unknown_variable, c.missed),
            (0, 0, 0),
            "{}",
            robot::INSTANCES[i].name
        );
    }
    let load = sim.bus().busy_ns as f64 / 10e9;
    assert!(load > 0.3 && load < 0.6, "bus load {load}");
    assert_eq!(sim.leader().appeared, 13);
}

/// The first of 16 free ports to run the robot on: the modules, the upstream and the host.
fn base_port() -> u16 {
    assert!(
        robot::INSTANCES.len() + 2 <= 16,
        "the modules, the upstream and the host need more than 16 ports"
    );
    ferrolink_test_support::free_ports(16)
}

/// The same robot over Ethernet-1 on UDP loopback, one thread per module, for 3 s of wall-clock
/// time. The bounds are loose on purpose: this checks that packets flow and the leader's
/// configuration and subscriptions work over UDP, not timing on a loaded machine.
#[test]
fn three_seconds_over_ethernet() {
    use std::sync::atomic::Ordering;
    let base = base_port();
    let shared = ferrolink_example_robot::ethernet::run(
        base,
        std::time::Duration::from_secs(3),
        ferrolink_example_robot::ethernet::Upstream::Host,
        |_, _| {},
    )
    .expect("runs");
    for (i, inst) in robot::INSTANCES.iter().enumerate() {
        if i != robot::ROBOT.leader {
            assert!(
                shared.configured[i].load(Ordering::Relaxed),
                "{} not configured",
                inst.name
            );
        }
    }
    for (target, _, _) in subscriptions() {
        let updates = shared.subscription_updates[target].load(Ordering::Relaxed);
        assert!(
            updates >= 50,
            "{}: {updates} updates in 3 s at 100 Hz",
            robot::INSTANCES[target].name
        );
    }
    assert!(shared.packets.load(Ordering::Relaxed) > 0);
    assert!(shared.upstream.load(Ordering::Relaxed) > 1_000);
}

/// The leader's upstream port on Zenoh: a Zenoh session of the test's own sees the motion
/// controller's publications under `<prefix>/modrob/<robot>/motion/...` as JSON, and a value put
/// on `.../linear_velocity/set` reaches the module, which then publishes it.
#[cfg(feature = "zenoh")]
#[test]
fn the_leaders_upstream_on_zenoh() {
    use std::time::{Duration, Instant};
    use zenoh::Wait;
    let zport = ferrolink_test_support::free_port();
    let base = base_port();
    let prefix = format!("robot{zport}");
    let uri =
        format!("zenoh://?mode=peer&listen=tcp/127.0.0.1:{zport}&encoding=json&prefix={prefix}");
    let upstream =
        ferrolink_example_robot::ethernet::Upstream::Zenoh(uri.parse().expect("a zenoh URI"));
    let robot_thread = std::thread::spawn(move || {
        ferrolink_example_robot::ethernet::run(base, Duration::from_secs(6), upstream, |_, _| {})
    });
    std::thread::sleep(Duration::from_millis(500));
    let mut config = zenoh::Config::default();
    config
        .insert_json5("connect/endpoints", &format!("[\"tcp/127.0.0.1:{zport}\"]"))
        .expect("config");
    let session = zenoh::open(config).wait().expect("a session");
    let root = format!("{prefix}/modrob/{}/motion", robot::ROBOT.name);
    let sub = session
        .declare_subscriber(format!("{root}/linear_velocity"))
        .wait()
        .expect("subscribed");
    let deadline = Instant::now() + Duration::from_secs(4);
    let mut last_put = Instant::now() - Duration::from_secs(1);
    let mut seen = None;
    while Instant::now() < deadline {
        if last_put.elapsed() >= Duration::from_millis(300) {
            session
                .put(format!("{root}/linear_velocity/set"), "0.75")
                .wait()
                .expect("put");
            last_put = Instant::now();
        }
        let Ok(Some(sample)) = sub.recv_timeout(Duration::from_millis(50)) else {
            continue;
        };
        let text = String::from_utf8(sample.payload().to_bytes().to_vec()).expect("utf-8");
        let value: serde_json::Value = serde_json::from_str(&text).expect("JSON");
        assert_eq!(value["type"], "publication", "{text}");
        if value["value"] == 0.75 {
            seen = Some(text);
            break;
        }
    }
    drop(sub);
    let _ = session.close().wait();
    let shared = robot_thread.join().expect("no panic").expect("runs");
    assert!(seen.is_some(), "the set value was never published back");
    assert!(
        shared.upstream.load(std::sync::atomic::Ordering::Relaxed) > 100,
        "little went up"
    );
}
