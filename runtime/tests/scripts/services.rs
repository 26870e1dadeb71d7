//! Scripts of arbitrary bytes for the microservices' state machines, shared by the property
//! tests (`tests/services/main.rs`) and the `mavlink_services` fuzz target.
//!
//! A script is a sequence of steps, each chosen by one byte:
//!
//! - a message (any payload bytes, of one of the services' message ids) from any address,
//!   handed to every server and client (parameters, commands, missions, FTP);
//! - a clock step;
//! - the link: what the clients and the servers sent is delivered to the other side, in order,
//!   for a few rounds of answers, losing the messages a mask byte picks;
//! - the application answering a command it was asked to run;
//! - a client starting an operation (a list, a read, a set, a command).
//!
//! After every step each state machine is polled until it has nothing to send. Invariants:
//!
//! - nothing panics, and no state machine sends without end at one instant;
//! - every PARAM_VALUE the server sends is one of its parameters, at its index, with the value
//!   it holds, and the count it has, or (when it offers it) `_HASH_CHECK` with the hash of what
//!   it holds;
//! - a set never changes a parameter's type;
//! - every COMMAND_ACK goes to the sender of a command, for that command's id;
//! - a client's list ends with no more missing values than the count;
//! - the mission server's store takes an upload only whole: every committed mission has the
//!   count its upload announced, and items are put only in order, each once;
//! - the FTP server reads and writes only through sessions it opened, in the mode it opened
//!   them, and the bytes of every read or burst reply are a file's open for reading, at that
//!   offset;
//!   an FTP client started on a listing, read or write ends with at most one `Done`;
//! - over the link, with no message of that service forged by the script since the operation
//!   began: every byte an FTP read brings is the file's at that offset, a read that ends well
//!   brought every byte, a write that ends well left the file holding what was written, a
//!   CRC-32 that ends well is the file's, an accepted mission upload is what the server's store
//!   holds, and a download that ends well brings what the store holds.

use ferrolink_runtime::crc::FTP_CRC32;
use ferrolink_runtime::mavlink::service::command::{self, Ack, Request};
use ferrolink_runtime::mavlink::service::ftp::{self, Entry, EntryKind, FileSystem, Nak, Payload};
use ferrolink_runtime::mavlink::service::messages::{
    MavCmd, MavMissionResult, MavMissionType, MavResult, Message,
};
use ferrolink_runtime::mavlink::service::mission::{self, Item};
use ferrolink_runtime::mavlink::service::param::{self, Encoding, Name, Param, Store, Value};
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_runtime::mavlink::Dialect;
use std::collections::VecDeque;

const OWN: Address = Address::new(1, 1);
const GCS: Address = Address::new(255, 190);

/// The services' message ids, to draw from.
fn ids() -> Vec<u32> {
    Message::META.iter().map(|m| m.id).collect()
}

fn store() -> Vec<Param> {
    (0..20u16)
        .map(|i| Param {
            name: Name::from(format!("P{i}").as_str()),
            value: match i % 10 {
                0 => Value::U8(i as u8),
                1 => Value::I8(-(i as i8)),
                2 => Value::U16(i * 1000),
                3 => Value::I16(-(i as i16) * 1000),
                4 => Value::U32(u32::from(i) << 20),
                5 => Value::I32(-(i32::from(i) << 20)),
                6 => Value::F32(f32::from(i) / 3.0),
                7 => Value::U64(u64::from(i) << 50),
                8 => Value::I64(-(i64::from(i) << 50)),
                _ => Value::F64(f64::from(i) / 3.0),
            },
        })
        .collect()
}

/// A mission store that checks the server's use of it.
#[derive(Default)]
struct Checked {
    held: Vec<Item>,
    staged: Option<(u16, Vec<Item>)>,
    current: u16,
}

