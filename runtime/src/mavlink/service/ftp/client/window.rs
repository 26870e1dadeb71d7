//! The FTP client's window: the reads that fill a download's gaps, and an upload's writes, as
//! many in flight as the window holds, each sent again when its wait runs out.

use super::super::super::messages::Message;
use super::super::buffers::Source;
use super::super::{Nak, Opcode, Payload, MAX_DATA};
use super::{Client, Error, Op, Pending, Phase, SLOTS};

impl Client {
    /// The slot to (re)send now, if any: a new one at `next` when there is room, else one
    /// whose wait ran out. `None` when nothing is due or the peer is given up.
    pub(super) fn due_slot(
        &mut self,
        now_us: u64,
        next: Option<(u32, u8)>,
    ) -> Option<Result<usize, ()>> {
        let retry = self.config.retry;
        let window = usize::from(self.config.window).clamp(1, SLOTS);
        if let Some((offset, len)) = next {
            if let Some(i) = self.slots[..window].iter().position(Option::is_none) {
                let seq = self.next_seq();
                self.slots[i] = Some(Pending {
                    seq,
                    offset,
                    len,
                    tries: 0,
                    deadline: 0,
                    due: true,
                    sent_us: None,
                });
            }
        }
        let i = self.slots[..window]
            .iter()
            .position(|s| s.is_some_and(|s| s.due || now_us >= s.deadline))?;
        let rtt = self.rtt;
        let s = self.slots[i].as_mut()?;
        if !s.due {
            s.tries = s.tries.saturating_add(1);
            if retry.exhausted(now_us.saturating_sub(self.heard_us), self.sends) {
                return Some(Err(()));
            }
        }
        s.due = false;
        s.sent_us = rtt.time_sending(now_us, s.tries == 0);
        s.deadline = now_us + rtt.backoff_us(retry.timeout_us, s.tries);
        self.sends = self.sends.saturating_add(1);
        Some(Ok(i))
    }

    /// The next read or write to add to the window: the first piece of a gap that no read
    /// out covers, or the next piece of an upload.
    pub(super) fn next_piece(&self) -> Option<(u32, u8)> {
        match self.op {
            Op::Read(Phase::Fill) => self.gaps.as_slice().iter().find_map(|&(start, end)| {
                let mut at = start;
                while at < end {
                    let len = (end - at).min(MAX_DATA as u32) as u8;
                    if !self.slots.iter().flatten().any(|s| s.offset == at) {
                        return Some((at, len));
                    }
                    at += u32::from(len);
                }
                None
            }),
            Op::Write(Phase::Data) => (self.mark < self.size).then(|| {
                let len = (self.size - self.mark).min(MAX_DATA as u32) as u8;
                (self.mark, len)
            }),
            _ => None,
        }
    }

    /// Whether the window has room for [`Client::next_piece`].
    pub(super) fn has_room(&self) -> bool {
        let window = usize::from(self.config.window).clamp(1, SLOTS);
        self.slots[..window].iter().any(Option::is_none) && self.next_piece().is_some()
    }

    /// The next read (filling gaps) or write of the window: a new one when there is room,
    /// else one whose wait ran out.
    pub(super) fn window_transmit<S: Source + ?Sized>(
        &mut self,
        now_us: u64,
        source: &mut S,
    ) -> Option<Message> {
        let writing = self.op == Op::Write(Phase::Data);
        let next = self.next_piece();
        if writing && self.has_room() {
            // `due_slot` takes the piece into the window.
            if let Some((offset, len)) = next {
                self.mark = offset + u32::from(len);
            }
        }
        let i = match self.due_slot(now_us, next)? {
            Ok(i) => i,
            Err(()) => {
                self.finish(Err(Error::Timeout));
                return None;
            }
        };
        let s = self.slots[i]?;
        let opcode = if writing {
            Opcode::WriteFile
        } else {
            Opcode::ReadFile
        };
        let mut p = Payload::request(s.seq, self.session, opcode, s.offset);
        if writing {
            let want = usize::from(s.len);
            if source.read(s.offset, &mut p.data[..want]) < want {
                self.finish(Err(Error::Nak(Nak::Fail)));
                return None;
            }
        }
        p.size = s.len;
        Some(p.to_message(self.target))
    }
}
