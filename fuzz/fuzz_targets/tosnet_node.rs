//! Arbitrary input for the TosNet node engine: a script of frames, clock steps, commits and
//! side-channel messages. The invariants are listed in `runtime/tests/scripts/tosnet.rs`, which
//! the property tests run too.
//!
//! Run with `cargo fuzz run tosnet_node`.
#![no_main]

#[path = "../../runtime/tests/scripts/tosnet.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| scripts::check_node(data));
