//! Generates Ferrolink's bindings for MAVLink's full common.xml, so that the benchmarks decode
//! into the same dialect on both sides: pymavlink's copy (`FERROLINK_COMMON_XML`, else the one
//! in the workspace's `.venv`, which `tests/run-all.sh` installs), else the copy inside the
//! `mavlink` crate this package compares against. The file used is recorded for the report.

use std::path::{Path, PathBuf};

fn main() {
    println!("cargo:rerun-if-env-changed=FERROLINK_COMMON_XML");
    let xml = common_xml().unwrap_or_else(|| {
        panic!("no common.xml: set FERROLINK_COMMON_XML, or run tests/run-all.sh to install pymavlink into .venv")
    });
    ferrolink_codegen::Config::new()
        .input(&xml)
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::write(out.join("common_facts.rs"), facts(&xml)).expect("write common_facts.rs");
    println!("cargo::rustc-check-cfg=cfg(c_mavlink)");
    match c_library(&xml, &out) {
        Ok(()) => println!("cargo::rustc-cfg=c_mavlink"),
        Err(why) => {
            println!("cargo::warning=the MAVLink C library is left out of the benchmarks: {why}")
        }
    }
}

/// Generates the MAVLink C library for `xml` with pymavlink's mavgen (from the Python that
/// `FERROLINK_PYTHON` names, else the workspace's `.venv`) and builds `c/mavlink_c.c` on it.
fn c_library(xml: &Path, out: &Path) -> Result<(), String> {
    println!("cargo:rerun-if-changed=c/mavlink_c.c");
    println!("cargo:rerun-if-env-changed=FERROLINK_PYTHON");
    let workspace = workspace();
    let python = std::env::var_os("FERROLINK_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join(".venv/bin/python"));
    let headers = out.join("mavlink-c");
    let status = std::process::Command::new(&python)
        .args([
            "-m",
            "pymavlink.tools.mavgen",
            "--lang=C",
            "--wire-protocol=2.0",
            "--output",
        ])
        .arg(&headers)
        .arg(xml)
        .stdout(std::process::Stdio::null())
        .status()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !status.success() {
        return Err(format!(
            "mavgen failed ({status}); is pymavlink installed for {}?",
            python.display()
        ));
    }
    cc::Build::new()
        .file("c/mavlink_c.c")
        .include(&headers)
        .warnings(false)
        .try_compile("mavlink_c")
        .map_err(|e| e.to_string())
}

/// The file's path, and the fields whose values both sides must agree on: enum fields get a
/// value their enum defines (the `mavlink` crate rejects others; bitmasks take any bits), and
/// `uint8_t_mavlink_version` fields the defining file's version (which we always send). The
/// benchmarks fill the rest of every payload with random bytes.
fn facts(xml: &Path) -> String {
    let ir = ferrolink_dictionary::load(&[xml.to_path_buf()])
        .unwrap_or_else(|e| panic!("{e}"))
        .ir;
    let mut rows = String::new();
    for module in &ir.modules {
        for m in &module.messages {
            for f in &m.fields {
                let (size, count) = (f.ty.primitive.size(), f.ty.array.unwrap_or(1));
                let value = if f.ty.mavlink_version {
                    u64::from(module.version.unwrap_or(0))
                } else {
                    let e = f
                        .enum_name
                        .as_ref()
                        .and_then(|n| ir.enums.iter().find(|e| &e.name.wire == n));
                    match e.filter(|e| !e.bitmask) {
                        Some(e) => e.entries.first().map_or(0, |x| x.value),
                        None => continue,
                    }
                };
                rows += &format!("    ({}, {}, {size}, {count}, {value}),\n", m.id, f.offset);
            }
        }
    }
    format!(
        "/// The common.xml our side was generated from.\npub const COMMON_XML: &str = {:?};\n\
         /// Fields with agreed values: message id, payload offset, element size, elements, value.\n\
         pub const FIXED_FIELDS: &[(u32, usize, usize, u8, u64)] = &[\n{rows}];\n",
        xml.display().to_string()
    )
}

fn common_xml() -> Option<PathBuf> {
    if let Some(path) = std::env::var_os("FERROLINK_COMMON_XML") {
        return Some(PathBuf::from(path));
    }
    let workspace = workspace();
    let venv_lib = workspace.join(".venv/lib");
    println!("cargo:rerun-if-changed={}", venv_lib.display());
    let pymavlink = std::fs::read_dir(&venv_lib).ok().and_then(|dirs| {
        dirs.flatten()
            .map(|d| {
                d.path()
                    .join("site-packages/pymavlink/dialects/v20/common.xml")
            })
            .find(|p| p.exists())
    });
    pymavlink.or_else(mavlink_crate_common)
}

/// The workspace this package is built in, read when the build script runs: `env!` would give
/// the directory the build script was compiled in, which a target directory shared by two
/// checkouts keeps.
fn workspace() -> PathBuf {
    let manifest = std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    PathBuf::from(manifest).join("..")
}

/// The copy inside the `mavlink` crate 0.21, in cargo's registry.
fn mavlink_crate_common() -> Option<PathBuf> {
    let home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))?;
    let src = home.join("registry/src");
    std::fs::read_dir(src).ok()?.flatten().find_map(|index| {
        std::fs::read_dir(index.path())
            .ok()?
            .flatten()
            .find_map(|krate| {
                let name = krate.file_name().to_string_lossy().into_owned();
                let path = krate
                    .path()
                    .join("mavlink/message_definitions/v1.0/common.xml");
                (name.starts_with("mavlink-0.21.") && path.exists()).then_some(path)
            })
    })
}
