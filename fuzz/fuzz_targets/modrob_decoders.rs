//! Feeds arbitrary bytes to the ModRob-1 decoders: `Message::from_can` (identifier and data
//! split from the input), `ethernet::Packet::new_checked` and its messages, and a piecewise
//! `Reassembler` (a chunk script made from the input, checked against a model of its rules,
//! and an array's own chunks in the input's order). The invariants are listed in
//! `runtime/tests/scripts/modrob_decoders.rs` and `runtime/tests/scripts/modrob.rs`, which the
//! property tests run too.
//!
//! Run with `cargo fuzz run modrob_decoders`.
#![no_main]

#[path = "../../runtime/tests/scripts/modrob.rs"]
#[allow(dead_code)]
mod packet;

#[path = "../../runtime/tests/scripts/modrob_decoders.rs"]
#[allow(dead_code)]
mod decoders;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    decoders::check_can(data);
    packet::check_packet(data);
    decoders::check_reassembler(data);
    decoders::check_text(data);
});
