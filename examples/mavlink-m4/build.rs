//! The standard cortex-m-rt set-up (`memory.x` on the linker search path, `link.x` as the
//! linker script) and the bindings for `definitions/mavlink/bench.xml`.

use std::path::PathBuf;
use std::{env, fs};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");

    ferrolink_codegen::Config::new()
        .input("../../definitions/mavlink/bench.xml")
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
}
