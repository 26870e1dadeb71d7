//! Arbitrary scripts for the MAVLink router core: raw bytes and well-formed (maybe corrupted)
//! frames on four links, clock steps, and links reopened with other configurations. The
//! invariants (no echo, nothing forwarded that failed its CRC, counters add up) are listed in
//! `runtime/tests/scripts/router.rs`, which the property tests run too.
//!
//! Run with `cargo fuzz run mavlink_router`.
#![no_main]

#[path = "../../runtime/tests/scripts/router.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_router(data));
