//! Arbitrary input for the MAVLink microservices: a script of messages (any payload bytes),
//! clock steps, answers, client operations and rounds of a lossy link between the clients and
//! the servers, for the parameter, command, mission and FTP state machines. The invariants are
//! listed in `runtime/tests/scripts/services.rs`, which the property tests run too.
//!
//! Run with `cargo fuzz run mavlink_services`.
#![no_main]

#[path = "../../runtime/tests/scripts/services.rs"]
#[allow(dead_code)]
mod scripts;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    scripts::check_servers(data);
});
