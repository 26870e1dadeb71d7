//! The standard cortex-m-rt set-up: `memory.x` on the linker search path, `link.x` as the
//! linker script, and the `device.x` that cortex-m-rt's `device` feature includes (empty: the
//! firmware's own `__INTERRUPTS` names no handlers but the default one).

use std::path::PathBuf;
use std::{env, fs};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("write memory.x");
    fs::write(
        out.join("device.x"),
        "/* mps2-an386: every interrupt goes to DefaultHandler (src/hw.rs). */\n",
    )
    .expect("write device.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
}
