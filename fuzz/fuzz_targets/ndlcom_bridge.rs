//! Drives a 3-interface NDLCom bridge with an arbitrary script of receives, polls, transmits
//! and configuration changes; the invariants are listed in `runtime/tests/scripts/ndlcom.rs`,
//! which the property tests run too.
//!
//! Run with `cargo fuzz run ndlcom_bridge`.
#![no_main]

#[path = "../../runtime/tests/scripts/ndlcom.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_bridge(data));
