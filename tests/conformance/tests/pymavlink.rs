//! Conformance against pymavlink 2.4.50, the reference encoder: vectors for every message of
//! common.xml and all.xml (and of our own dialects) are generated with pymavlink, then the
//! conformance runner, built with bindings for that dialect, checks both directions byte-exact.
//! For the standard dialects the runner is built from our own wire-facts copies
//! (`definitions/mavlink/standard/`), and every one of them is compared fact by fact with the
//! module pymavlink ships.
//!
//! Needs a Python with pymavlink 2.4.50: `FERROLINK_PYTHON`, else `.venv/bin/python` in the
//! workspace (`tests/run-all.sh` sets it up). Without one the test says so and passes, unless
//! `FERROLINK_REQUIRE_PYMAVLINK` is set, as the full test run does whenever the install worked.

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The reference Python and its dialect folder, if available.
fn pymavlink() -> Option<(PathBuf, PathBuf)> {
    let python = std::env::var_os("FERROLINK_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join(".venv/bin/python"));
    let out = Command::new(&python)
        .args(["-c", "import pymavlink, os; print(pymavlink.__version__ if hasattr(pymavlink,'__version__') else ''); print(os.path.dirname(pymavlink.__file__))"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let dir = PathBuf::from(text.lines().nth(1)?.trim());
    Some((python, dir.join("dialects/v20")))
}

fn scratch() -> PathBuf {
    let dir = workspace().join("target/conformance");
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scripts")
        .join(name)
}

fn run(cmd: &mut Command) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{cmd:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Builds the runner for `xml` (in its own target dir, as this test runs inside cargo) and runs
/// it with `args`.
fn runner(xml: &Path, args: &[&str]) -> String {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    run(Command::new(cargo)
        .current_dir(workspace())
        .env("FERROLINK_XML", xml)
        .args([
            "run",
            "--quiet",
            "--release",
            "-p",
            "ferrolink-conformance",
            "--target-dir",
        ])
        .arg(scratch().join("target"))
        .arg("--")
        .args(args))
}

/// pymavlink's vectors for `xml`, checked by the runner built from `ours` (the same dialect).
fn check_dialect(python: &Path, xml: &Path, ours: &Path, min_messages: usize) {
    let name = xml.file_stem().unwrap().to_string_lossy().into_owned();
    let vectors = scratch().join(format!("{name}.jsonl"));
    run(Command::new(python)
        .arg(script("gen_vectors.py"))
        .arg(xml)
        .arg(&vectors));
    let summary = runner(ours, &[vectors.to_str().unwrap()]);
    let line = summary.lines().last().unwrap_or_default().to_string();
    eprintln!("{name}: {line}");
    let passed: usize = line.split(' ').next().unwrap().parse().expect("N passed");
    assert!(line.ends_with(" 0 failed"), "{name}: {line}");
    assert!(passed >= min_messages, "{name}: only {passed} vectors");
}

fn require() -> Option<(PathBuf, PathBuf)> {
    let found = pymavlink();
    if found.is_none() {
        assert!(
            std::env::var_os("FERROLINK_REQUIRE_PYMAVLINK").is_none(),
            "pymavlink is required but not found (set FERROLINK_PYTHON)"
        );
        eprintln!("pymavlink not found: conformance skipped (run tests/run-all.sh)");
    }
    found
}

#[test]
fn common_xml_every_message_both_directions() {
    let Some((python, dialects)) = require() else {
        return;
    };
    check_dialect(
        &python,
        &dialects.join("common.xml"),
        &standard("common"),
        210,
    );
}

#[test]
fn all_xml_every_message_both_directions() {
    let Some((python, dialects)) = require() else {
        return;
    };
    check_dialect(&python, &dialects.join("all.xml"), &standard("all"), 353);
}

#[test]
fn our_dialects_match_the_reference() {
    let Some((python, _)) = require() else { return };
    for d in ["usv.xml", "bench.xml"] {
        let xml = workspace().join("definitions/mavlink").join(d);
        check_dialect(&python, &xml, &xml, 9);
    }
}

/// Our wire-facts copy of a standard dialect.
fn standard(name: &str) -> PathBuf {
    workspace()
        .join("definitions/mavlink/standard")
        .join(format!("{name}.xml"))
}

/// What our dictionary reads from our copy of dialect `name`, in the form `dialect_facts.py
/// facts` gives pymavlink's module: per message its id, CRC_EXTRA, fields in XML and wire order,
/// types, array lengths, units, enums, displays and length; per enum its values' names.
fn our_facts(name: &str) -> serde_json::Value {
    use serde_json::{json, Map, Value};
    let checked = ferrolink_dictionary::load(&[standard(name)]).unwrap_or_else(|e| panic!("{e}"));
    let ir = checked.ir;
    let mut messages: Vec<_> = ir.modules.iter().flat_map(|m| &m.messages).collect();
    messages.sort_by_key(|m| m.id);
    let messages: Vec<Value> = messages
        .into_iter()
        .map(|m| {
            let by = |attr: &str| -> Map<String, Value> {
                m.fields
                    .iter()
                    .filter_map(|f| Some((f.name.wire.clone(), json!(f.attr(attr)?))))
                    .collect()
            };
            // mavgen shows a field that holds a bitmask enum with the display `bitmask`.
            let bitmask = |f: &ferrolink_dictionary::ir::Field| {
                let e = f.enum_name.as_ref()?;
                ir.enums.iter().any(|x| &x.name.wire == e && x.bitmask).then_some("bitmask")
            };
            let displays: Map<String, Value> = m
                .fields
                .iter()
                .filter_map(|f| {
                    let display = f.attr("display").or_else(|| bitmask(f))?;
                    Some((f.name.wire.clone(), json!(display)))
                })
                .collect();
            let enums: Map<String, Value> = m
                .fields
                .iter()
                .filter_map(|f| Some((f.name.wire.clone(), json!(f.enum_name.as_ref()?))))
                .collect();
            json!({
                "id": m.id,
                "name": m.name.wire,
                "crc_extra": m.crc_extra,
                "fields": m.fields.iter().map(|f| &f.name.wire).collect::<Vec<_>>(),
                "wire_order": m.wire_order.iter().map(|&i| &m.fields[i].name.wire).collect::<Vec<_>>(),
                "types": m.fields.iter().map(|f| f.ty.primitive.c_name()).collect::<Vec<_>>(),
                // pymavlink lists array lengths in wire order.
                "array_lengths": m.wire_order.iter().map(|&i| m.fields[i].ty.array.unwrap_or(0)).collect::<Vec<_>>(),
                "units": by("units"),
                "enums": enums,
                "displays": displays,
                "length": m.max_len,
            })
        })
        .collect();
    let enums: Map<String, Value> = ir
        .enums
        .iter()
        .map(|e| {
            let values: Map<String, Value> = e
                .entries
                .iter()
                .map(|entry| (entry.value.to_string(), json!(entry.name.wire)))
                .collect();
            (e.name.wire.clone(), Value::Object(values))
        })
        .collect();
    json!({"messages": messages, "enums": enums})
}

/// Every standard dialect we build in is pymavlink's on the wire: the same messages with the
/// same ids, CRC_EXTRA, fields, order, types, array lengths, units, enums and displays, and the
/// same enum values, as in the module pymavlink 2.4.50 ships. And it is every dialect pymavlink
/// ships.
#[test]
fn standard_dialects_are_pymavlinks_fact_for_fact() {
    let Some((python, dialects)) = require() else {
        return;
    };
    let names = |dir: &Path| -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .expect("dialect folder")
            .filter_map(|e| {
                let path = e.ok()?.path();
                (path.extension()? == "xml")
                    .then(|| path.file_stem()?.to_str().map(str::to_owned))?
            })
            .collect();
        names.sort();
        names
    };
    let ours = names(&workspace().join("definitions/mavlink/standard"));
    assert_eq!(ours, names(&dialects), "the dialects pymavlink ships");
    let (mut messages, mut enums) = (0, 0);
    for name in &ours {
        let theirs: serde_json::Value = serde_json::from_str(&run(Command::new(&python)
            .arg(script("dialect_facts.py"))
            .args(["facts", name])))
        .expect("facts JSON");
        let ours = our_facts(name);
        let (a, b) = (&ours["messages"], &theirs["messages"]);
        assert_eq!(
            a.as_array().map(Vec::len),
            b.as_array().map(Vec::len),
            "{name}: messages"
        );
        for (m, t) in a.as_array().unwrap().iter().zip(b.as_array().unwrap()) {
            assert_eq!(m, t, "{name}: message {}", t["name"]);
        }
        messages += b.as_array().unwrap().len();
        let (a, b) = (&ours["enums"], &theirs["enums"]);
        for (enum_name, values) in b.as_object().unwrap() {
            assert_eq!(&a[enum_name], values, "{name}: enum {enum_name}");
        }
        assert_eq!(
            a.as_object().unwrap().len(),
            b.as_object().unwrap().len(),
            "{name}: enums"
        );
        enums += b.as_object().unwrap().len();
    }
    eprintln!(
        "{} dialects identical to pymavlink's: {messages} messages, {enums} enums (counted per dialect)",
        ours.len()
    );
}

/// A raw capture with garbage between frames decodes to exactly what pymavlink decodes.
#[test]
fn stream_capture_matches_pymavlink() {
    let Some((python, dialects)) = require() else {
        return;
    };
    let xml = dialects.join("common.xml");
    let (bin, expected) = (scratch().join("stream.bin"), scratch().join("stream.jsonl"));
    run(Command::new(&python)
        .arg(script("gen_stream.py"))
        .arg(&xml)
        .arg(&bin)
        .arg(&expected));
    let ours = runner(&xml, &["--stream", bin.to_str().unwrap()]);
    let parse = |text: &str| -> Vec<serde_json::Value> {
        text.lines()
            .filter(|l| !l.is_empty())
            .map(|l| serde_json::from_str(l).expect("json"))
            .collect()
    };
    let (ours, theirs) = (
        parse(&ours),
        parse(&std::fs::read_to_string(expected).unwrap()),
    );
    assert_eq!(ours.len(), theirs.len());
    for (a, b) in ours.iter().zip(&theirs) {
        assert_eq!(a, b);
    }
}
