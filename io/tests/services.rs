//! The blocking client against the software vehicle, in one process over loopback UDP:
//! parameters with PX4's `_HASH_CHECK` and over PARAM_EXT_*, and files over FTP.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use ferrolink_io::mavlink::services::{self, Remote};
use ferrolink_io::mavlink::{vehicle, Connection};
use ferrolink_runtime::mavlink::service::messages::{MavAutopilot, MavType};
use ferrolink_runtime::mavlink::service::param::{Name, Param, Protocol, Value};
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_test_support::free_port;

/// A PX4 vehicle with 40 parameters and `root` as its FTP root, on a thread until `stop`.
fn vehicle(root: &std::path::Path, stop: &Arc<AtomicBool>) -> (u16, std::thread::JoinHandle<()>) {
    let params = (0..40)
        .map(|i| {
            param(
                &format!("P{i}"),
                if i % 2 == 0 {
                    Value::I32(i * 3)
                } else {
                    Value::F32(i as f32 / 4.0)
                },
            )
        })
        .collect();
    vehicle_with(params, root, stop)
}

fn param(name: &str, value: Value) -> Param {
    Param {
        name: Name::from(name),
        value,
    }
}

/// A PX4 vehicle with `params` and `root` as its FTP root, on a thread until `stop`.
fn vehicle_with(
    params: Vec<Param>,
    root: &std::path::Path,
    stop: &Arc<AtomicBool>,
) -> (u16, std::thread::JoinHandle<()>) {
    let port = free_port();
    let endpoint = format!("udpin://127.0.0.1:{port}");
    (port, vehicle_at(params, Some(root), endpoint, stop))
}

/// A PX4 vehicle with `params` on `endpoint`, on a thread until `stop`.
fn vehicle_at(
    params: Vec<Param>,
    root: Option<&std::path::Path>,
    endpoint: String,
    stop: &Arc<AtomicBool>,
) -> std::thread::JoinHandle<()> {
    let config = vehicle::Config {
        address: Address::new(1, 1),
        autopilot: MavAutopilot::Px4,
        kind: MavType::Quadrotor,
        params,
        table: services::TABLE.into(),
        ftp_root: root.map(std::path::Path::to_path_buf),
        home: ferrolink_io::mavlink::vehicle::HOME,
    };
    let stop = stop.clone();
    std::thread::spawn(move || {
        vehicle::run(
            &config,
            &[endpoint],
            Some(Duration::from_secs(60)),
            &stop,
            || {},
        )
        .expect("the vehicle runs");
    })
}

/// A connection to the vehicle on `port`, and the vehicle as found.
fn connect(port: u16) -> (Connection, services::Peer) {
    let mut link =
        Connection::open(&format!("udpout://127.0.0.1:{port}"), services::TABLE).unwrap();
    let peer = services::wait_for_vehicle(&mut link, Duration::from_secs(10))
        .unwrap()
        .expect("the vehicle");
    (link, peer)
}

/// UDP between a vehicle (which sends to the returned port) and port `to`, losing `loss` of the
/// datagrams each way by a seeded generator, until `stop`.
fn relay(to: u16, loss: f64, stop: &Arc<AtomicBool>) -> u16 {
    use std::net::UdpSocket;
    let near = UdpSocket::bind("127.0.0.1:0").unwrap();
    let far = UdpSocket::bind("127.0.0.1:0").unwrap();
    let port = near.local_addr().unwrap().port();
    let vehicle = Arc::new(std::sync::Mutex::new(None));
    for (from, into, seed, back) in [
        (
            near.try_clone().unwrap(),
            far.try_clone().unwrap(),
            7u64,
            false,
        ),
        (far, near, 11u64, true),
    ] {
        let (stop, vehicle) = (stop.clone(), vehicle.clone());
        from.set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
        std::thread::spawn(move || {
            let mut state = seed;
            let mut buf = [0u8; 65536];
            while !stop.load(Ordering::Relaxed) {
                let Ok((n, src)) = from.recv_from(&mut buf) else {
                    continue;
                };
                // A 64-bit LCG: the same losses every run.
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let lost = ((state >> 33) as f64 / (1u64 << 31) as f64) < loss;
                let dest = if back {
                    *vehicle.lock().unwrap()
                } else {
                    *vehicle.lock().unwrap() = Some(src);
                    Some(std::net::SocketAddr::from(([127, 0, 0, 1], to)))
                };
                if let (false, Some(dest)) = (lost, dest) {
                    let _ = into.send_to(&buf[..n], dest);
                }
            }
        });
    }
    port
}

