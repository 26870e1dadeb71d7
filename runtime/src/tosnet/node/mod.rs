//! The node engine: one TosNet node, master or slave, driven by frames and a monotonic clock.
//!
//! A node is fed every frame that arrives from its upstream neighbour with [`Node::receive`]
//! (or [`Node::receive_timed`] when the link knows when the frame's first byte arrived) and is
//! polled with [`Node::poll`]; both hand back at most one frame to send to the downstream
//! neighbour. Times are nanoseconds of any monotonic clock.
//!
//! Setup, from cold or after the watchdog fired:
//!
//! 1. **Election.** Every master candidate sends MASTER_DSC with its id; each node forwards it
//!    with the lower of the frame's candidate and its own id. The candidate whose own id comes
//!    back is the master: the lowest candidate id in the ring.
//! 2. The master sends MASTER_SET, NET_DSC (each node appends its id: the ring order and the
//!    positions), NET_SET, REG_DSC (each node fills its in and out enable masks), REG_SET,
//!    SYNC_DSC (padded to a DATA frame's length; the master divides its round trip by the node
//!    count to get the node-to-node delay) and SYNC_SET. Each step waits for the frame to come
//!    back round.
//! 3. **Cycles.** The master sends DATA; when it is back, the master fires its sync strobe and
//!    sends the next one (at once, or after [`Config::cycle_ns`]).
//!
//! A node fires its sync strobe `(nodes - position) * delay` after a DATA frame's first byte
//! arrived: the moment the frame's first byte is back at the master. At the strobe, if the
//! cycle had no error and the application committed something, the application's view and the
//! network's copy are exchanged: received areas into the view, committed own areas out.
//!
//! The watchdog restarts setup when no frame arrived for [`Config::watchdog_ns`]: a broken
//! ring, or a node that joined (a node that is not set up swallows DATA, so the ring stalls
//! until everyone has set up again). A MASTER_DSC seen while running means a node restarted;
//! everyone restarts with it.
//!
//! A frame with a bad CRC is counted and reported, its data is not used, and it is forwarded
//! with the last four bits of its CRC inverted, so the cycle goes on but nobody downstream
//! accepts it. A cycle with an error does not swap.

use super::block::{Area, Block, InWriter, NodeId, OutWriter, AREA_LEN, REGISTERS};
use super::frame::{
    crc_ok, data_len, seal, seal_broken, Repr, MAX_ASYNC, MAX_FRAME_LEN, MAX_NODES,
};

/// A MASTER_DSC frame dies after this many hops (twice round the largest ring).
const MAX_HOPS: u8 = 2 * 16;

/// How a node takes part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Config {
    /// The node id, 0..=15.
    pub id: u8,
    /// May become the master. The lowest candidate id in the ring is elected.
    pub master_candidate: bool,
    /// Registers whose in area the master fills for this node (bit r = register r).
    pub in_mask: u8,
    /// Registers whose out area this node writes.
    pub out_mask: u8,
    /// Setup restarts when no frame arrived for this long.
    pub watchdog_ns: u64,
    /// The master starts a cycle at most this often; 0 is as fast as the ring goes.
    pub cycle_ns: u64,
}

impl Config {
    /// Node `id`, a master candidate, no registers, a 50 ms watchdog, free-running cycles.
    pub const fn new(id: u8) -> Self {
        Self {
            id: id & 0x0F,
            master_candidate: true,
            in_mask: 0,
            out_mask: 0,
            watchdog_ns: 50_000_000,
            cycle_ns: 0,
        }
    }

    /// The id and enable masks of a generated register map's node.
    pub const fn for_node<N: NodeId>() -> Self {
        Self::new(N::ID).registers(N::IN_MASK, N::OUT_MASK)
    }

    /// Sets the enable masks.
    pub const fn registers(mut self, in_mask: u8, out_mask: u8) -> Self {
        self.in_mask = in_mask;
        self.out_mask = out_mask;
        self
    }
}

/// The node's part in the ring.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Not decided (setup not far enough).
    Undecided,
    /// The master: sends DATA, writes every in area.
    Master,
    /// A slave: forwards DATA, writes its own out areas.
    Slave,
}

