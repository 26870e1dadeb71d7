//! `ferrolink diff` on two real versions of MAVLink's common.xml: pymavlink 2.4.50's (the
//! installed package, as OLD) against the copy the `mavlink` crate 0.21 was built from (NEW).
//! Every finding is checked against what each side's own software computes: pymavlink's
//! `crc_extra` for OLD, the `mavlink` crate's `extra_crc` for NEW.
//!
//! Needs the Python with pymavlink that `tests/run-all.sh` installs; with
//! `FERROLINK_REQUIRE_PYMAVLINK` set a missing pymavlink fails the test.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use ferrolink_tools::diff::{self, Category};
use mavlink::Message as _;

type Common = mavlink::dialects::common::MavMessage;

/// Message name to id and CRC_EXTRA.
type Crcs = BTreeMap<String, (u32, u8)>;

/// pymavlink's common.xml and its CRC_EXTRA per message name, as pymavlink computes them.
fn pymavlink() -> Option<(PathBuf, Crcs)> {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let python = std::env::var_os("FERROLINK_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join(".venv/bin/python"));
    let script = "import json, os, pymavlink\n\
        from pymavlink.dialects.v20 import common\n\
        print(os.path.join(os.path.dirname(pymavlink.__file__), 'dialects/v20/common.xml'))\n\
        print(json.dumps({c.msgname: [i, c.crc_extra] for i, c in common.mavlink_map.items()}))";
    let out = Command::new(python).args(["-c", script]).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8(out.stdout).ok()?;
    let (path, json) = text.split_once('\n')?;
    let crcs: Crcs = serde_json::from_str(json).ok()?;
    Some((PathBuf::from(path), crcs))
}

/// The common.xml inside the `mavlink` crate this package depends on.
fn mavlink_crate_common() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let out = Command::new(env!("CARGO"))
        .args(["metadata", "--format-version", "1", "--manifest-path"])
        .arg(&manifest)
        .output()
        .expect("cargo metadata runs");
    let meta: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON");
    let package = meta["packages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "mavlink" && p["version"].as_str().unwrap().starts_with("0.21."))
        .expect("the mavlink crate 0.21 is a dependency");
    let dir = Path::new(package["manifest_path"].as_str().unwrap())
        .parent()
        .unwrap()
        .to_path_buf();
    dir.join("mavlink/message_definitions/v1.0/common.xml")
}

#[test]
fn pymavlink_common_against_the_mavlink_crates_common() {
    let Some((old_path, py_crc)) = pymavlink() else {
        assert!(
            std::env::var_os("FERROLINK_REQUIRE_PYMAVLINK").is_none(),
            "pymavlink is missing, but FERROLINK_REQUIRE_PYMAVLINK is set"
        );
        eprintln!("skipped: pymavlink is missing");
        return;
    };
    let new_path = mavlink_crate_common();
    let load = |p: &PathBuf| {
        ferrolink_dictionary::load(std::slice::from_ref(p))
            .unwrap_or_else(|e| panic!("{e}"))
            .ir
    };
    let (old, new) = (load(&old_path), load(&new_path));
    let findings = diff::diff(&old, &new);

    let messages = |ir: &ferrolink_dictionary::ir::Ir| -> Crcs {
        ir.modules
            .iter()
            .flat_map(|m| &m.messages)
            .map(|m| (m.name.wire.clone(), (m.id, m.crc_extra)))
            .collect()
    };
    let (ours_old, ours_new) = (messages(&old), messages(&new));
    eprintln!(
        "pymavlink 2.4.50: {} messages; mavlink 0.21: {} messages",
        ours_old.len(),
        ours_new.len()
    );
    // Each side's loader agrees with that side's own software, message for message.
    let old_common: BTreeMap<_, _> = py_crc
        .iter()
        .filter(|(n, _)| ours_old.contains_key(*n))
        .collect();
    assert_eq!(
        old_common.len(),
        ours_old.len(),
        "pymavlink's common defines every message our OLD has"
    );
    for (name, &(id, crc)) in &ours_old {
        assert_eq!(
            py_crc[name],
            (id, crc),
            "{name}: our CRC_EXTRA for pymavlink's file"
        );
    }
    for (name, &(id, crc)) in &ours_new {
        assert_eq!(Common::message_id_from_name(name), Some(id), "{name}");
        assert_eq!(
            Common::extra_crc(id),
            crc,
            "{name}: our CRC_EXTRA for the crate's file"
        );
    }

    for f in &findings {
        match f.code {
            "crc-extra" => {
                let (old_crc, new_crc) = f.crc_extra.expect("crc-extra findings carry both values");
                let id = ours_new[&f.name].0;
                assert_eq!(new_crc, Common::extra_crc(id), "{}", f.name);
                let old_name = py_crc
                    .iter()
                    .find(|(_, v)| v.0 == id)
                    .map(|(n, _)| n)
                    .unwrap();
                assert_eq!(old_crc, py_crc[old_name].1, "{}", f.name);
                assert_ne!(old_crc, new_crc);
            }
            "message-added" => {
                assert!(!py_crc.contains_key(&f.name), "{} is new", f.name);
                assert!(
                    Common::message_id_from_name(&f.name).is_some(),
                    "{}",
                    f.name
                );
            }
            "message-removed" => {
                assert!(
                    py_crc.contains_key(&f.name) && Common::message_id_from_name(&f.name).is_none(),
                    "{}",
                    f.name
                );
            }
            _ => {}
        }
    }
    // Messages both sides have and no finding flags: both sides' software computes one CRC_EXTRA.
    for (name, &(id, _)) in ours_new.iter().filter(|(n, _)| ours_old.contains_key(*n)) {
        let flagged = findings
            .iter()
            .any(|f| f.code == "crc-extra" && &f.name == name);
        assert_eq!(py_crc[name].1 != Common::extra_crc(id), flagged, "{name}");
    }
    let added = findings
        .iter()
        .filter(|f| f.code == "message-added")
        .count();
    assert_eq!(
        added,
        ours_new
            .keys()
            .filter(|n| !ours_old.contains_key(*n))
            .count()
    );
    let count = |c| findings.iter().filter(|f| f.category == c).count();
    eprintln!(
        "{} findings: {} wire, {} semantic, {} api, {} safe",
        findings.len(),
        count(Category::Wire),
        count(Category::Semantic),
        count(Category::Api),
        count(Category::Safe)
    );
}
