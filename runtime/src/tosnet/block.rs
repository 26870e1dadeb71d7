//! The shared 4 KiB block, its word addressing, and the typed write capabilities.
//!
//! ```text
//! byte offset of node n, register r:  n * 256 + r * 32
//!   +0..16   out area (written by node n)          words (n << 6) + (r << 3) + 0..=3
//!   +16..32  in area  (written by the master)      words (n << 6) + (r << 3) + 4 + 0..=3
//! ```
//!
//! Words are 32 bits, little-endian (a project choice: the bytes of a field are laid out as in
//! MAVLink, so `ferrolink_runtime::wire` reads them).

use core::marker::PhantomData;

/// Node ids the block has room for (0..=15).
pub const IDS: usize = 16;
/// Registers per node.
pub const REGISTERS: usize = 8;
/// Bytes in one area (in or out).
pub const AREA_LEN: usize = 16;
/// Bytes in one register: its out area, then its in area.
pub const REGISTER_LEN: usize = 2 * AREA_LEN;
/// Bytes per node.
pub const NODE_LEN: usize = REGISTERS * REGISTER_LEN;
/// Bytes in the whole block.
pub const BLOCK_LEN: usize = IDS * NODE_LEN;

/// Which half of a register.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Area {
    /// Written by the register's node, read by everyone.
    Out,
    /// Written by the master, read by everyone.
    In,
}

/// Byte offset of an area. `node` and `reg` are masked to 0..=15 and 0..=7.
#[inline]
pub const fn area_offset(node: u8, reg: u8, area: Area) -> usize {
    let base = (node as usize & 0xF) * NODE_LEN + (reg as usize & 7) * REGISTER_LEN;
    match area {
        Area::Out => base,
        Area::In => base + AREA_LEN,
    }
}

/// Word address of word `index` (0..=3) of an out area, as in the C driver:
/// `(node << 6) + (reg << 3) + index`.
#[inline]
pub const fn out_word(node: u8, reg: u8, index: u8) -> u16 {
    ((node as u16 & 0xF) << 6) + ((reg as u16 & 7) << 3) + (index as u16 & 3)
}

/// Word address of word `index` (0..=3) of an in area: `(node << 6) + (reg << 3) + 4 + index`.
#[inline]
pub const fn in_word(node: u8, reg: u8, index: u8) -> u16 {
    out_word(node, reg, index) + 4
}

/// The shared memory: 16 nodes x 8 registers x (16-byte out area + 16-byte in area).
#[derive(Clone, PartialEq, Eq)]
pub struct Block([u8; BLOCK_LEN]);

impl Default for Block {
    fn default() -> Self {
        Self::new()
    }
}

impl core::fmt::Debug for Block {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Block").finish_non_exhaustive()
    }
}

impl Block {
    /// An all-zero block.
    pub const fn new() -> Self {
        Self([0; BLOCK_LEN])
    }

    /// The raw bytes.
    pub fn as_bytes(&self) -> &[u8; BLOCK_LEN] {
        &self.0
    }

    /// The 32-bit word at word address `addr` (masked to 0..1024).
    pub fn word(&self, addr: u16) -> u32 {
        let at = usize::from(addr & 0x3FF) * 4;
        crate::wire::get(&self.0, at)
    }

    /// An area of any node, for reading.
    pub fn area(&self, node: u8, reg: u8, area: Area) -> &[u8; AREA_LEN] {
        let at = area_offset(node, reg, area);
        self.0[at..at + AREA_LEN]
            .try_into()
            .unwrap_or(&[0; AREA_LEN])
    }

    /// The out area of `node`'s register `reg`.
    pub fn out_area(&self, node: u8, reg: u8) -> &[u8; AREA_LEN] {
        self.area(node, reg, Area::Out)
    }

    /// The in area of `node`'s register `reg`.
    pub fn in_area(&self, node: u8, reg: u8) -> &[u8; AREA_LEN] {
        self.area(node, reg, Area::In)
    }

    /// Crate-internal write access; applications write through [`OutWriter`] and [`InWriter`].
    pub(crate) fn area_mut(&mut self, node: u8, reg: u8, area: Area) -> &mut [u8; AREA_LEN] {
        let at = area_offset(node, reg, area);
        let slice = &mut self.0[at..at + AREA_LEN];
        slice.try_into().expect("areas are 16 bytes")
    }

