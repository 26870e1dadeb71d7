//! Output queues: a stream peer that does not read fast enough loses its own frames, and never
//! holds up whoever sends to it.

use std::collections::VecDeque;
use std::io;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};

use crate::LinkWriter;

/// What a stream peer's [`Sender`](super::Sender) does when the peer reads slower than it is
/// written to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Overflow {
    /// Write on the sender's thread, waiting for the peer (up to 100 ms a write, then the
    /// write fails): backpressure, for a program that talks to one peer.
    #[default]
    Wait,
    /// Queue frames for a writer thread; when the queue is full, drop the frame being sent.
    DropNewest,
    /// Queue frames for a writer thread; when the queue is full, drop the oldest queued frames
    /// to make room, so a peer that comes back gets the newest (a router's default).
    DropOldest,
}

/// How a stream peer's output is queued.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputQueue {
    /// What happens when the peer does not keep up.
    pub overflow: Overflow,
    /// The most bytes queued for a peer (with [`Overflow::DropNewest`] and
    /// [`Overflow::DropOldest`]), beside the batch its writer thread is writing.
    pub bytes: usize,
}

/// The default queue bound: 64 KiB, 1,600 frames of 40 bytes.
pub const DEFAULT_QUEUE_BYTES: usize = 64 * 1024;

/// What the router and bridge daemons queue by default: 64 KiB per peer, dropping the oldest
/// frames first, so a peer that comes back (a phone app brought to the front, say) gets the
/// newest.
pub const DAEMON_QUEUE: OutputQueue = OutputQueue {
    overflow: Overflow::DropOldest,
    bytes: DEFAULT_QUEUE_BYTES,
};

impl Default for OutputQueue {
    fn default() -> Self {
        Self {
            overflow: Overflow::Wait,
            bytes: DEFAULT_QUEUE_BYTES,
        }
    }
}

/// Frames waiting for one peer, whole: `data` holds them back to back, `lens` their lengths.
#[derive(Debug, Default)]
struct Pending {
    data: VecDeque<u8>,
    lens: VecDeque<usize>,
    closed: bool,
    dropped: u64,
}

/// The queue between the senders of one peer and its writer thread.
#[derive(Debug)]
pub(crate) struct Queue {
    pending: Mutex<Pending>,
    wake: Condvar,
    policy: OutputQueue,
}

impl Queue {
    /// A queue with `policy`, and the thread that writes it to `writer` until it is closed or a
    /// write fails.
    pub(crate) fn start(
        name: &str,
        policy: OutputQueue,
        writer: Arc<Mutex<Box<dyn LinkWriter>>>,
    ) -> io::Result<Arc<Queue>> {
        let queue = Arc::new(Queue {
            pending: Mutex::new(Pending::default()),
            wake: Condvar::new(),
            policy,
        });
        let q = queue.clone();
        super::spawn(name, move || q.write_out(&writer))?;
        Ok(queue)
    }

    fn lock(&self) -> MutexGuard<'_, Pending> {
        self.pending.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Queues one frame, or drops it (or older ones) as the policy says. Fails once the peer is
    /// gone.
    pub(crate) fn push(&self, frame: &[u8]) -> io::Result<()> {
        let mut p = self.lock();
        if p.closed {
            return Err(io::Error::new(
                io::ErrorKind::BrokenPipe,
                "the peer is gone",
            ));
        }
        let limit = self.policy.bytes;
        if frame.len() > limit {
            p.dropped += 1;
            return Ok(());
        }
        while p.data.len() + frame.len() > limit {
            if self.policy.overflow != Overflow::DropOldest {
                p.dropped += 1;
                return Ok(());
            }
            let n = p.lens.pop_front().unwrap_or(p.data.len());
            p.data.drain(..n);
            p.dropped += 1;
        }
        // The writer waits only for an empty queue: waking it for each frame of a burst would
        // cost a system call a frame.
        let was_empty = p.data.is_empty();
        p.data.extend(frame);
        p.lens.push_back(frame.len());
        drop(p);
        if was_empty {
            self.wake.notify_one();
        }
        Ok(())
    }

