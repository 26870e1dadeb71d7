//! Snapshots of the generated Rust, one per good fixture. The fixtures are the dictionary
//! crate's (`dictionary/tests/fixtures/ok/`, where their IR snapshots are too); paths in the
//! output are relative to that crate, as they are there.

use std::path::{Path, PathBuf};

use ferrolink_codegen::{Config, SerdeMode};

/// The dictionary crate, whose fixtures these tests read.
fn dictionary_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../dictionary")
        .canonicalize()
        .expect("the dictionary crate")
}

fn rel(path: &Path) -> PathBuf {
    path.strip_prefix(dictionary_dir())
        .unwrap_or(path)
        .to_path_buf()
}

/// Runs with the dictionary crate as working directory so that paths in output are stable.
fn in_fixture_dir() {
    std::env::set_current_dir(dictionary_dir()).expect("dictionary crate dir");
}

#[test]
fn generated_code() {
    in_fixture_dir();
    insta::glob!(
        "../../dictionary/tests/fixtures/ok",
        "*.{xml,toml}",
        |path| {
            let path = rel(path);
            let generated = Config::new()
                .input(&path)
                .serde(SerdeMode::Feature("serde".into()))
                .generate_modules()
                .unwrap_or_else(|e| panic!("{e}"));
            assert!(generated.warnings.is_empty(), "{:?}", generated.warnings);
            let mut text = String::new();
            for f in &generated.files {
                text.push_str(&format!("==> {} <==\n{}\n", f.name, f.content));
            }
            insta::assert_snapshot!("rust", text);
        }
    );
}

/// MAVLink dialects and TosNet register maps in one run: one module each.
#[test]
fn mixed_inputs() {
    in_fixture_dir();
    let generated = Config::new()
        .input("tests/fixtures/ok/arrays.xml")
        .input("tests/fixtures/ok/tosnet_named.toml")
        .generate_modules()
        .unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = generated.files.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["mod.rs", "arrays.rs", "tosnet_named.rs"]);
    assert_eq!(generated.read.len(), 2);
    let single = Config::new()
        .input("tests/fixtures/ok/tosnet_named.toml")
        .generate()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(single.files[0].content.contains("pub mod tosnet_named {"));
}
