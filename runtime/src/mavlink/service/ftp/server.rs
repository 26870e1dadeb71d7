//! The FTP server over the caller's [`FileSystem`].

use super::super::messages::Message;
use super::super::Address;
use super::{push_entry, Entry, EntryKind, FileSystem, Nak, Opcode, Payload, MAX_DATA};

/// The server's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServerConfig {
    /// Our own address.
    pub own: Address,
    /// Replies in one burst before `burst_complete` (the client then asks for the next burst):
    /// 64 by default, about 15 kB, so that a burst fits in a socket's receive buffer and a
    /// client that lost the end of one waits no longer than a burst takes.
    pub burst_replies: u16,
    /// The gap between the replies of a burst (µs): 0 by default, as fast as the caller sends.
    /// A firmware on a slow UART sets it to the time a reply takes on the wire.
    pub burst_gap_us: u64,
    /// A session unused this long (µs) is closed when a new one is needed and none is free,
    /// so a client that vanished holding one locks no one out: 5 s by default.
    pub session_idle_us: u64,
    /// How long after a request the same request (the same bytes from the same sender) is a
    /// repeat, answered with the first reply: 3 s by default. Later, it runs again: a new
    /// client that starts its numbering where an old one did is not answered from the past.
    pub repeat_window_us: u64,
}

