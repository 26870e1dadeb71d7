//! `ferrolink mavlink dump` against pymavlink 2.4.50 on the real captures in
//! `../shared/captures/`: every message pymavlink decodes must come out of ours, in the same
//! order, with the same sender, sequence number and values. Frames we recover that pymavlink
//! loses are counted, not failures. Ours decodes with its built-in default dialect
//! (ardupilotmega), and gives exactly the same output with pymavlink's own
//! `ardupilotmega.xml` given as `--dialect FILE`.
//!
//! Needs the captures and a Python with pymavlink (`FERROLINK_PYTHON`, else `.venv/bin/python`;
//! `tests/run-all.sh` installs it). Without the captures the test says so in one line and passes;
//! without pymavlink it does the same, unless `FERROLINK_REQUIRE_PYMAVLINK` is set.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{ferrolink, pymavlink, workspace};
use serde_json::Value;

fn captures() -> Option<Vec<PathBuf>> {
    let dir = common::captures()?;
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let name = p.to_string_lossy();
            name.ends_with(".tlog") || name.ends_with(".tlog.raw")
        })
        .collect();
    files.sort();
    Some(files)
}

fn lines(out: &[u8]) -> Vec<Value> {
    String::from_utf8_lossy(out)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// (sysid, compid, seq, msg) of every decoded message.
fn messages(all: &[Value]) -> Vec<(u64, u64, u64, &Value)> {
    all.iter()
        .filter(|v| v.get("msg").is_some_and(|m| !m.is_null()))
        .map(|v| {
            let n = |k: &str| v[k].as_u64().unwrap_or(u64::MAX);
            (n("sysid"), n("compid"), n("seq"), &v["msg"])
        })
        .collect()
}

/// pymavlink shows a one-element array as a scalar.
fn same_msg(ours: &Value, theirs: &Value) -> bool {
    let (Some(ours), Some(theirs)) = (ours.as_object(), theirs.as_object()) else {
        return false;
    };
    ours.len() == theirs.len()
        && ours.iter().all(|(k, v)| {
            theirs.get(k).is_some_and(|t| match v.as_array() {
                Some(list) if list.len() == 1 && !t.is_array() => &list[0] == t,
                _ => v == t,
            })
        })
}

/// What `ferrolink mavlink dump` prints for `file`, with `--dialect dialect` if given.
fn dump(file: &Path, dialect: Option<&Path>) -> Vec<u8> {
    let mut ours = Command::new(ferrolink());
    ours.args(["mavlink", "dump"]);
    if let Some(dialect) = dialect {
        ours.arg("--dialect").arg(dialect);
    }
    if file.to_string_lossy().ends_with(".raw") {
        ours.arg("--raw");
    }
    let ours = ours.arg(file).output().expect("run ferrolink");
    assert!(
        ours.status.success(),
        "{}",
        String::from_utf8_lossy(&ours.stderr)
    );
    ours.stdout
}

/// Compares the built-in dialect's dump of `file` with pymavlink's, and with the dump made with
/// pymavlink's `dialect` file.
fn compare(file: &Path, python: &Path, dialect: &Path) -> (usize, usize) {
    let raw = file.to_string_lossy().ends_with(".raw");
    let ours = dump(file, None);
    assert!(
        ours == dump(file, Some(dialect)),
        "{}: the built-in dialect and {} decode differently",
        file.display(),
        dialect.display()
    );
    let mut theirs = Command::new(python);
    theirs.arg(workspace().join("tests/mavlink/pymavlink_dump.py"));
    if raw {
        theirs.arg("--raw");
    }
    let theirs = theirs.arg(file).output().expect("run pymavlink");
    assert!(
        theirs.status.success(),
        "{}",
        String::from_utf8_lossy(&theirs.stderr)
    );
    let (ours, theirs) = (lines(&ours), lines(&theirs.stdout));
    assert!(ours.last().is_some_and(|l| l.get("summary").is_some()));
    let (ours, theirs) = (messages(&ours), messages(&theirs));
    // pymavlink's messages are a subsequence of ours.
    let mut at = 0;
    for (i, t) in theirs.iter().enumerate() {
        let found = ours[at..]
            .iter()
            .position(|o| (o.0, o.1, o.2) == (t.0, t.1, t.2) && same_msg(o.3, t.3));
        match found {
            Some(k) => at += k + 1,
            None => panic!(
                "{}: pymavlink's message #{i} is missing or differs: {}\nours next: {:?}",
                file.display(),
                t.3,
                ours.get(at).map(|o| o.3.to_string())
            ),
        }
    }
    (theirs.len(), ours.len() - theirs.len())
}

#[test]
fn every_capture_decodes_as_pymavlink_does() {
    let Some(files) = captures() else {
        return;
    };
    let Some((python, dialects)) = pymavlink() else {
        common::skip("pymavlink is missing");
        return;
    };
    let dialect = dialects.join("ardupilotmega.xml");
    assert!(!files.is_empty());
    for file in files {
        let (same, extra) = compare(&file, &python, &dialect);
        eprintln!(
            "{}: {same} messages as pymavlink, {extra} more recovered",
            file.file_name().unwrap_or_default().to_string_lossy()
        );
        assert!(same > 0, "{}: nothing decoded", file.display());
    }
}

/// A tlog the router wrote: three known frames from two sources with a gap in one sequence,
/// and an unknown id.
fn small_tlog(dir: &Path) -> PathBuf {
    use ferrolink_io::mavlink::tlog::Writer;
    use ferrolink_runtime::mavlink::{v2, Header};
    let mut bytes = Vec::new();
    let mut writer = Writer::new(&mut bytes);
    let mut frame = |seq, sysid, id, crc_extra, payload: &[u8], t| {
        let mut out = [0u8; v2::MAX_FRAME_LEN];
        let n = v2::encode_raw(Header::new(seq, sysid, 1), id, crc_extra, payload, &mut out)
            .expect("encode");
        writer.write(t, &out[..n]).expect("write");
    };
    frame(0, 1, 0, 50, &[0, 0, 0, 0, 2, 3, 0x51, 4, 3], 1_000_000);
    frame(3, 1, 0, 50, &[0, 0, 0, 0, 2, 3, 0x51, 4, 3], 2_000_000);
    frame(0, 2, 0, 50, &[0, 0, 0, 0, 6, 8, 0, 0, 3], 2_500_000);
    frame(1, 2, 42424, 0, &[1, 2, 3], 3_000_000);
    let path = dir.join("small.tlog");
    std::fs::write(&path, bytes).expect("write tlog");
    path
}

/// Runs `ferrolink mavlink ARGS...`, which must succeed, and returns what it printed.
fn mavlink(args: &[&std::ffi::OsStr]) -> String {
    let out = Command::new(ferrolink())
        .arg("mavlink")
        .args(args)
        .output()
        .expect("run ferrolink");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn stats_plot_and_csv() {
    let dir = tempfile::tempdir().expect("scratch");
    let log = small_tlog(dir.path());
    let svg = dir.path().join("rates.svg");
    let text = mavlink(&[
        "stats".as_ref(),
        "--plot".as_ref(),
        svg.as_os_str(),
        log.as_os_str(),
    ]);
    let row = |source: &str| {
        text.lines()
            .find(|l| l.starts_with(source))
            .unwrap_or_else(|| panic!("no row for {source}:\n{text}"))
            .split_whitespace()
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    // frames, seconds, per s, lost, loss %
    assert_eq!(row("1/1")[1..], ["2", "1.0", "2.0", "2", "50.00"]);
    assert_eq!(row("2/1")[1], "2");
    assert!(
        text.contains("HEARTBEAT") && text.contains("#42424"),
        "{text}"
    );
    let plot = std::fs::read_to_string(&svg).expect("plot written");
    assert!(plot.starts_with("<svg") && plot.contains("HEARTBEAT"));

    let csv = dir.path().join("csv");
    mavlink(&[
        "dump".as_ref(),
        "--csv".as_ref(),
        csv.as_os_str(),
        log.as_os_str(),
    ]);
    let heartbeats = std::fs::read_to_string(csv.join("HEARTBEAT.csv")).expect("csv");
    let mut lines = heartbeats.lines();
    assert!(lines
        .next()
        .is_some_and(|h| h.starts_with("t_us,sysid,compid,seq,type,autopilot")));
    assert_eq!(lines.count(), 3);
    let unknown = std::fs::read_to_string(csv.join("unknown.csv")).expect("unknown.csv");
    assert!(
        unknown.ends_with("3000000,2,1,1,42424,010203\n"),
        "{unknown}"
    );
}
