//! The MAVLink microservices' state machines, each side alone and both sides through a lossy
//! link.

mod command;
mod ftp;
mod lossy;
mod mission;
mod param;
#[path = "../scripts/services.rs"]
mod scripts;

use proptest::prelude::*;

proptest! {
    /// Arbitrary scripts: the invariants the `mavlink_services` fuzz target checks.
    #[test]
    fn scripts_keep_the_invariants(script in prop::collection::vec(any::<u8>(), 0..2000)) {
        scripts::check_servers(&script);
    }
}

/// Found by the `mavlink_services` fuzz target: a CRC-32 of a file that does not exist made the
/// FTP server close a session it never opened.
#[test]
fn a_crc_of_a_missing_file_closes_nothing() {
    let script = hex(
        "0101011101004000000000001401012e01010101105b0e10ffc400011101004000000000001111f606ffff",
    );
    scripts::check_servers(&script);
}

/// Found by the `mavlink_services` fuzz target: the script took the server's `_HASH_CHECK`
/// (index -1) for a parameter.
#[test]
fn a_hash_check_is_not_a_parameter() {
    scripts::check_servers(&hex("ff51ff51ff51ff511b50"));
}

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).expect("hex"))
        .collect()
}
