//! A MAVLink vehicle firmware for QEMU's `mps2-an386` board (a Cortex-M4 at 25 MHz): HEARTBEAT
//! at 1 Hz, 64 parameters, a mission of up to 100 items (with a geofence and rally points),
//! and commands, served by the runtime's sans-I/O state machines
//! (`ferrolink_runtime::mavlink::service`) over MAVLink 2 on UART0.
//!
//! The whole vehicle fits 32 kB of flash and 16 kB of RAM, the stack included: `memory.x`
//! gives the linker no more, and keeps a stack reserve free of static data.
//!
//! - [`hw`]: the UART, SysTick and the stack's high-water mark, by volatile register access
//!   (the only `unsafe` code);
//! - [`link`]: the stream parser and decoders in, the MAVLink 2 encoder out;
//! - [`params`]: the parameter table and its store;
//! - [`missions`]: the mission, geofence and rally point store;
//! - [`vehicle`]: the services and what the commands do;
//! - here: the clock and the main loop.
//!
//! The main loop polls: at most one received byte, the services' timers, at most one message
//! out, and again. When a pass finds nothing to do, the core sleeps until the next byte or
//! the next millisecond.

#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod hw;
mod link;
mod missions;
mod params;
mod vehicle;

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use ferrolink_runtime::mavlink::Parser;
use panic_halt as _;

use crate::link::Link;
use crate::missions::Missions;
use crate::params::Params;
use crate::vehicle::Vehicle;

/// Microseconds since start-up, from SysTick: monotonic, in 64 bits.
#[derive(Debug, Default)]
struct Clock {
    /// Milliseconds before the last wrap of the 32-bit millisecond count.
    epoch_ms: u64,
    last_ms: u32,
    last_us: u64,
}

impl Clock {
    fn now_us(&mut self) -> u64 {
        let (ms, us) = hw::uptime();
        if ms < self.last_ms {
            self.epoch_ms += 1 << 32;
        }
        self.last_ms = ms;
        let now = (self.epoch_ms + u64::from(ms)) * 1000 + u64::from(us);
        // A counter reload that the exception has not counted yet reads as a step back by up
        // to a millisecond: the clock stands still instead.
        self.last_us = self.last_us.max(now);
        self.last_us
    }
}

#[entry]
fn main() -> ! {
    // The firmware's state, as `&'static mut` references (`#[entry]` makes them so). Each
    // starts as zero bytes in .bss: what needs setting up is written at run time
    // (`MaybeUninit::write`), so no flash goes to an initial image of it.
    static mut PARSER: MaybeUninit<Parser> = MaybeUninit::uninit();
    static mut PARAMS: MaybeUninit<Params> = MaybeUninit::uninit();
    static mut MISSIONS: Missions = Missions::new();
    static mut VEHICLE: MaybeUninit<Vehicle> = MaybeUninit::uninit();

    let board = hw::Board::init();
    let mut clock = Clock::default();
    let mut link = Link::new(
        board.uart,
        PARSER.write(Parser::new(&link::RX_META)),
        vehicle::OWN,
    );
    let vehicle = VEHICLE.write(Vehicle::new(PARAMS.write(Params::new()), MISSIONS));

    loop {
        let now_us = clock.now_us();
        let received = link.receive();
        if let Some((from, msg)) = &received {
            vehicle.handle(now_us, *from, msg);
        }
        vehicle.tick(now_us);
        let outgoing = vehicle.poll_transmit(now_us);

        // ---- FTP ---------------------------------------------------------------------------
        // The place for the runtime's FTP server (`service::ftp::Server` over a `FileSystem`):
        //
        //     if let Some((from, msg)) = &received { ftp.handle(fs, now_us, *from, msg); }
        //     let outgoing = outgoing.or_else(|| ftp.poll_transmit(fs, now_us));
        //
        // with FILE_TRANSFER_PROTOCOL added to `link::RX_META`, `link::decode` and
        // `Link::send`. Until then the parser drops FTP frames and they go unanswered.
        // -------------------------------------------------------------------------------------

        match outgoing {
            Some(msg) => link.send(&msg),
            // Nothing came and nothing is due: sleep until a byte arrives or the next
            // millisecond, where the services' timers are looked at again.
            None if received.is_none() && link.is_drained() => hw::idle(),
            None => {}
        }
    }
}
