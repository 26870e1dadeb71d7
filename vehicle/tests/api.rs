//! The vehicle API, blocking and async, against the software vehicle in this process over
//! loopback UDP: discovery, the state from its heartbeat, actions with their true results, and
//! the services beside them.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use ferrolink_io::mavlink::{services, vehicle};
use ferrolink_runtime::mavlink::service::messages::{MavAutopilot, MavType};
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_test_support::free_port;
use ferrolink_vehicle::{ActionError, ActionResult, Node};

/// A PX4 quadrotor on `udpin` at a free port, until `stop`.
fn start_vehicle(stop: &Arc<AtomicBool>) -> (u16, std::thread::JoinHandle<()>) {
    let port = free_port();
    let config = vehicle::Config {
        address: Address::new(1, 1),
        autopilot: MavAutopilot::Px4,
        kind: MavType::Quadrotor,
        params: vec![ferrolink_runtime::mavlink::service::param::Param {
            name: "MIS_TAKEOFF_ALT".into(),
            value: ferrolink_runtime::mavlink::service::param::Value::F32(5.0),
        }],
        table: services::TABLE.into(),
        ftp_root: None,
        home: ferrolink_io::mavlink::vehicle::HOME,
    };
    let stop = stop.clone();
    let endpoint = format!("udpin://127.0.0.1:{port}");
    let thread = std::thread::spawn(move || {
        vehicle::run(
            &config,
            &[endpoint],
            Some(Duration::from_secs(60)),
            &stop,
            || {},
        )
        .expect("the vehicle runs");
    });
    (port, thread)
}

#[test]
fn blocking_discovery_state_and_actions() {
    let stop = Arc::new(AtomicBool::new(false));
    let (port, vehicle) = start_vehicle(&stop);
    let node = Node::connect(&format!("udpout://127.0.0.1:{port}")).unwrap();
    let system = node
        .wait_for_system(Duration::from_secs(10))
        .unwrap()
        .expect("the vehicle");
    assert_eq!(
        (system.id(), system.autopilot()),
        (1, ferrolink_vehicle::dialects::common::MavAutopilot::Px4)
    );
    let state = system
        .telemetry()
        .state()
        .expect("a state from its heartbeat");
    assert!(!state.armed);
    // Disarmed, it refuses to take off; armed, it takes off.
    let refused = system.takeoff(10.0).unwrap();
    assert_eq!(
        (refused.result, refused.command),
        (ActionResult::TemporarilyRejected, 22)
    );
    let armed = system.arm().unwrap();
    assert_eq!((armed.result, armed.command), (ActionResult::Accepted, 400));
    assert_eq!(system.takeoff(10.0).unwrap().result, ActionResult::Accepted);
    // The next heartbeat says it is armed.
    let updates = system
        .telemetry()
        .subscribe(&[ferrolink_vehicle::telemetry::Kind::State]);
    let mut armed_seen = system.telemetry().state().is_some_and(|s| s.armed);
    while !armed_seen {
        match updates.recv(Duration::from_secs(3)) {
            Some(ferrolink_vehicle::telemetry::Update::State(s)) => armed_seen = s.armed,
            Some(_) => {}
            None => panic!("no armed state within 3 s"),
        }
    }
    // A mode it does not have is refused before anything is sent, with the names it has.
    let Err(ActionError::UnknownMode { known, .. }) = system.set_mode("GUIDED") else {
        panic!("GUIDED is no PX4 mode")
    };
    assert!(known.contains(&"MISSION"));
    // It flies now: a reboot is refused, and so is a plain disarm.
    assert_eq!(system.reboot().unwrap().result, ActionResult::Denied);
    assert_eq!(system.disarm(false).unwrap().result, ActionResult::Denied);
    assert_eq!(system.disarm(true).unwrap().result, ActionResult::Accepted);
    // What it does not know, it says so.
    let unknown = ferrolink_runtime::mavlink::service::command::Command::long(
        ferrolink_runtime::mavlink::service::messages::MavCmd::from_raw(31_000),
        [0.0; 7],
    );
    assert_eq!(
        system.command(unknown, |_| {}).unwrap().result,
        ActionResult::Unsupported
    );
    stop.store(true, Ordering::Relaxed);
    vehicle.join().unwrap();
}

#[tokio::test(flavor = "current_thread")]
async fn async_actions_run_without_a_thread_each() {
    let stop = Arc::new(AtomicBool::new(false));
    let (port, vehicle) = start_vehicle(&stop);
    let node = Node::connect(&format!("udpout://127.0.0.1:{port}")).unwrap();
    let system = node
        .wait_for_system_async(Duration::from_secs(10))
        .await
        .unwrap()
        .expect("the vehicle");
    let before = thread_count();
    let (a, b) = tokio::join!(system.arm(), system.set_rate(33, 10.0));
    assert_eq!(a.unwrap().result, ActionResult::Accepted);
    assert_eq!(b.unwrap().result, ActionResult::Accepted);
    // A message it does not publish.
    assert_eq!(
        system.set_rate(74, 1.0).await.unwrap().result,
        ActionResult::Unsupported
    );
    assert_eq!(
        system.takeoff(5.0).await.unwrap().result,
        ActionResult::Accepted
    );
    assert!(
        thread_count() <= before,
        "no thread was started for the actions"
    );
    stop.store(true, Ordering::Relaxed);
    vehicle.join().unwrap();
}

/// This process's threads (Linux), or 0 where that cannot be read.
fn thread_count() -> usize {
    std::fs::read_dir("/proc/self/task").map_or(0, |d| d.count())
}