    /// Frames dropped because the peer did not keep up.
    pub(crate) fn dropped(&self) -> u64 {
        self.lock().dropped
    }

    /// Ends the writer thread (what is queued is dropped) and fails later pushes.
    pub(crate) fn close(&self) {
        self.lock().closed = true;
        self.wake.notify_one();
    }

    /// The writer thread: takes everything queued as one batch, so frames for one peer go out
    /// in as few writes as the peer allows.
    fn write_out(&self, writer: &Mutex<Box<dyn LinkWriter>>) {
        let mut batch = Vec::new();
        loop {
            {
                let mut p = self.lock();
                while p.data.is_empty() && !p.closed {
                    p = self.wake.wait(p).unwrap_or_else(PoisonError::into_inner);
                }
                if p.closed {
                    return;
                }
                batch.clear();
                batch.extend(p.data.drain(..));
                p.lens.clear();
            }
            let mut rest = &batch[..];
            while !rest.is_empty() {
                let written = writer
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .write(rest);
                match written {
                    Ok(n) => rest = &rest[n..],
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(_) => {
                        self.close();
                        return;
                    }
                }
                if self.lock().closed {
                    return;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn queue(overflow: Overflow, bytes: usize) -> Queue {
        Queue {
            pending: Mutex::new(Pending::default()),
            wake: Condvar::new(),
            policy: OutputQueue { overflow, bytes },
        }
    }

    fn queued(q: &Queue) -> Vec<u8> {
        q.lock().data.iter().copied().collect()
    }

    #[test]
    fn drop_oldest_keeps_the_newest_whole_frames() {
        let q = queue(Overflow::DropOldest, 10);
        for frame in [[1u8; 4], [2; 4], [3; 4]] {
            q.push(&frame).expect("open");
        }
        assert_eq!(queued(&q), [[2u8; 4], [3; 4]].concat());
        assert_eq!(q.dropped(), 1);
        q.push(&[9; 11]).expect("open");
        assert_eq!(q.dropped(), 2, "a frame larger than the queue is dropped");
    }

    #[test]
    fn drop_newest_keeps_what_was_queued() {
        let q = queue(Overflow::DropNewest, 10);
        for frame in [[1u8; 4], [2; 4], [3; 4]] {
            q.push(&frame).expect("open");
        }
        assert_eq!(queued(&q), [[1u8; 4], [2; 4]].concat());
        assert_eq!(q.dropped(), 1);
    }

    /// Collects what the writer thread writes, a few bytes a call.
    struct Collect(Arc<Mutex<Vec<u8>>>);

    impl LinkWriter for Collect {
        fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
            let n = bytes.len().min(7);
            self.0.lock().expect("lock").extend_from_slice(&bytes[..n]);
            Ok(n)
        }
    }

    #[test]
    fn the_writer_thread_gets_every_frame_of_bursts_and_lone_frames() {
        let out = Arc::new(Mutex::new(Vec::new()));
        let writer: Box<dyn LinkWriter> = Box::new(Collect(out.clone()));
        let policy = OutputQueue {
            overflow: Overflow::DropNewest,
            bytes: 1 << 20,
        };
        let q = Queue::start("test writer", policy, Arc::new(Mutex::new(writer))).expect("spawn");
        let mut sent = Vec::new();
        for i in 0..2000u32 {
            let frame = i.to_le_bytes();
            q.push(&frame).expect("open");
            sent.extend_from_slice(&frame);
            // Bursts, and frames alone that find the writer asleep.
            if i % 100 == 0 {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
        }
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
        while out.lock().expect("lock").len() < sent.len() && std::time::Instant::now() < deadline {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        q.close();
        assert_eq!(*out.lock().expect("lock"), sent);
        assert_eq!(q.dropped(), 0);
    }

    #[test]
    fn a_closed_queue_refuses() {
        let q = queue(Overflow::DropOldest, 10);
        q.close();
        assert!(q.push(&[1]).is_err());
    }
}
