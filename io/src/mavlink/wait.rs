//! One implementation of a protocol's drive loop for both faces, blocking and async.
//!
//! A sans-I/O state machine is driven the same way whoever waits: send what it has to send,
//! wait for the next frame until its next timeout, hand the frame in. The loop is written once,
//! as an `async fn` generic over a [`Wait`], the one thing the faces do differently:
//! [`Blocking`] waits in the calling thread (its futures are ready at once, so [`block_on`]
//! runs the whole loop in one poll, with no executor and no thread of its own), and `Tokio`
//! (feature `tokio`) waits on tokio's timer, so many operations run as tasks of one runtime
//! with no thread per operation.

use std::future::Future;
use std::io;
use std::pin::pin;
use std::task::{Context, Poll, Waker};
use std::time::Instant;

use super::{Frame, Subscription};

/// How a drive loop waits for the next frame of a subscription.
pub trait Wait {
    /// The next frame of `frames`, or `None` at `until`; an error once the connection stopped.
    fn next(
        &self,
        frames: &Subscription,
        until: Instant,
    ) -> impl Future<Output = io::Result<Option<Frame>>> + Send;
}

/// Waits in the calling thread: every future it returns is ready at once.
#[derive(Debug, Clone, Copy, Default)]
pub struct Blocking;

impl Wait for Blocking {
    fn next(
        &self,
        frames: &Subscription,
        until: Instant,
    ) -> impl Future<Output = io::Result<Option<Frame>>> + Send {
        std::future::ready(frames.recv(until.saturating_duration_since(Instant::now())))
    }
}

/// Waits on tokio's timer: use it inside a tokio runtime with time enabled.
#[cfg(feature = "tokio")]
#[derive(Debug, Clone, Copy, Default)]
pub struct Tokio;

#[cfg(feature = "tokio")]
impl Wait for Tokio {
    async fn next(&self, frames: &Subscription, until: Instant) -> io::Result<Option<Frame>> {
        match tokio::time::timeout_at(until.into(), frames.recv_async()).await {
            Ok(frame) => frame.map(Some),
            Err(_) => Ok(None),
        }
    }
}

/// Runs `future` to its end in this thread, which must need no waking: a drive loop on
/// [`Blocking`], whose every wait is ready at once.
///
/// # Panics
///
/// If the future waits on anything else (it would never be woken).
pub fn block_on<F: Future>(future: F) -> F::Output {
    let mut future = pin!(future);
    match future
        .as_mut()
        .poll(&mut Context::from_waker(Waker::noop()))
    {
        Poll::Ready(output) => output,
        Poll::Pending => panic!("block_on: the future waits on something other than Blocking"),
    }
}
