//! The format-neutral intermediate representation every frontend lowers into and every backend
//! reads.
//!
//! Names keep both spellings: `wire` is the dictionary's own (what goes into CRC_EXTRA, JSON and
//! docs) and `rust` is the identifier the backend emits. With the `serde` feature the IR
//! serialises, so that `ferrolink ir` can dump it, the dictionary tools can render it and tests
//! can snapshot it. Source spans are kept for diagnostics but not serialised.

mod mavlink;
mod modrob;
mod tosnet;

pub use mavlink::*;
pub use modrob::*;
pub use tosnet::*;

/// A name in both spellings.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Name {
    /// As written in the dictionary, e.g. `HEARTBEAT`, `type`.
    pub wire: String,
    /// As emitted in Rust, e.g. `Heartbeat`, `r#type`.
    pub rust: String,
}

/// Everything one generator run reads: one module per MAVLink dictionary file, one ring per
/// TosNet register map.
#[derive(Debug, Clone, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Ir {
    /// MAVLink modules in dependency order: a module comes after everything it includes.
    pub modules: Vec<Module>,
    /// All enums of the run, merged by wire name across files.
    pub enums: Vec<Enum>,
    /// TosNet register maps, one per file.
    pub rings: Vec<Ring>,
    /// ModRob-1 module dictionaries, one per file: those given and those a robot names.
    pub modrob: Vec<ModrobModule>,
    /// ModRob-1 robots (composite modules), one per file.
    pub robots: Vec<Robot>,
}
