//! The router's web API (`tests/mavlink/web.py`): mavlink2rest's REST and WebSocket API driven by
//! `requests` and `aiohttp`, fed by pymavlink vehicles in MAVLink 1 and 2; posting a command
//! that reaches the vehicle; a stalled WebSocket client that loses only its own messages;
//! malformed HTTP, a huge body and a thousand idle connections; and the inspector page in a
//! headless Chromium.
//!
//! Needs a Python with pymavlink, requests and aiohttp (`tests/run-all.sh` installs them). With
//! `FERROLINK_REQUIRE_HTTP_CLIENTS` or `FERROLINK_REQUIRE_CHROMIUM` set (the full run sets them
//! when the installs worked) a check skipped for their want fails the test.
#![cfg(feature = "http")]

mod common;

#[test]
fn the_web_api_against_real_clients() {
    let Some(stdout) = common::run_router_checks("web.py") else {
        return;
    };
    common::require_no_skip(
        &stdout,
        "FERROLINK_REQUIRE_HTTP_CLIENTS",
        "requests and aiohttp",
    );
    common::require_no_skip(&stdout, "FERROLINK_REQUIRE_CHROMIUM", "Chromium");
}