/// A 1,000-parameter PX4 vehicle talking to a shared connection (through a relay that loses
/// `loss` of the datagrams each way, when above 0), another system's ATTITUDE at 200 Hz sent
/// straight to it, and `work` done by the services' client meanwhile: every ATTITUDE must
/// arrive, in order, none lost to the work.
fn telemetry_during(loss: f64, work: impl FnOnce(&mut Remote<'_>)) -> u32 {
    use ferrolink_dialects::common::{Attitude, Message as Common};
    use ferrolink_io::mavlink::{Filter, SharedConnection};
    use ferrolink_runtime::mavlink::Dialect;

    let link = SharedConnection::open("udpin://127.0.0.1:0", Common::META).unwrap();
    let port = link.local_addr().unwrap().port();
    // The telemetry of a system beside the vehicle (the vehicle publishes ATTITUDE too).
    let attitude = link.subscribe(Filter::all().ids(&[Attitude::ID]).system(7));
    let stop = Arc::new(AtomicBool::new(false));
    let params = (0..1000)
        .map(|i| param(&format!("P{i}"), Value::I32(i)))
        .collect();
    let to = if loss > 0.0 {
        relay(port, loss, &stop)
    } else {
        port
    };
    let vehicle = vehicle_at(params, None, format!("udpout://127.0.0.1:{to}"), &stop);
    // Telemetry from another system (a camera, say), on a socket of its own, at 200 Hz.
    let telemetry =
        SharedConnection::open(&format!("udpout://127.0.0.1:{port}"), Common::META).unwrap();
    telemetry.set_ids(7, 100);
    let sender = {
        let (telemetry, stop) = (telemetry.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut sent = 0u32;
            while !stop.load(Ordering::Relaxed) {
                let a = Attitude {
                    time_boot_ms: sent,
                    ..Default::default()
                };
                if telemetry.send(&a).is_ok() {
                    sent += 1;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            sent
        })
    };
    let peer = services::wait_for_vehicle_on(&link, Duration::from_secs(10))
        .unwrap()
        .expect("the vehicle");
    let mut remote = Remote::on(&link, peer);
    work(&mut remote);
    std::thread::sleep(Duration::from_millis(200));
    stop.store(true, Ordering::Relaxed);
    let sent = sender.join().unwrap();
    vehicle.join().unwrap();
    let mut got = Vec::new();
    while let Some(f) = attitude.recv(Duration::from_millis(300)).unwrap() {
        let Ok(Common::Attitude(a)) = f.decode::<Common>() else {
            panic!("an ATTITUDE")
        };
        got.push(a.time_boot_ms);
    }
    assert!(sent > 20, "the work took {sent} telemetry periods");
    assert_eq!(
        got,
        (0..sent).collect::<Vec<_>>(),
        "every ATTITUDE, in order"
    );
    assert_eq!((attitude.dropped(), remote.dropped()), (0, 0));
    sent
}

/// On a shared connection a 1,000-parameter fetch runs beside a telemetry subscriber, and
/// costs it no frame: every ATTITUDE another system sends at 200 Hz meanwhile arrives.
#[test]
fn telemetry_keeps_flowing_during_a_parameter_fetch() {
    telemetry_during(0.0, |remote| {
        let list = remote
            .fetch_params(Duration::from_secs(30), |_| {})
            .unwrap();
        assert_eq!((list.count, list.missing()), (1000, 0));
        assert_eq!(
            list.get("P999").and_then(|p| p.value),
            Some(Value::I32(999))
        );
    });
}

/// The same through a link that loses 20 % each way: a 1,000-parameter fetch and a 500-item
/// mission upload both complete, and every ATTITUDE sent meanwhile arrives.
#[test]
fn telemetry_keeps_flowing_during_lossy_transfers() {
    use ferrolink_runtime::mavlink::service::messages::{
        MavCmd, MavFrame, MavMissionResult, MavMissionType,
    };
    use ferrolink_runtime::mavlink::service::mission::Item;
    let sent = telemetry_during(0.2, |remote| {
        let list = remote
            .fetch_params(Duration::from_secs(60), |_| {})
            .unwrap();
        assert_eq!((list.count, list.missing()), (1000, 0));
        let items: Vec<Item> = (0..500)
            .map(|i| Item {
                frame: MavFrame::GlobalRelativeAlt,
                command: MavCmd::NavWaypoint,
                autocontinue: 1,
                x: 473_977_420 + i,
                y: 85_455_940,
                z: 20.0,
                ..Default::default()
            })
            .collect();
        let result = remote
            .upload_mission(MavMissionType::Mission, &items, |_, _| {})
            .unwrap();
        assert_eq!(result, Some(MavMissionResult::MavMissionAccepted));
    });
    eprintln!("{sent} ATTITUDE at 200 Hz through a 1,000-parameter fetch and a 500-item upload at 20 % loss: every one arrived");
}

#[test]
fn a_cached_parameter_list_is_kept_while_the_hash_check_is_unchanged() {
    let root = tempfile::tempdir().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let (port, thread) = vehicle(root.path(), &stop);
    let (mut link, peer) = connect(port);
    let mut remote = Remote::new(&mut link, peer);
    let mut cache = remote
        .fetch_params(Duration::from_secs(10), |_| {})
        .unwrap();
    assert_eq!((cache.count, cache.missing()), (40, 0));
    assert!(cache.hash.is_some(), "a PX4 vehicle announces _HASH_CHECK");
    let before = cache.clone();
    assert!(!remote
        .refresh_params(&mut cache, Duration::from_secs(10))
        .unwrap());
    assert_eq!(cache, before);
    let set = remote.set_param("P3", Value::F32(99.5)).unwrap().unwrap();
    assert_eq!(set.value, Some(Value::F32(99.5)));
    assert!(remote
        .refresh_params(&mut cache, Duration::from_secs(10))
        .unwrap());
    assert_ne!(cache.hash, before.hash);
    assert_eq!(cache.values[3].unwrap().value, Some(Value::F32(99.5)));
    stop.store(true, Ordering::Relaxed);
    thread.join().unwrap();
}

#[test]
fn the_extended_protocol_carries_64_bit_values_whole() {
    let root = tempfile::tempdir().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let params = vec![
        param("U64", Value::U64(u64::MAX - 5)),
        param("I64", Value::I64(i64::MIN + 7)),
        param("F64", Value::F64(0.1)),
        param("I32", Value::I32(-5)),
        param("F32", Value::F32(0.25)),
    ];
    let (port, thread) = vehicle_with(params.clone(), root.path(), &stop);
    let (mut link, peer) = connect(port);
    let mut remote = Remote::new(&mut link, peer);
    // PARAM_VALUE cannot carry the 64-bit values: listed, without them.
    let v1 = remote
        .fetch_params(Duration::from_secs(10), |_| {})
        .unwrap();
    let values: Vec<_> = v1.values.iter().map(|r| r.unwrap().value).collect();
    assert_eq!(values[..3], [None, None, None]);
    assert_eq!(values[3..], [Some(Value::I32(-5)), Some(Value::F32(0.25))]);
    remote.param_config.protocol = Protocol::Ext;
    let ext = remote
        .fetch_params(Duration::from_secs(10), |_| {})
        .unwrap();
    assert_eq!((ext.count, ext.missing(), ext.hash), (5, 0, None));
    for (r, p) in ext.values.iter().zip(&params) {
        let r = r.unwrap();
        assert_eq!((r.name, r.value), (p.name, Some(p.value)));
    }
    let big = Value::U64(1 << 60 | 3);
    let set = remote.set_param("U64", big).unwrap().unwrap();
    assert_eq!(set.value, Some(big));
    let read = remote.read_param("U64").unwrap().unwrap();
    assert_eq!((read.index, read.value), (0, Some(big)));
    // A fraction for an integer parameter: refused, and nothing changes.
    let refused = remote.set_param("I32", Value::F64(0.5)).unwrap().unwrap();
    assert_eq!(refused.value, None);
    let read = remote.read_param("I32").unwrap().unwrap();
    assert_eq!(read.value, Some(Value::I32(-5)));
    stop.store(true, Ordering::Relaxed);
    thread.join().unwrap();
}

#[test]
fn files_go_both_ways_and_stay_inside_the_root() {
    let root = tempfile::tempdir().unwrap();
    std::fs::create_dir(root.path().join("logs")).unwrap();
    let data: Vec<u8> = (0..70_000u32).map(|i| (i * 7 + i / 300) as u8).collect();
    std::fs::write(root.path().join("logs/a.bin"), &data).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let (port, thread) = vehicle(root.path(), &stop);
    let (mut link, peer) = connect(port);
    let mut remote = Remote::new(&mut link, peer);
    let names: Vec<String> = remote
        .ftp_list("/")
        .unwrap()
        .into_iter()
        .map(|e| e.name)
        .collect();
    assert_eq!(names, ["logs"]);
    assert_eq!(remote.ftp_get("/logs/a.bin", |_, _| {}).unwrap(), data);
    let up: Vec<u8> = data.iter().rev().copied().collect();
    remote.ftp_put("/logs/b.bin", &up, |_, _| {}).unwrap();
    assert_eq!(std::fs::read(root.path().join("logs/b.bin")).unwrap(), up);
    let crc = remote.ftp_crc32("/logs/b.bin").unwrap();
    assert_eq!(crc, ferrolink_runtime::crc::FTP_CRC32.checksum(&up));
    remote.ftp_remove("/logs/b.bin").unwrap();
    assert!(!root.path().join("logs/b.bin").exists());
    let escape = remote.ftp_put("/../outside.bin", b"no", |_, _| {});
    assert_eq!(
        escape.unwrap_err().kind(),
        std::io::ErrorKind::PermissionDenied
    );
    let missing = remote.ftp_get("/nope", |_, _| {});
    assert_eq!(missing.unwrap_err().kind(), std::io::ErrorKind::NotFound);
    stop.store(true, Ordering::Relaxed);
    thread.join().unwrap();
}

#[cfg(feature = "tokio")]
#[test]
fn the_async_client_does_what_the_blocking_one_does() {
    use ferrolink_io::mavlink::services::AsyncRemote;
    use ferrolink_runtime::mavlink::service::command::Command;
    use ferrolink_runtime::mavlink::service::messages::{MavCmd, MavMissionType, MavResult};
    use ferrolink_runtime::mavlink::service::mission::Item;

    let root = tempfile::tempdir().unwrap();
    std::fs::write(root.path().join("f.txt"), b"hello").unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let (port, thread) = vehicle(root.path(), &stop);
    let (link, peer) = connect(port);
    let remote = AsyncRemote::new(link, peer);
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .unwrap();
    runtime.block_on(async {
        // Two at once take turns on the connection.
        let mut sizes = Vec::new();
        let (params, file) = tokio::join!(
            remote.fetch_params(Duration::from_secs(10), |_| {}),
            remote.ftp_get("/f.txt", |done, size| sizes.push((done, size)))
        );
        assert_eq!(params.unwrap().missing(), 0);
        assert_eq!(file.unwrap(), b"hello");
        assert_eq!(sizes.last(), Some(&(5, 5)), "progress, async too");
        // The connection's heartbeat has its thread by now; operations start none.
        let threads = || std::fs::read_dir("/proc/self/task").map_or(0, |d| d.count());
        let before = threads();
        let arm = Command::long(
            MavCmd::ComponentArmDisarm,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        let ack = remote
            .command(arm, |_| {})
            .await
            .unwrap()
            .expect("an answer");
        assert_eq!(ack.result, MavResult::Accepted);
        let items = vec![Item::default(); 12];
        remote
            .upload_mission(MavMissionType::Mission, &items, |_, _| {})
            .await
            .unwrap();
        let back = remote
            .download_mission(MavMissionType::Mission, |_, _| {})
            .await
            .unwrap();
        assert_eq!(back.map(|b| b.len()), Some(12));
        let after = threads();
        assert!(
            after <= before,
            "no thread per operation: {before} then {after}"
        );
    });
    stop.store(true, Ordering::Relaxed);
    thread.join().unwrap();
}
