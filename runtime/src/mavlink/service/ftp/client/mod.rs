//! The FTP client: lists, reads (in bursts, with what a burst lost read again by offset),
//! writes, and the one-request operations.

use super::super::messages::Message;
use super::super::{Address, Busy, Retry, Rtt};
use super::buffers::{Chunk, Gaps, Source};
use super::{entries, Nak, Opcode, Payload, MAX_DATA};

mod window;

/// Why an operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// The server refused it.
    Nak(Nak),
    /// No answer after the retries.
    Timeout,
    /// A path (or two, for a rename) longer than a request holds.
    PathTooLong,
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Nak(nak) => write!(f, "the vehicle refused: {nak}"),
            Error::Timeout => f.write_str("no answer after the retries"),
            Error::PathTooLong => write!(f, "path longer than {} bytes", MAX_DATA - 1),
        }
    }
}

/// What an operation brought.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// A reply's worth of directory entries: read them with [`super::entries`].
    Listing(Chunk),
    /// The size of the file being read, once it is open.
    Size(u32),
    /// File bytes at `offset`. Chunks come in any order; one may repeat bytes of an earlier
    /// one (write each at its offset).
    Data {
        /// Where in the file.
        offset: u32,
        /// The bytes.
        bytes: Chunk,
    },
    /// The operation ended: with the CRC-32 for [`Client::crc32`], `None` for the others.
    Done(Result<Option<u32>, Error>),
}

/// The client's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConfig {
    /// Our own address.
    pub own: Address,
    /// The longest wait for an answer, and how many such waits of silence end an operation:
    /// 1 s and 5 by default. Below it, waits follow the measured round trip ([`Rtt`]).
    pub retry: Retry,
    /// Reads or writes outstanding at once while filling what bursts lost and while writing:
    /// 8 by default, at most 16.
    pub window: u8,
}

impl ClientConfig {
    /// The defaults, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            retry: Retry {
                timeout_us: 1_000_000,
                retries: 5,
            },
            window: 8,
        }
    }
}

const SLOTS: usize = 16;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Open,
    Burst,
    Fill,
    Data,
    Close,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    Idle,
    /// One request; `crc` when its ACK carries a CRC-32.
    Simple {
        crc: bool,
    },
    List,
    Read(Phase),
    Write(Phase),
}

/// One request out and its retries.
#[derive(Debug, Clone, Copy)]
struct Pending {
    seq: u16,
    offset: u32,
    len: u8,
    tries: u8,
    deadline: u64,
    due: bool,
    sent_us: Option<u64>,
}

/// The FTP client for one target, one operation at a time.
#[derive(Debug, Clone)]
pub struct Client {
    config: ClientConfig,
    target: Address,
    op: Op,
    /// The request of a one-request step (its data is the path, or the two of a rename).
    request: Payload,
    single: Option<Pending>,
    slots: [Option<Pending>; SLOTS],
    seq: u16,
    /// The first sequence number of the operation: replies from before it are stale.
    epoch: u16,
    session: u8,
    size: u32,
    /// Reading: bytes up to here were received or are in `gaps`. Writing: sent up to here.
    mark: u32,
    /// Writing: bytes acknowledged.
    acked: u32,
    gaps: Gaps,
    /// A reply of the current burst arrived.
    burst_heard: bool,
    rtt: Rtt,
    heard_us: u64,
    sends: u8,
    /// A TerminateSession to send once, for an operation that failed with a session open.
    closing: bool,
    events: [Option<Event>; 4],
}

impl Client {
    /// A client for `target`.
    pub fn new(config: ClientConfig, target: Address) -> Self {
        Self {
            config,
            target,
            op: Op::Idle,
            request: Payload::request(0, 0, Opcode::None, 0),
            single: None,
            slots: [None; SLOTS],
            seq: 0,
            epoch: 0,
            session: 0,
            size: 0,
            mark: 0,
            acked: 0,
            gaps: Gaps::new(),
            burst_heard: false,
            rtt: Rtt::default(),
            heard_us: 0,
            sends: 0,
            closing: false,
            events: [None; 4],
        }
    }

    /// The client, numbering its requests from `seq`. A program that makes a client per run
    /// starts each from a different number (the clock's, say), so that a server that answers
    /// a repeated request from its last reply does not take the new run's first request for
    /// the last run's.
    pub fn with_seq(mut self, seq: u16) -> Self {
        self.seq = seq;
        self
    }

