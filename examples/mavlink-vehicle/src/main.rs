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
//! - [`params`]: the parameter table and its store;
//! - [`missions`]: the mission, geofence and rally point store;
//! - [`vehicle`]: the services and what the commands do;
//! - here: the clock, the link (stream parser in, MAVLink 2 encoder out) and the main loop.
//!
//! The main loop polls: one received byte, the services' timers, one message out, and again.
//! Nothing waits except for the UART's transmit buffer.

#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod hw;
mod missions;
mod params;
mod vehicle;

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use ferrolink_runtime::framing::Feed;
#[allow(deprecated)]
use ferrolink_runtime::mavlink::service::messages::{
    CommandCancel, CommandInt, CommandLong, Heartbeat, Message, MissionClearAll, MissionCount,
    MissionItem, MissionItemInt, MissionRequest, MissionRequestInt, MissionRequestList,
    MissionSetCurrent, ParamRequestList, ParamRequestRead, ParamSet,
};
use ferrolink_runtime::mavlink::{Dialect, Message as _, MessageMeta};
use ferrolink_runtime::mavlink::service::Address;
use ferrolink_runtime::mavlink::{v2, Header, Parser};
use panic_halt as _;

use crate::missions::Missions;
use crate::params::Params;
use crate::vehicle::{Vehicle, OWN};

/// Microseconds since start-up, from SysTick: monotonic, in 64 bits.
#[derive(Debug, Default)]
struct Clock {
    /// Milliseconds before the last wrap of SysTick's 32-bit count.
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

/// MAVLink on the UART: the stream parser for what comes in, the MAVLink 2 encoder for what
/// goes out.
#[derive(Debug)]
struct Link {
    uart: hw::Uart,
    parser: &'static mut Parser,
    /// A received byte the parser has not taken yet (it handed out a frame first).
    held: Option<u8>,
    /// The parser handed out a frame: it may hold another one, ask it before feeding more.
    again: bool,
    /// Our sequence number.
    seq: u8,
}

impl Link {
    /// Feeds the parser at most one received byte; a message when that completes a frame.
    #[inline(never)]
    fn receive(&mut self) -> Option<(Address, Message)> {
        let byte = match self.held.take() {
            Some(byte) => Some(byte),
            None if self.again => None,
            None => Some(self.uart.read()?),
        };
        self.again = false;
        let input = byte.as_slice();
        match self.parser.feed(input) {
            Feed::Consumed => None,
            Feed::Frame { frame, remaining } => {
                self.held = remaining.first().copied();
                self.again = true;
                let h = frame.header();
                // The parser checked the frame against the services' messages: it decodes.
                let msg = decode(frame.msg_id(), frame.payload())?;
                Some((Address::new(h.sysid, h.compid), msg))
            }
        }
    }

