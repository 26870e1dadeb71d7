//! A minimal MAVLink radio bridge on a Cortex-M4 that parses, routes and signs, built to be
//! measured: `measure.sh` prints its flash and static RAM next to the same bridge written with
//! the MAVLink C library (`c/router_c.c`).
//!
//! Two UARTs, the autopilot's and the radio's, and between them:
//!
//! - a stream parser per UART (the [`Router`] holds them) and the routing rules of mavlink.io:
//!   routes learnt from intact frames, broadcasts to the other link, addressed frames where
//!   their target was seen;
//! - signature checks on the radio link: unsigned, badly signed and replayed frames are dropped;
//! - signing of every unsigned MAVLink 2 frame that goes out over the radio: it is re-encoded
//!   with a [`Signer`], the sender's ids and sequence number kept.
//!
//! The UART data registers, the clock and the key are [`black_box`] stand-ins, as in the NDLCom
//! node: nothing is optimised away and nothing is `unsafe`. The router lives in a `static`, so
//! static RAM is the bridge's whole state.

#![no_std]
#![no_main]
#![deny(unsafe_code)]

use core::hint::black_box;

use cortex_m_rt::entry;
use ferrolink_runtime::mavlink::router::{LinkConfig, NoFilter, Router};
use ferrolink_runtime::mavlink::signing::{SecretKey, Signer};
use ferrolink_runtime::mavlink::{v2, Dialect};
use panic_halt as _;

#[allow(dead_code, clippy::all)]
mod mavlink {
    include!(concat!(env!("OUT_DIR"), "/ferrolink.rs"));
}

/// The autopilot's UART.
const AUTOPILOT: usize = 0;
/// The radio's UART.
const RADIO: usize = 1;
/// The link id in this bridge's signatures.
const LINK_ID: u8 = 1;

/// Two links, routes for 8 (system, component) pairs, no per-source counters, no duplicate
/// detection (one radio), no filters: what the C bridge does.
type Bridge = Router<2, 8, 0, 0, NoFilter>;

/// One received byte and the UART it came from (a data register read).
#[inline(always)]
fn rx() -> (usize, u8) {
    let (link, byte): (usize, u8) = black_box((0, 0));
    (link % 2, byte)
}

/// Sends bytes on a UART, one data-register write each.
#[inline(always)]
fn tx(link: usize, bytes: &[u8]) {
    for &byte in bytes {
        black_box((link, byte));
    }
}

/// Microseconds since 1 January 2015, the signing clock (an RTC on a real board).
#[inline(always)]
fn now_us() -> u64 {
    black_box(0)
}

/// The shared secret (from protected flash on a real board).
#[inline(always)]
fn key() -> SecretKey {
    SecretKey::new(black_box([0; 32]))
}

/// An `Option` whose empty state is a zero tag: a `static` that starts empty goes to `.bss`
/// (an empty `Option<Bridge>` is a niche value inside the router, all of whose bytes would then
/// be an initial image in flash).
#[repr(C, u8)]
enum Slot<T> {
    Empty,
    Full(T),
}

impl<T> Slot<T> {
    /// Stores `value` and returns it.
    fn fill(&mut self, value: T) -> &mut T {
        *self = Slot::Full(value);
        match self {
            Slot::Full(value) => value,
            Slot::Empty => unreachable!(),
        }
    }
}

#[entry]
fn main() -> ! {
    // `#[entry]` turns these into `&'static mut` references.
    static mut BRIDGE: Slot<Bridge> = Slot::Empty;
    static mut OUT: [u8; v2::MAX_FRAME_LEN] = [0; v2::MAX_FRAME_LEN];

    let bridge = BRIDGE.fill(Bridge::new(mavlink::bench::Message::META));
    let _ = bridge.open_link(LinkConfig::default());
    let _ = bridge.open_link(LinkConfig {
        require_signing: Some(key()),
        ..LinkConfig::default()
    });
    let mut signer = Signer::new(key(), LINK_ID);

    loop {
        let (link, byte) = rx();
        let now = now_us();
        bridge.receive(link, &[byte], now, now, |routed| {
            for to in [AUTOPILOT, RADIO] {
                if routed.to & (1 << to) == 0 {
                    continue;
                }
                let frame = &routed.frame;
                match (to, frame.as_v2(), frame.meta()) {
                    (RADIO, Some(v2), Some(meta)) if !v2.is_signed() => {
                        let signed = signer.encode_raw(
                            now,
                            frame.header(),
                            frame.msg_id(),
                            meta.crc_extra,
                            frame.payload(),
                            OUT,
                        );
                        if let Ok(len) = signed {
                            tx(RADIO, OUT.get(..len).unwrap_or_default());
                        }
                    }
                    _ => tx(to, routed.bytes),
                }
            }
        });
    }
}
