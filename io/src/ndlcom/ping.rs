//! The payload the NDLCom bridge answers and sends to measure its links: MAVLink's PING.

use ferrolink_runtime::mavlink::{Message, PayloadBuf};
use ferrolink_runtime::wire;

/// MAVLink's PING (common.xml and minimal.xml, id 4), which the bridge answers and sends. Its
/// layout has not changed since MAVLink 1; `generated/tests/ndlcom.rs` checks it against the
/// generated binding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Ping {
    /// Send time in microseconds.
    pub time_usec: u64,
    /// Sequence number.
    pub seq: u32,
    /// 0 for a request, the requester's system id in the answer.
    pub target_system: u8,
    /// 0 for a request, the requester's component id in the answer.
    pub target_component: u8,
}

impl Message for Ping {
    const ID: u32 = 4;
    const NAME: &'static str = "PING";
    const CRC_EXTRA: u8 = 237;
    const MIN_LEN: usize = 14;
    const MAX_LEN: usize = 14;

    fn encode(&self, buf: &mut PayloadBuf) -> usize {
        wire::put(buf, 0, self.time_usec);
        wire::put(buf, 8, self.seq);
        wire::put(buf, 12, self.target_system);
        wire::put(buf, 13, self.target_component);
        Self::MAX_LEN
    }

    fn decode(payload: &[u8]) -> Self {
        let p = &wire::zero_extend::<14>(payload);
        Self {
            time_usec: wire::get(p, 0),
            seq: wire::get(p, 8),
            target_system: wire::get(p, 12),
            target_component: wire::get(p, 13),
        }
    }
}
