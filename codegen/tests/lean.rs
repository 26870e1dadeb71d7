//! The generator as a `build.rs` uses it, without default features: no formatting and no TOML.
//! Its output, formatted here as the `format` feature would, must be exactly the snapshots, and
//! a TOML input must be reported, not ignored. Run with
//! `cargo test -p ferrolink-codegen --no-default-features --test lean`.
#![cfg(not(any(feature = "format", feature = "toml")))]

use std::path::{Path, PathBuf};

use ferrolink_codegen::{Config, SerdeMode};

fn crate_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The good fixtures, which are the dictionary crate's.
fn fixtures() -> PathBuf {
    crate_dir().join("../dictionary/tests/fixtures/ok")
}

/// The files of a `generated_code_and_ir` snapshot, as (name, text).
fn snapshot_files(fixture: &str) -> Vec<(String, String)> {
    let path = crate_dir()
        .join("tests/snapshots")
        .join(format!("snapshots__rust@{fixture}.snap"));
    let snap = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    // Front matter between the first two `---` lines, then the text.
    let body = snap.splitn(3, "---\n").nth(2).expect("snapshot body");
    let mut files = Vec::new();
    for chunk in body.split("==> ").skip(1) {
        let (name, text) = chunk.split_once(" <==\n").expect("file header");
        files.push((name.to_owned(), text.to_owned()));
    }
    files
}

/// `text` (after its first line, the header) formatted as the `format` feature formats.
fn formatted(text: &str) -> String {
    let (header, code) = text.split_once('\n').expect("header line");
    let file = syn::parse_file(code).unwrap_or_else(|e| panic!("does not parse: {e}\n{code}"));
    format!("{header}\n{}", prettyplease::unparse(&file))
}

#[test]
fn formatting_the_output_gives_the_snapshots() {
    let fixtures: Vec<PathBuf> = std::fs::read_dir(fixtures())
        .expect("fixtures")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    assert!(fixtures.len() >= 8, "{fixtures:?}");
    for fixture in fixtures {
        let name = fixture.file_name().unwrap().to_string_lossy().into_owned();
        let generated = Config::new()
            .input(&fixture)
            .serde(SerdeMode::Feature("serde".into()))
            .generate_modules()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let expected = snapshot_files(&name);
        assert_eq!(generated.files.len(), expected.len(), "{name}");
        for (file, (want_name, want_text)) in generated.files.iter().zip(&expected) {
            assert_eq!(&file.name, want_name, "{name}");
            // The snapshot shows each file followed by a blank line, but trims the last one.
            assert_eq!(
                formatted(&file.content).trim_end(),
                want_text.trim_end(),
                "{name}: {want_name}"
            );
            // A line per item, not one line for the whole file.
            let items = want_text.matches("\npub ").count();
            assert!(file.content.lines().count() > items, "{name}: {want_name}");
        }
    }
}

#[test]
fn toml_input_is_an_error_without_the_toml_feature() {
    let ring = fixtures().join("tosnet_named.toml");
    let failed = Config::new()
        .input(ring)
        .generate()
        .expect_err("a TOML input must fail");
    let text = failed.to_string();
    assert!(text.contains("[E0004]"), "{text}");
    assert!(text.contains("`toml` feature"), "{text}");
}
