//! `ferrolink mavlink fleet`: the routers on a Zenoh network, each with its links and the
//! systems behind them.

use std::time::Duration;

use zenoh::Wait;

use crate::uri::ZenohUri;

/// Asks every router under `uri`'s prefix who it is, waiting up to `timeout` for answers.
///
/// The question is asked as a Zenoh client of the endpoints `uri` connects to, whatever its
/// mode: a peer or router answers for the peers it knows, so one connection reaches the fleet.
/// Returns one JSON object per router, sorted by router id:
/// `{"router": ZID, "endpoint": URI, "links": [NAME, ...], "systems": [{"sysid", "compid",
/// "link"}, ...]}`.
pub fn list(uri: &ZenohUri, timeout: Duration) -> Result<Vec<serde_json::Value>, String> {
    if uri.connect.is_empty() {
        return Err(format!(
            "{uri}: give connect=PROTOCOL/ADDRESS of a router of the fleet"
        ));
    }
    let session = zenoh::open(uri.config_as(crate::uri::Mode::Client)?)
        .wait()
        .map_err(|e| format!("{uri}: {e}"))?;
    let mut routers = Vec::new();
    let replies = session
        .get(format!("{}/*", uri.fleet_root()))
        .timeout(timeout)
        .wait()
        .map_err(|e| format!("{uri}: {e}"))?;
    while let Ok(reply) = replies.recv() {
        let Ok(sample) = reply.result() else {
            continue;
        };
        let bytes = sample.payload().to_bytes();
        if let Ok(value) = serde_json::from_slice::<serde_json::Value>(&bytes) {
            routers.push(value);
        }
    }
    let _ = session.close().wait();
    routers.sort_by(|a, b| a["router"].as_str().cmp(&b["router"].as_str()));
    Ok(routers)
}
