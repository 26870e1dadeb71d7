//! One convention for every stream parser: [`Deframer`].
//!
//! A byte stream (a UART, a TCP connection, a pty, the datagrams of one UDP peer) carries frames
//! of one protocol. Each protocol's stream parser is a `Deframer`:
//!
//! - [`feed`](Deframer::feed) takes whatever bytes arrived and returns either "all consumed, no
//!   frame yet" or one frame plus the input it has not looked at yet ([`Feed`]), the shape of
//!   postcard's `CobsAccumulator`. Frames are views: into the input or into the parser's own
//!   storage, valid until the next `feed`;
//! - [`stats`](Deframer::stats) counts the frames handed out and every drop, by reason
//!   ([`Counters`]);
//! - [`finish`](Deframer::finish) ends the input: a frame in progress is dropped and counted;
//! - [`drain_stalled`](Deframer::drain_stalled) judges what is buffered after the input paused
//!   for longer than a link pauses inside a frame, so a false start (a stray start byte whose
//!   claimed length never comes) holds back no frame behind it.
//!
//! | protocol | parser | frame |
//! |----------|--------|-------|
//! | MAVLink 1 and 2 | [`mavlink::parser::Parser`](crate::mavlink::parser::Parser) | [`ParsedFrame`](crate::mavlink::parser::ParsedFrame), a checked view |
//! | NDLCom | [`ndlcom::parser::Parser`](crate::ndlcom::parser::Parser) | [`ndlcom::parser::Frame`](crate::ndlcom::parser::Frame), a checked view |
//! | ModRob-1 UART.B-1 / SPI-1 | [`modrob::parser::Parser`](crate::modrob::parser::Parser) | [`Message`](crate::modrob::Message), owned |
//! | TosNet over a byte stream | [`tosnet::stream::Parser`](crate::tosnet::stream::Parser) | the frame's bytes, for [`Repr::parse`](crate::tosnet::frame::Repr::parse) |
//!
//! Code that reads links is written once over this trait (the PC link layer's `Framed` is), so
//! every protocol runs on every link.
//!
//! Every wire module follows one convention, smoltcp's: a checked view over bytes with
//! accessors (`Frame::new_checked`, then `header()`, `payload()`...), and an owned
//! representation that parses from a view and emits into a buffer (`Repr::parse`,
//! `Repr::emit`, or a generated message's `decode` and `encode`).

/// The outcome of [`Deframer::feed`].
#[derive(Debug)]
#[must_use = "a frame and the rest of the input may be in the result"]
pub enum Feed<'a, F> {
    /// All input was consumed (kept in the parser or dropped); no complete frame yet.
    Consumed,
    /// A frame, and the input after it, which the parser has not looked at yet.
    Frame {
        /// The frame, valid until the next `feed`.
        frame: F,
        /// The input the parser has not consumed; feed it next.
        remaining: &'a [u8],
    },
}

/// What a parser accepted and dropped so far. Every parser's counters say how many frames it
/// handed out, how many it dropped, and why.
pub trait Counters: Copy + Default + core::fmt::Debug {
    /// Frames handed out.
    fn frames(&self) -> u64;

    /// Frames or candidates dropped, for any reason.
    fn dropped(&self) -> u64;

    /// Every counter with its name: `frames` first, then each drop reason and what else the
    /// parser counts.
    fn each(&self, f: &mut dyn FnMut(&'static str, u64));
}

/// A stream parser (see the [module documentation](self)).
pub trait Deframer {
    /// What [`feed`](Self::feed) hands out, borrowed from the parser or the input.
    type Frame<'p>
    where
        Self: 'p;

    /// The counters.
    type Stats: Counters;

    /// Feeds bytes and returns the first complete frame, if any, with the input after it. Call
    /// it again with `remaining` until it returns [`Feed::Consumed`].
    fn feed<'p, 'a: 'p>(&'p mut self, input: &'a [u8]) -> Feed<'a, Self::Frame<'p>>;

    /// The counters since creation (or the last [`take_stats`](Self::take_stats)).
    fn stats(&self) -> &Self::Stats;

    /// Returns the counters and zeroes them.
    fn take_stats(&mut self) -> Self::Stats;

    /// Ends the input: the bytes of a frame in progress are dropped and counted.
    fn finish(&mut self);

    /// The input paused for longer than a link ever pauses inside a frame, so what is buffered
    /// is all there is of it: gives up the candidate frame the buffer starts with (counted),
    /// so that the next `feed`, empty or not, looks at the bytes behind it. Returns whether
    /// there was one. Parsers that resynchronise on a delimiter (NDLCom's flag) keep the
    /// default, which gives up nothing.
    fn give_up_stalled(&mut self) -> bool {
        false
    }

    /// After such a pause, judges everything buffered: every complete frame behind a false
    /// start goes to `on_frame`, and what is left is given up. Returns how many frames.
    fn drain_stalled(&mut self, mut on_frame: impl FnMut(Self::Frame<'_>)) -> usize
    where
        Self: Sized,
    {
        let mut n = 0;
        while self.give_up_stalled() {
            n += self.feed_all(&[], &mut on_frame);
        }
        n
    }

    /// Feeds bytes and calls `on_frame` for every frame they complete; returns how many.
    fn feed_all(&mut self, mut input: &[u8], mut on_frame: impl FnMut(Self::Frame<'_>)) -> usize
    where
        Self: Sized,
    {
        let mut n = 0;
        while let Feed::Frame { frame, remaining } = self.feed(input) {
            on_frame(frame);
            input = remaining;
            n += 1;
        }
        n
    }
}

/// A counter in `usize` (a parser's native width) as the `u64` of [`Counters`].
#[inline]
#[allow(dead_code)]
pub(crate) fn wide(n: usize) -> u64 {
    n as u64
}