    /// Sends `msg` as a MAVLink 2 frame from this vehicle.
    #[inline(never)]
    fn send(&mut self, msg: &Message) {
        let mut frame = [0u8; v2::MAX_UNSIGNED_FRAME_LEN];
        let header = Header::new(self.seq, OWN.system, OWN.component);
        let encoded = match msg {
            Message::Heartbeat(m) => v2::encode(header, m, &mut frame),
            Message::ParamValue(m) => v2::encode(header, m, &mut frame),
            Message::MissionCount(m) => v2::encode(header, m, &mut frame),
            Message::MissionItemInt(m) => v2::encode(header, m, &mut frame),
            Message::MissionItem(m) => v2::encode(header, m, &mut frame),
            Message::MissionRequestInt(m) => v2::encode(header, m, &mut frame),
            Message::MissionAck(m) => v2::encode(header, m, &mut frame),
            Message::MissionCurrent(m) => v2::encode(header, m, &mut frame),
            Message::CommandAck(m) => v2::encode(header, m, &mut frame),
            _ => return,
        };
        if let Ok(len) = encoded {
            self.uart.write(frame.get(..len).unwrap_or_default());
            self.seq = self.seq.wrapping_add(1);
        }
    }
}

/// The messages the services take, sorted by id: the parser drops every other.
static RX_META: [MessageMeta; 15] = pick([
    Heartbeat::ID,
    ParamRequestRead::ID,
    ParamRequestList::ID,
    ParamSet::ID,
    MissionItem::ID,
    MissionRequest::ID,
    MissionSetCurrent::ID,
    MissionRequestList::ID,
    MissionCount::ID,
    MissionClearAll::ID,
    MissionRequestInt::ID,
    MissionItemInt::ID,
    CommandInt::ID,
    CommandLong::ID,
    CommandCancel::ID,
]);

/// The entries of `Message::META` for `ids`.
const fn pick<const N: usize>(ids: [u32; N]) -> [MessageMeta; N] {
    let all = <Message as Dialect>::META;
    let mut out = [all[0]; N];
    let mut i = 0;
    while i < N {
        let mut j = 0;
        while all[j].id != ids[i] {
            j += 1;
        }
        out[i] = all[j];
        i += 1;
    }
    out
}

#[allow(deprecated)]
fn decode(id: u32, p: &[u8]) -> Option<Message> {
    Some(match id {
        Heartbeat::ID => Message::Heartbeat(Heartbeat::decode(p)),
        ParamRequestRead::ID => Message::ParamRequestRead(ParamRequestRead::decode(p)),
        ParamRequestList::ID => Message::ParamRequestList(ParamRequestList::decode(p)),
        ParamSet::ID => Message::ParamSet(ParamSet::decode(p)),
        MissionItem::ID => Message::MissionItem(MissionItem::decode(p)),
        MissionRequest::ID => Message::MissionRequest(MissionRequest::decode(p)),
        MissionSetCurrent::ID => Message::MissionSetCurrent(MissionSetCurrent::decode(p)),
        MissionRequestList::ID => Message::MissionRequestList(MissionRequestList::decode(p)),
        MissionCount::ID => Message::MissionCount(MissionCount::decode(p)),
        MissionClearAll::ID => Message::MissionClearAll(MissionClearAll::decode(p)),
        MissionRequestInt::ID => Message::MissionRequestInt(MissionRequestInt::decode(p)),
        MissionItemInt::ID => Message::MissionItemInt(MissionItemInt::decode(p)),
        CommandInt::ID => Message::CommandInt(CommandInt::decode(p)),
        CommandLong::ID => Message::CommandLong(CommandLong::decode(p)),
        CommandCancel::ID => Message::CommandCancel(CommandCancel::decode(p)),
        _ => return None,
    })
}

#[entry]
fn main() -> ! {
    // The firmware's state, as `&'static mut` references (`/// The messages the services take, sorted by id: the parser drops every other.
static RX_META: [MessageMeta; 15] = pick([
    Heartbeat::ID,
    ParamRequestRead::ID,
    ParamRequestList::ID,
    ParamSet::ID,
    MissionItem::ID,
    MissionRequest::ID,
    MissionSetCurrent::ID,
    MissionRequestList::ID,
    MissionCount::ID,
    MissionClearAll::ID,
    MissionRequestInt::ID,
    MissionItemInt::ID,
    CommandInt::ID,
    CommandLong::ID,
    CommandCancel::ID,
]);

/// The entries of `Message::META` for `ids`.
const fn pick<const N: usize>(ids: [u32; N]) -> [MessageMeta; N] {
    let all = <Message as Dialect>::META;
    let mut out = [all[0]; N];
    let mut i = 0;
    while i < N {
        let mut j = 0;
        while all[j].id != ids[i] {
            j += 1;
        }
        out[i] = all[j];
        i += 1;
    }
    out
}

#[allow(deprecated)]
fn decode(id: u32, p: &[u8]) -> Option<Message> {
    Some(match id {
        Heartbeat::ID => Message::Heartbeat(Heartbeat::decode(p)),
        ParamRequestRead::ID => Message::ParamRequestRead(ParamRequestRead::decode(p)),
        ParamRequestList::ID => Message::ParamRequestList(ParamRequestList::decode(p)),
        ParamSet::ID => Message::ParamSet(ParamSet::decode(p)),
        MissionItem::ID => Message::MissionItem(MissionItem::decode(p)),
        MissionRequest::ID => Message::MissionRequest(MissionRequest::decode(p)),
        MissionSetCurrent::ID => Message::MissionSetCurrent(MissionSetCurrent::decode(p)),
        MissionRequestList::ID => Message::MissionRequestList(MissionRequestList::decode(p)),
        MissionCount::ID => Message::MissionCount(MissionCount::decode(p)),
        MissionClearAll::ID => Message::MissionClearAll(MissionClearAll::decode(p)),
        MissionRequestInt::ID => Message::MissionRequestInt(MissionRequestInt::decode(p)),
        MissionItemInt::ID => Message::MissionItemInt(MissionItemInt::decode(p)),
        CommandInt::ID => Message::CommandInt(CommandInt::decode(p)),
        CommandLong::ID => Message::CommandLong(CommandLong::decode(p)),
        CommandCancel::ID => Message::CommandCancel(CommandCancel::decode(p)),
        _ => return None,
    })
}

#[entry]` makes them so). Each
    // starts as zero bytes in .bss: what needs setting up is written at run time
    // (`MaybeUninit::write`), so no flash goes to an initial image of it.
    static mut PARSER: MaybeUninit<Parser> = MaybeUninit::uninit();
    static mut PARAMS: MaybeUninit<Params> = MaybeUninit::uninit();
    static mut MISSIONS: Missions = Missions::new();
    static mut VEHICLE: MaybeUninit<Vehicle> = MaybeUninit::uninit();

    let board = hw::Board::init();
    let mut clock = Clock::default();
    let mut link = Link {
        uart: board.uart,
        parser: PARSER.write(Parser::new(&RX_META)),
        held: None,
        again: false,
        seq: 0,
    };
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
        // The place for the runtime's FTP server, once it has one:
        //
        //     if let Some((from, msg)) = &received { ftp.handle(now_us, *from, msg); }
        //     let outgoing = outgoing.or_else(|| ftp.poll_transmit(now_us));
        //
        // Until then FILE_TRANSFER_PROTOCOL is decoded and left unanswered.
        // -------------------------------------------------------------------------------------

        if let Some(msg) = outgoing {
            link.send(&msg);
        }
    }
}
