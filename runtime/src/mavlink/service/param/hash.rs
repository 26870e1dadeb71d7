//! PX4's `_HASH_CHECK`: one number for the whole parameter set, so that a client holding a
//! cached copy can tell from the first value of a list whether the rest would tell it anything.
//!
//! On PARAM_REQUEST_LIST, a server that offers it sends a PARAM_VALUE named `_HASH_CHECK`
//! first: index -1 (65535 on the wire), type UINT32, the hash's bits as the value. A client
//! whose cache has the same hash sends PARAM_SET `_HASH_CHECK`, and the server stops the list
//! (QGroundControl does this with PX4).
//!
//! The hash is PX4's: the FTP CRC-32 ([`crate::crc::FTP_CRC32`], running from 0) over each
//! parameter in index order, its name's bytes then its value's four bytes as PARAM_VALUE
//! carries them bytewise. For PX4's types (INT32, REAL32) these are the value's own bytes, as
//! PX4 hashes them.

use super::super::messages::{MavParamType, Message, ParamSet, ParamValue};
use super::super::Address;
use super::{Encoding, Name, Param, Store};

/// The name of the hash's PARAM_VALUE and PARAM_SET.
pub const HASH_CHECK: &str = "_HASH_CHECK";

/// The running hash of a parameter set, fed in index order.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Hasher {
    crc: u32,
}

impl Hasher {
    /// A hash of nothing yet.
    pub const fn new() -> Self {
        Self { crc: 0 }
    }

    /// Adds the next parameter.
    pub fn add(&mut self, p: &Param) {
        self.add_value(&p.name, p.value.encode(Encoding::Bytewise));
    }

    /// Adds a parameter called `name` whose PARAM_VALUE float, bytewise, is `value`.
    fn add_value(&mut self, name: &Name, value: f32) {
        let value = value.to_bits().to_le_bytes();
        // The crate takes an initial value as written, and reflects it for this algorithm:
        // reflected once more, the running value goes on where it stopped.
        let mut digest = crate::crc::FTP_CRC32.digest_with_initial(self.crc.reverse_bits());
        digest.update(name.text_bytes());
        digest.update(&value);
        self.crc = digest.finalize();
    }

    /// The hash so far.
    pub fn value(&self) -> u32 {
        self.crc
    }
}

/// The hash of every parameter of `store`.
pub fn hash<S: Store + ?Sized>(store: &S) -> u32 {
    let mut h = Hasher::new();
    for i in 0..store.count() {
        if let Some(p) = store.get(i) {
            match S::EXTENDED {
                true => h.add(&p),
                // A store of 32-bit values only: their code alone.
                false => h.add_value(
                    &p.name,
                    p.value
                        .encode_narrow(Encoding::Bytewise)
                        .unwrap_or_default(),
                ),
            }
        }
    }
    h.value()
}

/// Whether `name` is `_HASH_CHECK`.
pub fn is_hash_check(name: &Name) -> bool {
    name.as_str() == HASH_CHECK
}

/// The PARAM_VALUE announcing `hash` for a set of `count`.
pub(super) fn announce(hash: u32, count: u16) -> Message {
    Message::ParamValue(ParamValue {
        param_id: Name::from(HASH_CHECK),
        param_value: f32::from_bits(hash),
        param_type: MavParamType::Uint32,
        param_count: count,
        param_index: u16::MAX,
    })
}

/// The PARAM_SET that tells `target` the client's cache is right.
pub(super) fn stop(target: Address, hash: u32) -> Message {
    Message::ParamSet(ParamSet {
        target_system: target.system,
        target_component: target.component,
        param_id: Name::from(HASH_CHECK),
        param_value: f32::from_bits(hash),
        param_type: MavParamType::Uint32,
    })
}

#[cfg(test)]
mod tests {
    use super::super::Value;
    use super::*;

    #[test]
    fn the_hash_is_one_crc_over_names_and_value_bytes() {
        let params = [
            Param {
                name: Name::from("MPC_XY_VEL_MAX"),
                value: Value::F32(12.0),
            },
            Param {
                name: Name::from("COM_ARM_WO_GPS"),
                value: Value::I32(-2),
            },
        ];
        let mut bytes = std::vec::Vec::new();
        bytes.extend_from_slice(b"MPC_XY_VEL_MAX");
        bytes.extend_from_slice(&12.0f32.to_le_bytes());
        bytes.extend_from_slice(b"COM_ARM_WO_GPS");
        bytes.extend_from_slice(&(-2i32).to_le_bytes());
        assert_eq!(hash(&params[..]), crate::crc::FTP_CRC32.checksum(&bytes));
        assert_ne!(hash(&params[..1]), hash(&params[..]));
    }
}