    /// The sequence number the next request will carry.
    pub fn seq(&self) -> u16 {
        self.seq
    }

    /// Its settings.
    pub fn config(&self) -> &ClientConfig {
        &self.config
    }

    /// Whether no operation is under way.
    pub fn is_idle(&self) -> bool {
        self.op == Op::Idle
    }

    /// Bytes transferred so far and the file's size, while reading or writing.
    pub fn progress(&self) -> (u32, u32) {
        match self.op {
            Op::Read(_) => (self.mark - self.gaps.missing(), self.size),
            Op::Write(_) => (self.acked, self.size),
            _ => (0, 0),
        }
    }

    /// The measured round trip.
    pub fn rtt(&self) -> Rtt {
        self.rtt
    }

    fn begin(&mut self, now_us: u64, op: Op, opcode: Opcode, paths: &[&str]) -> Result<(), Busy> {
        if self.op != Op::Idle {
            return Err(Busy);
        }
        self.op = op;
        self.epoch = self.seq;
        self.mark = 0;
        self.acked = 0;
        self.size = 0;
        self.gaps = Gaps::new();
        self.slots = [None; SLOTS];
        self.heard_us = now_us;
        self.sends = 0;
        let mut data = [0u8; MAX_DATA];
        let mut used = 0;
        for path in paths {
            let b = path.as_bytes();
            if used + b.len() + 1 > MAX_DATA {
                self.finish(Err(Error::PathTooLong));
                return Ok(());
            }
            data[used..used + b.len()].copy_from_slice(b);
            used += b.len() + 1;
        }
        // Each path with its NUL, counted in `size`, as MAVSDK and pymavlink send them.
        self.request = Payload::request(0, 0, opcode, 0);
        self.request.set_bytes(&data[..used]);
        self.send_single(opcode, 0, 0);
        Ok(())
    }

    /// Lists directory `path`: [`Event::Listing`]s, then [`Event::Done`].
    pub fn list(&mut self, now_us: u64, path: &str) -> Result<(), Busy> {
        self.begin(now_us, Op::List, Opcode::ListDirectory, &[path])
    }

    /// Reads file `path`: [`Event::Size`], [`Event::Data`]s, then [`Event::Done`].
    pub fn read(&mut self, now_us: u64, path: &str) -> Result<(), Busy> {
        self.begin(now_us, Op::Read(Phase::Open), Opcode::OpenFileRO, &[path])
    }

    /// Writes `size` bytes, taken from the [`Source`] given to [`Client::poll_transmit`], to
    /// file `path`, created or emptied first.
    pub fn write(&mut self, now_us: u64, path: &str, size: u32) -> Result<(), Busy> {
        self.begin(now_us, Op::Write(Phase::Open), Opcode::CreateFile, &[path])?;
        self.size = size;
        Ok(())
    }

    /// Removes file `path`.
    pub fn remove(&mut self, now_us: u64, path: &str) -> Result<(), Busy> {
        self.begin(
            now_us,
            Op::Simple { crc: false },
            Opcode::RemoveFile,
            &[path],
        )
    }

    /// Creates directory `path`.
    pub fn create_dir(&mut self, now_us: u64, path: &str) -> Result<(), Busy> {
        self.begin(
            now_us,
            Op::Simple { crc: false },
            Opcode::CreateDirectory,
            &[path],
        )
    }

    /// Removes directory `path`.
    pub fn remove_dir(&mut self, now_us: u64, path: &str) -> Result<(), Busy> {
        self.begin(
            now_us,
            Op::Simple { crc: false },
            Opcode::RemoveDirectory,
            &[path],
        )
    }

    /// Renames `from` to `to`.
    pub fn rename(&mut self, now_us: u64, from: &str, to: &str) -> Result<(), Busy> {
        self.begin(
            now_us,
            Op::Simple { crc: false },
            Opcode::Rename,
            &[from, to],
        )
    }

    /// Cuts or extends file `path` to `len` bytes.
    pub fn truncate(&mut self, now_us: u64, path: &str, len: u32) -> Result<(), Busy> {
        self.begin(
            now_us,
            Op::Simple { crc: false },
            Opcode::TruncateFile,
            &[path],
        )?;
        self.request.offset = len;
        Ok(())
    }