impl ServerConfig {
    /// The defaults, as `own`.
    pub const fn new(own: Address) -> Self {
        Self {
            own,
            burst_replies: 64,
            burst_gap_us: 0,
            session_idle_us: 5_000_000,
            repeat_window_us: 3_000_000,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Read { size: u32 },
    Write,
}

#[derive(Debug, Clone, Copy)]
struct Session {
    /// The number on the wire: the one the client asked for when it is free (pymavlink and
    /// ArduPilot number sessions on the client's side), another otherwise (PX4 and MAVSDK
    /// clients use the one the reply gives).
    wire: u8,
    mode: Mode,
    used_us: u64,
}

#[derive(Debug, Clone, Copy)]
struct Burst {
    to: Address,
    /// The session's slot, and its number on the wire.
    session: u8,
    wire: u8,
    seq: u16,
    offset: u32,
    end: u32,
    chunk: usize,
    left: u16,
    next_us: u64,
}

/// The FTP server, with `S` sessions (files open at once, 1 to 255).
///
/// A repeat of the last request (its reply was lost) is answered with the same reply and not
/// run again, so a repeated create, write, remove or rename does no harm and reports what the
/// first did. A late copy of an earlier one that would change something or open or close a
/// session (of the last eight such, within [`ServerConfig::repeat_window_us`]) is dropped;
/// reads, writes at an offset, listings and CRCs run again, and however many of them a client
/// pipelines, they never push a create out of that memory. A repeated burst read starts the
/// burst again.
#[derive(Debug, Clone)]
pub struct Server<const S: usize> {
    config: ServerConfig,
    sessions: [Option<Session>; S],
    replies: [Option<(Address, Payload)>; 4],
    /// The last request (its sender, bytes and arrival) and its reply.
    last: Option<(Address, [u8; 251], u64, Payload)>,
    /// The requests that must not run twice before it: sender, CRC-32 of the bytes, arrival.
    recent: [Option<(Address, u32, u64)>; 8],
    burst: Option<Burst>,
    dropped: usize,
}

impl<const S: usize> Server<S> {
    /// A server with no open sessions.
    pub fn new(config: ServerConfig) -> Self {
        Self {
            config,
            sessions: [None; S],
            replies: [None; 4],
            last: None,
            recent: [None; 8],
            burst: None,
            dropped: 0,
        }
    }

    /// Its settings.
    pub fn config(&self) -> &ServerConfig {
        &self.config
    }

    /// Replies dropped because the caller did not drain [`Server::poll_transmit`] in time.
    pub fn dropped(&self) -> usize {
        self.dropped
    }

    /// Sessions open.
    pub fn open_sessions(&self) -> usize {
        self.sessions.iter().flatten().count()
    }

    fn queue(&mut self, to: Address, reply: Payload) {
        match self.replies.iter_mut().find(|s| s.is_none()) {
            Some(slot) => *slot = Some((to, reply)),
            None => crate::bump(&mut self.dropped, 1),
        }
    }

    /// A message from `from`. FILE_TRANSFER_PROTOCOL requests for us are served from `fs`;
    /// anything else is ignored.
    pub fn handle<F: FileSystem + ?Sized>(
        &mut self,
        fs: &mut F,
        now_us: u64,
        from: Address,
        msg: &Message,
    ) {
        let Message::FileTransferProtocol(m) = msg else {
            return;
        };
        if !self
            .config
            .own
            .is_addressed_by(m.target_system, m.target_component)
        {
            return;
        }
        let req = Payload::parse(&m.payload);
        let Some(op) = Opcode::from_u8(req.opcode) else {
            self.queue(from, Payload::nak(&req, Nak::UnknownCommand));
            return;
        };
        if matches!(op, Opcode::None | Opcode::Ack | Opcode::Nak) {
            return;
        }
        if let Some((to, bytes, at, reply)) = self.last {
            let repeat = to == from
                && bytes == m.payload
                && now_us.saturating_sub(at) < self.config.repeat_window_us;
            if repeat && op != Opcode::BurstReadFile {
                self.queue(from, reply);
                return;
            }
        }
        // A late copy of an earlier request (a radio repeats frames, and delays some): one that
        // would change something, or open or close a session, is not run again. Its client had
        // its answer, or it would not have gone on to another request. Reads and writes at an
        // offset do no harm run twice, and pipelined clients retry them out of turn.
        let fingerprint = crate::crc::FTP_CRC32.checksum(&m.payload);
        let window = self.config.repeat_window_us;
        let seen = self.recent.iter().flatten().any(|&(to, crc, at)| {
            to == from && crc == fingerprint && now_us.saturating_sub(at) < window
        });
        let harmless = matches!(
            op,
            Opcode::ReadFile
                | Opcode::WriteFile
                | Opcode::ListDirectory
                | Opcode::BurstReadFile
                | Opcode::CalcFileCRC32
        );
        // Only what must not run twice is remembered: a window of pipelined writes would
        // otherwise push out the create that opened their session, and a late copy of it would
        // create the file again under them.
        if !harmless {
            if seen {
                return;
            }
            self.recent.rotate_right(1);
            self.recent[0] = Some((from, fingerprint, now_us));
        }
        if usize::from(req.size) > MAX_DATA {
            let reply = Payload::nak(&req, Nak::InvalidDataSize);
            self.answer(from, &m.payload, now_us, reply);
            return;
        }
        let reply = match self.serve(fs, now_us, from, op, &req) {
            Ok(Some(reply)) => reply,
            Ok(None) => return,
            Err(why) => {
                // The offset asked for, so that a client can tell an end-of-file NAK of its
                // read from a stale one (pymavlink does).
                let mut nak = Payload::nak(&req, why);
                nak.offset = req.offset;
                nak
            }
        };
        self.answer(from, &m.payload, now_us, reply);
    }

    fn answer(&mut self, to: Address, request: &[u8; 251], now_us: u64, reply: Payload) {
        self.last = Some((to, *request, now_us, reply));
        self.queue(to, reply);
    }

    /// Serves one request: its reply, or `None` when the reply is a burst.
    fn serve<F: FileSystem + ?Sized>(
        &mut self,
        fs: &mut F,
        now_us: u64,
        from: Address,
        op: Opcode,
        req: &Payload,
    ) -> Result<Option<Payload>, Nak> {
        let mut ack = Payload::reply(req, Opcode::Ack);
        let path = || req.path(0).filter(|p| !p.is_empty()).ok_or(Nak::Fail);
        match op {
            Opcode::TerminateSession => {
                if let Some(slot) = self.slot_of(req.session) {
                    self.close(fs, slot);
                }
            }
            Opcode::ResetSessions => {
                for s in 0..S {
                    self.close(fs, s as u8);
                }
            }
            Opcode::ListDirectory => {
                let path = req.path(0).ok_or(Nak::Fail)?;
                let mut used = 0;
                let mut data = [0; MAX_DATA];
                fs.list(path, req.offset, &mut |entry: Entry<'_>| {
                    if push_entry(&mut data, &mut used, entry) {
                        return true;
                    }
                    // An entry too long for any reply is listed as a skip, so the index
                    // still moves on.
                    if used == 0 {
                        let skip = Entry {
                            kind: EntryKind::Skip,
                            name: "",
                            size: 0,
                        };
                        push_entry(&mut data, &mut used, skip);
                    }
                    false
                })?;
                if used == 0 {
                    return Err(Nak::Eof);
                }
                ack.set_bytes(&data[..used]);
                ack.offset = req.offset;
            }
            Opcode::OpenFileRO | Opcode::CreateFile | Opcode::OpenFileWO => {
                let path = path()?;
                let slot = self.allocate(fs, now_us)?;
                let opened = match op {
                    Opcode::OpenFileRO => fs
                        .open_read(slot, path)
                        .map(|size| (Mode::Read { size }, size)),
                    _ => fs
                        .open_write(slot, path, op == Opcode::CreateFile)
                        .map(|size| (Mode::Write, size)),
                };
                let (mode, size) = opened?;
                let wire = if self.slot_of(req.session).is_none() {
                    req.session
                } else {
                    (0..=u8::MAX)
                        .find(|&w| self.slot_of(w).is_none())
                        .unwrap_or(slot)
                };
                self.sessions[usize::from(slot)] = Some(Session {
                    wire,
                    mode,
                    used_us: now_us,
                });
                ack.session = wire;
                if op != Opcode::CreateFile {
                    ack.set_bytes(&size.to_le_bytes());
                }
            }
            Opcode::ReadFile => {
                let (slot, size) = self.reading(req.session, now_us)?;
                if req.offset >= size {
                    return Err(Nak::Eof);
                }
                let want = chunk(req.size).min((size - req.offset) as usize);
                let n = fs.read(slot, req.offset, &mut ack.data[..want])?;
                if n == 0 {
                    return Err(Nak::Eof);
                }
                ack.size = n.min(want) as u8;
                ack.offset = req.offset;
            }
            Opcode::BurstReadFile => {
                let (slot, size) = self.reading(req.session, now_us)?;
                if req.offset >= size {
                    return Err(Nak::Eof);
                }
                self.burst = Some(Burst {
                    to: from,
                    session: slot,
                    wire: req.session,
                    seq: req.seq.wrapping_add(1),
                    offset: req.offset,
                    end: size,
                    chunk: chunk(req.size),
                    left: self.config.burst_replies.max(1),
                    next_us: now_us,
                });
                return Ok(None);
            }
            Opcode::WriteFile => {
                let slot = match self.session(req.session, now_us) {
                    Some((slot, Mode::Write)) => slot,
                    _ => return Err(Nak::InvalidSession),
                };
                fs.write(slot, req.offset, req.bytes())?;
                ack.offset = req.offset;
            }
            Opcode::RemoveFile => fs.remove_file(path()?)?,
            Opcode::CreateDirectory => fs.create_dir(path()?)?,
            Opcode::RemoveDirectory => fs.remove_dir(path()?)?,
            Opcode::TruncateFile => fs.truncate(path()?, req.offset)?,
            Opcode::Rename => {
                let to = req.path(1).filter(|p| !p.is_empty()).ok_or(Nak::Fail)?;
                fs.rename(path()?, to)?;
            }
            Opcode::CalcFileCRC32 => {
                let path = path()?;
                let slot = self.allocate(fs, now_us)?;
                ack.set_bytes(&crc_of(fs, slot, path)?.to_le_bytes());
            }
            Opcode::None | Opcode::Ack | Opcode::Nak => return Ok(None),
        }
        Ok(Some(ack))
    }

    /// The slot of the open session numbered `wire`.
    fn slot_of(&self, wire: u8) -> Option<u8> {
        let slot = self
            .sessions
            .iter()
            .position(|s| s.is_some_and(|s| s.wire == wire))?;
        Some(slot as u8)
    }

    /// The slot and mode of the open session numbered `wire`, marked used now.
    fn session(&mut self, wire: u8, now_us: u64) -> Option<(u8, Mode)> {
        let slot = self.slot_of(wire)?;
        let s = self.sessions[usize::from(slot)].as_mut()?;
        s.used_us = now_us;
        Some((slot, s.mode))
    }

    /// The slot and file size of the session numbered `wire`, open for reading.
    fn reading(&mut self, wire: u8, now_us: u64) -> Result<(u8, u32), Nak> {
        match self.session(wire, now_us) {
            Some((slot, Mode::Read { size })) => Ok((slot, size)),
            _ => Err(Nak::InvalidSession),
        }
    }

    fn close<F: FileSystem + ?Sized>(&mut self, fs: &mut F, session: u8) {
        if let Some(slot) = self.sessions.get_mut(usize::from(session)) {
            if slot.take().is_some() {
                fs.close(session);
            }
        }
        if self.burst.is_some_and(|b| b.session == session) {
            self.burst = None;
        }
    }

    /// The lowest free session, or the one idle longest if idle past the limit.
    fn allocate<F: FileSystem + ?Sized>(&mut self, fs: &mut F, now_us: u64) -> Result<u8, Nak> {
        if let Some(free) = self.sessions.iter().position(Option::is_none) {
            return Ok(free as u8);
        }
        let idle = self
            .sessions
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.map(|s| (i, s.used_us)))
            .filter(|&(_, used)| now_us.saturating_sub(used) >= self.config.session_idle_us)
            .min_by_key(|&(_, used)| used);
        match idle {
            Some((i, _)) => {
                self.close(fs, i as u8);
                Ok(i as u8)
            }
            None => Err(Nak::NoSessionsAvailable),
        }
    }

