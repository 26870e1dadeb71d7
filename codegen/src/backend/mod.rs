//! Backends: IR to source text, one module per format.

pub mod modrob;
pub mod rust;
pub mod tosnet;
