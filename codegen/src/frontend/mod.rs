//! Frontends: read dictionary files into IR parts, reporting every problem with its position.

pub mod mavlink;
pub mod xml;