    /// The CRC-32 of file `path` ([`crate::crc::FTP_CRC32`]), in [`Event::Done`].
    pub fn crc32(&mut self, now_us: u64, path: &str) -> Result<(), Busy> {
        self.begin(
            now_us,
            Op::Simple { crc: true },
            Opcode::CalcFileCRC32,
            &[path],
        )
    }

    fn next_seq(&mut self) -> u16 {
        let s = self.seq;
        self.seq = self.seq.wrapping_add(1);
        s
    }

    /// Queues the one-request step `opcode` (with the path data for the path operations).
    fn send_single(&mut self, opcode: Opcode, offset: u32, len: u8) {
        self.request.opcode = opcode as u8;
        self.request.session = self.session;
        if !matches!(opcode, Opcode::TruncateFile) {
            self.request.offset = offset;
        }
        if matches!(opcode, Opcode::TerminateSession | Opcode::BurstReadFile) {
            self.request.size = len;
        }
        self.burst_heard = false;
        self.single = Some(Pending {
            seq: self.next_seq(),
            offset,
            len,
            tries: 0,
            deadline: 0,
            due: true,
            sent_us: None,
        });
    }

    fn push(&mut self, event: Event) {
        match self.events.iter_mut().find(|e| e.is_none()) {
            Some(slot) => *slot = Some(event),
            None => {
                // The end must get through. Data and listings never get here: they wait for
                // room (`has_event_room`), so what this drops is never bytes of the file.
                self.events.rotate_left(1);
                self.events[3] = Some(event);
            }
        }
    }

    /// Room for one more [`Event::Data`] or [`Event::Listing`] and the [`Event::Done`] that
    /// may follow it. Without it, what arrives is treated as lost and asked for again.
    fn has_event_room(&self) -> bool {
        self.events.iter().filter(|e| e.is_none()).count() >= 2
    }

    fn finish(&mut self, result: Result<Option<u32>, Error>) {
        self.op = Op::Idle;
        self.single = None;
        self.slots = [None; SLOTS];
        self.push(Event::Done(result));
    }

    /// Ends a read or write: closes the session, then reports `result`.
    fn close(&mut self, phase_of: fn(Phase) -> Op) {
        self.op = phase_of(Phase::Close);
        self.slots = [None; SLOTS];
        self.request.set_bytes(&[]);
        self.send_single(Opcode::TerminateSession, 0, 0);
    }

    /// What a read does next, once a burst or the fill step has ended.
    fn read_next(&mut self) {
        self.single = None;
        if !self.gaps.as_slice().is_empty() && (self.gaps.is_full() || self.mark >= self.size) {
            self.op = Op::Read(Phase::Fill);
        } else if self.mark < self.size {
            self.op = Op::Read(Phase::Burst);
            self.request.set_bytes(&[]);
            self.send_single(Opcode::BurstReadFile, self.mark, MAX_DATA as u8);
        } else {
            self.close(Op::Read);
        }
    }

    /// Bytes read at `offset`: an [`Event::Data`] if any of them were missing. While the
    /// events are not taken, they are treated as lost, and read again later.
    fn take(&mut self, offset: u32, bytes: &[u8]) {
        let end = offset.saturating_add(bytes.len() as u32).min(self.size);
        if offset >= end || !self.has_event_room() {
            return;
        }
        let mut new = false;
        if offset > self.mark {
            if !self.gaps.push(self.mark, offset) {
                return;
            }
        } else if offset < self.mark {
            new |= self.gaps.fill(offset, end.min(self.mark));
        }
        if end > self.mark {
            self.mark = end;
            new = true;
        }
        if new {
            let n = (end - offset) as usize;
            self.push(Event::Data {
                offset,
                bytes: Chunk::new(&bytes[..n]),
            });
        }
    }

    fn heard(&mut self, now_us: u64) {
        self.heard_us = now_us;
        self.sends = 0;
    }

    fn sample(&mut self, now_us: u64, sent_us: Option<u64>) {
        if let Some(sent) = sent_us {
            self.rtt.sample(now_us.saturating_sub(sent));
        }
    }