/// Where setup is. For the master, the step whose frame is going round.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Looking for the master.
    Electing,
    /// MASTER_SET.
    MasterSet,
    /// NET_DSC.
    NetDsc,
    /// NET_SET.
    NetSet,
    /// REG_DSC.
    RegDsc,
    /// REG_SET.
    RegSet,
    /// SYNC_DSC.
    SyncDsc,
    /// SYNC_SET.
    SyncSet,
    /// Exchanging DATA.
    Running,
    /// Stopped by HALT.
    Halted,
}

/// Counters since power-up.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Setup restarts (watchdog, a restarting node, a failed setup step).
    pub resets: u32,
    /// Frames received.
    pub packets: u32,
    /// Frames with a bad CRC (data discarded, frame forwarded marked broken).
    pub errors: u32,
    /// Frames with a good CRC that are not a valid frame, or a DATA frame of the wrong size.
    pub malformed: u32,
    /// Setups that found two nodes with the same id.
    pub duplicate_ids: u32,
    /// DATA frames handled while running.
    pub cycles: u32,
    /// Sync strobes.
    pub syncs: u32,
    /// Buffer exchanges at a strobe.
    pub swaps: u32,
    /// Side-channel messages dropped because the inbox was full.
    pub async_dropped: u32,
    /// Frames not sent because the caller's buffer was too small.
    pub tx_overflows: u32,
}

/// A snapshot of a node's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    /// Master, slave or undecided.
    pub role: Role,
    /// The setup phase.
    pub phase: Phase,
    /// The master's id (valid once decided).
    pub master: u8,
    /// Position in the ring, the master being 0.
    pub position: u8,
    /// Nodes in the ring.
    pub nodes: u8,
    /// Enabled registers in the whole ring (the model's `r`).
    pub registers: u8,
    /// The measured node-to-node delay.
    pub delay_ns: u32,
    /// The last DATA frame's cycle counter.
    pub cycle: u16,
    /// Whether the last cycle had no error.
    pub last_cycle_ok: bool,
    /// When the last sync strobe fired.
    pub last_sync_ns: Option<u64>,
}

impl Status {
    /// The C driver's network register: bits 3..0 the node id, 7..4 the position in the ring,
    /// 15..8 the read-enable mask (the registers whose in area the node reads), 23..16 the
    /// write-enable mask (those whose out area it writes).
    pub fn network_register(&self, cfg: &Config) -> u32 {
        u32::from(cfg.id & 0x0F)
            | u32::from(self.position & 0x0F) << 4
            | u32::from(cfg.in_mask) << 8
            | u32::from(cfg.out_mask) << 16
    }
}

/// A side-channel message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AsyncMessage {
    /// The sender.
    pub source: u8,
    /// The destination; 0 is everyone.
    pub dest: u8,
    len: u8,
    data: [u8; MAX_ASYNC],
}

impl AsyncMessage {
    /// The data.
    pub fn data(&self) -> &[u8] {
        &self.data[..usize::from(self.len)]
    }

    fn new(source: u8, dest: u8, data: &[u8]) -> Option<Self> {
        let mut msg = Self {
            source,
            dest,
            len: u8::try_from(data.len()).ok()?,
            data: [0; MAX_ASYNC],
        };
        msg.data.get_mut(..data.len())?.copy_from_slice(data);
        Some(msg)
    }
}

/// Why a side-channel message was not queued.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum AsyncError {
    /// The previous message has not been sent yet.
    Busy,
    /// More than 64 bytes.
    TooLong,
}

impl core::fmt::Display for AsyncError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            AsyncError::Busy => "the previous side-channel message is still queued",
            AsyncError::TooLong => "side-channel messages are at most 64 bytes",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for AsyncError {}

