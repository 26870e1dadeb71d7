//! `ferrolink docs`: the site for our definitions and pymavlink's common.xml, opened in
//! headless Chromium from `file://` (`tests/docs/browser.py`): search finds a message and leads
//! to it, every link resolves, nothing is fetched from the network, the pages read without
//! JavaScript. Screenshots land in `target/docs-screenshots/`.
//!
//! Needs Chromium; `tests/run-all.sh` installs it and sets `FERROLINK_REQUIRE_CHROMIUM`, under
//! which a check skipped for a missing browser fails.

mod common;

use std::ffi::OsStr;
use std::path::PathBuf;

#[test]
fn the_site_works_in_a_real_browser() {
    let shots = common::workspace().join("target/docs-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let shot = shots.join("dialect.png");
    let mut args: Vec<&OsStr> = vec![
        "--ferrolink".as_ref(),
        common::ferrolink().as_ref(),
        "--screenshot".as_ref(),
        shot.as_os_str(),
    ];
    let pymavlink = common::pymavlink();
    if let Some((_, dialects)) = &pymavlink {
        args.extend(["--dialect-dir".as_ref(), dialects.as_os_str()]);
    }
    let python = pymavlink
        .as_ref()
        .map_or_else(|| PathBuf::from("python3"), |(p, _)| p.clone());
    let out = common::run_checks(&python, "docs/browser.py", &args);
    common::require_no_skip(&out, "FERROLINK_REQUIRE_CHROMIUM", "chromium");
    eprintln!("screenshots in {}", shots.display());
}
