//! The compatibility checker on fixtures that make every kind of change: the MAVLink pair
//! `tests/diff/old.xml` -> `new.xml`, and the ModRob-1 module and TosNet ring in
//! `tests/diff/old/` -> `new/`. Snapshots pin the findings in each output form.

use std::path::PathBuf;

use ferrolink_tools::diff::{self, Category, Finding, Format};

fn findings(old: &[&str], new: &[&str]) -> Vec<Finding> {
    let load = |paths: &[&str]| {
        let paths: Vec<PathBuf> = paths.iter().map(PathBuf::from).collect();
        ferrolink_dictionary::load(&paths)
            .unwrap_or_else(|e| panic!("{e}"))
            .ir
    };
    diff::diff(&load(old), &load(new))
}

const OLD_TOML: [&str; 4] = [
    "tests/diff/old/arm.toml",
    "tests/diff/old/cart.toml",
    "tests/diff/old/gripper.toml",
    "tests/diff/old/wheel.toml",
];
const NEW_TOML: [&str; 4] = [
    "tests/diff/new/arm.toml",
    "tests/diff/new/camera.toml",
    "tests/diff/new/cart.toml",
    "tests/diff/new/wheel.toml",
];

fn mavlink() -> Vec<Finding> {
    findings(&["tests/diff/old.xml"], &["tests/diff/new.xml"])
}

fn codes(findings: &[Finding]) -> Vec<(&'static str, &str)> {
    findings.iter().map(|f| (f.code, f.name.as_str())).collect()
}

#[test]
fn mavlink_text() {
    insta::assert_snapshot!(diff::render(&mavlink(), Format::Text));
}

#[test]
fn mavlink_json() {
    let out = diff::render(&mavlink(), Format::Json);
    for line in out.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        let crc = v["code"] == "crc-extra";
        for key in ["category", "code", "kind", "name", "old", "new", "reason"] {
            assert!(keys.contains(&key), "{key} missing in {line}");
        }
        assert_eq!(keys.len(), if crc { 9 } else { 7 }, "{line}");
    }
    insta::assert_snapshot!(out);
}

#[test]
fn mavlink_github() {
    insta::assert_snapshot!(diff::render(&mavlink(), Format::Github));
}

#[test]
fn modrob_and_tosnet_text() {
    let out = findings(&OLD_TOML, &NEW_TOML);
    insta::assert_snapshot!(diff::render(&out, Format::Text));
}

#[test]
fn crc_extra_findings_carry_both_values_and_their_cause() {
    let all = mavlink();
    let crc = |name: &str| {
        all.iter()
            .find(|f| f.code == "crc-extra" && f.name == name)
            .unwrap_or_else(|| panic!("no crc-extra finding for {name}"))
    };
    for (name, cause) in [
        ("FIELD_RENAMED", "field speed renamed to velocity"),
        (
            "TYPE_CHANGED",
            "field level type changed from uint8_t to uint16_t",
        ),
        (
            "ARRAY_CHANGED",
            "field data array length changed from 4 to 8",
        ),
        ("BASE_ADDED", "base field b added"),
        ("REORDERED", "fields reordered on the wire"),
        (
            "NEW_MESSAGE_NAME",
            "message renamed from OLD_MESSAGE_NAME to NEW_MESSAGE_NAME",
        ),
    ] {
        let f = crc(name);
        let (old, new) = f.crc_extra.unwrap();
        assert_ne!(old, new);
        assert_eq!(f.old, serde_json::json!(old));
        assert!(f.reason.contains(cause), "{name}: {}", f.reason);
        assert_eq!(f.category, Category::Wire);
    }
    // Changes outside the base fields leave CRC_EXTRA alone.
    for name in [
        "EXTENSIONS",
        "EXTENSION_APPENDED",
        "MEANING",
        "UNCHANGED",
        "ID_CHANGED",
    ] {
        assert!(
            !all.iter().any(|f| f.code == "crc-extra" && f.name == name),
            "{name}"
        );
    }
}

#[test]
fn categories_follow_the_contract() {
    let all = mavlink();
    let category = |code: &str, name: &str| {
        all.iter()
            .find(|f| f.code == code && f.name == name)
            .unwrap_or_else(|| panic!("no {code} for {name} in {:?}", codes(&all)))
            .category
    };
    assert_eq!(
        category("entry-renamed", "KEPT_STATE.KEPT_STATE_OLD_NAME"),
        Category::Api
    );
    assert_eq!(
        category("entry-added", "KEPT_STATE.KEPT_STATE_ADDED"),
        Category::Safe
    );
    assert_eq!(
        category("extension-added", "EXTENSION_APPENDED.c"),
        Category::Safe
    );
    assert_eq!(category("message-added", "ADDED"), Category::Safe);
    assert_eq!(
        category("entry-value-reused", "KEPT_STATE.KEPT_STATE_REUSED"),
        Category::Semantic
    );
    assert_eq!(
        category("bitmask-bit", "KEPT_FLAGS.KEPT_FLAGS_B"),
        Category::Semantic
    );
    assert_eq!(category("message-id", "ID_CHANGED"), Category::Wire);
    assert_eq!(
        category("extension-removed", "EXTENSIONS.ext_removed"),
        Category::Wire
    );
    assert!(diff::fails(&all, Category::Wire));
    let additions: Vec<Finding> = all
        .into_iter()
        .filter(|f| f.category == Category::Safe)
        .collect();
    for fail_on in [Category::Wire, Category::Semantic, Category::Api] {
        assert!(!diff::fails(&additions, fail_on));
    }
}

#[test]
fn every_code_has_a_fixture() {
    let mut all = mavlink();
    all.extend(findings(&OLD_TOML, &NEW_TOML));
    let seen: std::collections::BTreeSet<&str> = all.iter().map(|f| f.code).collect();
    // `rust-name` needs two versions of the naming rules: one generator run has one.
    let every = [
        "crc-extra",
        "message-id",
        "message-removed",
        "message-added",
        "extension-changed",
        "extension-removed",
        "extension-added",
        "field-enum",
        "units",
        "multiplier",
        "limits-narrowed",
        "limits-widened",
        "description",
        "deprecated",
        "wip",
        "enum-removed",
        "enum-added",
        "enum-kind",
        "entry-renamed",
        "entry-removed",
        "entry-value",
        "entry-value-reused",
        "entry-added",
        "bitmask-bit",
        "module-id",
        "module-removed",
        "module-added",
        "vi-changed",
        "vi-reused",
        "array-length",
        "direction",
        "default",
        "rate",
        "variable-removed",
        "variable-added",
        "instance-dictionary",
        "instance-removed",
        "instance-added",
        "area-field",
        "area-field-removed",
        "area-field-added",
        "area-bytes-reused",
        "area-removed",
        "area-added",
        "node-id",
        "node-removed",
        "node-added",
        "register-index",
        "register-area",
        "register-removed",
        "register-added",
    ];
    let missing: Vec<&str> = every
        .iter()
        .copied()
        .filter(|c| !seen.contains(c))
        .collect();
    assert!(missing.is_empty(), "no fixture makes {missing:?}");
}

#[test]
fn a_dictionary_against_itself_has_no_findings() {
    assert!(findings(&["tests/diff/new.xml"], &["tests/diff/new.xml"]).is_empty());
    assert!(findings(&OLD_TOML, &OLD_TOML).is_empty());
}
