//! The routers under test, each started as its own process on UDP ports: ours, mavlink-routerd
//! and MAVProxy, and how much CPU a process used.

use super::*;

/// A router under test, started on three UDP ports.
pub struct Router {
    pub name: &'static str,
    pub child: Child,
    _dir: PathBuf,
}

impl Drop for Router {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self._dir);
    }
}

pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ferrolink-bench-{name}-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    dir
}

pub fn start_ferrolink(ports: &[u16]) -> Option<Router> {
    let endpoints = ports.iter().map(|p| format!("udpin://127.0.0.1:{p}"));
    start_ferrolink_with(endpoints.collect())
}

pub fn start_ferrolink_with(endpoints: Vec<String>) -> Option<Router> {
    let bin = workspace().join("target/release/ferrolink");
    if !bin.exists() {
        eprintln!(
            "note: {} missing; run cargo build --release -p ferrolink-cli",
            bin.display()
        );
        return None;
    }
    let mut child = Command::new(bin)
        .args(["mavlink", "router"])
        .args(endpoints)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let mut line = String::new();
    BufReader::new(child.stdout.take()?)
        .read_line(&mut line)
        .ok()?;
    line.contains("ready").then_some(Router {
        name: "ferrolink",
        child,
        _dir: scratch("ferrolink"),
    })
}

pub fn which(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|p| p.join(name))
            .find(|p| p.exists())
    })
}

pub fn start_mavlink_routerd(ports: &[u16]) -> Option<Router> {
    let Some(bin) = std::env::var_os("MAVLINK_ROUTERD")
        .map(PathBuf::from)
        .or_else(|| which("mavlink-routerd"))
    else {
        eprintln!("note: mavlink-routerd not found (set MAVLINK_ROUTERD); skipped");
        return None;
    };
    let dir = scratch("mavlink-routerd");
    let mut conf = String::from("[General]\nTcpServerPort = 0\nReportStats = false\n");
    for (i, p) in ports.iter().enumerate() {
        conf += &format!("[UdpEndpoint e{i}]\nMode = Server\nAddress = 127.0.0.1\nPort = {p}\n");
    }
    let path = dir.join("main.conf");
    std::fs::write(&path, conf).ok()?;
    // `-d` with an empty folder: nothing from /etc/mavlink-router/config.d is read.
    let confd = dir.join("conf.d");
    std::fs::create_dir_all(&confd).ok()?;
    let child = Command::new(bin)
        .arg("-c")
        .arg(&path)
        .arg("-d")
        .arg(&confd)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    thread::sleep(Duration::from_millis(500));
    Some(Router {
        name: "mavlink-routerd",
        child,
        _dir: dir,
    })
}

pub fn start_mavproxy(ports: &[u16]) -> Option<Router> {
    let venv = workspace().join(".venv/bin/mavproxy.py");
    let Some(bin) = venv
        .exists()
        .then_some(venv)
        .or_else(|| which("mavproxy.py"))
    else {
        eprintln!("note: MAVProxy not found (pip install MAVProxy into .venv); skipped");
        return None;
    };
    let dir = scratch("mavproxy");
    let child = Command::new(bin)
        .arg(format!("--master=udpin:127.0.0.1:{}", ports[0]))
        .arg(format!("--out=udpin:127.0.0.1:{}", ports[1]))
        .arg(format!("--out=udpin:127.0.0.1:{}", ports[2]))
        .args([
            "--daemon",
            "--non-interactive",
            "--nowait",
            "--state-basedir",
        ])
        .arg(&dir)
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    thread::sleep(Duration::from_secs(4));
    Some(Router {
        name: "MAVProxy",
        child,
        _dir: dir,
    })
}

/// CPU time of a process: the scheduler's nanosecond count summed over its live threads
/// (/proc/PID/task/*/schedstat), or, where the kernel keeps no schedstat, user and system time
/// in 10 ms ticks (/proc/PID/stat).
pub fn cpu_time(pid: u32) -> Option<Duration> {
    let tasks = std::fs::read_dir(format!("/proc/{pid}/task")).ok()?;
    let mut ns = 0u64;
    for task in tasks.flatten() {
        let schedstat = std::fs::read_to_string(task.path().join("schedstat")).unwrap_or_default();
        if let Some(t) = schedstat
            .split_whitespace()
            .next()
            .and_then(|f| f.parse::<u64>().ok())
        {
            ns += t;
        }
    }
    if ns > 0 {
        return Some(Duration::from_nanos(ns));
    }
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: u64 = fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?;
    // The kernel's USER_HZ is 100 on every Linux this runs on.
    Some(Duration::from_millis(ticks * 10))
}
