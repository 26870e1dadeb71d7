//! What the master does with each frame that comes back round: the next setup step, the end of a cycle, the next DATA frame.

use super::*;

impl Node {
    pub(super) fn master_receive(
        &mut self,
        repr: Repr<'_>,
        frame: &[u8],
        started: u64,
        now: u64,
        out: &mut [u8],
    ) -> Option<usize> {
        let id = self.cfg.id;
        match (self.phase, repr) {
            (_, Repr::MasterDsc { candidate, hops }) => {
                if candidate == id {
                    // A late copy of our own election frame.
                    return None;
                }
                // Someone restarted (a node joined, or a lower candidate appeared).
                self.restart(now);
                self.relay_election(candidate, hops, out)
            }
            (Phase::MasterSet, Repr::MasterSet { master }) if master == id => {
                self.phase = Phase::NetDsc;
                self.emit(
                    out,
                    &Repr::Net {
                        master: id,
                        complete: false,
                        ids: &[id],
                    },
                )
            }
            (
                Phase::NetDsc,
                Repr::Net {
                    master,
                    complete: false,
                    ids,
                },
            ) if master == id => {
                let duplicate = ids.iter().enumerate().any(|(i, a)| ids[..i].contains(a));
                if duplicate || ids.first() != Some(&id) {
                    self.counters.duplicate_ids += 1;
                    self.restart(now);
                    return self.announce(out);
                }
                self.set_ring(ids);
                self.phase = Phase::NetSet;
                self.emit(
                    out,
                    &Repr::Net {
                        master: id,
                        complete: true,
                        ids,
                    },
                )
            }
            (Phase::NetSet, Repr::Net { complete: true, .. }) => {
                self.phase = Phase::RegDsc;
                let n = usize::from(self.count);
                let mut masks = [0u8; 2 * MAX_NODES];
                masks[0] = self.cfg.in_mask;
                masks[1] = self.cfg.out_mask;
                self.emit(
                    out,
                    &Repr::Reg {
                        master: id,
                        complete: false,
                        masks: &masks[..2 * n],
                    },
                )
            }
            (
                Phase::RegDsc,
                Repr::Reg {
                    complete: false,
                    masks,
                    ..
                },
            ) if masks.len() == 2 * usize::from(self.count) => {
                self.set_masks(masks);
                self.phase = Phase::RegSet;
                self.emit(
                    out,
                    &Repr::Reg {
                        master: id,
                        complete: true,
                        masks,
                    },
                )
            }
            (Phase::RegSet, Repr::Reg { complete: true, .. }) => {
                self.phase = Phase::SyncDsc;
                self.sent_at = now;
                let len = data_len(usize::from(self.registers)) - 2;
                self.emit(out, &Repr::SyncDsc { master: id, len })
            }
            (Phase::SyncDsc, Repr::SyncDsc { .. }) => {
                let round_trip = started.saturating_sub(self.sent_at);
                let per_node = round_trip / u64::from(self.count.max(1));
                self.delay_ns = u32::try_from(per_node).unwrap_or(u32::MAX);
                self.phase = Phase::SyncSet;
                self.emit(
                    out,
                    &Repr::SyncSet {
                        master: id,
                        delay_ns: self.delay_ns,
                    },
                )
            }
            (Phase::SyncSet, Repr::SyncSet { .. }) => {
                self.phase = Phase::Running;
                self.send_data(now, out)
            }
            (Phase::Running, Repr::Data { areas, .. }) => {
                if areas.len() == usize::from(self.registers) * 2 * AREA_LEN {
                    self.take_outs(areas);
                } else {
                    self.counters.malformed += 1;
                    self.cycle_error = true;
                }
                self.end_cycle(started, now, out)
            }
            (_, Repr::Async { dest, source, data }) => {
                self.side_channel(dest, source, data, frame, out)
            }
            (_, Repr::Halt { master }) if master == id => {
                self.phase = Phase::Halted;
                None
            }
            // Anything else is stale (a frame of an earlier setup) and dies here.
            _ => None,
        }
    }

    /// The master's DATA frame is back (or lost its data): strobe, then the next cycle.
    pub(super) fn end_cycle(&mut self, started: u64, now: u64, out: &mut [u8]) -> Option<usize> {
        self.counters.cycles = self.counters.cycles.wrapping_add(1);
        self.strobe(started);
        if self.cfg.cycle_ns == 0 {
            return self.send_data(now, out);
        }
        let due = self.sent_at.saturating_add(self.cfg.cycle_ns);
        if now >= due {
            return self.send_data(now, out);
        }
        self.next_cycle_at = Some(due);
        None
    }

    pub(super) fn send_data(&mut self, now: u64, out: &mut [u8]) -> Option<usize> {
        let len = data_len(usize::from(self.registers));
        let Some(frame) = out.get_mut(..len) else {
            self.counters.tx_overflows += 1;
            return None;
        };
        self.cycle = self.cycle.wrapping_add(1);
        self.sent_at = now;
        frame[0] = 0xA0 | self.cfg.id;
        frame[1..3].copy_from_slice(&self.cycle.to_le_bytes());
        let mut at = 3;
        for (node, reg) in self.enabled() {
            for area in [Area::Out, Area::In] {
                frame[at..at + AREA_LEN].copy_from_slice(self.net.area(node, reg, area));
                at += AREA_LEN;
            }
        }
        seal(frame);
        Some(len)
    }
}
