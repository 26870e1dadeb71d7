//! Backends: IR to source text, one module per format.

#[cfg(feature = "tools")]
pub mod docs;
#[cfg(feature = "tools")]
mod jinja;
#[cfg(feature = "toml")]
pub mod modrob;
pub mod rust;
#[cfg(feature = "toml")]
pub mod tosnet;
#[cfg(feature = "tools")]
pub mod wireshark;
