//! `ferrolink mavlink stats --plot`: the plot comes out as SVG or PNG by its extension, for a
//! small log written here and for every real capture in `../shared/captures/`.
//!
//! Without the captures that part says so in one line and passes. A PNG needs a TrueType font
//! on the system; without one the PNG checks say so and pass, unless `FERROLINK_REQUIRE_FONTS`
//! is set.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::ferrolink;

/// Runs `ferrolink mavlink stats --plot PLOT LOG`.
fn stats(plot: &Path, log: &Path) -> Output {
    Command::new(ferrolink())
        .args(["mavlink", "stats", "--plot"])
        .arg(plot)
        .arg(log)
        .output()
        .expect("run ferrolink")
}

/// What the command says it drew: image width and height, and heat map cells with frames.
struct Drawn {
    width: u32,
    height: u32,
    cells: usize,
}

/// Reads the `…: plot written, WxH px, …, N cells` line of `stderr`.
fn drawn(stderr: &str) -> Drawn {
    let line = stderr
        .lines()
        .find(|l| l.contains("plot written, "))
        .unwrap_or_else(|| panic!("no `plot written` line:\n{stderr}"));
    let fields: Vec<&str> = line.split(", ").collect();
    let field = |suffix: &str| {
        fields
            .iter()
            .find_map(|f| f.strip_suffix(suffix))
            .unwrap_or_else(|| panic!("no `{suffix}` in: {line}"))
    };
    let (width, height) = field(" px").split_once('x').expect("WxH px");
    let number = |s: &str| s.parse::<u64>().unwrap_or_else(|e| panic!("{e}: {line}"));
    Drawn {
        width: number(width) as u32,
        height: number(height) as u32,
        cells: number(field(" cells")) as usize,
    }
}

/// The message names of the text report: the indented lines under each source.
fn message_names(stdout: &str) -> Vec<String> {
    stdout
        .lines()
        .filter(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_owned)
        .collect()
}

/// Plots `log` as SVG into `dir` and checks the file: an `<svg>` document with a `<rect>` per
/// heat map cell with frames, naming a message type the text report lists. Returns stdout.
fn check_svg(dir: &Path, log: &Path) -> String {
    let svg = dir.join("x.svg");
    let out = stats(&svg, log);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{}: {stderr}", log.display());
    let drawn = drawn(&stderr);
    assert!(drawn.width > 0 && drawn.height > 0, "{stderr}");
    assert!(
        drawn.cells > 0,
        "{}: no cells drawn: {stderr}",
        log.display()
    );
    let text = std::fs::read_to_string(&svg).expect("SVG written");
    let body = match text.trim_start().strip_prefix("<?xml") {
        Some(rest) => rest.split_once("?>").expect("end of the XML declaration").1,
        None => text.as_str(),
    };
    assert!(body.trim_start().starts_with("<svg"), "{}", log.display());
    assert!(text.trim_end().ends_with("</svg>"), "{}", log.display());
    let rects = text.matches("<rect").count();
    assert!(
        rects >= drawn.cells,
        "{}: {rects} <rect> for {} cells",
        log.display(),
        drawn.cells
    );
    let names = message_names(&stdout);
    assert!(
        names.iter().any(|name| text.contains(name.as_str())),
        "{}: the SVG names none of {names:?}",
        log.display()
    );
    stdout
}

/// Plots `log` as PNG into `dir` and checks the file's signature and size against what the
/// command says it drew. False, after a note, when no font was found and that is allowed.
fn check_png(dir: &Path, log: &Path) -> bool {
    let png = dir.join("x.png");
    let out = stats(&png, log);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() && stderr.contains("needs a TrueType font") {
        assert!(
            std::env::var_os("FERROLINK_REQUIRE_FONTS").is_none(),
            "no font for the PNG plot, but FERROLINK_REQUIRE_FONTS is set: {stderr}"
        );
        eprintln!("skipped the PNG plot: no TrueType font on this system");
        return false;
    }
    assert!(out.status.success(), "{}: {stderr}", log.display());
    let drawn = drawn(&stderr);
    let bytes = std::fs::read(&png).expect("PNG written");
    assert!(
        bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
        "{}: not a PNG",
        log.display()
    );
    // The IHDR chunk comes first: length, "IHDR", width, height (big-endian).
    assert_eq!(bytes.get(12..16), Some(&b"IHDR"[..]), "{}", log.display());
    let be = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    assert!(drawn.width > 0 && drawn.height > 0, "{stderr}");
    assert_eq!(
        (be(16), be(20)),
        (drawn.width, drawn.height),
        "{}",
        log.display()
    );
    true
}

