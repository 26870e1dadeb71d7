//! Invariant checks shared by the `modrob_decoders` fuzz target and the property tests.
//!
//! `check_can`: the first four input bytes are a CAN identifier (little-endian), the next one
//! picks a data length of 0..=9, and that many bytes follow. Checked: no panic; a message that
//! decodes re-encodes to the same identifier, and its re-encoded form decodes to the same wire
//! form; an identifier with bits above 25 set or message type 3 never decodes.
//!
//! `check_reassembler`: the input is a script of piecewise chunks (numbers, counts and bytes
//! drawn so that restarts, duplicates, conflicts, out-of-range numbers and arrays longer than
//! the buffer are frequent), pushed into a `Reassembler` and into a plain model of the
//! documented rules. Checked: no panic; the same outcome from both for every chunk; a completed
//! array has no trailing zero, fits the buffer, and equals the model's chunks joined; the
//! counters add up.
//!
//! `check_text`: the input makes an array without NUL bytes and an arbitrary sequence of its
//! own chunks (repeated, dropped, reordered, some numbered out of range). Checked: no panic;
//! every `Complete` is exactly the array; an array longer than the buffer never completes;
//! there is never a conflict; a sequence that holds every chunk after its last restart
//! completes.

use ferrolink_runtime::modrob::message::CHUNK_LEN;
use ferrolink_runtime::modrob::piecewise::{Lost, Outcome, Progress, Reassembler, Sender};
use ferrolink_runtime::modrob::Message;

/// The buffer size the scripts reassemble into: not a multiple of 7, and smaller than the
/// longest arrays they make.
pub const CAP: usize = 40;

/// Checks CAN-1 decoding of one input.
pub fn check_can(data: &[u8]) {
    let Some((id, rest)) = data.split_first_chunk::<4>() else {
        return;
    };
    let id = u32::from_le_bytes(*id);
    let Some((&len, rest)) = rest.split_first() else {
        return;
    };
    let bytes = &rest[..rest.len().min(usize::from(len % 10))];
    let expected_len = match id >> 24 {
        0 | 1 => 6,
        _ => 8,
    };
    let valid = id >> 26 == 0
        && id >> 24 != 3
        && bytes.len() == expected_len
        && (id >> 24 != 0 || bytes[4] < 3);
    let decoded = Message::from_can(id, bytes);
    assert_eq!(
        decoded.is_ok(),
        valid,
        "{id:#010x} {bytes:02x?}: {decoded:?}"
    );
    if let Ok(message) = decoded {
        let can = message.to_can();
        assert_eq!(can.id, id);
        assert_eq!(can.data().len(), bytes.len());
        let again = Message::from_can(can.id, can.data()).expect("the re-encoded form decodes");
        assert!(again.same_wire(&message));
        if let Message::Piecewise { .. } = message {
            assert_eq!(can.data(), bytes);
        }
    }
}

/// What the model expects of one chunk.
#[derive(Debug, PartialEq, Eq)]
enum Expect {
    Pending(u16, u8),
    Complete(Vec<u8>),
    Duplicate(u8),
    OutOfRange(u8, u8),
    Conflict(u8, u8),
    TooLong(u8, u8),
}

/// The reassembly rules of `modrob::piecewise`, written plainly over a `Vec`.
#[derive(Debug, Default)]
struct Model {
    /// The transfer's chunks by number; empty when there is none.
    slots: Vec<Option<[u8; CHUNK_LEN]>>,
    highest: u8,
    complete: bool,
}

impl Model {
    fn received(&self) -> u16 {
        self.slots.iter().filter(|s| s.is_some()).count() as u16
    }

    fn clear(&mut self) {
        *self = Model::default();
    }

    fn push(
        &mut self,
        chunk: u8,
        chunks: u8,
        data: [u8; CHUNK_LEN],
    ) -> (Expect, Option<Lost>, bool) {
        if chunk >= chunks {
            return (Expect::OutOfRange(chunk, chunks), None, false);
        }
        let mut lost = None;
        if !self.slots.is_empty() {
            let same = self.slots.len() == usize::from(chunks);
            let stored = if same {
                self.slots[usize::from(chunk)]
            } else {
                None
            };
            if self.complete {
                if stored == Some(data) {
                    return (Expect::Duplicate(chunk), None, false);
                }
                self.clear();
            } else if !same || (chunk == 0 && stored.is_some()) {
                let received = self.received();
                lost = Some(Lost {
                    chunks: self.slots.len() as u8,
                    received,
                    missing: self.slots.len() as u16 - received,
                });
                self.clear();
            } else if let Some(stored) = stored {
                if stored == data {
                    return (Expect::Duplicate(chunk), None, false);
                }
                self.clear();
                return (Expect::Conflict(chunk, chunks), None, false);
            }
        }
        let start = usize::from(chunk) * CHUNK_LEN;
        if (0..CHUNK_LEN).any(|i| start + i >= CAP && data[i] != 0) {
            self.clear();
            return (Expect::TooLong(chunk, chunks), lost, false);
        }
        let reordered = self.received() > 0 && chunk < self.highest;
        if self.slots.is_empty() {
            self.slots = vec![None; usize::from(chunks)];
        }
        self.slots[usize::from(chunk)] = Some(data);
        self.highest = self.highest.max(chunk);
        let received = self.received();
        if received == u16::from(chunks) {
            self.complete = true;
            let mut all: Vec<u8> = self.slots.iter().flat_map(|s| s.unwrap()).collect();
            while all.last() == Some(&0) {
                all.pop();
            }
            (Expect::Complete(all), lost, reordered)
        } else {
            (Expect::Pending(received, chunks), lost, reordered)
        }
    }
}