    /// Copies one area from `other`.
    pub(crate) fn copy_area(&mut self, other: &Block, node: u8, reg: u8, area: Area) {
        let at = area_offset(node, reg, area);
        self.0[at..at + AREA_LEN].copy_from_slice(&other.0[at..at + AREA_LEN]);
    }
}

/// A node of a generated register map: its id is a type, so write access can be typed.
pub trait NodeId {
    /// The node id, 0..=15.
    const ID: u8;
    /// The dictionary's name for the node.
    const NAME: &'static str;
    /// Registers whose out area this node writes (bit r = register r).
    const OUT_MASK: u8;
    /// Registers whose in area the master fills for this node.
    const IN_MASK: u8;
}

/// The right to write node `N`'s out areas. Only a [`Node`](super::Node) whose id is `N::ID`
/// hands it out, so a slave cannot write another node's data: a writer for one node does not
/// type-check where another's is wanted.
///
/// ```compile_fail
/// use ferrolink_runtime::tosnet::{NodeId, OutWriter};
/// struct A;
/// struct B;
/// impl NodeId for A { const ID: u8 = 1; const NAME: &'static str = "a"; const OUT_MASK: u8 = 1; const IN_MASK: u8 = 0; }
/// impl NodeId for B { const ID: u8 = 2; const NAME: &'static str = "b"; const OUT_MASK: u8 = 1; const IN_MASK: u8 = 0; }
/// fn write_b(_: &mut OutWriter<'_, B>) {}
/// fn as_a(w: &mut OutWriter<'_, A>) {
///     write_b(w); // error: A's writer is not B's
/// }
/// ```
pub struct OutWriter<'a, N: NodeId> {
    block: &'a mut Block,
    node: PhantomData<N>,
}

impl<N: NodeId> core::fmt::Debug for OutWriter<'_, N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("OutWriter").field("node", &N::ID).finish()
    }
}

impl<'a, N: NodeId> OutWriter<'a, N> {
    pub(crate) fn new(block: &'a mut Block) -> Self {
        Self {
            block,
            node: PhantomData,
        }
    }

    /// Register `reg`'s out area of node `N`.
    pub fn area(&mut self, reg: u8) -> &mut [u8; AREA_LEN] {
        self.block.area_mut(N::ID, reg, Area::Out)
    }
}

/// The right to write every node's in areas. Only the master's [`Node`](super::Node) hands
/// it out.
#[derive(Debug)]
pub struct InWriter<'a> {
    block: &'a mut Block,
}

impl<'a> InWriter<'a> {
    pub(crate) fn new(block: &'a mut Block) -> Self {
        Self { block }
    }

    /// Register `reg`'s in area of node `N`.
    pub fn area<N: NodeId>(&mut self, reg: u8) -> &mut [u8; AREA_LEN] {
        self.block.area_mut(N::ID, reg, Area::In)
    }

    /// Register `reg`'s in area of node `node` (untyped, for tools).
    pub fn area_of(&mut self, node: u8, reg: u8) -> &mut [u8; AREA_LEN] {
        self.block.area_mut(node, reg, Area::In)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn word_addressing_matches_the_c_driver() {
        let mut b = Block::new();
        b.area_mut(5, 3, Area::Out)[4..8].copy_from_slice(&0xDEAD_BEEFu32.to_le_bytes());
        b.area_mut(5, 3, Area::In)[12..16].copy_from_slice(&0x0102_0304u32.to_le_bytes());
        assert_eq!(out_word(5, 3, 1), (5 << 6) + (3 << 3) + 1);
        assert_eq!(b.word(out_word(5, 3, 1)), 0xDEAD_BEEF);
        assert_eq!(in_word(5, 3, 3), (5 << 6) + (3 << 3) + 4 + 3);
        assert_eq!(b.word(in_word(5, 3, 3)), 0x0102_0304);
        assert_eq!(area_offset(15, 7, Area::In) + AREA_LEN, BLOCK_LEN);
    }
}
