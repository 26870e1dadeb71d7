//! Snapshots of the lowered IR (as `ferrolink ir` prints it), one per good fixture.
#![cfg(feature = "serde")]

#[test]
fn ir() {
    std::env::set_current_dir(env!("CARGO_MANIFEST_DIR")).expect("crate dir");
    insta::glob!("fixtures/ok/*.{xml,toml}", |path| {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let path = path.strip_prefix(root).unwrap_or(path).to_path_buf();
        let ir = ferrolink_dictionary::load(&[path]).expect("loads").ir;
        insta::assert_json_snapshot!("ir", ir);
    });
}