fn expect_of(outcome: &Outcome<'_>) -> Expect {
    match outcome.progress {
        Progress::Pending { received, chunks } => Expect::Pending(received, chunks),
        Progress::Complete(data) => Expect::Complete(data.to_vec()),
        Progress::Duplicate { chunk } => Expect::Duplicate(chunk),
        Progress::OutOfRange { chunk, chunks } => Expect::OutOfRange(chunk, chunks),
        Progress::Conflict { chunk, chunks } => Expect::Conflict(chunk, chunks),
        Progress::TooLong { chunk, chunks } => Expect::TooLong(chunk, chunks),
        Progress::Ignored => panic!("a chunk of the followed module was ignored"),
    }
}

/// Checks the reassembler against the model on one input script.
pub fn check_reassembler(data: &[u8]) {
    const COUNTS: [u8; 8] = [0, 1, 2, 3, 3, 4, 6, 7];
    let palette: [[u8; CHUNK_LEN]; 4] = [[b'a'; 7], [b'b'; 7], *b"ab\0\0\0\0\0", [0; 7]];
    let mut reassembler = Reassembler::<CAP>::new(5);
    let mut model = Model::default();
    let (mut completes, mut losses, mut reorders) = (0u32, 0u32, 0u32);
    let mut input = data.iter().copied();
    while let (Some(op), Some(pick)) = (input.next(), input.next()) {
        let chunks = COUNTS[usize::from(op % 8)];
        let chunk = (op >> 3) % (chunks + 1);
        let bytes = if pick & 0x80 != 0 {
            let mut raw = [0u8; CHUNK_LEN];
            for byte in &mut raw {
                *byte = input.next().unwrap_or(0);
            }
            raw
        } else {
            palette[usize::from(pick % 4)]
        };
        let message = Message::Piecewise {
            module: if pick & 0x40 != 0 && pick & 0x80 == 0 {
                6
            } else {
                5
            },
            chunk,
            chunks,
            data: bytes,
        };
        let outcome = reassembler.push_message(&message);
        if message.module() != 5 {
            assert_eq!(outcome.progress, Progress::Ignored);
            continue;
        }
        let got = (expect_of(&outcome), outcome.lost, outcome.reordered);
        let (expected, lost, reordered) = model.push(chunk, chunks, bytes);
        if let Expect::Complete(array) = &got.0 {
            assert!(array.len() <= CAP);
            assert_ne!(array.last(), Some(&0));
        }
        completes += u32::from(matches!(got.0, Expect::Complete(_)));
        losses += u32::from(got.1.is_some());
        reorders += u32::from(got.2);
        assert_eq!(
            got,
            (expected, lost, reordered),
            "chunk {chunk} of {chunks}"
        );
        assert_eq!(reassembler.received(), model.received());
        assert_eq!(
            reassembler.missing().count(),
            usize::from(reassembler.missing_count())
        );
        assert_eq!(reassembler.is_complete(), model.complete);
    }
    let stats = reassembler.stats();
    assert_eq!(
        (stats.completed, stats.lost, stats.reordered),
        (completes, losses, reorders)
    );
}

/// Checks that an array's own chunks, in any order and number, reassemble only into it.
pub fn check_text(data: &[u8]) {
    let Some((&len, rest)) = data.split_first() else {
        return;
    };
    let len = usize::from(len) % 60;
    let text: Vec<u8> = (0..len)
        .map(|i| rest.get(i).copied().unwrap_or(b'x').max(1))
        .collect();
    let order = rest.get(len..).unwrap_or_default();
    let mut sender = Sender::new(9, &text);
    sender.restart();
    let chunks: Vec<Message> = core::iter::from_fn(|| sender.next_chunk()).collect();
    let count = chunks.len();
    let mut reassembler = Reassembler::<CAP>::new(9);
    let mut seen = vec![false; count];
    let mut completed = false;
    for &pick in order {
        let index = usize::from(pick) % (count + 1);
        let outcome = match chunks.get(index) {
            Some(message) => reassembler.push_message(message),
            None => {
                let outcome = reassembler.push(index as u8, count as u8, &[1; CHUNK_LEN]);
                assert!(matches!(outcome.progress, Progress::OutOfRange { .. }));
                continue;
            }
        };
        assert!(!matches!(outcome.progress, Progress::Conflict { .. }));
        if let Some(array) = outcome.complete() {
            assert_eq!(array, &text[..]);
            completed = true;
        }
        if index == 0 && seen[0] && !completed {
            // A restart: what came before is gone.
            seen.iter_mut().for_each(|s| *s = false);
        }
        seen[index] = true;
        if text.len() > CAP {
            assert!(reassembler.text().is_none());
        } else if seen.iter().all(|&s| s) {
            assert_eq!(reassembler.text(), Some(&text[..]));
        }
    }
}
