//! A no_std NDLCom node on a Cortex-M3/M4: one id, two links (UARTs), the paper's routing
//! (Algorithm 1), store & forward by re-encoding, and an echo service for frames to its own id.
//!
//! The firmware exists to be measured (`size.sh`): the UART data registers are stood in for by
//! [`black_box`], which the optimiser has to treat as unknown input and as a use of its
//! argument. Nothing is optimised away, and no `unsafe`, volatile access or device crate is
//! needed. On a real board `rx()` would read the data register of whichever UART raised its
//! RXNE flag and `tx()` would wait for TXE and write the data register.
//!
//! Every piece of state is a `static` that starts as zero bytes (`.bss`), built by a `const fn`,
//! so the static RAM figure is the node's whole state, no flash is spent on an initial image and
//! no set-up code copies state into place; the stack only holds call frames. On thumbv7em, in
//! bytes:
//!
//! | state | default | `small` |
//! |---|---:|---:|
//! | parser storage, one unescaped frame each (4 + payload + 2) | 2 x 261 | 2 x 70 |
//! | parser bookkeeping (position, limit, state, six word-sized counters) | 2 x 34 | 2 x 34 |
//! | routing table (2 bits per address) | 64 | 4 |
//! | own and pinned id sets (256 bits each), mirror set | 68 | 68 |
//! | outgoing counters (one byte per address) | 256 | 16 |
//! | padding (parsers are word-aligned) | 2 x 5 | 2 x 4 |
//! | total | 988 | 304 |
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

    /// A parser with its own storage.
    pub type NodeParser = Parser<[u8; STORAGE]>;
    /// Two interfaces need 2 bits per route (unknown, 0, 1): four entries to a byte.
    pub type NodeRouter = Router<IFACES, ADDRS, { ADDRS / 4 }>;
    pub type NodeCounters = TxCounters<ADDRS>;

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
    // body). Every one of them starts as zero bytes, from a `const fn`, so they land in .bss:
    // no flash for an initial image, and no set-up code that builds them on the stack and
    // copies them over.
    static mut PARSERS: [node::NodeParser; IFACES] =
        [node::NodeParser::zeroed(), node::NodeParser::zeroed()];
    static mut ROUTER: node::NodeRouter = node::NodeRouter::new();
    static mut COUNTERS: node::NodeCounters = node::NodeCounters::new();

    let parsers = PARSERS;
    let mut node = node::Node {
        router: ROUTER,
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
