//! What a slave does with each frame: forward it, add itself to discovery, take and put DATA.

use super::*;

impl Node {
    pub(super) fn slave_receive(
        &mut self,
        repr: Repr<'_>,
        frame: &[u8],
        started: u64,
        out: &mut [u8],
    ) -> Option<usize> {
        let id = self.cfg.id;
        match repr {
            Repr::MasterDsc { candidate, hops } => {
                if candidate == id && self.cfg.master_candidate {
                    self.role = Role::Master;
                    self.master = id;
                    self.phase = Phase::MasterSet;
                    return self.emit(out, &Repr::MasterSet { master: id });
                }
                if self.phase == Phase::Running {
                    self.restart(self.last_rx);
                }
                self.relay_election(candidate, hops, out)
            }
            Repr::MasterSet { master } => {
                self.adopt(master, Phase::MasterSet);
                copy(frame, out, &mut self.counters)
            }
            Repr::Net {
                master,
                complete: false,
                ids,
            } => {
                self.adopt(master, Phase::NetDsc);
                if ids.len() >= MAX_NODES {
                    return copy(frame, out, &mut self.counters);
                }
                let mut list = [0u8; MAX_NODES];
                list[..ids.len()].copy_from_slice(ids);
                list[ids.len()] = id;
                self.emit(
                    out,
                    &Repr::Net {
                        master,
                        complete: false,
                        ids: &list[..=ids.len()],
                    },
                )
            }
            Repr::Net {
                master,
                complete: true,
                ids,
            } => {
                self.adopt(master, Phase::NetSet);
                self.set_ring(ids);
                copy(frame, out, &mut self.counters)
            }
            Repr::Reg {
                master,
                complete,
                masks,
            } => {
                self.adopt(
                    master,
                    if complete {
                        Phase::RegSet
                    } else {
                        Phase::RegDsc
                    },
                );
                let n = usize::from(self.count);
                let p = usize::from(self.position);
                if n == 0 || masks.len() != 2 * n {
                    return copy(frame, out, &mut self.counters);
                }
                if complete {
                    self.set_masks(masks);
                    return copy(frame, out, &mut self.counters);
                }
                let mut filled = [0u8; 2 * MAX_NODES];
                filled[..masks.len()].copy_from_slice(masks);
                filled[2 * p] = self.cfg.in_mask;
                filled[2 * p + 1] = self.cfg.out_mask;
                self.emit(
                    out,
                    &Repr::Reg {
                        master,
                        complete: false,
                        masks: &filled[..masks.len()],
                    },
                )
            }
            Repr::SyncDsc { master, .. } => {
                self.adopt(master, Phase::SyncDsc);
                copy(frame, out, &mut self.counters)
            }
            Repr::SyncSet { master, delay_ns } => {
                let before = self.phase;
                // `adopt` forgets the ring when the master changed, so decide after it.
                self.adopt(master, Phase::SyncSet);
                self.delay_ns = delay_ns;
                if self.count > 0 && matches!(before, Phase::RegSet | Phase::SyncDsc) {
                    self.phase = Phase::Running;
                }
                copy(frame, out, &mut self.counters)
            }
            Repr::Data { cycle, areas, .. } => {
                if self.phase != Phase::Running {
                    // Not set up: swallow it, so the master's watchdog sets the ring up again.
                    return None;
                }
                self.cycle = cycle;
                self.counters.cycles = self.counters.cycles.wrapping_add(1);
                let behind = u64::from(self.count.saturating_sub(self.position));
                self.sync_at = Some(started + behind * u64::from(self.delay_ns));
                let len = copy(frame, out, &mut self.counters)?;
                if areas.len() != usize::from(self.registers) * 2 * AREA_LEN {
                    self.counters.malformed += 1;
                    self.cycle_error = true;
                    return Some(len);
                }
                self.exchange_data(&mut out[3..len - 1]);
                seal(&mut out[..len]);
                Some(len)
            }
            Repr::Async { dest, source, data } => self.side_channel(dest, source, data, frame, out),
            Repr::Halt { .. } => {
                self.phase = Phase::Halted;
                self.sync_at = None;
                copy(frame, out, &mut self.counters)
            }
            Repr::Idle { .. } => None,
        }
    }
}
