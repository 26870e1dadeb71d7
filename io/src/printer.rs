//! Outputs that never hold up the program writing them: standard output and error, statistics
//! files, logs.
//!
//! A router or bridge that prints or logs while it forwards must go on forwarding when nobody
//! reads what it writes: a terminal paused with Ctrl-S, a pager left open, a pipe or FIFO into a
//! program that stopped, a disk (an SD card) that stalls. A [`Printer`] hands each line, or each
//! chunk of a binary log, to a thread of its own through a bounded queue. When the queue is full
//! the line is dropped and counted, and a note says how many were dropped before the next line
//! that gets through (a binary output has no room for notes: its writer counts what it lost).
//! Memory stays bounded, and the caller never waits.

use std::io::{self, Write};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use std::thread;
use std::time::{Duration, Instant};

/// Lines a printer holds for an output that is not read before it drops them.
pub const LINES: usize = 1024;

/// How long a program at its end waits for its outputs to take what is queued for them.
pub const FLUSH_PATIENCE: Duration = Duration::from_secs(2);

enum Item {
    /// A line with its newline, or a chunk of a binary output.
    Bytes(Vec<u8>),
    /// Answered once every line before it is written and flushed.
    Flush(mpsc::Sender<()>),
}

/// Prints lines on a thread of its own; see the [module](self).
pub struct Printer {
    tx: SyncSender<Item>,
    /// Lines dropped since the last note.
    unprinted: AtomicU64,
    /// The note for `n` lines dropped (`None` for a binary output).
    note: Option<fn(u64) -> String>,
    /// What ended the printing thread (a closed pipe, say).
    failed: Arc<Mutex<Option<io::Error>>>,
}

impl std::fmt::Debug for Printer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Printer")
            .field("unprinted", &self.unprinted)
            .finish_non_exhaustive()
    }
}

/// The note for `n` lines dropped, as text.
pub fn text_note(n: u64) -> String {
    format!("note: {n} line(s) not printed: the output was not read")
}

/// The note for `n` lines dropped, as a JSON line.
pub fn json_note(n: u64) -> String {
    format!("{{\"event\":\"not_printed\",\"lines\":{n}}}")
}

impl Printer {
    /// A printer to `out` that holds up to `lines` lines while `out` is not read; `note` words
    /// the note for lines dropped.
    pub fn new(out: impl Write + Send + 'static, lines: usize, note: fn(u64) -> String) -> Printer {
        Printer::spawn(out, lines, Some(note))
    }

    /// A printer of binary chunks ([`chunk`](Self::chunk)) to `out`, holding up to `chunks`
    /// of them while `out` is not read.
    pub fn binary(out: impl Write + Send + 'static, chunks: usize) -> Printer {
        Printer::spawn(out, chunks, None)
    }

    fn spawn(
        out: impl Write + Send + 'static,
        items: usize,
        note: Option<fn(u64) -> String>,
    ) -> Printer {
        let (tx, rx) = mpsc::sync_channel(items.max(1));
        let failed = Arc::new(Mutex::new(None));
        let thread_failed = Arc::clone(&failed);
        let spawned = thread::Builder::new()
            .name("printer".into())
            .spawn(move || print(out, &rx, &thread_failed));
        if let Err(e) = spawned {
            // The queue's receiver is gone with the closure: every line reports this.
            *failed.lock().unwrap_or_else(PoisonError::into_inner) = Some(e);
        }
        Printer {
            tx,
            unprinted: AtomicU64::new(0),
            note,
            failed,
        }
    }

    /// A printer to standard output, with the text note.
    pub fn stdout() -> Printer {
        Printer::new(io::stdout(), LINES, text_note)
    }

