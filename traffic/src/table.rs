//! The message table a parser or router needs, built from the IR at run time.

use std::collections::BTreeMap;
use std::sync::Arc;

use ferrolink_dictionary::ir::Ir;
use ferrolink_runtime::mavlink::MessageMeta;

/// The message table a parser or router needs ([`MessageMeta`] per message, sorted by id),
/// built from the IR at run time.
///
/// If several modules define an id, the later one wins, as in [`PayloadDecoder::new`]. The table
/// is shared: every parser and router that checks frames with it holds a clone of the `Arc`, so
/// it lives as long as they do, on any thread, and is freed after the last.
pub fn message_table(ir: &Ir) -> Arc<[MessageMeta]> {
    let mut by_id: BTreeMap<u32, MessageMeta> = BTreeMap::new();
    for message in ir.modules.iter().flat_map(|m| &m.messages) {
        let offset = |o: Option<usize>| o.and_then(|o| u8::try_from(o).ok());
        by_id.insert(
            message.id,
            MessageMeta {
                id: message.id,
                crc_extra: message.crc_extra,
                min_len: u8::try_from(message.min_len).unwrap_or(u8::MAX),
                max_len: u8::try_from(message.max_len).unwrap_or(u8::MAX),
                target_system: offset(message.target_system),
                target_component: offset(message.target_component),
            },
        );
    }
    by_id.into_values().collect()
}
