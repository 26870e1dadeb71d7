//! The README's first MAVLink program: connects, waits for a vehicle, prints its position, arms
//! it and takes off to 10 m; blocking, or with `--async` the same on tokio.
//!
//! ```sh
//! ferrolink mavlink vehicle --autopilot px4 udpout://127.0.0.1:14550 &
//! cargo run -p ferrolink-example-fly -- udpin://0.0.0.0:14550 [--async]
//! ```

use std::time::Duration;

use ferrolink_vehicle::Node;

fn blocking(uri: &str) -> Result<(), Box<dyn std::error::Error>> {
    let node = Node::connect(uri)?;
    let drone = node
        .wait_for_system(Duration::from_secs(10))?
        .ok_or("no vehicle")?;
    println!(
        "position: {:?}",
        drone.telemetry().wait_position(Duration::from_secs(5))
    );
    println!("arm: {:?}", drone.arm()?.result);
    println!("takeoff: {:?}", drone.takeoff(10.0)?.result);
    Ok(())
}

async fn asynchronous(uri: &str) -> Result<(), Box<dyn std::error::Error>> {
    let node = Node::connect(uri)?;
    let drone = node
        .wait_for_system_async(Duration::from_secs(10))
        .await?
        .ok_or("no vehicle")?;
    println!(
        "position: {:?}",
        drone
            .telemetry()
            .wait_position_async(Duration::from_secs(5))
            .await
    );
    println!("arm: {:?}", drone.arm().await?.result);
    println!("takeoff: {:?}", drone.takeoff(10.0).await?.result);
    Ok(())
}

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let uri = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .map_or("udpin://0.0.0.0:14550", String::as_str);
    let done = if args.iter().any(|a| a == "--async") {
        tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .build()
            .map_err(Into::into)
            .and_then(|rt| rt.block_on(asynchronous(uri)))
    } else {
        blocking(uri)
    };
    match done {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{uri}: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