    /// The next message to send: replies first, then the next reply of a burst when due.
    pub fn poll_transmit<F: FileSystem + ?Sized>(
        &mut self,
        fs: &mut F,
        now_us: u64,
    ) -> Option<Message> {
        if let Some((to, reply)) = self.replies[0].take() {
            self.replies.rotate_left(1);
            return Some(reply.to_message(to));
        }
        let mut b = self.burst?;
        if now_us < b.next_us {
            return None;
        }
        let req = Payload::request(
            b.seq.wrapping_sub(1),
            b.wire,
            Opcode::BurstReadFile,
            b.offset,
        );
        let mut reply = Payload::reply(&req, Opcode::Ack);
        let want = b.chunk.min((b.end - b.offset) as usize);
        match fs.read(b.session, b.offset, &mut reply.data[..want]) {
            Ok(n) if n > 0 => {
                reply.size = n.min(want) as u8;
                reply.offset = b.offset;
                b.offset += u32::from(reply.size);
                b.left -= 1;
                reply.burst_complete = b.offset >= b.end || b.left == 0;
            }
            Ok(_) => {
                reply = Payload::nak(&req, Nak::Eof);
                reply.offset = b.offset;
                reply.burst_complete = true;
            }
            Err(why) => {
                reply = Payload::nak(&req, why);
                reply.burst_complete = true;
            }
        }
        b.seq = b.seq.wrapping_add(1);
        b.next_us = now_us.saturating_add(self.config.burst_gap_us);
        if let Some(s) = self.sessions[usize::from(b.session)].as_mut() {
            s.used_us = now_us;
        }
        self.burst = (!reply.burst_complete).then_some(b);
        Some(reply.to_message(b.to))
    }

