//! A MAVLink vehicle firmware for QEMU's `mps2-an386` board (a Cortex-M4 at 25 MHz): HEARTBEAT
//! at 1 Hz, 64 parameters, a mission of up to 100 items (with a geofence and rally points),
//! commands, and the parameters as a file over MAVLink FTP, served by the runtime's sans-I/O
//! state machines (`ferrolink_runtime::mavlink::service`) over MAVLink 2 on UART0.
//!
//! The whole vehicle fits 32 kB of flash and 16 kB of RAM, the stack included: `memory.x`
//! gives the linker no more, and keeps a stack reserve free of static data.
//!
//! - [`hw`]: the UART, SysTick and the stack's high-water mark, by volatile register access;
//! - [`mem`]: `memcpy` and its kin, a byte at a time (with [`hw`], the only `unsafe` code);
//! - [`link`]: the stream parser and decoders in, the MAVLink 2 encoder out;
//! - [`params`]: the parameter table and its store;
//! - [`missions`]: the mission, geofence and rally point store;
//! - [`files`]: the read-only file table served over FTP, `@PARAM/param.pck`;
//! - [`vehicle`]: the services and what the commands do;
//! - here: the clock, the set-up and the main loop.
//!
//! The main loop polls: at most one received byte, the services' timers, at most one message
//! out, and again. When a pass finds nothing to do, the core sleeps until the next byte or
//! the next millisecond.

#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod files;
mod hw;
mod link;
mod mem;
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
use crate::vehicle::{FtpServer, Vehicle};

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
    static mut FTP: MaybeUninit<FtpServer> = MaybeUninit::uninit();
    static mut VEHICLE: MaybeUninit<Vehicle> = MaybeUninit::uninit();

    let board = hw::Board::init();
    let mut clock = Clock::default();
    let (mut link, vehicle) = set_up(board.uart, PARSER, PARAMS, MISSIONS, FTP, VEHICLE);

    loop {
        let now_us = clock.now_us();
        let received = link.receive();
        if let Some((from, msg)) = &received {
            vehicle.handle(now_us, *from, msg);
        }
        vehicle.tick(now_us);
        match &vehicle.poll_transmit(now_us) {
            Some(msg) => link.send(msg),
            // Nothing came and nothing is due: sleep until a byte arrives or the next
            // millisecond, where the services' timers are looked at again.
            None if received.is_none() && link.is_drained() => hw::idle(),
            None => {}
        }
    }
}

/// Writes the parser, the parameters, the FTP server and the vehicle into their statics; the
/// link and the vehicle.
///
/// Out of line, and each static written by a call of its own ([`put`]): what is built here
/// passes through the stack on its way to a static (the FTP server's 1 kB of replies, the
/// parameter values, the vehicle), and the compiler keeps a frame's temporaries apart. Inlined
/// into `main`, that room would stay taken under every service's calls; all in one frame, it
/// would add up.
#[inline(never)]
fn set_up(
    uart: hw::Uart,
    parser: &'static mut MaybeUninit<Parser>,
    params: &'static mut MaybeUninit<Params>,
    missions: &'static mut Missions,
    ftp: &'static mut MaybeUninit<FtpServer>,
    vehicle: &'static mut MaybeUninit<Vehicle>,
) -> (Link, &'static mut Vehicle) {
    let link = Link::new(
        uart,
        put(parser, || Parser::new(&link::RX_META)),
        vehicle::OWN,
    );
    let params = put(params, Params::new);
    let ftp = put(ftp, || FtpServer::new(vehicle::ftp_config()));
    let vehicle = put(vehicle, || Vehicle::new(params, missions, ftp));
    (link, vehicle)
}

/// Writes what `make` builds into `slot`, in a frame of its own.
#[inline(never)]
fn put<T>(slot: &'static mut MaybeUninit<T>, make: impl FnOnce() -> T) -> &'static mut T {
    slot.write(make())
}
