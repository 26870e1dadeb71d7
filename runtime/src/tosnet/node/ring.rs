//! The bookkeeping both roles share: DATA areas, sync strobes, the side channel, ring and register setup, restarts and election, emitting frames.

use super::*;

impl Node {
    /// A slave's work on a DATA frame's areas: take everything but its own out areas, put its
    /// own out areas in.
    pub(super) fn exchange_data(&mut self, areas: &mut [u8]) {
        let me = self.cfg.id;
        let mut at = 0;
        for (node, reg) in self.enabled() {
            for area in [Area::Out, Area::In] {
                let bytes = &mut areas[at..at + AREA_LEN];
                if node == me && area == Area::Out {
                    bytes.copy_from_slice(self.net.area(node, reg, area));
                } else {
                    self.net.area_mut(node, reg, area).copy_from_slice(bytes);
                }
                at += AREA_LEN;
            }
        }
    }

    /// The master takes every other node's out areas from a returned DATA frame.
    pub(super) fn take_outs(&mut self, areas: &[u8]) {
        let me = self.cfg.id;
        let mut at = 0;
        for (node, reg) in self.enabled() {
            if node != me {
                self.net
                    .area_mut(node, reg, Area::Out)
                    .copy_from_slice(&areas[at..at + AREA_LEN]);
            }
            at += 2 * AREA_LEN;
        }
    }

    /// Enabled (node, register) pairs in DATA order. Works on a copy of the ring tables, so
    /// the blocks can be changed while iterating.
    pub(super) fn enabled(&self) -> impl Iterator<Item = (u8, u8)> {
        let (ids, masks, n) = (self.ids, self.masks, usize::from(self.count));
        (0..n).flat_map(move |p| {
            let mask = masks[2 * p] | masks[2 * p + 1];
            (0..REGISTERS as u8)
                .filter(move |r| mask & (1 << r) != 0)
                .map(move |r| (ids[p], r))
        })
    }

    /// The sync strobe: exchange the application's view and the network's copy if the cycle
    /// was good and something was committed.
    pub(super) fn strobe(&mut self, at: u64) {
        self.last_sync = Some(at);
        self.counters.syncs = self.counters.syncs.wrapping_add(1);
        let ok = !self.cycle_error;
        self.last_cycle_ok = ok;
        self.cycle_error = false;
        if !ok || !(self.commit_in || self.commit_out) {
            return;
        }
        let me = self.cfg.id;
        let master = self.role == Role::Master;
        for (node, reg) in self.enabled() {
            for area in [Area::Out, Area::In] {
                let own = match area {
                    Area::Out => node == me,
                    Area::In => master,
                };
                let committed = match area {
                    Area::Out => self.commit_out,
                    Area::In => self.commit_in,
                };
                if !own {
                    self.app.copy_area(&self.net, node, reg, area);
                } else if committed {
                    self.net.copy_area(&self.app, node, reg, area);
                }
            }
        }
        self.commit_in = false;
        self.commit_out = false;
        self.counters.swaps = self.counters.swaps.wrapping_add(1);
    }

    /// A side-channel message: the destination takes it off the ring, a broadcast goes round
    /// to its sender, which drops it.
    pub(super) fn side_channel(
        &mut self,
        dest: u8,
        source: u8,
        data: &[u8],
        frame: &[u8],
        out: &mut [u8],
    ) -> Option<usize> {
        let id = self.cfg.id;
        if source == id {
            return None;
        }
        if dest == id || dest == 0 {
            self.deliver(source, dest, data);
        }
        if dest == id {
            return None;
        }
        copy(frame, out, &mut self.counters)
    }

    pub(super) fn deliver(&mut self, source: u8, dest: u8, data: &[u8]) {
        if self.inbox.is_some() {
            self.counters.async_dropped += 1;
            return;
        }
        self.inbox = AsyncMessage::new(source, dest, data);
    }

    pub(super) fn adopt(&mut self, master: u8, phase: Phase) {
        if self.master != master || self.role != Role::Slave {
            self.count = 0;
        }
        self.role = Role::Slave;
        self.master = master;
        self.phase = phase;
    }

    pub(super) fn set_ring(&mut self, ids: &[u8]) {
        let n = ids.len().min(MAX_NODES);
        self.ids[..n].copy_from_slice(&ids[..n]);
        self.count = n as u8;
        self.position = ids
            .iter()
            .position(|&i| i == self.cfg.id)
            .map_or(0, |p| p as u8);
        if !ids.contains(&self.cfg.id) {
            self.count = 0;
        }
    }

    pub(super) fn set_masks(&mut self, masks: &[u8]) {
        let n = usize::from(self.count);
        self.masks[..2 * n].copy_from_slice(&masks[..2 * n]);
        self.registers = (0..n)
            .map(|p| (self.masks[2 * p] | self.masks[2 * p + 1]).count_ones() as u8)
            .sum();
    }

    pub(super) fn restart(&mut self, now: u64) {
        self.counters.resets += 1;
        self.role = Role::Undecided;
        self.phase = Phase::Electing;
        self.count = 0;
        self.position = 0;
        self.registers = 0;
        self.sync_at = None;
        self.next_cycle_at = None;
        self.cycle_error = false;
        self.last_rx = now;
    }

    /// A master candidate announces itself.
    pub(super) fn announce(&mut self, out: &mut [u8]) -> Option<usize> {
        if !self.cfg.master_candidate {
            return None;
        }
        self.emit(
            out,
            &Repr::MasterDsc {
                candidate: self.cfg.id,
                hops: 0,
            },
        )
    }

    pub(super) fn relay_election(
        &mut self,
        candidate: u8,
        hops: u8,
        out: &mut [u8],
    ) -> Option<usize> {
        if hops >= MAX_HOPS {
            return None;
        }
        let own = if self.cfg.master_candidate {
            self.cfg.id
        } else {
            u8::MAX
        };
        self.emit(
            out,
            &Repr::MasterDsc {
                candidate: candidate.min(own),
                hops: hops + 1,
            },
        )
    }

    pub(super) fn emit(&mut self, out: &mut [u8], repr: &Repr<'_>) -> Option<usize> {
        match repr.emit(out) {
            Ok(len) => Some(len),
            Err(_) => {
                self.counters.tx_overflows += 1;
                None
            }
        }
    }
}
