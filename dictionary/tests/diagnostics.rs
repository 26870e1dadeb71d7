//! Snapshots of the rendered diagnostics, one bad fixture per code, and the promise that one run
//! reports every problem.

use std::path::{Path, PathBuf};

use ferrolink_dictionary::diag::Code;
use ferrolink_dictionary::Carrier;

fn rel(path: &Path) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    path.strip_prefix(root).unwrap_or(path).to_path_buf()
}

/// Runs with the crate root as working directory so that paths in output are stable.
fn in_crate_dir() {
    std::env::set_current_dir(env!("CARGO_MANIFEST_DIR")).expect("crate dir");
}

/// Fixtures named `*_ndlcom_*` are also checked against the NDLCom carrier.
fn diagnostics_for(path: &Path) -> String {
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let carriers: &[Carrier] = if name.contains("_ndlcom_") {
        &[Carrier::Ndlcom]
    } else {
        &[]
    };
    match ferrolink_dictionary::load_for(&[path.to_path_buf()], carriers) {
        Ok(checked) => checked.warnings.iter().map(|d| format!("{d}\n")).collect(),
        Err(failed) => failed.to_string(),
    }
}

#[test]
fn diagnostics() {
    in_crate_dir();
    insta::glob!("fixtures/bad/*.{xml,toml}", |path| {
        insta::assert_snapshot!(diagnostics_for(&rel(path)));
    });
}

#[test]
fn missing_input_is_reported_not_panicked() {
    in_crate_dir();
    insta::assert_snapshot!(diagnostics_for(Path::new(
        "tests/fixtures/bad/no_such_file.xml"
    )));
}

/// Every code but E0001 (a missing input, tested above) and E0004 (a TOML input without the
/// `toml` feature, in `tests/lean.rs`) has a bad fixture named after it, and that fixture really
/// produces it.
#[test]
fn every_code_has_a_fixture() {
    in_crate_dir();
    for code in Code::ALL {
        if matches!(code, Code::Io | Code::TomlNotBuilt) {
            continue;
        }
        let prefix = code.as_str();
        let fixture = std::fs::read_dir("tests/fixtures/bad")
            .expect("fixtures")
            .filter_map(Result::ok)
            .map(|e| e.path())
            .find(|p| {
                p.file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with(prefix))
            })
            .unwrap_or_else(|| panic!("no fixture for {prefix}"));
        let out = diagnostics_for(&fixture);
        assert!(
            out.contains(&format!("[{prefix}]")),
            "{} does not produce {prefix}:\n{out}",
            fixture.display()
        );
    }
}

/// One run reports every problem of a file, not just the first.
#[test]
fn all_errors_in_one_run_toml() {
    in_crate_dir();
    let out = diagnostics_for(Path::new("tests/fixtures/bad/many_errors.toml"));
    for code in [
        "W0103", "E0105", "E0401", "E0402", "E0403", "E0405", "E0407", "E0408", "E0410", "E0412",
    ] {
        assert!(
            out.contains(&format!("[{code}]")),
            "missing {code} in:\n{out}"
        );
    }
}

/// One run reports every problem of a file, not just the first.
#[test]
fn all_errors_in_one_run() {
    in_crate_dir();
    let out = diagnostics_for(Path::new("tests/fixtures/bad/many_errors.xml"));
    for code in [
        "E0201", "E0305", "E0306", "E0105", "E0301", "E0303", "E0308",
    ] {
        assert!(
            out.contains(&format!("[{code}]")),
            "missing {code} in:\n{out}"
        );
    }
}

/// A field with a bad type hides none of its message's other problems: its duplicate name, its
/// missing enum, the message's duplicate id and its other bad fields are reported with it.
#[test]
fn a_bad_field_type_hides_nothing_else() {
    in_crate_dir();
    let out = diagnostics_for(Path::new("tests/fixtures/bad/many_errors_one_message.xml"));
    for code in ["E0105", "E0303", "E0306", "E0301", "E0106"] {
        assert!(
            out.contains(&format!("[{code}]")),
            "missing {code} in:\n{out}"
        );
    }
}
