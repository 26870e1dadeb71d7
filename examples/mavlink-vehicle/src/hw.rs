//! The board, by volatile register access: mps2-an386's UART0, the Cortex-M4's SysTick, sleep,
//! and the stack's high-water mark. All the firmware's `unsafe` is in this module, but for
//! `mem`'s `memcpy` and kin.
//!
//! - **UART0** is a CMSDK APB UART at `0x4000_4000` (Arm DDI0479C; QEMU's
//!   `hw/char/cmsdk-apb-uart.c`): DATA `+0x0`, STATE `+0x4` (bit 0 TX buffer full, bit 1 RX
//!   buffer full), CTRL `+0x8` (bit 0 TX enable, bit 1 RX enable, bit 3 RX interrupt enable),
//!   INTSTATUS `+0xC`, BAUDDIV `+0x10` (at least 16). One byte each way, no FIFO. QEMU offers
//!   the next received byte only once DATA has been read, so polling loses nothing: the bytes
//!   wait in the host's socket. The receive interrupt (IRQ 0) only wakes the core from
//!   [`idle`]; the main loop reads the byte.
//! - **SysTick** counts the 25 MHz processor clock down from 24 999 and raises its exception
//!   every millisecond; [`uptime`] reads the millisecond count and the counter together.
//! - **The stack** is painted with a pattern at start-up, from the end of `.bss` (cortex-m-rt's
//!   `_stack_end`) up to the stack pointer; [`stack_used`] finds the deepest word overwritten.

// The registers are fixed addresses of the board; nothing here aliases memory that Rust owns.
#![allow(unsafe_code)]

use core::ptr::{addr_of, read_volatile, write_volatile};
use core::sync::atomic::{compiler_fence, AtomicU32, Ordering};

use cortex_m_rt::exception;

/// mps2-an386's system clock, which drives the UART and SysTick.
pub const SYSCLK_HZ: u32 = 25_000_000;

/// The UART's baud rate. QEMU ignores it (bytes go to the host as fast as they are written),
/// but the register must hold a valid divisor before the transmitter is enabled.
pub const BAUD: u32 = 115_200;

/// The interrupts portion of the vector table (cortex-m-rt's `device` feature): the board's
/// 32 interrupt lines. cortex-m-rt's generic table would have 240 entries, 832 bytes more of
/// flash. Only UART0's receive interrupt is enabled; the rest go to cortex-m-rt's default
/// handler.
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
static __INTERRUPTS: [unsafe extern "C" fn(); 32] = {
    let mut vectors: [unsafe extern "C" fn(); 32] = [DefaultHandler; 32];
    vectors[UART0_RX_IRQ] = uart0_rx;
    vectors
};

extern "C" {
    fn DefaultHandler();
}

/// A 32-bit device register.
#[derive(Clone, Copy)]
struct Reg(usize);

impl Reg {
    #[inline(always)]
    fn read(self) -> u32 {
        // SAFETY: every `Reg` below is a word-aligned device register of mps2-an386 or of the
        // Cortex-M4's system control space, always mapped; reading it touches no Rust object.
        unsafe { read_volatile(self.0 as *const u32) }
    }

    #[inline(always)]
    fn write(self, value: u32) {
        // SAFETY: as for `read`.
        unsafe { write_volatile(self.0 as *mut u32, value) }
    }
}

const UART0: usize = 0x4000_4000;
const UART_DATA: Reg = Reg(UART0);
const UART_STATE: Reg = Reg(UART0 + 0x4);
const UART_CTRL: Reg = Reg(UART0 + 0x8);
const UART_INTSTATUS: Reg = Reg(UART0 + 0xC);
const UART_BAUDDIV: Reg = Reg(UART0 + 0x10);
const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_RX_INTEN: u32 = 1 << 3;
/// INTSTATUS: a byte was received (write 1 to clear).
const INT_RX: u32 = 1 << 1;
/// UART0's receive interrupt line (QEMU's `hw/arm/mps2.c`: RX is 0, TX 1).
const UART0_RX_IRQ: usize = 0;

/// NVIC: interrupt set-enable for lines 0..32.
const NVIC_ISER0: Reg = Reg(0xE000_E100);

const SYST_CSR: Reg = Reg(0xE000_E010);
const SYST_RVR: Reg = Reg(0xE000_E014);
const SYST_CVR: Reg = Reg(0xE000_E018);
const CSR_ENABLE: u32 = 1 << 0;
const CSR_TICKINT: u32 = 1 << 1;
/// Count the processor clock (25 MHz), not the 1 MHz reference clock.
const CSR_CLKSOURCE: u32 = 1 << 2;
/// SysTick counts from this down to 0, then starts again and raises its exception: 1 ms.
const SYST_RELOAD: u32 = SYSCLK_HZ / 1000 - 1;
const CYCLES_PER_US: u32 = SYSCLK_HZ / 1_000_000;

/// What the stack is painted with.
const PAINT: u32 = 0x5354_4b21;

