//! What the router daemon's tests share: a message table, frames, and a router
//! running in a thread of the test.
#![allow(dead_code)]

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::Duration;

use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::config::EndpointConfig;
use ferrolink_io::mavlink::router::{self, Config};
use ferrolink_runtime::mavlink::{v2, Header, MessageMeta};

/// HEARTBEAT alone.
pub static HEARTBEAT_ONLY: &[MessageMeta] = &[HEARTBEAT];

/// HEARTBEAT's entry.
pub const HEARTBEAT: MessageMeta = MessageMeta {
    id: 0,
    crc_extra: 50,
    min_len: 9,
    max_len: 9,
    target_system: None,
    target_component: None,
};

/// An unsigned HEARTBEAT from `sysid`, component 1.
pub fn heartbeat(sysid: u8) -> Vec<u8> {
    let mut out = [0u8; v2::MAX_FRAME_LEN];
    let n = v2::encode_raw(Header::new(0, sysid, 1), 0, 50, &[0; 9], &mut out).expect("fits");
    out[..n].to_vec()
}

/// A router on one endpoint that knows HEARTBEAT alone.
pub fn on(endpoint: Endpoint) -> Config {
    Config {
        endpoints: vec![EndpointConfig::new(endpoint)],
        table: HEARTBEAT_ONLY.into(),
        ..Config::default()
    }
}

/// The router daemon running in a thread of the test.
pub struct Running {
    stop: Arc<AtomicBool>,
    thread: thread::JoinHandle<io::Result<()>>,
}

/// Starts the router on `config` and gives it 300 ms to open its endpoints.
pub fn start(config: Config) -> Running {
    let stop = Arc::new(AtomicBool::new(false));
    let thread = {
        let stop = stop.clone();
        thread::spawn(move || router::run(&config, Vec::new(), &stop))
    };
    thread::sleep(Duration::from_millis(300));
    Running { stop, thread }
}

impl Running {
    /// Stops the router; it must have run without an error.
    pub fn stop(self) {
        self.stop.store(true, Ordering::Relaxed);
        self.thread
            .join()
            .expect("router thread")
            .expect("router ran");
    }
}