/// One TosNet node. About 8.3 KiB: the network's copy of the block and the application's.
#[derive(Debug, Clone)]
pub struct Node {
    cfg: Config,
    role: Role,
    phase: Phase,
    master: u8,
    ids: [u8; MAX_NODES],
    count: u8,
    position: u8,
    /// Per position: in mask, out mask.
    masks: [u8; 2 * MAX_NODES],
    registers: u8,
    delay_ns: u32,
    net: Block,
    app: Block,
    commit_in: bool,
    commit_out: bool,
    cycle_error: bool,
    started: bool,
    last_rx: u64,
    sync_at: Option<u64>,
    last_sync: Option<u64>,
    sent_at: u64,
    next_cycle_at: Option<u64>,
    cycle: u16,
    last_cycle_ok: bool,
    halt: bool,
    counters: Counters,
    outbox: Option<AsyncMessage>,
    inbox: Option<AsyncMessage>,
}

impl Node {
    /// A node that has not started; its first [`poll`](Self::poll) starts it.
    pub fn new(cfg: Config) -> Self {
        Self {
            cfg,
            role: Role::Undecided,
            phase: Phase::Electing,
            master: 0,
            ids: [0; MAX_NODES],
            count: 0,
            position: 0,
            masks: [0; 2 * MAX_NODES],
            registers: 0,
            delay_ns: 0,
            net: Block::new(),
            app: Block::new(),
            commit_in: false,
            commit_out: false,
            cycle_error: false,
            started: false,
            last_rx: 0,
            sync_at: None,
            last_sync: None,
            sent_at: 0,
            next_cycle_at: None,
            cycle: 0,
            last_cycle_ok: false,
            halt: false,
            counters: Counters::default(),
            outbox: None,
            inbox: None,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// The counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Where the node is.
    pub fn status(&self) -> Status {
        Status {
            role: self.role,
            phase: self.phase,
            master: self.master,
            position: self.position,
            nodes: self.count,
            registers: self.registers,
            delay_ns: self.delay_ns,
            cycle: self.cycle,
            last_cycle_ok: self.last_cycle_ok,
            last_sync_ns: self.last_sync,
        }
    }

    /// Node ids in ring order, the master first (empty before NET_SET).
    pub fn ring(&self) -> &[u8] {
        &self.ids[..usize::from(self.count)]
    }

    /// The application's view of the block: stable between swaps, so reads never tear.
    pub fn view(&self) -> &Block {
        &self.app
    }

    /// Write access to node `N`'s out areas, if this node is `N`. Writes stay in the
    /// application's view until [`commit_out`](Self::commit_out) and the next good strobe.
    pub fn out_writer<N: NodeId>(&mut self) -> Option<OutWriter<'_, N>> {
        (N::ID == self.cfg.id).then(|| OutWriter::new(&mut self.app))
    }

    /// Write access to every in area, while this node is the master.
    pub fn in_writer(&mut self) -> Option<InWriter<'_>> {
        (self.role == Role::Master).then(|| InWriter::new(&mut self.app))
    }

    /// Sends the out areas written so far at the next error-free strobe, and refreshes the
    /// view then.
    pub fn commit_out(&mut self) {
        self.commit_out = true;
    }

    /// Sends the in areas written so far (master) at the next error-free strobe, and
    /// refreshes the view then.
    pub fn commit_in(&mut self) {
        self.commit_in = true;
    }

    /// Queues a side-channel message for `dest` (0: everyone).
    pub fn send_async(&mut self, dest: u8, data: &[u8]) -> Result<(), AsyncError> {
        if self.outbox.is_some() {
            return Err(AsyncError::Busy);
        }
        let msg = AsyncMessage::new(self.cfg.id, dest & 0x0F, data).ok_or(AsyncError::TooLong)?;
        self.outbox = Some(msg);
        Ok(())
    }

    /// The side-channel message received, if any.
    pub fn take_async(&mut self) -> Option<AsyncMessage> {
        self.inbox.take()
    }

    /// Stops the ring (master only): HALT goes round and every node stops.
    pub fn halt(&mut self) {
        if self.role == Role::Master {
            self.halt = true;
        }
    }

