//! A simulated CAN bus on a virtual clock, carrying real ModRob.CAN-1 frames.
//!
//! Every node has a transmit queue. When the bus is idle, the head frames of all queues with a
//! frame ready arbitrate and the lowest identifier wins, as on a real bus (ModRob's type bits make
//! commands win over publications, and publications over piecewise chunks). A frame occupies the
//! bus for its exact length in bits, bit stuffing included ([`frame_bits`]), and is delivered to
//! every other node when its last bit is sent. Time is in nanoseconds and only moves when the
//! caller says so, so a run is deterministic and as fast as the CPU allows.
//!
//! ```
//! use ferrolink_io::modrob::can_sim::Bus;
//! use ferrolink_runtime::modrob::Message;
//!
//! let mut bus = Bus::new(1_000_000, 2);
//! let frame = Message::Publication { module: 1, variable: 0, value: 1.0 }.to_can();
//! bus.send(0, frame, 0);
//! let mut got = Vec::new();
//! bus.run_until(1_000_000, |node, frame| got.push((node, frame.id)));
//! assert_eq!(got, [(1, frame.id)]);
//! assert!(bus.stats().busy_ns > 100_000); // more than 100 bits at 1 Mbit/s
//! ```

use std::collections::VecDeque;

use ferrolink_runtime::modrob::CanFrame;

/// Bits of an extended data frame with `frame`'s id and data: start of frame to end of CRC
/// with stuff bits, then CRC delimiter, ACK slot and delimiter, end of frame (7) and the
/// inter-frame space (3).
pub fn frame_bits(frame: &CanFrame) -> u32 {
    let mut bits: Vec<bool> = Vec::with_capacity(160);
    let push = |value: u32, n: u32, bits: &mut Vec<bool>| {
        for i in (0..n).rev() {
            bits.push(value >> i & 1 == 1);
        }
    };
    let id = frame.id & 0x1FFF_FFFF;
    push(0, 1, &mut bits); // SOF
    push(id >> 18, 11, &mut bits); // base id
    push(1, 1, &mut bits); // SRR
    push(1, 1, &mut bits); // IDE
    push(id & 0x3FFFF, 18, &mut bits); // extended id
    push(0, 3, &mut bits); // RTR, r1, r0
    push(u32::from(frame.len), 4, &mut bits); // DLC
    for &b in frame.data() {
        push(u32::from(b), 8, &mut bits);
    }
    let crc = crc15(&bits);
    push(u32::from(crc), 15, &mut bits);
    let mut stuffed = 0;
    let mut run = 0;
    let mut last = None;
    for &b in &bits {
        if Some(b) == last {
            run += 1;
        } else {
            run = 1;
            last = Some(b);
        }
        if run == 5 {
            // The stuff bit has the opposite level and starts a new run.
            stuffed += 1;
            last = Some(!b);
            run = 1;
        }
    }
    bits.len() as u32 + stuffed + 1 + 2 + 7 + 3
}

/// CAN's CRC-15 (polynomial 0x4599) over a bit sequence; the frame is not byte aligned, so the
/// byte-oriented CRC catalogue does not apply.
fn crc15(bits: &[bool]) -> u16 {
    let mut crc: u16 = 0;
    for &b in bits {
        let next = b ^ (crc >> 14 & 1 == 1);
        crc = (crc << 1) & 0x7FFF;
        if next {
            crc ^= 0x4599;
        }
    }
    crc
}

/// What the bus carried.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Frames delivered.
    pub frames: u64,
    /// Bits sent, stuffing and inter-frame space included.
    pub bits: u64,
    /// Time the bus was busy, in ns.
    pub busy_ns: u64,
    /// Frames per ModRob message type (command, publication, piecewise, reserved).
    pub by_type: [u64; 4],
    /// The longest a frame waited in its queue before it started, in ns.
    pub max_wait_ns: u64,
}

#[derive(Debug, Clone)]
struct Queued {
    frame: CanFrame,
    ready_ns: u64,
}

/// The bus.
#[derive(Debug)]
pub struct Bus {
    bitrate: u64,
    queues: Vec<VecDeque<Queued>>,
    now_ns: u64,
    /// The frame on the bus: sender, frame, end time.
    on_air: Option<(usize, CanFrame, u64)>,
    stats: Stats,
}

impl Bus {
    /// A bus at `bitrate` bit/s with `nodes` nodes (0..nodes).
    pub fn new(bitrate: u32, nodes: usize) -> Self {
        Self {
            bitrate: u64::from(bitrate.max(1)),
            queues: vec![VecDeque::new(); nodes],
            now_ns: 0,
            on_air: None,
            stats: Stats::default(),
        }
    }

    /// The bus time, in ns.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// What the bus carried so far.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Frames waiting to be sent, over all nodes.
    pub fn queued(&self) -> usize {
        self.queues.iter().map(VecDeque::len).sum()
    }

    /// Queues `frame` at node `node`, ready from `at_ns` (not before the bus time).
    pub fn send(&mut self, node: usize, frame: CanFrame, at_ns: u64) {
        let ready_ns = at_ns.max(self.now_ns);
        if let Some(q) = self.queues.get_mut(node) {
            q.push_back(Queued { frame, ready_ns });
        }
    }