/// CRC-16/MCRF4XX, MAVLink's checksum.
fn crc(bytes: &[u8]) -> u16 {
    bytes.iter().fold(0xFFFF, |crc: u16, &b| {
        let mut t = b ^ (crc & 0xFF) as u8;
        t ^= t << 4;
        let t = u16::from(t);
        (crc >> 8) ^ (t << 8) ^ (t << 3) ^ (t >> 4)
    })
}

/// A MAVLink 1 HEARTBEAT from `sysid`/1 with sequence number `seq`.
fn heartbeat(seq: u8, sysid: u8) -> Vec<u8> {
    let mut frame = vec![0xFE, 9, seq, sysid, 1, 0];
    // custom_mode, type, autopilot, base_mode, system_status, mavlink_version
    frame.extend_from_slice(&[0, 0, 0, 0, 2, 3, 0x51, 4, 3]);
    let mut checked = frame[1..].to_vec();
    checked.push(50); // HEARTBEAT's CRC_EXTRA
    frame.extend_from_slice(&crc(&checked).to_le_bytes());
    frame
}

/// A .tlog of 20 s: sources 1/1 and 2/1 each send a HEARTBEAT a second; 1/1 skips three
/// sequence numbers after its tenth.
fn synthetic_tlog(dir: &Path) -> PathBuf {
    let t0: u64 = 1_700_000_000_000_000;
    let mut bytes = Vec::new();
    for i in 0..20u8 {
        let t = t0 + u64::from(i) * 1_000_000;
        let seq = if i < 10 { i } else { i + 3 };
        for (sysid, seq, t) in [(1, seq, t), (2, i, t + 400_000)] {
            bytes.extend_from_slice(&t.to_be_bytes());
            bytes.extend_from_slice(&heartbeat(seq, sysid));
        }
    }
    let path = dir.join("synthetic.tlog");
    std::fs::write(&path, bytes).expect("write the tlog");
    path
}

#[test]
fn plots_a_small_log_as_svg_and_png() {
    let dir = tempfile::tempdir().expect("scratch");
    let log = synthetic_tlog(dir.path());
    let stdout = check_svg(dir.path(), &log);
    let lost = |source: &str| {
        let row = stdout
            .lines()
            .find(|l| l.starts_with(source))
            .unwrap_or_else(|| panic!("no row for {source}:\n{stdout}"));
        row.split_whitespace().nth(4).map(str::to_owned)
    };
    assert_eq!(lost("1/1 ").as_deref(), Some("3"), "{stdout}");
    assert_eq!(lost("2/1 ").as_deref(), Some("0"), "{stdout}");
    let svg = std::fs::read_to_string(dir.path().join("x.svg")).expect("SVG");
    assert!(svg.contains("1/1 HEARTBEAT") && svg.contains("2/1 HEARTBEAT"));
    check_png(dir.path(), &log);
}

#[test]
fn an_unknown_plot_extension_is_refused() {
    let dir = tempfile::tempdir().expect("scratch");
    let log = synthetic_tlog(dir.path());
    let plot = dir.path().join("x.xyz");
    let out = stats(&plot, &log);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("x.xyz") && stderr.contains(".svg") && stderr.contains(".png"),
        "{stderr}"
    );
    assert!(!plot.exists());
}

#[test]
fn plots_every_capture() {
    let Some(dir) = common::captures() else {
        return;
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("read the captures")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let name = p.to_string_lossy();
            name.ends_with(".tlog") || name.ends_with(".tlog.raw")
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no captures in {}", dir.display());
    let scratch = tempfile::tempdir().expect("scratch");
    let mut png = true;
    for file in &files {
        check_svg(scratch.path(), file);
        png = png && check_png(scratch.path(), file);
        eprintln!("{}: plotted", file.display());
    }
}
