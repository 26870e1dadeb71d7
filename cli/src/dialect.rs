//! The MAVLink dictionaries a command knows: the standard dialects built into the binary
//! (`--dialect ardupilotmega`), files (`--dialect my.xml`), or, without `--dialect`, the
//! command's default built-in dialect ([`ferrolink_traffic::dialect`] loads them), and our own
//! definitions and the services' messages, built in here.
//!
//! Nothing here uses generated bindings, so the CLI keeps working (and can regenerate
//! `generated/`) even when the checked-in bindings do not compile.

pub use ferrolink_traffic::dialect::{names, DEFAULT};
pub use ferrolink_traffic::Dialects;

/// What the router checks and routes with when no `--dialect` is given: every standard
/// dialect, so that the services' messages are routed by their targets, not broadcast.
pub const ROUTER_DEFAULT: &str = "all";

/// Our own MAVLink definitions (`definitions/mavlink/`), as built into the binary.
const OWN: &[(&str, &str)] = &[
    (
        "minimal.xml",
        include_str!("../../definitions/mavlink/minimal.xml"),
    ),
    ("usv.xml", include_str!("../../definitions/mavlink/usv.xml")),
    (
        "bench.xml",
        include_str!("../../definitions/mavlink/bench.xml"),
    ),
];

/// The microservices' messages and enums, as the runtime's state machines know them.
const SERVICES: &[(&str, &str)] = &[(
    "microservices.xml",
    include_str!("../../definitions/runtime/microservices.xml"),
)];

/// Loads dialects as [`Dialects::load`] does, with its warnings printed to stderr.
pub fn load(given: &[std::path::PathBuf], default: &str) -> Result<Dialects, String> {
    // The error names the argument: "--dialect NAME: ...".
    let loaded = Dialects::load(given, default).map_err(|e| format!("--{e}"))?;
    for w in &loaded.warnings {
        eprintln!("{w}\n");
    }
    Ok(loaded)
}

/// Our own definitions.
pub fn own() -> Result<Dialects, String> {
    Dialects::from_texts("ferrolink", OWN)
}

/// The microservices' messages and enums (common.xml's), as the runtime's state machines know
/// them: the names of MAV_CMD and MAV_RESULT values.
pub fn services() -> Result<Dialects, String> {
    Dialects::from_texts("ferrolink", SERVICES)
}