    /// Runs the bus up to `until_ns`, handing each delivered frame to `deliver(receiver,
    /// frame)` for every node but its sender, in delivery order.
    pub fn run_until(&mut self, until_ns: u64, mut deliver: impl FnMut(usize, &CanFrame)) {
        loop {
            if let Some((sender, frame, end)) = self.on_air {
                if end > until_ns {
                    break;
                }
                self.now_ns = end;
                self.on_air = None;
                self.stats.frames += 1;
                self.stats.by_type[(frame.id >> 24 & 3) as usize] += 1;
                for node in (0..self.queues.len()).filter(|&n| n != sender) {
                    deliver(node, &frame);
                }
                continue;
            }
            // Idle: the earliest time any head frame is ready, then arbitration among all
            // heads ready by then.
            let Some(start) = self
                .queues
                .iter()
                .filter_map(|q| q.front().map(|f| f.ready_ns))
                .min()
            else {
                break;
            };
            let start = start.max(self.now_ns);
            if start > until_ns {
                break;
            }
            let winner = (0..self.queues.len())
                .filter(|&n| self.queues[n].front().is_some_and(|f| f.ready_ns <= start))
                .min_by_key(|&n| self.queues[n].front().map_or(u32::MAX, |f| f.frame.id));
            let Some((node, queued)) = winner.and_then(|n| Some((n, self.queues[n].pop_front()?)))
            else {
                break;
            };
            let bits = u64::from(frame_bits(&queued.frame));
            let duration = (bits * 1_000_000_000).div_ceil(self.bitrate);
            self.stats.bits += bits;
            self.stats.busy_ns += duration;
            self.stats.max_wait_ns = self.stats.max_wait_ns.max(start - queued.ready_ns);
            self.now_ns = start;
            self.on_air = Some((node, queued.frame, start + duration));
        }
        self.now_ns = self.now_ns.max(until_ns);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ferrolink_runtime::modrob::{CommandKind, Message};

    #[test]
    fn frame_lengths_are_within_the_textbook_bounds() {
        // An extended frame with n data bytes is 67 + 8n bits unstuffed (IFS included) and at
        // most ⌊(54 + 8n − 1)/4⌋ stuff bits longer.
        for (message, n) in [
            (
                Message::Publication {
                    module: 0x0111,
                    variable: 1,
                    value: 1.5,
                },
                6,
            ),
            (
                Message::Publication {
                    module: 0,
                    variable: 0,
                    value: 0.0,
                },
                6,
            ),
            (
                Message::Piecewise {
                    module: 0xFFFF,
                    chunk: 255,
                    chunks: 255,
                    data: [0xFF; 7],
                },
                8,
            ),
        ] {
            let bits = frame_bits(&message.to_can());
            let base = 67 + 8 * n;
            assert!(
                bits >= base && bits <= base + (54 + 8 * n - 1) / 4,
                "{bits} for {message:?}"
            );
        }
        // All zeros stuffs the most: a zero id and zero data.
        let zeros = Message::Command {
            module: 0,
            variable: 0,
            command: CommandKind::SetValue(0.0),
        };
        assert!(frame_bits(&zeros.to_can()) > 67 + 48 + 10);
    }

    #[test]
    fn crc15_is_the_can_polynomial() {
        assert_eq!(crc15(&[false; 40]), 0);
        assert_eq!(crc15(&[true]), 0x4599);
        // A message followed by its own CRC leaves a zero remainder.
        let mut bits: Vec<bool> = (0..50).map(|i| i % 3 == 0 || i % 7 == 0).collect();
        let crc = crc15(&bits);
        bits.extend((0..15).rev().map(|i| crc >> i & 1 == 1));
        assert_eq!(crc15(&bits), 0);
    }

    #[test]
    fn lowest_id_wins_and_nobody_hears_itself() {
        let mut bus = Bus::new(500_000, 3);
        let publication = Message::Publication {
            module: 1,
            variable: 0,
            value: 1.0,
        }
        .to_can();
        let command = Message::Command {
            module: 2,
            variable: 0,
            command: CommandKind::SetValue(1.0),
        }
        .to_can();
        bus.send(0, publication, 0);
        bus.send(1, command, 0);
        let mut order = Vec::new();
        bus.run_until(10_000_000, |node, f| order.push((node, f.id)));
        assert_eq!(
            order,
            [
                (0, command.id),
                (2, command.id),
                (1, publication.id),
                (2, publication.id)
            ]
        );
        assert_eq!(bus.stats().frames, 2);
        assert_eq!(bus.stats().by_type[0..2], [1, 1]);
        assert!(bus.stats().max_wait_ns > 0);
    }

    #[test]
    fn frames_take_their_airtime() {
        let mut bus = Bus::new(1_000_000, 2);
        let f = Message::Publication {
            module: 1,
            variable: 0,
            value: 1.0,
        }
        .to_can();
        bus.send(0, f, 1_000);
        let mut at = Vec::new();
        let bits = u64::from(frame_bits(&f));
        bus.run_until(1_000 + bits * 1_000 - 1, |_, _| at.push(0));
        assert!(at.is_empty());
        bus.run_until(1_000 + bits * 1_000, |_, _| at.push(1));
        assert_eq!(at, [1]);
    }
}
