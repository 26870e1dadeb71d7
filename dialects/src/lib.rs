//! The standard MAVLink dialects, built in: every dialect pymavlink 2.4.50 ships, with the files
//! they include, as generated bindings behind a cargo feature per dialect (as the `mavlink`
//! crate has them), and as text for decoding at run time ([`definitions`]).
//!
//! ```toml
//! [dependencies]
//! ferrolink-dialects = { git = "https://github.com/ferrolink/ferrolink", default-features = false, features = ["common"] }
//! ```
//!
//! ```
//! # #[cfg(feature = "ardupilotmega")] {
//! use ferrolink_dialects::ardupilotmega::{Message, SensorOffsets};
//! use ferrolink_dialects::common::Heartbeat;
//! use ferrolink_runtime::mavlink::Dialect;
//!
//! assert_eq!(SensorOffsets::ID, 150);
//! assert_eq!(Heartbeat::CRC_EXTRA, 50);
//! // The dialect's table holds what it includes: common's HEARTBEAT, ArduPilot's own messages.
//! assert!(Message::META.iter().any(|m| m.id == 0));
//! # }
//! ```
//!
//! The features are the modules' names: `all`, `ardupilotmega`, `asluav`, `avssuas`, `common`,
//! `cs_air_link`, `cubepilot`, `development`, `icarous`, `loweheiser`, `matrixpilot`,
//! `minimal`, `paparazzi`, `python_array_test`, `standard`, `storm32`, `test`, `ualberta`,
//! `u_avionix`; `ardupilotmega` is the default. Each enables what its file includes, and types
//! are shared: `ardupilotmega::Heartbeat` is `common::Heartbeat`, compiled once. An enum that
//! several dialects extend (`MAV_CMD`) is one type holding every dialect's entries, as mavgen
//! merges them for `all.xml`; values a dialect does not know still decode, as `Unknown(raw)`.
//! `serde` derives serde's traits in pymavlink's `to_dict()` form.
//!
//! The definitions are our own files of wire facts (names, ids, types and order, extensions,
//! enum values, units), without the descriptions, in `definitions/mavlink/standard/`. A test
//! proves each identical on the wire to the module pymavlink ships: every message's CRC_EXTRA,
//! fields in XML and wire order, types, array lengths, units and enums, and every enum's
//! values.
#![no_std]

pub mod definitions;

// Formatted by the generator (prettyplease); rustfmt would make it stale.
#[rustfmt::skip]
mod generated;
#[allow(unused_imports)] // with no dialect enabled there is nothing to re-export
pub use generated::*;
