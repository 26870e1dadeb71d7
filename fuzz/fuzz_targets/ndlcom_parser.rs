//! Feeds arbitrary bytes to the NDLCom stream parser in arbitrary chunks; the invariants are
//! listed in `runtime/tests/scripts/ndlcom.rs`, which the property tests run too.
//!
//! Run with `cargo fuzz run ndlcom_parser`.
#![no_main]

#[path = "../../runtime/tests/scripts/ndlcom.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_parser(data));
