//! A companion computer on a vehicle's MAVLink link, on the vehicle API.
//!
//! ```sh
//! cargo run -p ferrolink-example-companion -- udpin://0.0.0.0:14550 --seconds 10
//! ```
//!
//! It announces itself with a heartbeat every second (an onboard controller, sysid 1 compid
//! 191 by default), waits for the vehicle, prints its heartbeats and, once a second, its
//! latest attitude. It asks for ATTITUDE at 10 Hz (`MAV_CMD_SET_MESSAGE_INTERVAL`, through
//! the command service) and prints the vehicle's answer. It exits after the given time, with
//! status 0 if it saw a heartbeat, attitude and the acknowledgement.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use ferrolink_io::mavlink::{OwnHeartbeat, SharedConnection};
use ferrolink_runtime::mavlink::service::messages::{MavState, MavType};
use ferrolink_runtime::mavlink::Dialect;
use ferrolink_vehicle::dialects::common::{Attitude, Message};
use ferrolink_vehicle::telemetry::{Kind, Update};
use ferrolink_vehicle::{ActionResult, Node};

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let mut uri = "udpin://0.0.0.0:14550".to_owned();
    let mut seconds = 10.0;
    let mut ids = (1u8, 191u8);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--seconds" => seconds = args.next().and_then(|s| s.parse().ok()).unwrap_or(seconds),
            "--sysid" => ids.0 = args.next().and_then(|s| s.parse().ok()).unwrap_or(ids.0),
            "--compid" => ids.1 = args.next().and_then(|s| s.parse().ok()).unwrap_or(ids.1),
            other => uri = other.to_owned(),
        }
    }
    match run(&uri, Duration::from_secs_f64(seconds), ids) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("{uri}: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(uri: &str, duration: Duration, (sysid, compid): (u8, u8)) -> std::io::Result<bool> {
    let start = Instant::now();
    let link = SharedConnection::open(uri, Message::META)?;
    link.set_ids(sysid, compid);
    link.start_heartbeat(OwnHeartbeat {
        mav_type: MavType::OnboardController,
        system_status: MavState::Active,
        ..OwnHeartbeat::default()
    });
    let node = Node::on(link);
    let Some(vehicle) = node.wait_for_system(duration)? else {
        return Ok(false);
    };
    let updates = vehicle
        .telemetry()
        .subscribe(&[Kind::State, Kind::Attitude]);
    let outcome = vehicle.set_rate(Attitude::ID, 10.0)?;
    println!("sent SET_MESSAGE_INTERVAL(ATTITUDE, 100 ms)");
    println!("ack: SET_MESSAGE_INTERVAL {}", outcome.result.name());
    let mut next_print = Instant::now() + Duration::from_secs(1);
    let mut seen = (false, false);
    while start.elapsed() < duration {
        let wait = duration
            .saturating_sub(start.elapsed())
            .min(Duration::from_millis(100));
        match updates.recv(wait) {
            Some(Update::State(_)) => {
                seen.0 = true;
                println!(
                    "heartbeat from {}/1: {:?} {:?}",
                    vehicle.id(),
                    vehicle.kind(),
                    vehicle.autopilot()
                );
            }
            Some(Update::Attitude(_)) => seen.1 = true,
            _ => {}
        }
        if Instant::now() >= next_print {
            if let Some(a) = vehicle.telemetry().attitude() {
                println!(
                    "attitude: roll {:+.2} pitch {:+.2} yaw {:+.2} deg",
                    a.roll, a.pitch, a.yaw
                );
            }
            next_print += Duration::from_secs(1);
        }
    }
    Ok(seen.0 && seen.1 && outcome.result == ActionResult::Accepted)
}