impl mission::Store for Checked {
    fn count(&self, _: MavMissionType) -> u16 {
        self.held.len() as u16
    }
    fn get(&self, _: MavMissionType, seq: u16) -> Option<Item> {
        self.held.get(usize::from(seq)).copied()
    }
    fn begin(&mut self, _: MavMissionType, count: u16) -> bool {
        if count > 500 {
            return false;
        }
        self.staged = Some((count, Vec::new()));
        true
    }
    fn put(&mut self, _: MavMissionType, seq: u16, item: Item) {
        let (count, items) = self.staged.as_mut().expect("an item without an upload");
        assert_eq!(usize::from(seq), items.len(), "items out of order");
        assert!(seq < *count, "an item past the count");
        items.push(item);
    }
    fn commit(&mut self, _: MavMissionType) {
        let (count, items) = self.staged.take().expect("a commit without an upload");
        assert_eq!(items.len(), usize::from(count), "half a mission committed");
        self.held = items;
    }
    fn clear(&mut self, _: MavMissionType) {
        self.held.clear();
    }
    fn current(&self) -> u16 {
        self.current
    }
    fn set_current(&mut self, seq: u16) -> bool {
        self.current = seq;
        true
    }
}

/// Three small files, read and written only as the server may.
struct Files {
    files: Vec<(&'static str, Vec<u8>)>,
    /// Session -> (file index, writable).
    open: Vec<Option<(usize, bool)>>,
}

impl Files {
    fn new() -> Self {
        Self {
            files: vec![
                ("a", (0..=255).collect()),
                ("dir/b", (0..1000u32).map(|i| (i * 7) as u8).collect()),
                ("c", Vec::new()),
            ],
            open: vec![None; 2],
        }
    }

    fn find(&self, path: &str) -> Result<usize, Nak> {
        let p = path.trim_start_matches('/');
        self.files
            .iter()
            .position(|(n, _)| *n == p)
            .ok_or(Nak::FileNotFound)
    }

    fn session(&self, session: u8) -> (usize, bool) {
        let s = self.open.get(usize::from(session)).copied().flatten();
        s.expect("the server used a session it did not open")
    }
}

impl FileSystem for Files {
    fn list(
        &mut self,
        path: &str,
        from: u32,
        out: &mut dyn FnMut(Entry<'_>) -> bool,
    ) -> Result<(), Nak> {
        if !path.trim_matches('/').is_empty() {
            return Err(Nak::FileNotFound);
        }
        let all = [
            Entry {
                kind: EntryKind::File,
                name: "a",
                size: 256,
            },
            Entry {
                kind: EntryKind::Dir,
                name: "dir",
                size: 0,
            },
            Entry {
                kind: EntryKind::File,
                name: "c",
                size: self.files[2].1.len() as u32,
            },
        ];
        for e in all.into_iter().skip(from as usize) {
            if !out(e) {
                break;
            }
        }
        Ok(())
    }
    fn open_read(&mut self, session: u8, path: &str) -> Result<u32, Nak> {
        let i = self.find(path)?;
        assert!(
            self.open[usize::from(session)].is_none(),
            "a session opened twice"
        );
        self.open[usize::from(session)] = Some((i, false));
        Ok(self.files[i].1.len() as u32)
    }
    fn open_write(&mut self, session: u8, path: &str, create: bool) -> Result<u32, Nak> {
        let i = self.find(path)?;
        assert!(
            self.open[usize::from(session)].is_none(),
            "a session opened twice"
        );
        if create {
            self.files[i].1.clear();
        }
        self.open[usize::from(session)] = Some((i, true));
        Ok(self.files[i].1.len() as u32)
    }
    fn read(&mut self, session: u8, offset: u32, buf: &mut [u8]) -> Result<usize, Nak> {
        let (i, _) = self.session(session);
        let rest = self.files[i].1.get(offset as usize..).unwrap_or(&[]);
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        Ok(n)
    }
    fn write(&mut self, session: u8, offset: u32, data: &[u8]) -> Result<(), Nak> {
        let (i, writable) = self.session(session);
        assert!(writable, "a write through a session opened for reading");
        let end = offset as usize + data.len();
        if end > 4096 {
            return Err(Nak::Fail);
        }
        let file = &mut self.files[i].1;
        if file.len() < end {
            file.resize(end, 0);
        }
        file[offset as usize..end].copy_from_slice(data);
        Ok(())
    }
    fn close(&mut self, session: u8) {
        assert!(
            self.open[usize::from(session)].take().is_some(),
            "closed a session not open"
        );
    }
    fn remove_file(&mut self, path: &str) -> Result<(), Nak> {
        self.find(path).and(Err(Nak::FileProtected))
    }
    fn create_dir(&mut self, _: &str) -> Result<(), Nak> {
        Err(Nak::FileProtected)
    }
    fn remove_dir(&mut self, _: &str) -> Result<(), Nak> {
        Err(Nak::FileProtected)
    }
    fn rename(&mut self, from: &str, _: &str) -> Result<(), Nak> {
        self.find(from).and(Err(Nak::FileProtected))
    }
    fn truncate(&mut self, path: &str, len: u32) -> Result<(), Nak> {
        let i = self.find(path)?;
        if len > 4096 {
            return Err(Nak::Fail);
        }
        self.files[i].1.resize(len as usize, 0);
        Ok(())
    }
}

struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn byte(&mut self) -> Option<u8> {
        let (&b, rest) = self.0.split_first()?;
        self.0 = rest;
        Some(b)
    }
    fn take(&mut self, n: usize) -> &[u8] {
        let n = n.min(self.0.len());
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        a
    }
}

/// What a script's operations achieved over the link, so tests can tell the invariants above
/// were reached.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Outcome {
    /// FTP operations that ended well: listings, reads, writes, CRC-32s.
    pub ftp: [usize; 4],
    /// Mission uploads accepted, downloads ended well.
    pub uploads: usize,
    pub downloads: usize,
}

