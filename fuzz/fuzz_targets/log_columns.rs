//! Arbitrary bytes as a telemetry log, into one Arrow table per message type with the built-in
//! `common` dialect (what `load_log`, `save_parquet` and `mavlink export` build): never panics,
//! and every frame of a known id is one row of its type's table.
//!
//! Run with `cargo fuzz run log_columns`.
#![no_main]

use std::collections::HashMap;
use std::sync::OnceLock;

use ferrolink_io::mavlink::tlog::read_tlog;
use ferrolink_traffic::columns::Tables;
use ferrolink_traffic::Dialects;

static COMMON: OnceLock<Dialects> = OnceLock::new();

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let common = COMMON.get_or_init(|| Dialects::load(&[], "common").expect("built in"));
    let decoder = common.decoder();
    let mut rows: HashMap<String, usize> = HashMap::new();
    let mut tables = Tables::new(decoder.clone(), None).expect("all types");
    read_tlog(data, &common.table, |r| {
        let (frame, header) = (&r.frame, r.frame.header());
        let id = frame.msg_id();
        let pushed = tables.push(r.t_us, header.sysid, header.compid, id, frame.payload());
        if let Some(message) = decoder.message(id) {
            *rows.entry(message.name.wire.clone()).or_default() += 1;
            assert_eq!(pushed, rows[&message.name.wire]);
        } else {
            assert_eq!(pushed, 0);
        }
    });
    let tables = tables.finish();
    assert_eq!(tables.len(), rows.len());
    for (name, batch) in tables {
        assert_eq!(batch.num_rows(), rows[&name], "{name}");
        assert_eq!(batch.num_columns(), batch.schema().fields().len());
    }
});
