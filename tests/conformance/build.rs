//! Generates bindings for the dialect named by `FERROLINK_XML` (default: our USV dialect).

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=FERROLINK_XML");
    let xml = std::env::var_os("FERROLINK_XML")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../../definitions/mavlink/usv.xml"));
    ferrolink_codegen::Config::new()
        .input(&xml)
        .serde(ferrolink_codegen::SerdeMode::Always)
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let stem = xml
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let root = ferrolink_dictionary::ident::value_name(&stem);
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::write(
        out.join("root.rs"),
        format!(
            "pub use crate::dialects::{root} as root;\npub const DIALECT_FILE: &str = {:?};\n",
            xml.display().to_string()
        ),
    )
    .expect("write root.rs");
}
