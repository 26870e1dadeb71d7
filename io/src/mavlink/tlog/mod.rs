//! Telemetry logs (`.tlog`), the form every ground station and log tool reads: records of an
//! 8-byte big-endian timestamp (microseconds since the Unix epoch) followed by one MAVLink frame
//! exactly as received.
//!
//! [`Writer`] writes them: timestamps never decrease, each record goes out whole, and
//! `SETUP_SIGNING`'s secret key is zeroed (its checksum recomputed), the one change to a frame.
//! [`Spool`] is a writer for a program that logs while it forwards: a file that stalls costs
//! records, counted, never the caller's time.
//! [`files::open`] says where a log goes: a file appended to, or a directory with a new
//! numbered file per run and the oldest deleted as a [`Retention`] asks.
//! [`LogReader`] reads them back from any `Read`, a chunk at a time (files larger than memory
//! too), record by record, and resynchronises on damage; it reads raw captures of link bytes as
//! well. [`read_tlog`] and [`read_raw`] do the same for bytes held in memory.

use std::io::{self, Write};
use std::time::Instant;

use ferrolink_runtime::crc::mcrf4xx_digest;
use ferrolink_runtime::mavlink::{v1, v2};

pub mod files;
mod read;

pub use files::Retention;
pub use read::{read_raw, read_tlog, LogReader, ReadStats, Record};

/// `SETUP_SIGNING` (common.xml): id, CRC_EXTRA, and where its `secret_key[32]` lies.
const SETUP_SIGNING_ID: u32 = 256;
const SETUP_SIGNING_CRC_EXTRA: u8 = 71;
const SECRET_KEY: std::ops::Range<usize> = 10..42;

/// Writes `.tlog` records.
#[derive(Debug)]
pub struct Writer<W: Write> {
    out: W,
    last_us: u64,
    record: Vec<u8>,
    /// Records written.
    pub records: u64,
}

impl<W: Write> Writer<W> {
    /// A writer on `out` (wrap files in a `BufWriter`; each record is handed over in one
    /// `write_all`, so a buffered writer only ever holds whole records).
    pub fn new(out: W) -> Self {
        Self {
            out,
            last_us: 0,
            record: Vec::with_capacity(8 + v2::MAX_FRAME_LEN),
            records: 0,
        }
    }

    /// Appends one frame received at `unix_us`. A time earlier than the last one written (the
    /// wall clock stepped back) is written as the last one.
    pub fn write(&mut self, unix_us: u64, frame: &[u8]) -> io::Result<()> {
        self.last_us = self.last_us.max(unix_us);
        self.record.clear();
        self.record.extend_from_slice(&self.last_us.to_be_bytes());
        self.record.extend_from_slice(frame);
        redact_setup_signing(&mut self.record[8..]);
        self.out.write_all(&self.record)?;
        self.records += 1;
        Ok(())
    }

    /// Flushes the underlying writer.
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// The underlying writer.
    pub fn get_mut(&mut self) -> &mut W {
        &mut self.out
    }
}

/// A `.tlog` written by a thread of its own, for a program that must never wait for its log (a
/// router: a FIFO nobody reads, or an SD card that stalls for seconds, must not stop routing).
///
/// Records gather in memory and go to the thread in chunks of up to [`Spool::CHUNK`] bytes,
/// when a chunk is full and whenever [`hand_over`](Spool::hand_over) is called (a router does
/// once a second, so the file is never much behind). At most [`Spool::CHUNKS`] chunks wait for
/// the file; past that a chunk is dropped whole, so the file only ever holds whole records,
/// and its records are counted in [`dropped`](Spool::dropped).
#[derive(Debug)]
pub struct Spool {
    writer: Writer<Vec<u8>>,
    /// Records in the chunk being filled.
    pending: u64,
    out: crate::printer::Printer,
    dropped: u64,
}

impl Spool {
    /// The size a chunk is handed over at.
    pub const CHUNK: usize = 64 * 1024;
    /// Chunks that may wait for the file: 4 MiB.
    pub const CHUNKS: usize = 64;

    /// A spool writing to `out`.
    pub fn new(out: impl Write + Send + 'static) -> Spool {
        Spool {
            writer: Writer::new(Vec::new()),
            pending: 0,
            out: crate::printer::Printer::binary(out, Self::CHUNKS),
            dropped: 0,
        }
    }

    /// Appends one frame received at `unix_us` (see [`Writer::write`]).
    pub fn write(&mut self, unix_us: u64, frame: &[u8]) {
        // Writing into memory cannot fail.
        let _ = self.writer.write(unix_us, frame);
        self.pending += 1;
        if self.writer.get_mut().len() >= Self::CHUNK {
            self.hand_over();
        }
    }

