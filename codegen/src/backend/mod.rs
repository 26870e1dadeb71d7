//! Backends: IR to source text.

pub mod rust;