    /// When to call [`Server::poll_transmit`] again if nothing arrives: now while replies
    /// wait, else when a burst's next reply is due.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.replies[0].is_some() {
            return Some(0);
        }
        self.burst.map(|b| b.next_us)
    }
}

/// Data per read reply for a request's `size`: as asked, 0 and anything over the maximum
/// meaning a full reply.
fn chunk(size: u8) -> usize {
    match usize::from(size) {
        0 => MAX_DATA,
        n => n.min(MAX_DATA),
    }
}

/// The CRC-32 of file `path`, read through the free slot `session` and closed again.
fn crc_of<F: FileSystem + ?Sized>(fs: &mut F, session: u8, path: &str) -> Result<u32, Nak> {
    let size = fs.open_read(session, path)?;
    let crc = crc_open(fs, session, size);
    fs.close(session);
    crc
}

fn crc_open<F: FileSystem + ?Sized>(fs: &mut F, session: u8, size: u32) -> Result<u32, Nak> {
    let mut digest = crate::crc::FTP_CRC32.digest();
    let mut buf = [0; MAX_DATA];
    let mut at = 0u32;
    while at < size {
        let n = fs.read(session, at, &mut buf)?;
        if n == 0 {
            break;
        }
        digest.update(&buf[..n.min(MAX_DATA)]);
        at += n.min(MAX_DATA) as u32;
    }
    Ok(digest.finalize())
}