    /// A message from `from`: replies from the target to us move the operation on.
    pub fn handle(&mut self, now_us: u64, from: Address, msg: &Message) {
        let Message::FileTransferProtocol(m) = msg else {
            return;
        };
        if from.system != self.target.system
            || (self.target.component != 0 && from.component != self.target.component)
            || !self
                .config
                .own
                .is_addressed_by(m.target_system, m.target_component)
        {
            return;
        }
        let p = Payload::parse(&m.payload);
        let nak = match Opcode::from_u8(p.opcode) {
            Some(Opcode::Ack) => None,
            Some(Opcode::Nak) => Some(Nak::from_data(p.bytes())),
            _ => return,
        };
        // Later operations start past every sequence number the server used.
        if p.seq.wrapping_sub(self.seq) < 0x8000 {
            self.seq = p.seq.wrapping_add(1);
        }
        if self.op == Op::Idle || p.seq.wrapping_sub(self.epoch) >= 0x8000 {
            return;
        }
        let req_opcode = Opcode::from_u8(p.req_opcode);
        if req_opcode == Some(Opcode::BurstReadFile) {
            // A burst reply is answered data wherever it falls: one held back past its burst
            // still fills a gap. It is never the answer to a read (its sequence number may
            // be the one a read waits for).
            if p.session == self.session {
                match self.op {
                    Op::Read(Phase::Burst) => self.on_burst(now_us, &p, nak),
                    Op::Read(Phase::Fill) if nak.is_none() => {
                        self.take(p.offset, p.bytes());
                        self.fill_done();
                    }
                    _ => {}
                }
            }
            return;
        }
        if let Some(single) = self.single {
            if p.seq == single.seq.wrapping_add(1) && p.req_opcode == self.request.opcode {
                self.single = None;
                self.heard(now_us);
                if single.tries == 0 {
                    self.sample(now_us, single.sent_us);
                }
                self.on_single(&p, nak);
                return;
            }
        }
        // The answer to a read or a write: its sequence number, the opcode answered, and for
        // a read's data the offset asked (every server echoes it).
        let expected = match self.op {
            Op::Read(Phase::Fill) => Opcode::ReadFile,
            Op::Write(Phase::Data) => Opcode::WriteFile,
            _ => return,
        };
        if req_opcode != Some(expected) {
            return;
        }
        let slot = self.slots.iter().position(|s| {
            s.is_some_and(|s| {
                s.seq.wrapping_add(1) == p.seq
                    && (expected != Opcode::ReadFile || nak.is_some() || p.offset == s.offset)
            })
        });
        if let Some(i) = slot {
            let Some(s) = self.slots[i].take() else {
                return;
            };
            self.heard(now_us);
            if s.tries == 0 {
                self.sample(now_us, s.sent_us);
            }
            self.on_slot(s, &p, nak);
        }
    }

    fn on_single(&mut self, p: &Payload, nak: Option<Nak>) {
        match (self.op, nak) {
            (Op::Simple { crc }, None) => {
                let value = match (crc, p.bytes()) {
                    (true, [a, b, c, d, ..]) => Some(u32::from_le_bytes([*a, *b, *c, *d])),
                    _ => None,
                };
                self.finish(Ok(value));
            }
            (Op::List, None) if p.size > 0 => {
                // With no room for the entries, ask for them again rather than lose them.
                let mut index = self.request.offset;
                if self.has_event_room() {
                    index += entries(p.bytes()).count() as u32;
                    self.push(Event::Listing(Chunk::new(p.bytes())));
                }
                self.send_single(Opcode::ListDirectory, index, 0);
            }
            (Op::List, None) | (Op::List, Some(Nak::Eof)) => self.finish(Ok(None)),
            (Op::Read(Phase::Open), None) => {
                self.session = p.session;
                self.size = match p.bytes() {
                    [a, b, c, d, ..] => u32::from_le_bytes([*a, *b, *c, *d]),
                    _ => 0,
                };
                self.push(Event::Size(self.size));
                self.read_next();
            }
            (Op::Write(Phase::Open), None) => {
                self.session = p.session;
                self.op = Op::Write(Phase::Data);
                if self.size == 0 {
                    self.close(Op::Write);
                }
            }
            (Op::Read(Phase::Close) | Op::Write(Phase::Close), _) => self.finish(Ok(None)),
            (_, Some(nak)) => self.fail(nak),
            _ => {}
        }
    }

    /// Fails the operation, closing a session it opened.
    fn fail(&mut self, nak: Nak) {
        let opened = matches!(
            self.op,
            Op::Read(Phase::Burst | Phase::Fill) | Op::Write(Phase::Data)
        );
        if opened {
            // Best effort: the server closes an idle session by itself.
            self.request.set_bytes(&[]);
            self.request.opcode = Opcode::TerminateSession as u8;
            self.request.session = self.session;
            self.request.seq = self.next_seq();
            self.finish(Err(Error::Nak(nak)));
            self.closing = true;
        } else {
            self.finish(Err(Error::Nak(nak)));
        }
    }