pub fn check_servers(data: &[u8]) -> Outcome {
    let mut outcome = Outcome::default();
    let ids = ids();
    let mut input = Bytes(data);
    let mut params = store();
    let types: Vec<_> = params.iter().map(|p| p.value.param_type()).collect();
    let encoding = if data.first().is_some_and(|b| b & 1 == 1) {
        Encoding::CCast
    } else {
        Encoding::Bytewise
    };
    let hash_check = data.first().is_some_and(|b| b & 2 == 2);
    let mut param_server: param::Server<4> = param::Server::new(param::ServerConfig {
        own: OWN,
        encoding,
        list_interval_us: 0,
        hash_check,
    });
    let mut command_server: command::Server<3> =
        command::Server::new(command::ServerConfig::new(OWN));
    let mut param_config = param::ClientConfig::new(GCS);
    if data.first().is_some_and(|b| b & 4 == 4) {
        param_config.protocol = param::Protocol::Ext;
    }
    let mut param_client: param::Client<1> = param::Client::new(param_config, OWN);
    let mut command_client: command::Client<2> =
        command::Client::new(command::ClientConfig::new(GCS));
    let mut mission_server = mission::Server::new(mission::ServerConfig::new(OWN));
    let mut missions = Checked::default();
    let mut mission_client = mission::Client::new(mission::ClientConfig::new(GCS), OWN);
    let mut upload = seven();
    let mut ftp_server: ftp::Server<2> = ftp::Server::new(ftp::ServerConfig::new(OWN));
    let mut files = Files::new();
    let mut ftp_client = ftp::Client::new(ftp::ClientConfig::new(GCS), OWN);
    let mut ftp_done = 0usize;
    let mut ftp_started = 0usize;
    let mut now: u64 = 0;
    // Commands the server handed out and not yet answered: (from, id).
    let mut asked: Vec<(Address, MavCmd)> = Vec::new();
    // Every (sender, command id) the server ever heard.
    let mut heard: Vec<(Address, MavCmd)> = Vec::new();
    // What the clients sent (from GCS) and what the servers sent (from OWN), not yet delivered.
    let mut up: VecDeque<Message> = VecDeque::new();
    let mut down: VecDeque<Message> = VecDeque::new();
    // Messages to hand to every state machine this round: (from, message, forged by the script).
    let mut inbox: Vec<(Address, Message, bool)> = Vec::new();
    // The FTP client's operation (0 list, 1 read, 2 write, 3 CRC-32) and what it brought.
    let mut ftp_op = None;
    let mut ftp_forged = false;
    let mut ftp_size = None;
    let mut ftp_got: Vec<bool> = Vec::new();
    let mut source: Vec<u8> = (0..255u32).map(|i| (i * 13 + 5) as u8).collect();
    let mut mission_forged = false;
    while let Some(op) = input.byte() {
        // Rounds of delivery and answers this step, and the link's loss mask (`None`: no link).
        let mut rounds = 1;
        let mut link = None;
        match op % 8 {
            0..=3 => {
                let Some(which) = input.byte() else { break };
                let id = ids[usize::from(which) % ids.len()];
                let from = Address::new(input.byte().unwrap_or(0), input.byte().unwrap_or(0));
                let len = usize::from(input.byte().unwrap_or(0));
                let payload = input.take(len).to_vec();
                let Ok(msg) = Message::decode(id, &payload) else {
                    continue;
                };
                inbox.push((from, msg, true));
            }
            4 if op & 8 == 0 => now += u64::from(input.byte().unwrap_or(0)) * 10_000,
            4 => {
                rounds = usize::from(op >> 4) + 1;
                link = Some(input.byte().unwrap_or(0));
            }
            5 => {
                if !asked.is_empty() {
                    let i = usize::from(input.byte().unwrap_or(0)) % asked.len();
                    let (from, cmd) = asked[i];
                    let result = MavResult::from_raw(input.byte().unwrap_or(0) % 9);
                    command_server.respond(now, from, cmd, Ack::new(result));
                    if result != MavResult::InProgress {
                        asked.remove(i);
                    }
                }
            }
            6 => {
                let which = input.byte().unwrap_or(0);
                let name = Name::from(format!("P{}", which % 24).as_str());
                // Refused while another operation runs: that is part of the script too.
                match which % 8 {
                    0 => drop(param_client.list()),
                    1 => drop(param_client.read(name)),
                    2 => drop(param_client.read_index(u16::from(which))),
                    3 if which & 0x80 != 0 => {
                        let _ = param_client.set_custom(name, param::Bytes::from_bytes(&[which]));
                    }
                    3 => drop(param_client.set(name, Value::F32(f32::from(which)))),
                    4 | 5 => {
                        let started = if which % 8 == 4 {
                            if mission_client.is_idle() {
                                upload = seven();
                            }
                            mission_client.upload(MavMissionType::Mission, 7)
                        } else {
                            mission_client.download(MavMissionType::Fence)
                        };
                        if started.is_ok() {
                            mission_forged = false;
                        }
                    }
                    6 => drop(mission_client.clear(MavMissionType::Rally)),
                    7 if which & 0x30 != 0 => {
                        let started = match which >> 6 {
                            0 => ftp_client.list(now, "/"),
                            1 => ftp_client.read(now, "/dir/b"),
                            2 => ftp_client.write(now, "/a", u32::from(which)),
                            _ => ftp_client.crc32(now, "/a"),
                        };
                        if started.is_ok() {
                            ftp_started += 1;
                            ftp_op = Some(which >> 6);
                            ftp_forged = false;
                            // A write's size; a read's comes with its `Size` event.
                            ftp_size = (which >> 6 == 2).then_some(u32::from(which));
                            ftp_got.clear();
                        }
                    }
                    _ => drop(mission_client.set_current(u16::from(which))),
                }
            }
            _ => {
                let cmd = MavCmd::from_raw(u16::from(input.byte().unwrap_or(0)));
                let _ = command_client.send(
                    now,
                    OWN,
                    command::Command::long(cmd, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                );
            }
        }
        for _ in 0..rounds {
            if let Some(mask) = link {
                if up.is_empty() && down.is_empty() {
                    break;
                }
                // Requests first, then answers; the mask's bits lose every eighth message.
                let queued = up.drain(..).map(|m| (GCS, m));
                let queued = queued.chain(down.drain(..).map(|m| (OWN, m)));
                for (i, (from, m)) in queued.enumerate() {
                    if mask & (1 << (i % 8)) == 0 {
                        inbox.push((from, m, false));
                    }
                }
            }
            for (from, msg, forged) in inbox.drain(..) {
                if forged && matches!(msg, Message::FileTransferProtocol(_)) {
                    ftp_forged = true;
                }
                if forged && is_mission(&msg) {
                    mission_forged = true;
                }
                param_server.handle(&mut params[..], now, from, &msg);
                match command_server.handle(now, from, &msg) {
                    Some(Request::Run { from, command }) => {
                        asked.push((from, command.command));
                        heard.push((from, command.command));
                    }
                    Some(Request::Cancel { from, command }) => {
                        assert!(
                            heard.contains(&(from, command)),
                            "a cancel for a command never run"
                        );
                    }
                    None => {}
                }
                if let Message::CommandLong(m) = &msg {
                    heard.push((from, m.command));
                }
                if let Message::CommandInt(m) = &msg {
                    heard.push((from, m.command));
                }
                let _ = param_client.handle(now, from, &msg);
                command_client.handle(now, from, &msg);
                mission_server.handle(&mut missions, now, from, &msg);
                mission_client.handle(&mut upload, now, from, &msg);
                ftp_server.handle(&mut files, now, from, &msg);
                ftp_client.handle(now, from, &msg);
            }
            // Everything each one has to send now, within reason.
            for _ in 0..10_000 {
                let Some(m) = param_server.poll_transmit(&params[..], now) else {
                    break;
                };
                down.push_back(m.clone());
                let v = match m {
                    Message::ParamValue(v) => v,
                    Message::ParamExtValue(v) => {
                        // Every value whole, bytewise.
                        assert_eq!(v.param_count, params.count());
                        let p = params[usize::from(v.param_index)];
                        assert_eq!(v.param_id, p.name);
                        let value = Value::from_ext(&v.param_value, v.param_type);
                        assert!(
                            value.is_some_and(|x| x.same(p.value)),
                            "{value:?} for {p:?}"
                        );
                        continue;
                    }
                    Message::ParamExtAck(a) => {
                        // Accepted or not, the value it holds when the answer goes.
                        let i = params[..].index_of(&a.param_id).expect("a known name");
                        let p = params[usize::from(i)];
                        let value = Value::from_ext(&a.param_value, a.param_type);
                        assert!(value.is_some_and(|x| x.same(p.value)), "{a:?} for {p:?}");
                        continue;
                    }
                    m => panic!("the parameter server sent {m:?}"),
                };
                assert_eq!(v.param_count, params.count());
                if param::hash::is_hash_check(&v.param_id) {
                    assert!(hash_check, "a _HASH_CHECK from a server without it");
                    assert_eq!(v.param_index, u16::MAX);
                    assert_eq!(v.param_value.to_bits(), param::hash::hash(&params[..]));
                    continue;
                }
                let p = params[usize::from(v.param_index)];
                assert_eq!(v.param_id, p.name);
                assert_eq!(v.param_type, p.value.param_type());
                match Value::decode(v.param_value, v.param_type, encoding) {
                    Some(value) => assert!(value.same(p.value), "{value:?} sent for {p:?}"),
                    // A 64-bit value: its number as the float.
                    None => assert_eq!(
                        v.param_value.to_bits(),
                        p.value.encode(encoding).to_bits(),
                        "{p:?}"
                    ),
                }
            }
            for (p, ty) in params.iter().zip(&types) {
                assert_eq!(p.value.param_type(), *ty, "a set changed {}'s type", p.name);
            }
            for _ in 0..10_000 {
                let Some(m) = command_server.poll_transmit(now) else {
                    break;
                };
                let Message::CommandAck(a) = &m else {
                    panic!("the command server sent {m:?}")
                };
                let to = Address::new(a.target_system, a.target_component);
                assert!(
                    heard.contains(&(to, a.command)),
                    "an ACK nobody asked for: {a:?}"
                );
                down.push_back(m);
            }
            for _ in 0..10_000 {
                let Some(m) = mission_server.poll_transmit(&missions, now) else {
                    break;
                };
                assert!(is_mission(&m), "the mission server sent {m:?}");
                down.push_back(m);
            }
            for _ in 0..10_000 {
                let Some(m) = ftp_server.poll_transmit(&mut files, now) else {
                    break;
                };
                let Message::FileTransferProtocol(f) = &m else {
                    panic!("the FTP server sent {m:?}")
                };
                let p = Payload::parse(&f.payload);
                let read = p.req_opcode == 5 || p.req_opcode == 15;
                if p.opcode == 128 && read && p.size > 0 {
                    // Session numbers on the wire are the server's to map, so: one of the files
                    // open for reading holds these bytes there.
                    let at = p.offset as usize;
                    let end = at + usize::from(p.size);
                    let held = files.open.iter().flatten().any(|&(i, writable)| {
                        !writable && files.files[i].1.get(at..end) == Some(p.bytes())
                    });
                    assert!(held, "read reply data that is no open file's");
                }
                down.push_back(m);
            }
            let mut sent = 0;
            loop {
                let before = up.len();
                up.extend(param_client.poll_transmit(now));
                up.extend(command_client.poll_transmit(now));
                up.extend(mission_client.poll_transmit(&upload, now));
                up.extend(ftp_client.poll_transmit(now, &mut source[..]));
                if up.len() == before {
                    break;
                }
                sent += 1;
                assert!(sent < 100, "a client keeps sending at one instant");
            }
            // A link holds a few frames, not a backlog.
            for queue in [&mut up, &mut down] {
                while queue.len() > 64 {
                    queue.pop_front();
                }
            }
            while let Some(e) = param_client.poll_event() {
                if let param::Event::Listed { count, missing } = e {
                    assert!(missing <= count);
                }
            }
            while command_client.poll_event().is_some() {}
            while let Some(e) = mission_client.poll_event() {
                match e {
                    _ if mission_forged => {}
                    mission::Event::Uploaded(Some(MavMissionResult::MavMissionAccepted)) => {
                        assert_eq!(missions.held, upload.0, "an accepted upload not held");
                        outcome.uploads += 1;
                    }
                    mission::Event::Downloaded(Some(n)) => {
                        assert_eq!(usize::from(n), missions.held.len());
                        assert_eq!(upload.0, missions.held, "a download not what is held");
                        outcome.downloads += 1;
                    }
                    _ => {}
                }
            }
            while let Some(e) = ftp_client.poll_event() {
                let file = |name: &str| &files.files[files.find(name).unwrap()].1;
                match e {
                    ftp::Event::Size(n) => ftp_size = Some(n),
                    ftp::Event::Data { offset, bytes } if !ftp_forged && ftp_op == Some(1) => {
                        let at = offset as usize;
                        let data = bytes.as_slice();
                        assert_eq!(file("dir/b").get(at..at + data.len()), Some(data));
                        if ftp_got.len() < at + data.len() {
                            ftp_got.resize(at + data.len(), false);
                        }
                        ftp_got[at..at + data.len()].fill(true);
                    }
                    ftp::Event::Done(done) => {
                        ftp_done += 1;
                        assert!(ftp_done <= ftp_started, "an FTP operation ended twice");
                        let op = ftp_op.take();
                        if let (Some(op), Ok(_), false) = (op, done, ftp_forged) {
                            outcome.ftp[usize::from(op)] += 1;
                        }
                        match (op, done) {
                            _ if ftp_forged => {}
                            (Some(1), Ok(None)) => {
                                let size = file("dir/b").len();
                                assert_eq!(ftp_size, Some(size as u32));
                                assert!(ftp_got.len() == size && ftp_got.iter().all(|&b| b));
                            }
                            (Some(2), Ok(None)) => {
                                let n = ftp_size.map_or(0, |n| n as usize);
                                assert_eq!(file("a")[..], source[..n], "a write not held");
                            }
                            (Some(3), Ok(Some(crc))) => {
                                assert_eq!(crc, FTP_CRC32.checksum(file("a")));
                            }
                            _ => {}
                        }
                    }
                    _ => {}
                }
            }
            let _ = (
                param_client.poll_timeout(),
                command_client.poll_timeout(),
                mission_client.poll_timeout(),
                mission_server.poll_timeout(),
                ftp_client.poll_timeout(),
                ftp_server.poll_timeout(),
            );
        }
    }
    outcome
}

fn is_mission(m: &Message) -> bool {
    matches!(
        m,
        Message::MissionCount(_)
            | Message::MissionRequestInt(_)
            | Message::MissionRequest(_)
            | Message::MissionItemInt(_)
            | Message::MissionItem(_)
            | Message::MissionAck(_)
            | Message::MissionCurrent(_)
            | Message::MissionSetCurrent(_)
            | Message::MissionClearAll(_)
            | Message::MissionRequestList(_)
            | Message::MissionItemReached(_)
    )
}

/// Seven mission items to upload, each its own.
fn seven() -> MissionItems {
    MissionItems(
        (0..7)
            .map(|x| Item {
                x,
                ..Item::default()
            })
            .collect(),
    )
}

/// Mission items in a `Vec`, for the mission client.
struct MissionItems(Vec<Item>);

impl mission::Items for MissionItems {
    fn len(&self) -> u16 {
        self.0.len() as u16
    }
    fn get(&self, seq: u16) -> Option<Item> {
        self.0.get(usize::from(seq)).copied()
    }
    fn reset(&mut self, count: u16) -> bool {
        if count > 500 {
            return false;
        }
        self.0 = vec![Item::default(); usize::from(count)];
        true
    }
    fn put(&mut self, seq: u16, item: Item) {
        self.0[usize::from(seq)] = item;
    }
}
