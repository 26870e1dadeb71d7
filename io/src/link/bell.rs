//! An endpoint's stop as something a thread can wait on beside its device: a pipe whose write
//! end is closed at the stop, so that from then on its read end is readable (hung up) for every
//! thread that polls it, however many and whenever they look.
//!
//! A device's blocked read is not woken by another thread, as a socket's is by its shutdown;
//! a serial or pty reader instead waits for its device and the bell at once, and an idle link
//! sleeps until bytes come or the endpoint stops.

use std::io;
use std::sync::{Mutex, PoisonError};
use std::time::Duration;

#[cfg(unix)]
use std::os::fd::{AsFd, BorrowedFd};

/// What a wait on a device and the bell ended with.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Rang {
    /// The device has something to read, or hung up: its read says which.
    Device,
    /// The bell rang: the endpoint stopped.
    Bell,
    /// The time given passed first (or a signal came in).
    TimedOut,
}

#[derive(Debug)]
pub(crate) struct Bell {
    reader: io::PipeReader,
    /// Dropped when the bell rings.
    writer: Mutex<Option<io::PipeWriter>>,
}

impl Bell {
    /// A bell, or `None` where the system will not give a pipe (out of descriptors): its users
    /// then look at the stop now and then instead.
    pub(crate) fn new() -> Option<Bell> {
        let (reader, writer) = io::pipe().ok()?;
        Some(Bell {
            reader,
            writer: Mutex::new(Some(writer)),
        })
    }

    /// Rings it for good; ringing again does nothing.
    pub(crate) fn ring(&self) {
        self.writer
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take();
    }

    /// Sleeps for `timeout` or until the bell rings, whichever is first.
    pub(crate) fn sleep(&self, timeout: Duration) {
        #[cfg(unix)]
        let _ = self.wait(None, timeout);
        #[cfg(not(unix))]
        std::thread::sleep(timeout);
    }

    /// Waits up to `timeout` until `device` is readable (or hung up) or the bell rings.
    #[cfg(unix)]
    pub(crate) fn wait(
        &self,
        device: Option<BorrowedFd<'_>>,
        timeout: Duration,
    ) -> io::Result<Rang> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        // Rounded up: a wait never ends before its time is up.
        let ms = timeout.as_nanos().div_ceil(1_000_000);
        let timeout = PollTimeout::try_from(ms).unwrap_or(PollTimeout::MAX);
        let bell = PollFd::new(self.reader.as_fd(), PollFlags::POLLIN);
        let (mut both, mut one);
        let fds: &mut [PollFd] = match device {
            Some(fd) => {
                both = [bell, PollFd::new(fd, PollFlags::POLLIN)];
                &mut both
            }
            None => {
                one = [bell];
                &mut one
            }
        };
        match poll(fds, timeout) {
            Ok(0) | Err(nix::errno::Errno::EINTR) => Ok(Rang::TimedOut),
            Ok(_) if fds.get(1).is_some_and(|d| d.any() == Some(true)) => Ok(Rang::Device),
            Ok(_) => Ok(Rang::Bell),
            Err(e) => Err(e.into()),
        }
    }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::time::Instant;

    #[test]
    fn a_bell_wakes_every_sleeper_and_stays_rung() {
        let bell = Arc::new(Bell::new().expect("a pipe"));
        let sleepers: Vec<_> = (0..3)
            .map(|_| {
                let bell = bell.clone();
                std::thread::spawn(move || bell.wait(None, Duration::from_secs(60)))
            })
            .collect();
        std::thread::sleep(Duration::from_millis(50));
        bell.ring();
        for s in sleepers {
            assert_eq!(s.join().unwrap().unwrap(), Rang::Bell);
        }
        // Later waits end at once, and ringing again is harmless.
        bell.ring();
        let start = Instant::now();
        bell.sleep(Duration::from_secs(60));
        assert!(start.elapsed() < Duration::from_secs(30));
    }

    #[test]
    fn a_wait_tells_the_device_from_the_bell_and_the_timeout() {
        let bell = Bell::new().expect("a pipe");
        let (device, mut other_end) = std::os::unix::net::UnixStream::pair().unwrap();
        let wait = |timeout| bell.wait(Some(device.as_fd()), timeout).unwrap();
        assert_eq!(wait(Duration::from_millis(20)), Rang::TimedOut);
        std::io::Write::write_all(&mut other_end, b"x").unwrap();
        assert_eq!(wait(Duration::from_secs(60)), Rang::Device);
        // A device with bytes waiting still says so after the stop; its reader looks at the
        // stop first.
        bell.ring();
        assert_eq!(wait(Duration::from_secs(60)), Rang::Device);
        let mut x = [0];
        std::io::Read::read_exact(&mut &device, &mut x).unwrap();
        assert_eq!(wait(Duration::from_secs(60)), Rang::Bell);
    }
}
