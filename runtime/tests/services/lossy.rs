//! Two sans-I/O state machines joined by a seeded lossy link, on a fake clock.
//!
//! Every message is encoded to a MAVLink 2 frame and decoded again on arrival, so the wire
//! layouts (and v2's trailing-zero truncation) are on the path. The link loses, repeats and
//! delays frames; a delay with jitter reorders them. With `TRACE` set in the environment,
//! every message sent and delivered is printed.

use ferrolink_runtime::mavlink::service::messages::Message;
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_runtime::mavlink::{v2, Header};

/// One side: a state machine and the application around it.
pub trait Node {
    fn address(&self) -> Address;
    fn handle(&mut self, now_us: u64, from: Address, msg: &Message);
    fn poll_transmit(&mut self, now_us: u64) -> Option<Message>;
    fn poll_timeout(&self) -> Option<u64>;
}

/// What the link does to frames, in parts per thousand, and its delay.
#[derive(Debug, Clone, Copy)]
pub struct Faults {
    pub loss: u32,
    pub duplicate: u32,
    /// Frames that get an extra delay of up to `jitter_us`, overtaken by later ones.
    pub reorder: u32,
    pub delay_us: u64,
    pub jitter_us: u64,
}

impl Faults {
    pub const CLEAN: Faults = Faults {
        loss: 0,
        duplicate: 0,
        reorder: 0,
        delay_us: 5_000,
        jitter_us: 0,
    };
    /// The bad radio: 20 % lost, 5 % repeated, some reordered.
    pub const BAD_RADIO: Faults = Faults {
        loss: 200,
        duplicate: 50,
        reorder: 50,
        delay_us: 5_000,
        jitter_us: 20_000,
    };
}

#[derive(Debug, Default, Clone, Copy)]
pub struct LinkStats {
    pub sent: u64,
    pub lost: u64,
    pub duplicated: u64,
    pub delivered: u64,
}

struct InFlight {
    at: u64,
    order: u64,
    to_b: bool,
    frame: Vec<u8>,
}

/// The simulation: run until `done` says so or `limit_us` passes; returns the end time.
pub struct Sim {
    rng: u64,
    faults: Faults,
    flight: Vec<InFlight>,
    order: u64,
    seq: u8,
    pub stats: LinkStats,
    pub now_us: u64,
}

impl Sim {
    pub fn new(seed: u64, faults: Faults) -> Self {
        Self {
            rng: seed | 1,
            faults,
            flight: Vec::new(),
            order: 0,
            seq: 0,
            stats: LinkStats::default(),
            now_us: 0,
        }
    }

    fn next(&mut self) -> u64 {
        // xorshift64*
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        self.rng.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn chance(&mut self, per_mille: u32) -> bool {
        (self.next() % 1000) < u64::from(per_mille)
    }

    fn send(&mut self, from: Address, to_b: bool, msg: &Message) {
        let mut buf = [0u8; 280];
        let header = Header::new(self.seq, from.system, from.component);
        self.seq = self.seq.wrapping_add(1);
        let n = v2::encode_dialect(header, msg, &mut buf).expect("encode");
        self.stats.sent += 1;
        if std::env::var_os("TRACE").is_some() {
            eprintln!(
                "{} {} -> {msg:?}",
                self.now_us,
                if to_b { "a" } else { "b" }
            );
        }
        if self.chance(self.faults.loss) {
            self.stats.lost += 1;
            return;
        }
        let copies = if self.chance(self.faults.duplicate) {
            self.stats.duplicated += 1;
            2
        } else {
            1
        };
        for _ in 0..copies {
            let mut at = self.now_us + self.faults.delay_us;
            if self.faults.jitter_us > 0 && self.chance(self.faults.reorder) {
                at += self.next() % self.faults.jitter_us;
            }
            self.order += 1;
            self.flight.push(InFlight {
                at,
                order: self.order,
                to_b,
                frame: buf[..n].to_vec(),
            });
        }
    }

    fn flush(&mut self, a: &mut dyn Node, b: &mut dyn Node) {
        let now = self.now_us;
        // Bounded: a state machine that never stops sending is a bug the limit would hide.
        for _ in 0..100_000 {
            let mut any = false;
            while let Some(m) = a.poll_transmit(now) {
                self.send(a.address(), true, &m);
                any = true;
            }
            while let Some(m) = b.poll_transmit(now) {
                self.send(b.address(), false, &m);
                any = true;
            }
            if !any {
                return;
            }
        }
        panic!("a state machine keeps sending at {now} µs");
    }

    /// Runs `a` and `b` until `done(a, b)` or the clock passes `limit_us`.
    pub fn run<A: Node, B: Node>(
        &mut self,
        a: &mut A,
        b: &mut B,
        limit_us: u64,
        mut done: impl FnMut(&mut A, &mut B) -> bool,
    ) -> bool {
        loop {
            self.flush(a, b);
            if done(a, b) {
                return true;
            }
            let mut next = [
                self.flight.iter().map(|f| f.at).min(),
                a.poll_timeout(),
                b.poll_timeout(),
            ]
            .into_iter()
            .flatten()
            .min()
            .unwrap_or(u64::MAX);
            // A deadline in the past was just polled; time must move on.
            next = next.max(self.now_us + 1);
            if next > limit_us {
                return false;
            }
            self.now_us = next;
            self.flight.sort_by_key(|f| (f.at, f.order));
            while self.flight.first().is_some_and(|f| f.at <= next) {
                let f = self.flight.remove(0);
                let frame = v2::Frame::new_checked(&f.frame[..]).expect("frame");
                let msg: Message = frame.decode().expect("a microservice message");
                let from = Address::new(frame.sysid(), frame.compid());
                self.stats.delivered += 1;
                if std::env::var_os("TRACE").is_some() {
                    eprintln!("{next} {} <- {msg:?}", if f.to_b { "b" } else { "a" });
                }
                if f.to_b {
                    b.handle(next, from, &msg);
                } else {
                    a.handle(next, from, &msg);
                }
                self.flush(a, b);
            }
        }
    }
}
