//! The benchmarks' small harness: every case is calibrated to batches of about
//! [`BATCH_TARGET`], then the two operations compared run alternating batches (so load from
//! other processes hits both alike) and the median time per call of each is taken.

use std::time::{Duration, Instant};

/// Wall time of one timed batch.
pub const BATCH_TARGET: Duration = Duration::from_millis(20);
/// Timed batches per implementation and case (odd, for a clean median).
pub const BATCHES: usize = 31;
/// Untimed running before calibration.
pub const WARMUP: Duration = Duration::from_millis(100);

/// Runs `op` `reps` times, passing the iteration number.
#[inline(never)]
pub fn run_batch(op: &mut impl FnMut(u64), reps: u64) -> Duration {
    let start = Instant::now();
    for i in 0..reps {
        op(i);
    }
    start.elapsed()
}

/// How many calls of `op` take about `BATCH_TARGET`, after warming up.
pub fn calibrate(op: &mut impl FnMut(u64)) -> u64 {
    let start = Instant::now();
    let mut reps = 1u64;
    while start.elapsed() < WARMUP {
        run_batch(op, reps);
        reps = (reps * 2).min(1 << 30);
    }
    let mut reps = 1u64;
    loop {
        let t = run_batch(op, reps);
        if t >= BATCH_TARGET / 4 {
            let scaled = reps as f64 * BATCH_TARGET.as_secs_f64() / t.as_secs_f64();
            return (scaled as u64).max(1);
        }
        reps *= 2;
    }
}

pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median seconds per call of three operations, from batches taking turns (the MAVLink bench
/// compares three implementations; the others, two).
#[allow(dead_code)]
pub fn compare3(
    mut a: impl FnMut(u64),
    mut b: impl FnMut(u64),
    mut c: impl FnMut(u64),
) -> (f64, f64, f64) {
    let (ra, rb, rc) = (calibrate(&mut a), calibrate(&mut b), calibrate(&mut c));
    let (mut ta, mut tb, mut tc) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..BATCHES {
        ta.push(run_batch(&mut a, ra).as_secs_f64() / ra as f64);
        tb.push(run_batch(&mut b, rb).as_secs_f64() / rb as f64);
        tc.push(run_batch(&mut c, rc).as_secs_f64() / rc as f64);
    }
    (median(ta), median(tb), median(tc))
}

/// Median seconds per call of each operation, from alternating batches.
pub fn compare(mut a: impl FnMut(u64), mut b: impl FnMut(u64)) -> (f64, f64) {
    let (ra, rb) = (calibrate(&mut a), calibrate(&mut b));
    let mut ta = Vec::with_capacity(BATCHES);
    let mut tb = Vec::with_capacity(BATCHES);
    for _ in 0..BATCHES {
        ta.push(run_batch(&mut a, ra).as_secs_f64() / ra as f64);
        tb.push(run_batch(&mut b, rb).as_secs_f64() / rb as f64);
    }
    (median(ta), median(tb))
}

/// The CPU model and how many cores there are, for every report.
pub fn machine() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find_map(|l| l.strip_prefix("model name"))
        .and_then(|l| l.split_once(':'))
        .map_or("unknown CPU", |(_, m)| m.trim())
        .to_owned();
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{model}, {cores} cores")
}

/// The Python that runs the peers' scripts: `FERROLINK_PYTHON`, else the workspace's `.venv`,
/// else `python3`.
pub fn python() -> std::path::PathBuf {
    if let Some(p) = std::env::var_os("FERROLINK_PYTHON") {
        return p.into();
    }
    let venv = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../.venv/bin/python");
    if venv.exists() {
        venv
    } else {
        "python3".into()
    }
}