    /// Once the gaps are filled: the next burst, or the end.
    fn fill_done(&mut self) {
        if self.gaps.as_slice().is_empty() {
            // Reads still out answer bytes already here.
            self.slots = [None; SLOTS];
            self.read_next();
        }
    }

    fn on_burst(&mut self, now_us: u64, p: &Payload, nak: Option<Nak>) {
        if let Some(nak) = nak {
            if nak == Nak::Eof && self.mark >= self.size {
                self.read_next();
            } else {
                self.fail(nak);
            }
            return;
        }
        self.heard(now_us);
        self.burst_heard = true;
        if let Some(single) = self.single.as_mut() {
            // The burst is alive: wait for its next reply, not to ask again.
            single.tries = 0;
            single.deadline = now_us + self.rtt.timeout_us(self.config.retry.timeout_us);
            if let Some(sent) = single.sent_us.take() {
                self.rtt.sample(now_us.saturating_sub(sent));
            }
        }
        self.take(p.offset, p.bytes());
        if p.burst_complete || p.offset.saturating_add(u32::from(p.size)) >= self.size {
            self.read_next();
        }
    }

    fn on_slot(&mut self, s: Pending, p: &Payload, nak: Option<Nak>) {
        match (self.op, nak) {
            (Op::Read(Phase::Fill), None) => {
                self.take(s.offset, p.bytes());
                self.fill_done();
            }
            (Op::Write(Phase::Data), None) => {
                self.acked += u32::from(s.len);
                if self.acked >= self.size && self.slots.iter().all(Option::is_none) {
                    self.close(Op::Write);
                }
            }
            (_, Some(nak)) => self.fail(nak),
            _ => {}
        }
    }

    /// The next message to send, until `None`. Uploads take their bytes from `source`.
    pub fn poll_transmit<S: Source + ?Sized>(
        &mut self,
        now_us: u64,
        source: &mut S,
    ) -> Option<Message> {
        if self.closing {
            self.closing = false;
            return Some(self.request.to_message(self.target));
        }
        if self.op == Op::Idle {
            return None;
        }
        let retry = self.config.retry;
        if let Some(mut single) = self.single {
            if single.due || now_us >= single.deadline {
                if !single.due {
                    if self.op == Op::Read(Phase::Burst) && self.burst_heard {
                        // The end of the burst was lost: go on from where it got to.
                        self.read_next();
                        return self.poll_transmit(now_us, source);
                    }
                    single.tries = single.tries.saturating_add(1);
                    if retry.exhausted(now_us.saturating_sub(self.heard_us), self.sends) {
                        if matches!(self.op, Op::Read(Phase::Close) | Op::Write(Phase::Close)) {
                            // Everything was transferred; the server closes an idle session.
                            self.finish(Ok(None));
                        } else {
                            self.finish(Err(Error::Timeout));
                        }
                        return None;
                    }
                }
                single.due = false;
                single.sent_us = self.rtt.time_sending(now_us, single.tries == 0);
                single.deadline = now_us + self.rtt.backoff_us(retry.timeout_us, single.tries);
                self.sends = self.sends.saturating_add(1);
                self.single = Some(single);
                let mut p = self.request;
                p.seq = single.seq;
                return Some(p.to_message(self.target));
            }
            return None;
        }
        match self.op {
            Op::Read(Phase::Fill) | Op::Write(Phase::Data) => self.window_transmit(now_us, source),
            _ => None,
        }
    }

    /// When to call [`Client::poll_transmit`] again if nothing arrives.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.closing {
            return Some(0);
        }
        let mut at: Option<u64> = None;
        let pending = self.single.iter().chain(self.slots.iter().flatten());
        for p in pending {
            let t = if p.due { 0 } else { p.deadline };
            at = Some(at.map_or(t, |a| a.min(t)));
        }
        if self.has_room() {
            return Some(0);
        }
        at
    }

    /// What an operation brought, until `None`. The client holds four events: while they
    /// are not taken, it takes no more file data or entries (they are asked for again), so
    /// calling this after each [`Client::handle`] keeps a transfer at full speed.
    pub fn poll_event(&mut self) -> Option<Event> {
        let e = self.events[0].take();
        self.events.rotate_left(1);
        e
    }
}
