//! A companion computer on a vehicle's MAVLink link.
//!
//! ```sh
//! cargo run -p ferrolink-example-companion -- udpin://0.0.0.0:14550 --seconds 10
//! ```
//!
//! It announces itself with a heartbeat every second (an onboard controller, sysid 1 compid
//! 191 by default), prints the vehicle's heartbeats and, once a second, its latest attitude. On
//! the first heartbeat of an autopilot it asks for ATTITUDE at 10 Hz with
//! `MAV_CMD_SET_MESSAGE_INTERVAL` and prints the vehicle's COMMAND_ACK. It exits after the given
//! time, with status 0 if it saw a heartbeat, attitude and the acknowledgement.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use ferrolink_dialects::common::{
    Attitude, CommandLong, Heartbeat, MavAutopilot, MavCmd, MavModeFlag, MavState, MavType, Message,
};
use ferrolink_io::mavlink::Connection;
use ferrolink_runtime::mavlink::Dialect;

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
    let mut vehicle = Connection::open(uri, Message::META)?;
    vehicle.set_ids(sysid, compid);
    let heartbeat = Heartbeat {
        r#type: MavType::OnboardController,
        autopilot: MavAutopilot::Invalid,
        base_mode: MavModeFlag(0),
        custom_mode: 0,
        system_status: MavState::Active,
        mavlink_version: 3,
    };
    let start = Instant::now();
    let mut next_heartbeat = start;
    let mut next_print = start + Duration::from_secs(1);
    let (mut seen_heartbeat, mut acked) = (false, false);
    let mut attitude: Option<Attitude> = None;
    let mut asked = false;
    while start.elapsed() < duration {
        let now = Instant::now();
        if now >= next_heartbeat {
            // Nobody to send to yet is fine on a listening endpoint.
            let _ = vehicle.send(&heartbeat);
            next_heartbeat += Duration::from_secs(1);
        }
        if now >= next_print {
            if let Some(a) = attitude {
                println!(
                    "attitude: roll {:+.3} pitch {:+.3} yaw {:+.3} rad",
                    a.roll, a.pitch, a.yaw
                );
            }
            next_print += Duration::from_secs(1);
        }
        let Some((header, message)) = vehicle.recv_message::<Message>(Duration::from_millis(50))?
        else {
            continue;
        };
        match message {
            Message::Heartbeat(hb) if hb.autopilot != MavAutopilot::Invalid => {
                println!(
                    "heartbeat from {}/{}: {:?} {:?} {:?}",
                    header.sysid, header.compid, hb.r#type, hb.autopilot, hb.system_status
                );
                seen_heartbeat = true;
                if !asked {
                    asked = true;
                    let command = CommandLong {
                        target_system: header.sysid,
                        target_component: header.compid,
                        command: MavCmd::SetMessageInterval,
                        confirmation: 0,
                        param1: Attitude::ID as f32,
                        param2: 100_000.0,
                        param3: 0.0,
                        param4: 0.0,
                        param5: 0.0,
                        param6: 0.0,
                        param7: 0.0,
                    };
                    vehicle.send(&command)?;
                    println!("sent SET_MESSAGE_INTERVAL(ATTITUDE, 100 ms)");
                }
            }
            Message::Attitude(a) => attitude = Some(a),
            Message::CommandAck(ack) if ack.target_system == sysid || ack.target_system == 0 => {
                println!("ack: {:?} {:?}", ack.command, ack.result);
                acked = true;
            }
            _ => {}
        }
    }
    Ok(seen_heartbeat && attitude.is_some() && acked)
}
