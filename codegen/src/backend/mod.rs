//! Backends: IR to source text, one module per format.

#[cfg(feature = "tools")]
pub mod docs;
#[cfg(feature = "tools")]
mod jinja;
pub mod modrob;
pub mod rust;
pub mod tosnet;
#[cfg(feature = "tools")]
pub mod wireshark;
