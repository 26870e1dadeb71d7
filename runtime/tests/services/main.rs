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

/// The script's link reaches the end of every operation whose result it checks: an FTP listing,
/// read, write and CRC-32, and a mission upload and download, over a clean link and over one
/// that loses messages (the clock steps let the clients ask again). Its first run found the FTP
/// client dropping read data when more than four events waited: the read still ended well.
#[test]
fn the_link_carries_operations_to_their_end() {
    // 04 00: no time passes (and the first byte picks the settings). 06 xx: a client starts an
    // operation. fc mm: sixteen rounds of the link, losing what mask mm picks. 04 tt: tt × 10 ms.
    let clean = "fc00fc00fc00fc00";
    let lossy = "fc55fc5504ff fc22fc22 04ff fc81fc81 04ff fc00fc00 04ff fc00fc00 04ff fc00fc00";
    for link in [clean, lossy] {
        let ops = ["0637", "0677", "06b7", "06f7", "0604", "0605"];
        let script: String = ops.iter().map(|op| format!("0400{op}{link}")).collect();
        let outcome = scripts::check_servers(&hex(&script.replace(' ', "")));
        assert_eq!(
            outcome,
            scripts::Outcome {
                ftp: [1, 1, 1, 1],
                uploads: 1,
                downloads: 1,
            },
            "over {link}"
        );
    }
}

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).expect("hex"))
        .collect()
}

/// Found by the `mavlink_services` fuzz target: an upload, a clear, then the same upload again
/// at once. The server took the new count for a late copy of the old one and repeated the old
/// upload's final ACK, and the client took that for the end of the new upload: it reported a
/// mission the vehicle did not hold.
#[test]
fn a_repeated_final_ack_does_not_end_the_next_upload() {
    scripts::check_servers(&hex("debcbc64bcbc16c6bc7edebc64bcbc"));
}
