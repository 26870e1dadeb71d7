//! MAVLink 2 pack and parse+decode on a Cortex-M4, the functions that `count.py` runs in an
//! emulator and counts instructions of (see `measure.sh` and the README).
//!
//! Every measured function is `#[inline(never)]` and `extern "C"`, and `main` hands its address
//! to [`black_box`]: the optimiser can neither drop it nor change its signature, so the emulator
//! can call it with the C calling convention (arguments in r0..r3, buffers in RAM). Nothing is
//! `unsafe`, nothing is `#[no_mangle]`: `count.py` finds the functions by their mangled names.
//!
//! - `pack_bench_1(value, seq, out)`, `pack_bench_248(fields, seq, out)`: builds the message
//!   (from the argument, from a [`Fields248`] in memory) and encodes a MAVLink 2 frame into
//!   `out` with [`v2::encode`]; returns the frame length.
//! - `parse_bench_1(parser, frame, len, msg)`, `parse_bench_248(...)`: feeds a whole frame to a
//!   [`Parser`] and decodes each frame it hands out into `msg` with `decode_into`; returns the
//!   decoded value (`BENCH_1`) or the number of `BENCH_248` frames decoded.
//! - `parse_bytes_bench_1`, `parse_bytes_bench_248`: the same, fed one byte at a time (as a
//!   UART receive interrupt would, and as the C library's `mavlink_parse_char` is).
//! - `parser_init`, `message_init`, `export_bench_248`: set-up and read-back for the emulator,
//!   not measured.

#![no_std]
#![no_main]
#![deny(unsafe_code)]

use core::hint::black_box;
use core::mem::{size_of, MaybeUninit};

use cortex_m_rt::entry;
use ferrolink_runtime::mavlink::{v2, CharArray, Header, Parser};
use panic_halt as _;

#[allow(dead_code, clippy::all)]
mod mavlink {
    include!(concat!(env!("OUT_DIR"), "/ferrolink.rs"));
}

use mavlink::bench::{Bench1, Bench248, Message};

/// System and component id of every frame (the C harness uses the same).
const SYSID: u8 = 1;
const COMPID: u8 = 1;

/// An output buffer that holds the largest unsigned frame, so the payload is encoded in place.
pub type FrameBuf = [u8; v2::MAX_UNSIGNED_FRAME_LEN];

/// The fields of `BENCH_248` in wire order, as the caller hands them over: the same layout as
/// the C library's `mavlink_bench_248_t`.
#[repr(C)]
pub struct Fields248 {
    pub time_usec: u64,
    pub d: [f64; 4],
    pub f: [f32; 40],
    pub label: [u8; 32],
    pub raw: [u8; 16],
}

/// The emulator gives the parser and the message this much memory each.
const SLOT: usize = 4096;
const _: () = assert!(size_of::<Parser>() <= SLOT && size_of::<Message>() <= SLOT);
const _: () = assert!(size_of::<Fields248>() == 248);

/// Packs `BENCH_1 { value }` with sequence number `seq` into `out`.
#[inline(never)]
extern "C" fn pack_bench_1(value: u8, seq: u8, out: &mut FrameBuf) -> usize {
    let msg = Bench1 { value };
    v2::encode(Header::new(seq, SYSID, COMPID), &msg, out).unwrap_or(0)
}

/// Packs `BENCH_248` with the fields in `src` and sequence number `seq` into `out`.
#[inline(never)]
extern "C" fn pack_bench_248(src: &Fields248, seq: u8, out: &mut FrameBuf) -> usize {
    let msg = Bench248 {
        time_usec: src.time_usec,
        d: src.d,
        f: src.f,
        label: CharArray(src.label),
        raw: src.raw,
    };
    v2::encode(Header::new(seq, SYSID, COMPID), &msg, out).unwrap_or(0)
}

/// Feeds `frame[..len]` to `parser` and decodes every frame it completes into `msg`; returns
/// how many were decoded.
#[inline(always)]
fn parse(parser: &mut Parser, frame: &FrameBuf, len: usize, msg: &mut Message) -> u32 {
    let mut n = 0;
    parser.feed_all(frame.get(..len).unwrap_or_default(), |f| {
        if f.decode_into(msg).is_ok() {
            n += 1;
        }
    });
    n
}

