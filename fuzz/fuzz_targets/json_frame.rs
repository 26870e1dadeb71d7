//! Arbitrary bytes as JSON to re-encode as a MAVLink frame, the way the Zenoh endpoint takes
//! JSON samples. The invariants are listed in `traffic/tests/scripts/traffic.rs`.
//!
//! Run with `cargo fuzz run json_frame`.
#![no_main]

#[path = "../../traffic/tests/scripts/traffic.rs"]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_json_frame(data));
