//! Arbitrary input for the TosNet frame parser (any bytes as one frame); the invariants are
//! `runtime/tests/scripts/tosnet.rs`, which the property tests run too.
//!
//! Run with `cargo fuzz run tosnet_frame`.
#![no_main]

#[path = "../../runtime/tests/scripts/tosnet.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_frame(data));
