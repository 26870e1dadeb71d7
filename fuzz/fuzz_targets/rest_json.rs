//! Arbitrary bytes as mavlink2rest's JSON form of a message (what the router's web API takes in
//! a POST or from a WebSocket), or as a payload to write in that form. The invariants are listed
//! in `traffic/tests/scripts/traffic.rs` (`check_rest_json`).
//!
//! Run with `cargo fuzz run rest_json`.
#![no_main]

#[path = "../../traffic/tests/scripts/traffic.rs"]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_rest_json(data));