    /// The next time [`poll`](Self::poll) has something to do, if not before a frame arrives.
    pub fn next_deadline(&self) -> Option<u64> {
        if !self.started {
            return Some(0);
        }
        let mut next = self.last_rx.saturating_add(self.cfg.watchdog_ns);
        if self.phase == Phase::Halted {
            next = u64::MAX;
        }
        for t in [self.sync_at, self.next_cycle_at].into_iter().flatten() {
            next = next.min(t);
        }
        if self.outbox.is_some() || self.halt {
            next = 0;
        }
        Some(next)
    }

    /// Timers: the first start, sync strobes, the watchdog, paced cycles, HALT and the side
    /// channel. Returns the length of a frame written to `out` for the downstream neighbour;
    /// call again until it returns `None`.
    pub fn poll(&mut self, now: u64, out: &mut [u8]) -> Option<usize> {
        if !self.started {
            self.started = true;
            self.last_rx = now;
            return self.announce(out);
        }
        if let Some(at) = self.sync_at {
            if now >= at {
                self.sync_at = None;
                self.strobe(at);
            }
        }
        if self.phase != Phase::Halted && now.saturating_sub(self.last_rx) >= self.cfg.watchdog_ns {
            self.restart(now);
            return self.announce(out);
        }
        if self.halt {
            self.halt = false;
            return self.emit(
                out,
                &Repr::Halt {
                    master: self.cfg.id,
                },
            );
        }
        if let Some(at) = self.next_cycle_at {
            if now >= at {
                self.next_cycle_at = None;
                return self.send_data(now, out);
            }
        }
        let msg = self.outbox.take()?;
        self.emit(
            out,
            &Repr::Async {
                dest: msg.dest,
                source: msg.source,
                data: msg.data(),
            },
        )
    }

    /// Handles a frame from the upstream neighbour that arrived whole at `now`. Returns the
    /// length of a frame written to `out` for the downstream neighbour.
    pub fn receive(&mut self, frame: &[u8], now: u64, out: &mut [u8]) -> Option<usize> {
        self.receive_timed(frame, now, now, out)
    }

    /// Like [`receive`](Self::receive), for links that know when the frame's first byte
    /// arrived (`started`): sync strobes and the delay measurement are taken from first bytes.
    pub fn receive_timed(
        &mut self,
        frame: &[u8],
        started: u64,
        now: u64,
        out: &mut [u8],
    ) -> Option<usize> {
        self.started = true;
        self.counters.packets = self.counters.packets.wrapping_add(1);
        self.last_rx = now;
        if let Some(at) = self.sync_at {
            if now >= at {
                self.sync_at = None;
                self.strobe(at);
            }
        }
        if !crc_ok(frame) {
            return self.broken(frame, started, now, out);
        }
        let Ok(repr) = Repr::parse_unchecked(frame) else {
            self.counters.malformed += 1;
            return (self.role != Role::Master).then(|| copy(frame, out, &mut self.counters))?;
        };
        if self.role == Role::Master {
            self.master_receive(repr, frame, started, now, out)
        } else {
            self.slave_receive(repr, frame, started, out)
        }
    }

    fn broken(&mut self, frame: &[u8], started: u64, now: u64, out: &mut [u8]) -> Option<usize> {
        self.counters.errors += 1;
        if self.phase == Phase::Running {
            self.cycle_error = true;
        }
        if self.role != Role::Master {
            let len = copy(frame, out, &mut self.counters)?;
            seal_broken(&mut out[..len]);
            return Some(len);
        }
        // The master's own frame came back broken: a DATA cycle ends without its data; a setup
        // step starts over.
        match (self.phase, frame.first().map(|b| b >> 4)) {
            (Phase::Running, Some(0xA)) => self.end_cycle(started, now, out),
            (Phase::Running, _) => None,
            _ => {
                self.restart(now);
                self.announce(out)
            }
        }
    }
}

mod master;
mod ring;
mod slave;

/// Copies a frame to be forwarded.
fn copy(frame: &[u8], out: &mut [u8], counters: &mut Counters) -> Option<usize> {
    match out.get_mut(..frame.len()) {
        Some(dst) if frame.len() <= MAX_FRAME_LEN => {
            dst.copy_from_slice(frame);
            Some(frame.len())
        }
        _ => {
            counters.tx_overflows += 1;
            None
        }
    }
}
