//! Arbitrary bytes as a telemetry log and as a raw capture. The invariants are listed in
//! `io/tests/scripts/mavlink.rs`, which the tests run on real and damaged logs too.
//!
//! Run with `cargo fuzz run tlog_reader`.
#![no_main]

#[path = "../../io/tests/scripts/mavlink.rs"]
#[allow(dead_code)]
mod io_scripts;
#[path = "../../runtime/tests/scripts/router.rs"]
#[allow(dead_code)]
mod router_scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| io_scripts::check_tlog(data, router_scripts::META));
