//! Generated decode on arbitrary payloads: never panics, and decode -> encode -> decode is stable.
#![no_main]

use ferrolink_generated::mavlink::bench::Message;
use ferrolink_runtime::mavlink::{Dialect, PayloadBuf};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, payload)) = data.split_first() else {
        return;
    };
    let meta = &Message::META[usize::from(pick) % Message::META.len()];
    let msg = Message::decode(meta.id, payload).expect("id from META");
    let mut once: PayloadBuf = [0; 255];
    let n = msg.encode(&mut once);
    assert_eq!(n, usize::from(meta.max_len));
    let mut twice: PayloadBuf = [0; 255];
    Message::decode(meta.id, &once[..n])
        .expect("same id")
        .encode(&mut twice);
    assert_eq!(once[..n], twice[..n]);
    // Unknown ids are an error, not a panic.
    let _ = Message::decode(0x00FF_FFFF, payload);
});
