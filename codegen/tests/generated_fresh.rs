//! `generated/` must be exactly what `ferrolink generate` makes from `definitions/`. In CI a
//! stale file fails the test; locally the test rewrites it and asks for a commit.

use std::path::{Path, PathBuf};

use ferrolink_codegen::{Config, SerdeMode};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The files with extension `ext` in `dir`, sorted.
fn inputs(dir: &str, ext: &str) -> Vec<PathBuf> {
    let mut inputs: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("definitions")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    inputs.sort();
    inputs
}

/// Checks (and outside CI rewrites) one output directory; returns its stale files.
fn check(config: &mut Config, inputs: &[PathBuf], out: &str) -> Vec<String> {
    for i in inputs {
        config.input(i);
    }
    let generated = config.generate_modules().unwrap_or_else(|e| panic!("{e}"));
    let out = Path::new(out);
    let stale: Vec<String> = ferrolink_dictionary::write::stale(out, &generated.files)
        .into_iter()
        .map(|name| format!("{}/{name}", out.display()))
        .collect();
    if !stale.is_empty() && std::env::var_os("CI").is_none() {
        ferrolink_dictionary::write::write_all(out, &generated.files).expect("rewrite");
    }
    stale
}

#[test]
fn generated_bindings_are_fresh() {
    std::env::set_current_dir(workspace()).expect("workspace dir");
    let mut stale = check(
        Config::new().serde(SerdeMode::Feature("serde".into())),
        &inputs("definitions/mavlink", "xml"),
        "generated/src/mavlink",
    );
    stale.extend(check(
        &mut Config::new(),
        &inputs("definitions/tosnet", "toml"),
        "generated/src/tosnet",
    ));
    stale.extend(check(
        &mut Config::new(),
        &inputs("definitions/modrob", "toml"),
        "generated/src/modrob",
    ));
    stale.extend(check(
        Config::new()
            .serde(SerdeMode::Feature("serde".into()))
            .module_features(true),
        &inputs("definitions/mavlink/standard", "xml"),
        "dialects/src/generated",
    ));
    // The microservices' messages live in the runtime, which names itself `ferrolink_runtime`.
    stale.extend(check(
        &mut Config::new(),
        &inputs("definitions/runtime", "xml"),
        "runtime/src/mavlink/service/generated",
    ));
    if stale.is_empty() {
        return;
    }
    if std::env::var_os("CI").is_none() {
        panic!(
            "generated code was stale ({}); it has been regenerated, please commit it",
            stale.join(", ")
        );
    }
    panic!(
        "generated code is stale ({}); run:\n  cargo run -p ferrolink-cli -- generate definitions/mavlink/*.xml --out generated/src/mavlink --serde-feature serde\n  cargo run -p ferrolink-cli -- generate definitions/mavlink/standard/*.xml --out dialects/src/generated --serde-feature serde --module-features\n  cargo run -p ferrolink-cli -- generate definitions/tosnet/*.toml --out generated/src/tosnet\n  cargo run -p ferrolink-cli -- generate definitions/modrob/*.toml --out generated/src/modrob\n  cargo run -p ferrolink-cli -- generate definitions/runtime/*.xml --out runtime/src/mavlink/service/generated",
        stale.join(", ")
    );
}
