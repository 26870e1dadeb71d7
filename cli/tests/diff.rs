//! `ferrolink diff`'s command-line contract: exit statuses, `--fail-on`, the JSON form and
//! `--against GIT_REF`.

mod common;

use std::path::Path;
use std::process::{Command, Output};

fn diff(args: &[&str], cwd: &Path) -> Output {
    Command::new(common::ferrolink())
        .arg("diff")
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("ferrolink runs")
}

fn fixture(name: &str) -> String {
    common::workspace()
        .join("tools/tests/diff")
        .join(name)
        .display()
        .to_string()
}

fn status(out: &Output) -> i32 {
    out.status.code().expect("an exit status")
}

#[test]
fn exit_status_follows_fail_on() {
    let here = common::workspace();
    let (old, new) = (fixture("old.xml"), fixture("new.xml"));
    assert_eq!(status(&diff(&[&old, &new], &here)), 1);
    assert_eq!(status(&diff(&[&old, &new, "--fail-on", "api"], &here)), 1);
    assert_eq!(status(&diff(&[&new, &new], &here)), 0);

    // Only additions: safe under every --fail-on.
    let dir = tempfile::tempdir().unwrap();
    let added = std::fs::read_to_string(&old).unwrap().replace(
        "  </messages>",
        "    <message id=\"99\" name=\"BRAND_NEW\"><field type=\"uint8_t\" name=\"a\">A.</field></message>\n  </messages>",
    );
    let added_path = dir.path().join("added.xml");
    std::fs::write(&added_path, added).unwrap();
    let added_path = added_path.display().to_string();
    for fail_on in ["wire", "semantic", "api"] {
        let out = diff(&[&old, &added_path, "--fail-on", fail_on], &here);
        assert_eq!(
            status(&out),
            0,
            "{fail_on}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
}

#[test]
fn unreadable_or_invalid_input_exits_2() {
    let here = common::workspace();
    let dir = tempfile::tempdir().unwrap();
    let broken = dir.path().join("broken.xml");
    std::fs::write(&broken, "<mavlink><messages><message id=\"1\"").unwrap();
    let missing = dir.path().join("missing.xml").display().to_string();
    let out = diff(&[&fixture("old.xml"), &missing], &here);
    assert_eq!(status(&out), 2);
    let out = diff(&[&fixture("old.xml"), &broken.display().to_string()], &here);
    assert_eq!(status(&out), 2);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("broken.xml:1:"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn json_lines_have_the_seven_keys() {
    let out = diff(
        &[&fixture("old.xml"), &fixture("new.xml"), "--format", "json"],
        &common::workspace(),
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.lines().count() > 20);
    for line in text.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        for key in ["category", "code", "kind", "name", "old", "new", "reason"] {
            assert!(v.get(key).is_some(), "{key} in {line}");
        }
    }
    let renamed = text
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .find(|v| v["code"] == "entry-renamed")
        .unwrap();
    assert_eq!(renamed["name"], "KEPT_STATE.KEPT_STATE_OLD_NAME");
    assert_eq!(renamed["category"], "api");
    assert_eq!(renamed["kind"], "entry");
}

#[test]
fn against_a_git_revision() {
    let repo = tempfile::tempdir().unwrap();
    let git = |args: &[&str]| {
        let out = Command::new("git")
            .args(args)
            .current_dir(repo.path())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "git {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    git(&["init", "-q"]);
    std::fs::create_dir(repo.path().join("defs")).unwrap();
    std::fs::copy(fixture("old.xml"), repo.path().join("defs/dialect.xml")).unwrap();
    git(&["add", "."]);
    git(&[
        "-c",
        "user.name=t",
        "-c",
        "user.email=t@example.com",
        "commit",
        "-qm",
        "old",
    ]);
    std::fs::copy(fixture("new.xml"), repo.path().join("defs/dialect.xml")).unwrap();

    let out = diff(
        &[
            "--against",
            "HEAD",
            "defs/dialect.xml",
            "--format",
            "github",
        ],
        repo.path(),
    );
    assert_eq!(status(&out), 1);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("::error file=defs/dialect.xml,line="),
        "{text}"
    );
    assert!(text.contains("(old: HEAD:defs/dialect.xml:"), "{text}");
    assert!(
        text.contains("title=wire crc-extra::message FIELD_RENAMED"),
        "{text}"
    );

    // A directory works too, and an unknown revision is invalid input.
    let out = diff(&["--against", "HEAD", "defs"], repo.path());
    assert_eq!(status(&out), 1);
    let out = diff(&["--against", "no-such-ref", "defs"], repo.path());
    assert_eq!(status(&out), 2);
}
