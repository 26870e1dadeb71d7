//! Arbitrary text as an endpoint URI, a TOML router configuration and a mavlink-router
//! `main.conf`. The invariants are listed in `io/tests/scripts/mavlink.rs`.
//!
//! Run with `cargo fuzz run router_config`.
#![no_main]

#[path = "../../io/tests/scripts/mavlink.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_config(data));