    /// Hands the records gathered so far to the writing thread. Once the file has failed
    /// (see [`failure`](Self::failure)) they are dropped.
    pub fn hand_over(&mut self) {
        if self.pending == 0 {
            return;
        }
        // The next chunk is given room for as much as this one took: rates are steady.
        let room = self
            .writer
            .get_mut()
            .len()
            .min(Self::CHUNK + v2::MAX_FRAME_LEN + 8);
        let chunk = std::mem::replace(self.writer.get_mut(), Vec::with_capacity(room));
        if !matches!(self.out.chunk(chunk), Ok(true)) {
            self.dropped += self.pending;
        }
        self.pending = 0;
    }

    /// Records taken, whether written or dropped.
    pub fn records(&self) -> u64 {
        self.writer.records
    }

    /// Records dropped: the file did not keep up, or failed.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// What made the file fail (a full disk, a closed pipe), if it has.
    pub fn failure(&self) -> Option<io::Error> {
        self.out.failure()
    }

    /// Hands over what is gathered and waits, up to `deadline`, until it is written and flushed.
    pub fn flush_until(&mut self, deadline: Instant) -> io::Result<()> {
        self.hand_over();
        self.out.flush_until(deadline)
    }
}

/// Zeroes the secret key of a `SETUP_SIGNING` frame in place and recomputes its checksum. Other
/// frames are left alone.
pub fn redact_setup_signing(frame: &mut [u8]) {
    let Some((&magic, rest)) = frame.split_first() else {
        return;
    };
    let (head, id) = match magic {
        v2::MAGIC if rest.len() >= 9 => (
            v2::HEADER_LEN,
            u32::from_le_bytes([rest[6], rest[7], rest[8], 0]),
        ),
        v1::MAGIC if rest.len() >= 5 => (v1::HEADER_LEN, u32::from(rest[4])),
        _ => return,
    };
    if id != SETUP_SIGNING_ID {
        return;
    }
    let len = usize::from(frame[1]);
    let Some(payload) = frame.get_mut(head..head + len) else {
        return;
    };
    for b in payload
        .iter_mut()
        .skip(SECRET_KEY.start)
        .take(SECRET_KEY.len())
    {
        *b = 0;
    }
    let body = head + len;
    let mut digest = mcrf4xx_digest();
    digest.update(&frame[1..body]);
    digest.update(&[SETUP_SIGNING_CRC_EXTRA]);
    let crc = digest.finalize();
    if let Some(slot) = frame.get_mut(body..body + 2) {
        slot.copy_from_slice(&crc.to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{mpsc, Arc, Mutex};
    use std::time::Duration;

    use ferrolink_runtime::mavlink::Header;

    use super::*;

    /// An output that takes nothing until it is told to, then keeps what it is given.
    struct Stalled {
        open: mpsc::Receiver<()>,
        opened: bool,
        got: Arc<Mutex<Vec<u8>>>,
    }

    impl Write for Stalled {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            if !self.opened {
                self.opened = self.open.recv().is_ok();
            }
            self.got.lock().expect("lock").extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_spool_whose_file_stalls_drops_whole_chunks_and_counts_their_records() {
        let (open, opened) = mpsc::channel();
        let got = Arc::new(Mutex::new(Vec::new()));
        let mut spool = Spool::new(Stalled {
            open: opened,
            opened: false,
            got: Arc::clone(&got),
        });
        let mut frame = [0u8; v2::MAX_FRAME_LEN];
        // Twice what the spool holds, in frames of every length.
        let mut taken = 0;
        let mut seq = 0u8;
        while taken < 2 * Spool::CHUNK * (Spool::CHUNKS + 1) {
            let payload = [seq | 1; 40];
            let len = 1 + usize::from(seq) % 40;
            let n = v2::encode_raw(Header::new(seq, 1, 1), 0, 50, &payload[..len], &mut frame)
                .expect("fits");
            spool.write(u64::from(seq), &frame[..n]);
            taken += 8 + n;
            seq = seq.wrapping_add(1);
        }
        assert!(spool.dropped() > 0);
        open.send(()).expect("open");
        spool
            .flush_until(Instant::now() + Duration::from_secs(10))
            .expect("flushed");
        let got = got.lock().expect("lock");
        let mut read = 0;
        let stats = read_tlog(&got, &[], |_| read += 1);
        // Only whole records, and what was written and what was dropped add up.
        assert_eq!(stats.skipped_bytes + stats.truncated_bytes, 0, "{stats:?}");
        assert_eq!(read + spool.dropped(), spool.records());
        assert!(spool.failure().is_none());
    }

    /// An output that fails every write, as a full disk does.
    struct Full;

    impl Write for Full {
        fn write(&mut self, _: &[u8]) -> io::Result<usize> {
            Err(io::Error::other("no space left on device"))
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_spool_whose_file_fails_says_so_and_counts_what_it_lost() {
        let mut spool = Spool::new(Full);
        spool.write(1, &[v2::MAGIC]);
        assert!(spool
            .flush_until(Instant::now() + Duration::from_secs(10))
            .is_err());
        assert!(spool.failure().is_some());
        spool.write(2, &[v2::MAGIC]);
        spool.hand_over();
        assert_eq!((spool.records(), spool.dropped()), (2, 1));
    }
}