    /// Queues `line` (a newline is added); drops it if the queue is full. An error says the
    /// output failed (a closed pipe): nothing more is printed.
    pub fn line(&self, line: impl Into<String>) -> io::Result<()> {
        if let Some(e) = self.failure() {
            return Err(e);
        }
        let unprinted = self.unprinted.load(Ordering::Relaxed);
        if let Some(note) = self.note.filter(|_| unprinted > 0) {
            if !self.offer(with_newline(note(unprinted)))? {
                self.unprinted.fetch_add(1, Ordering::Relaxed);
                return Ok(());
            }
            self.unprinted.fetch_sub(unprinted, Ordering::Relaxed);
        }
        if !self.offer(with_newline(line.into()))? {
            self.unprinted.fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    }

    /// Queues `bytes` as they are (a chunk of a binary output); `false` if it was dropped, the
    /// queue being full. An error says the output failed: nothing more is written.
    pub fn chunk(&self, bytes: Vec<u8>) -> io::Result<bool> {
        if let Some(e) = self.failure() {
            return Err(e);
        }
        let queued = self.offer(bytes)?;
        if !queued {
            self.unprinted.fetch_add(1, Ordering::Relaxed);
        }
        Ok(queued)
    }

    /// Lines dropped and not yet noted.
    pub fn unprinted(&self) -> u64 {
        self.unprinted.load(Ordering::Relaxed)
    }

    /// Waits, up to `patience`, until every line queued so far is written and flushed. An
    /// error says the output failed, or was not read for that long.
    pub fn flush(&self, patience: Duration) -> io::Result<()> {
        self.flush_until(Instant::now() + patience)
    }

    /// Waits, up to `deadline`, until everything queued so far is written and flushed. An error
    /// says the output failed, or was not read by then.
    pub fn flush_until(&self, deadline: Instant) -> io::Result<()> {
        let (ack, acked) = mpsc::channel();
        let mut item = Item::Flush(ack);
        loop {
            match self.tx.try_send(item) {
                Ok(()) => break,
                Err(TrySendError::Full(back)) if Instant::now() < deadline => {
                    item = back;
                    thread::sleep(Duration::from_millis(10));
                }
                Err(TrySendError::Full(_)) => return Err(stalled()),
                Err(TrySendError::Disconnected(_)) => return Err(self.error()),
            }
        }
        match acked.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
            Ok(()) => Ok(()),
            Err(mpsc::RecvTimeoutError::Timeout) => Err(stalled()),
            Err(mpsc::RecvTimeoutError::Disconnected) => Err(self.error()),
        }
    }

    /// Queues `bytes` if there is room; `false` if not.
    fn offer(&self, bytes: Vec<u8>) -> io::Result<bool> {
        match self.tx.try_send(Item::Bytes(bytes)) {
            Ok(()) => Ok(true),
            Err(TrySendError::Full(_)) => Ok(false),
            Err(TrySendError::Disconnected(_)) => Err(self.error()),
        }
    }

    /// What ended the printing thread, if it has ended (a closed pipe, a full disk).
    pub fn failure(&self) -> Option<io::Error> {
        self.failed
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .as_ref()
            .map(|e| io::Error::new(e.kind(), e.to_string()))
    }

    /// What ended the printing thread.
    fn error(&self) -> io::Error {
        self.failure()
            .unwrap_or_else(|| io::Error::new(io::ErrorKind::BrokenPipe, "the output was closed"))
    }
}

fn with_newline(line: String) -> Vec<u8> {
    let mut bytes = line.into_bytes();
    bytes.push(b'\n');
    bytes
}

fn stalled() -> io::Error {
    io::Error::new(
        io::ErrorKind::TimedOut,
        "the output was not read in time; what was queued last was not written",
    )
}

/// The printing thread: writes what is queued, flushing whenever the queue is empty, until
/// every [`Printer`] handle is gone or the output fails. A failure is stored before anything
/// that waits on the thread (a flush's answer, the queue) is let go.
fn print(out: impl Write, rx: &Receiver<Item>, failed: &Mutex<Option<io::Error>>) {
    let mut out = io::BufWriter::new(out);
    let fail = |e: io::Error| *failed.lock().unwrap_or_else(PoisonError::into_inner) = Some(e);
    while let Ok(first) = rx.recv() {
        let mut next = Some(first);
        while let Some(item) = next {
            let written = match &item {
                Item::Bytes(bytes) => out.write_all(bytes),
                Item::Flush(_) => out.flush(),
            };
            if let Err(e) = written {
                return fail(e);
            }
            if let Item::Flush(ack) = item {
                let _ = ack.send(());
            }
            next = rx.try_recv().ok();
        }
        if let Err(e) = out.flush() {
            return fail(e);
        }
    }
}

