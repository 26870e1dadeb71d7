//! A no_std NDLCom node on a Cortex-M3/M4: one id, two links (UARTs), the paper's routing
//! (Algorithm 1), store & forward by re-encoding, and an echo service for frames to its own id.
//!
//! The firmware exists to be measured (`size.sh`): the UART data registers are stood in for by
//! [`black_box`], which the optimiser has to treat as unknown input and as a use of its
//! argument. Nothing is optimised away, and no `unsafe`, volatile access or device crate is
//! needed. On a real board `rx()` would read the data register of whichever UART raised its
//! RXNE flag and `tx()` would wait for TXE and write the data register.
//!
//! Every piece of state is a `static` that starts as zero bytes (`.bss`), so the static RAM
//! figure is the node's whole state and no flash is spent on an initial image; the stack only
//! holds call frames. On thumbv7em, in bytes:
//!
//! | state | default | `small` |
//! |---|---:|---:|
//! | parser storage, one unescaped frame each (4 + payload + 2) | 2 x 261 | 2 x 70 |
//! | parser bookkeeping (positions, state, six `u64` counters) | 2 x 72 | 2 x 72 |
//! | routing table (one byte per address) | 256 | 16 |
//! | own and pinned id sets (256 bits each), mirror set | 68 | 68 |
//! | outgoing counters (one byte per address) | 256 | 16 |
//! | `Slot` tags, padding | 14 | 12 |
//! | total | 1260 | 396 |
//!
//! Features: `small` lowers the compile-time limits (payload 64, 16 addresses), `bare` drops
//! NDLCom altogether and echoes raw bytes: the skeleton the node is compared against.

#![no_std]
#![no_main]
#![deny(unsafe_code)]

use core::hint::black_box;

use cortex_m_rt::entry;
use panic_halt as _;

/// Interfaces (UARTs).
const IFACES: usize = 2;

/// Reads one received byte and the interface it came from (a UART data register).
#[inline(always)]
fn rx() -> (usize, u8) {
    let (iface, byte): (usize, u8) = black_box((0, 0));
    // Interfaces are numbered 0..IFACES; a register read cannot say otherwise.
    (iface % IFACES, byte)
}

/// Sends bytes on an interface, one data-register write each.
#[inline(always)]
fn tx(iface: usize, bytes: &[u8]) {
    for &byte in bytes {
        black_box((iface, byte));
    }
}

#[cfg(not(feature = "bare"))]
mod node {
    use ferrolink_runtime::ndlcom::counters::TxCounters;
    use ferrolink_runtime::ndlcom::router::Router;
    use ferrolink_runtime::ndlcom::{encode_with, storage_len, Frame, Parser};

    use super::{tx, IFACES};

    /// This node's address.
    pub const OWN_ID: u8 = 0x21;

    /// The largest payload the node accepts (and so forwards).
    #[cfg(not(feature = "small"))]
    pub const MAX_PAYLOAD: usize = 255;
    /// Addresses with a routing-table entry and an outgoing counter.
    #[cfg(not(feature = "small"))]
    pub const ADDRS: usize = 256;

    #[cfg(feature = "small")]
    pub const MAX_PAYLOAD: usize = 64;
    #[cfg(feature = "small")]
    pub const ADDRS: usize = 16;

    /// Parser storage: one unescaped frame.
    pub const STORAGE: usize = storage_len(MAX_PAYLOAD);

    /// A parser over a static buffer.
    pub type NodeParser = Parser<&'static mut [u8; STORAGE]>;
    pub type NodeRouter = Router<IFACES, ADDRS>;
    pub type NodeCounters = TxCounters<ADDRS>;

    /// An `Option` without the niche optimisation: `Empty` is a zero tag, so a `static` that
    /// starts empty goes to .bss (an empty `Option<Parser>` would be a niche value in the
    /// parser's state, which puts the whole static into .data and its image into flash).
    #[derive(Debug)]
    #[repr(C, u8)]
    pub enum Slot<T> {
        Empty,
        Full(T),
    }

    impl<T> Slot<T> {
        /// Stores `value` and returns it.
        pub fn fill(&mut self, value: T) -> &mut T {
            *self = Slot::Full(value);
            match self {
                Slot::Full(value) => value,
                Slot::Empty => unreachable!(),
            }
        }
    }

    /// Routing and outgoing counters.
    #[derive(Debug)]
    pub struct Node {
        pub router: &'static mut NodeRouter,
        pub counters: &'static mut NodeCounters,
    }

    impl Node {
        /// One frame that arrived intact on `origin`.
        pub fn handle(&mut self, origin: usize, frame: Frame<'_>) {
            let header = frame.header();
            let decision = self.router.route(origin, &header);
            // Store & forward: re-encode the frame as it came, straight into each UART. The
            // parser checked its length, so encoding cannot fail.
            for out in decision.forward.iter() {
                let _ = encode_with(&header, &[frame.payload()], |run| tx(out, run));
            }
            // The echo service: the payload back to its sender, with this node's counter. In an
            // acyclic network the sender is behind the interface its frame came in on.
            if header.receiver == OWN_ID {
                let reply = self.counters.header(header.sender, OWN_ID, header.length);
                let _ = encode_with(&reply, &[frame.payload()], |run| tx(origin, run));
            }
        }
    }
}

#[cfg(not(feature = "bare"))]
#[entry]
fn main() -> ! {
    // `#[entry]` turns these into `&'static mut` references (they must come first in the
    // body). All of them start as zero bytes, so they land in .bss and cost no flash for an
    // initial image: the parsers (whose empty state is not all zero bytes) and the router are
    // set up here, at run time, instead of in a `const` initialiser that could go to .data.
    static mut STORAGE: [[u8; node::STORAGE]; IFACES] = [[0; node::STORAGE]; IFACES];
    static mut PARSERS: node::Slot<[node::NodeParser; IFACES]> = node::Slot::Empty;
    static mut ROUTER: node::Slot<node::NodeRouter> = node::Slot::Empty;
    static mut COUNTERS: node::NodeCounters = node::NodeCounters::new();

    let [a, b] = STORAGE;
    let parsers = PARSERS.fill([node::NodeParser::new(a), node::NodeParser::new(b)]);
    let mut node = node::Node {
        router: ROUTER.fill(node::NodeRouter::new()),
        counters: COUNTERS,
    };
    node.router.add_own_id(node::OWN_ID);

    loop {
        let (iface, byte) = rx();
        if let Some(parser) = parsers.get_mut(iface) {
            parser.feed_all(&[byte], |frame| node.handle(iface, frame));
        }
    }
}

#[cfg(feature = "bare")]
#[entry]
fn main() -> ! {
    loop {
        let (iface, byte) = rx();
        tx(iface, &[byte]);
    }
}
