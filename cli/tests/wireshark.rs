//! `ferrolink wireshark`: the generated Lua dissectors, loaded into the real tshark with an
//! empty configuration, decode pcaps of frames from pymavlink and from our own encoders
//! (garbage, bad checksums, truncation and signing mixed in) to the expected field values
//! (`tests/wireshark/mavlink.py`, `tests/wireshark/others.py`).
//!
//! Needs tshark (and pymavlink for MAVLink); `tests/run-all.sh` installs both and sets
//! `FERROLINK_REQUIRE_TSHARK`, under which a check skipped for a missing tool fails.

mod common;

use std::path::PathBuf;

#[test]
fn the_mavlink_dissector_decodes_what_pymavlink_sends() {
    let Some((python, dialects)) = common::pymavlink() else {
        common::skip("pymavlink is missing");
        return;
    };
    let out = common::run_checks(
        &python,
        "wireshark/mavlink.py",
        &[
            "--ferrolink".as_ref(),
            common::ferrolink().as_ref(),
            "--dialect-dir".as_ref(),
            dialects.as_os_str(),
        ],
    );
    common::require_no_skip(&out, "FERROLINK_REQUIRE_TSHARK", "tshark");
}

#[test]
fn the_ndlcom_modrob_and_tosnet_dissectors_decode_our_frames() {
    let python = common::pymavlink().map_or_else(|| PathBuf::from("python3"), |(p, _)| p);
    let captures = common::captures();
    let out = common::run_checks(
        &python,
        "wireshark/others.py",
        &["--ferrolink".as_ref(), common::ferrolink().as_ref()],
    );
    // The real-capture check reads `../shared/captures`: required only where it is there.
    let allowed: &[&str] = match captures {
        Some(_) => &[],
        None => &["ndlcom_real_captures"],
    };
    common::require_no_skip_but(&out, "FERROLINK_REQUIRE_TSHARK", "tshark", allowed);
}
