//! The MAVLink microservices' state machines, each side alone and both sides through a lossy
//! link.

mod command;
mod ftp;
mod lossy;
mod mission;
mod param;
#[path = "../scripts/services.rs"]
mod scripts;

use proptest::prelude::*;

proptest! {
    /// Arbitrary scripts: the invariants the `mavlink_services` fuzz target checks.
    #[test]
    fn scripts_keep_the_invariants(script in prop::collection::vec(any::<u8>(), 0..2000)) {
        scripts::check_servers(&script);
    }
}