/// The process's printer for log lines on standard error (links up and down, refusals), for
/// code that holds a lock others forward under.
pub fn stderr() -> &'static Printer {
    STDERR.get_or_init(|| Printer::new(io::stderr(), LINES, text_note))
}

/// [`Printer::flush`] of the [`stderr`] printer, if anything was printed through it.
pub fn flush_stderr(patience: Duration) -> io::Result<()> {
    STDERR.get().map_or(Ok(()), |p| p.flush(patience))
}

static STDERR: OnceLock<Printer> = OnceLock::new();

#[cfg(test)]
mod tests {
    use super::*;

    /// An output that takes nothing until `open` is set, then keeps what it is given.
    #[derive(Clone, Default)]
    struct Gate {
        open: Arc<(Mutex<bool>, std::sync::Condvar)>,
        got: Arc<Mutex<Vec<u8>>>,
        /// Set once a write waits at the gate.
        waiting: Arc<std::sync::atomic::AtomicBool>,
    }

    impl Gate {
        fn open(&self) {
            let (open, cv) = &*self.open;
            *open.lock().expect("lock") = true;
            cv.notify_all();
        }
        fn text(&self) -> String {
            String::from_utf8(self.got.lock().expect("lock").clone()).expect("utf-8")
        }
    }

    impl Write for Gate {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            let (open, cv) = &*self.open;
            let mut guard = open.lock().expect("lock");
            while !*guard {
                self.waiting.store(true, Ordering::Relaxed);
                guard = cv.wait(guard).expect("wait");
            }
            self.got.lock().expect("lock").extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn an_output_not_read_drops_lines_and_the_next_line_through_says_how_many() {
        let gate = Gate::default();
        let printer = Printer::new(gate.clone(), 4, text_note);
        // The thread takes the first line and waits at the gate with it; four more fill the
        // queue; the rest are dropped, and no call waits.
        printer.line("line 0").expect("queued");
        let start = Instant::now();
        while !gate.waiting.load(Ordering::Relaxed) {
            assert!(start.elapsed() < Duration::from_secs(5), "never written");
            thread::sleep(Duration::from_millis(1));
        }
        let start = Instant::now();
        for i in 1..100 {
            printer
                .line(format!("line {i}"))
                .expect("queued or dropped");
        }
        assert!(start.elapsed() < Duration::from_secs(1), "a call waited");
        assert_eq!(printer.unprinted(), 95);
        assert!(printer.flush(Duration::from_millis(50)).is_err());
        let dropped = printer.unprinted();
        gate.open();
        printer.flush(Duration::from_secs(5)).expect("flushed");
        printer.line("after").expect("queued");
        printer.flush(Duration::from_secs(5)).expect("flushed");
        let text = gate.text();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "line 0");
        assert_eq!(
            lines[lines.len() - 2..],
            [
                format!("note: {dropped} line(s) not printed: the output was not read").as_str(),
                "after"
            ]
        );
        // What was printed and what was dropped add up.
        assert_eq!(lines.len() - 2 + dropped as usize, 100, "{text}");
        assert_eq!(printer.unprinted(), 0);
    }

    /// An output that fails every write, as a closed pipe does.
    struct Closed;

    impl Write for Closed {
        fn write(&mut self, _: &[u8]) -> io::Result<usize> {
            Err(io::ErrorKind::BrokenPipe.into())
        }
        fn flush(&mut self) -> io::Result<()> {
            Err(io::ErrorKind::BrokenPipe.into())
        }
    }

    #[test]
    fn a_failed_output_is_reported_to_the_caller() {
        let printer = Printer::new(Closed, 4, text_note);
        printer.line("first").expect("queued");
        let e = printer
            .flush(Duration::from_secs(5))
            .expect_err("the output failed");
        assert_eq!(e.kind(), io::ErrorKind::BrokenPipe);
        let e = printer.line("second").expect_err("nothing more is printed");
        assert_eq!(e.kind(), io::ErrorKind::BrokenPipe);
    }
}
