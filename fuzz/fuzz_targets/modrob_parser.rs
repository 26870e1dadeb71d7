//! Feeds arbitrary bytes to the ModRob-1 UART.B-1 stream parser in arbitrary chunks, and reads
//! them as an Ethernet-1 packet; the invariants are listed in `runtime/tests/scripts/modrob.rs`,
//! which the property tests run too.
//!
//! Run with `cargo fuzz run modrob_parser corpus/modrob_parser seeds/modrob_parser`.
#![no_main]

#[path = "../../runtime/tests/scripts/modrob.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    scripts::check_parser(data);
    scripts::check_packet(data);
});
