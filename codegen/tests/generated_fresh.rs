//! `generated/` must be exactly what `ferrolink generate` makes from `definitions/`. In CI a
//! stale file fails the test; locally the test rewrites it and asks for a commit.

use std::path::{Path, PathBuf};

use ferrolink_codegen::{Config, SerdeMode};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn generated_bindings_are_fresh() {
    let root = workspace();
    std::env::set_current_dir(&root).expect("workspace dir");
    let mut inputs: Vec<PathBuf> = std::fs::read_dir("definitions/mavlink")
        .expect("definitions")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    inputs.sort();
    let mut config = Config::new();
    for i in &inputs {
        config.input(i);
    }
    let generated = config
        .serde(SerdeMode::Feature("serde".into()))
        .generate_modules()
        .unwrap_or_else(|e| panic!("{e}"));
    let out = Path::new("generated/src/mavlink");
    let stale = ferrolink_codegen::write::stale(out, &generated.files);
    if stale.is_empty() {
        return;
    }
    if std::env::var_os("CI").is_none() {
        ferrolink_codegen::write::write_all(out, &generated.files).expect("rewrite");
        panic!(
            "generated/ was stale ({}); it has been regenerated, please commit it",
            stale.join(", ")
        );
    }
    panic!(
        "generated/ is stale ({}); run: cargo run -p ferrolink-codegen --features cli -- generate definitions/mavlink/*.xml --out generated/src/mavlink --serde-feature serde",
        stale.join(", ")
    );
}
