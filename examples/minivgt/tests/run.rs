//! The demo end to end: four nodes over UDP loopback, a target sent from another process, and
//! the motor reaching it.

use std::process::{Command, Stdio};
use std::time::Duration;

const EXE: &str = env!("CARGO_BIN_EXE_ferrolink-example-minivgt");

#[test]
fn a_target_sent_over_udp_moves_its_motor() {
    let demo = Command::new(EXE)
        .args(["--base-port", "36100", "--control-port", "36200"])
        .args(["--run-for", "4", "--no-sweep"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("starts");
    std::thread::sleep(Duration::from_millis(1500));
    let sent = Command::new(EXE)
        .args(["--control-port", "36200", "send", "2", "3", "0.5", "2.0"])
        .status()
        .expect("send runs");
    assert!(sent.success());
    let out = demo.wait_with_output().expect("ends");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let last = text
        .lines()
        .find(|l| l.starts_with("final:"))
        .unwrap_or_else(|| panic!("no final line in:\n{text}"));
    assert!(last.contains("crc errors 0"), "{last}");
    for id in 0..4 {
        assert!(last.contains(&format!("{id}:Running")), "{last}");
    }
    let rate: f64 = last
        .trim_start_matches("final:")
        .split_whitespace()
        .next()
        .and_then(|r| r.parse().ok())
        .expect("rate");
    assert!(rate > 100.0, "{last}");
    let positions: Vec<f32> = last
        .split('|')
        .filter(|part| part.trim_start().starts_with('s'))
        .flat_map(|part| {
            part.split_whitespace()
                .skip(1)
                .map(|v| v.parse().expect("number"))
        })
        .collect();
    assert_eq!(positions.len(), 9, "{last}");
    for (i, p) in positions.iter().enumerate() {
        let expected = if i == 5 { 0.5 } else { 0.0 };
        assert!((p - expected).abs() < 1e-3, "motor {i}: {p} in {last}");
    }
}