/// Parses and decodes one `BENCH_1` frame; returns its value, `u32::MAX` if there was none.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn parse_bench_1(
    parser: &mut Parser,
    frame: &FrameBuf,
    len: usize,
    msg: &mut Message,
) -> u32 {
    match (parse(parser, frame, len, msg), &*msg) {
        (1, Message::Bench1(m)) => u32::from(m.value),
        _ => u32::MAX,
    }
}

/// Parses and decodes one `BENCH_248` frame into `msg`; returns 1 if it was one.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn parse_bench_248(
    parser: &mut Parser,
    frame: &FrameBuf,
    len: usize,
    msg: &mut Message,
) -> u32 {
    match (parse(parser, frame, len, msg), &*msg) {
        (1, Message::Bench248(_)) => 1,
        _ => 0,
    }
}

/// [`parse`], but fed one byte at a time, as a UART receive interrupt would.
#[inline(always)]
fn parse_bytes(parser: &mut Parser, frame: &FrameBuf, len: usize, msg: &mut Message) -> u32 {
    let mut n = 0;
    for byte in frame.get(..len).unwrap_or_default() {
        parser.feed_all(core::slice::from_ref(byte), |f| {
            if f.decode_into(msg).is_ok() {
                n += 1;
            }
        });
    }
    n
}

/// [`parse_bench_1`], one byte at a time.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn parse_bytes_bench_1(
    parser: &mut Parser,
    frame: &FrameBuf,
    len: usize,
    msg: &mut Message,
) -> u32 {
    match (parse_bytes(parser, frame, len, msg), &*msg) {
        (1, Message::Bench1(m)) => u32::from(m.value),
        _ => u32::MAX,
    }
}

/// [`parse_bench_248`], one byte at a time.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn parse_bytes_bench_248(
    parser: &mut Parser,
    frame: &FrameBuf,
    len: usize,
    msg: &mut Message,
) -> u32 {
    match (parse_bytes(parser, frame, len, msg), &*msg) {
        (1, Message::Bench248(_)) => 1,
        _ => 0,
    }
}

/// Set-up: a parser for the bench dialect in `slot`.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn parser_init(slot: &mut MaybeUninit<Parser>) {
    slot.write(Parser::for_dialect::<Message>());
}

/// Set-up: a valid message in `slot` for the parse functions to overwrite.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn message_init(slot: &mut MaybeUninit<Message>) {
    slot.write(Message::Bench1(Bench1 { value: 0 }));
}

/// Read-back: copies a decoded `BENCH_248` out of `msg`; 1 if it is one.
#[allow(improper_ctypes_definitions)]
#[inline(never)]
extern "C" fn export_bench_248(msg: &Message, out: &mut Fields248) -> u32 {
    match msg {
        Message::Bench248(m) => {
            out.time_usec = m.time_usec;
            out.d = m.d;
            out.f = m.f;
            out.label = m.label.0;
            out.raw = m.raw;
            1
        }
        _ => 0,
    }
}

#[entry]
fn main() -> ! {
    // A firmware's parser and decoded message would be statics: set them up here so the
    // static RAM figure counts them (`MaybeUninit` statics start in .bss).
    static mut PARSER: MaybeUninit<Parser> = MaybeUninit::uninit();
    static mut MSG: MaybeUninit<Message> = MaybeUninit::uninit();
    parser_init(PARSER);
    message_init(MSG);
    black_box((&*PARSER, &*MSG));

    // Every function's address escapes, so each keeps its symbol and its C signature.
    black_box([
        pack_bench_1 as *const () as usize,
        pack_bench_248 as *const () as usize,
        parse_bench_1 as *const () as usize,
        parse_bench_248 as *const () as usize,
        parse_bytes_bench_1 as *const () as usize,
        parse_bytes_bench_248 as *const () as usize,
        parser_init as *const () as usize,
        message_init as *const () as usize,
        export_bench_248 as *const () as usize,
    ]);
    loop {
        black_box(());
    }
}