extern "C" {
    // cortex-m-rt's link.x: the top of RAM, where the stack starts, and the end of the static
    // data, where the stack must stop.
    static _stack_start: u32;
    static _stack_end: u32;
}

/// The UART, owned by the [`Board`].
#[derive(Debug)]
pub struct Uart {
    _owned: (),
}

impl Uart {
    /// The received byte waiting in the data register, if any.
    #[inline]
    pub fn read(&mut self) -> Option<u8> {
        (UART_STATE.read() & STATE_RX_FULL != 0).then(|| UART_DATA.read() as u8)
    }

    /// Sends `bytes`, waiting for the transmit buffer before each.
    pub fn write(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            while UART_STATE.read() & STATE_TX_FULL != 0 {}
            UART_DATA.write(u32::from(byte));
        }
    }
}

/// The peripherals this firmware uses.
#[derive(Debug)]
pub struct Board {
    /// UART0, 8N1, transmitter and receiver enabled.
    pub uart: Uart,
}

impl Board {
    /// Paints the stack, starts SysTick and sets up the UART. Call it once, first thing in
    /// `main`, so that the painting reaches as high as it can.
    pub fn init() -> Self {
        paint_stack();
        SYST_RVR.write(SYST_RELOAD);
        SYST_CVR.write(0);
        SYST_CSR.write(CSR_ENABLE | CSR_TICKINT | CSR_CLKSOURCE);
        UART_BAUDDIV.write(SYSCLK_HZ / BAUD);
        UART_CTRL.write(CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INTEN);
        NVIC_ISER0.write(1 << UART0_RX_IRQ);
        Board {
            uart: Uart { _owned: () },
        }
    }
}

/// UART0's receive interrupt: it only wakes the core from [`idle`]. The byte stays in the data
/// register for the main loop.
extern "C" fn uart0_rx() {
    UART_INTSTATUS.write(INT_RX);
}

/// Sleeps until an interrupt (a received byte, or SysTick within a millisecond), unless a
/// received byte is waiting already. Interrupts are masked while it looks, so one that comes
/// between the look and the sleep still ends the sleep.
pub fn idle() {
    // SAFETY (the three blocks): `cpsid i` and `cpsie i` mask and unmask interrupts, `wfi`
    // waits for one (a pending interrupt ends it even while masked, and runs once unmasked).
    // None of them touches memory or the stack.
    unsafe { core::arch::asm!("cpsid i", options(nomem, nostack, preserves_flags)) };
    if UART_STATE.read() & STATE_RX_FULL == 0 {
        unsafe { core::arch::asm!("wfi", options(nomem, nostack, preserves_flags)) };
    }
    unsafe { core::arch::asm!("cpsie i", options(nomem, nostack, preserves_flags)) };
}

/// Milliseconds since SysTick started, wrapping.
static MILLIS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    MILLIS.fetch_add(1, Ordering::Relaxed);
}

/// Milliseconds since start-up (wrapping after 49.7 days) and microseconds into the current
/// one (0..=999). A counter reload between the two reads is seen as a changed millisecond
/// count, and the pair is read again.
pub fn uptime() -> (u32, u32) {
    loop {
        let ms = MILLIS.load(Ordering::Relaxed);
        compiler_fence(Ordering::SeqCst);
        let count = SYST_CVR.read().min(SYST_RELOAD);
        compiler_fence(Ordering::SeqCst);
        if MILLIS.load(Ordering::Relaxed) == ms {
            return (ms, (SYST_RELOAD - count) / CYCLES_PER_US);
        }
    }
}

/// The current stack pointer.
#[inline(always)]
fn stack_pointer() -> usize {
    let sp: usize;
    // SAFETY: reads a register into a local, nothing else.
    unsafe {
        core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags))
    };
    sp
}

/// The bounds of the stack: (lowest address it may reach, where it starts).
fn stack_bounds() -> (usize, usize) {
    // Only the addresses of the linker's symbols are taken, never their contents.
    (
        addr_of!(_stack_end) as usize,
        addr_of!(_stack_start) as usize,
    )
}

/// Fills the free stack, from the end of the static data up to just below the current stack
/// pointer, with [`PAINT`].
fn paint_stack() {
    let (bottom, _) = stack_bounds();
    // Stop short of the stack pointer: nothing lives below it, but leave room for this
    // function's own spills.
    let top = stack_pointer().saturating_sub(64) & !3;
    let mut p = bottom;
    while p < top {
        // SAFETY: `bottom..top` lies between the end of the static data and the stack
        // pointer: RAM that no Rust object occupies (the stack grows down towards it and has
        // not reached it yet), and no interrupt is enabled yet that could push a frame there.
        unsafe { write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// The most stack used since start-up, in bytes: from where the stack starts down to the
/// deepest word that no longer holds the paint.
pub fn stack_used() -> u32 {
    let (bottom, start) = stack_bounds();
    let mut p = bottom;
    // SAFETY: reads, never writes, the words from the end of the static data up to the first
    // that is not paint: paint, then a stale or (at the deepest point) live stack word. Plain,
    // aligned RAM.
    while p < start && unsafe { read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    (start - p) as u32
}
