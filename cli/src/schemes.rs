//! The URI schemes this build takes besides its protocols' own: `zenoh://`, registered by the
//! Zenoh crate, or an error that says how to get it.

use ferrolink_io::uri::Extension;

/// What an extension scheme's URI parses to.
#[cfg(feature = "zenoh")]
pub type Extra = ferrolink_zenoh::ZenohUri;
/// What an extension scheme's URI parses to: nothing, in a build without Zenoh.
#[cfg(not(feature = "zenoh"))]
pub type Extra = std::convert::Infallible;

/// The extension schemes, for [`Grammar::parse_with`](ferrolink_io::uri::Grammar::parse_with).
#[cfg(feature = "zenoh")]
pub const EXTENSIONS: &[Extension<Extra>] = &[ferrolink_zenoh::SCHEME];
/// The extension schemes: `zenoh://` only says it was left out.
#[cfg(not(feature = "zenoh"))]
pub const EXTENSIONS: &[Extension<Extra>] = &[Extension {
    scheme: "zenoh",
    usage: "zenoh://... (in builds with Zenoh)",
    parse: |uri| Err(without_zenoh(uri)),
}];

/// The error for a `zenoh://` URI in a build without Zenoh.
#[cfg(not(feature = "zenoh"))]
pub fn without_zenoh(uri: &str) -> ferrolink_io::uri::UriError {
    ferrolink_io::uri::UriError::new(uri, 0, "this ferrolink was built without Zenoh")
        .with_hint("build it with the default features (cargo build --release -p ferrolink-cli)")
}
