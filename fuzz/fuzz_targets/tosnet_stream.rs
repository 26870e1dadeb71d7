//! Arbitrary bytes, in arbitrary chunks, for the TosNet byte-stream parser; the invariants are
//! `runtime/tests/scripts/tosnet.rs`, which the property tests run too.
//!
//! Run with `cargo fuzz run tosnet_stream`.
#![no_main]

#[path = "../../runtime/tests/scripts/tosnet.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_stream(data));
