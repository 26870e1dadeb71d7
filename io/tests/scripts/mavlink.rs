//! Invariant checks of the MAVLink readers in `ferrolink-io`, shared by the fuzz targets
//! (`tlog_reader`, `router_config`) and the tests.
//!
//! `check_tlog`: any bytes as a `.tlog` and as a raw capture. Checked: no panic; records come in
//! order without overlapping, each inside the input; the bytes at a record's offset are its
//! frame; a checked frame passes its CRC; a tlog record's timestamp is the 8 bytes before its
//! frame; the counts add up.
//!
//! `check_config`: any text as an endpoint URI, a TOML router configuration and a mavlink-router
//! `main.conf`. Checked: no panic; an endpoint that parses prints as a URI that parses back to
//! it, also for every endpoint a configuration file yields.

use ferrolink_io::link::Endpoint;
use ferrolink_io::mavlink::config::{from_main_conf, from_toml, FileConfig};
use ferrolink_io::mavlink::tlog::{read_raw, read_tlog, LogReader, ReadStats, Record};
use ferrolink_io::mavlink::ENDPOINTS;
use ferrolink_runtime::mavlink::MessageMeta;

pub fn check_tlog(data: &[u8], table: &[MessageMeta]) {
    for raw in [false, true] {
        let mut end = 0;
        let mut records = 0u64;
        let mut unchecked = 0u64;
        let mut check = |r: Record<'_>| {
            let bytes = r.frame.as_bytes();
            assert!(r.offset >= end, "records overlap or go back");
            assert_eq!(data.get(r.offset..r.offset + bytes.len()), Some(bytes));
            end = r.offset + bytes.len();
            match r.frame.meta() {
                Some(meta) => assert!(r.frame.frame().check_crc(meta.crc_extra)),
                None => unchecked += 1,
            }
            if raw {
                assert_eq!(r.t_us, None);
            } else {
                let ts = data
                    .get(r.offset - 8..r.offset)
                    .expect("a timestamp before");
                assert_eq!(
                    r.t_us,
                    Some(u64::from_be_bytes(ts.try_into().expect("8 bytes")))
                );
            }
            records += 1;
        };
        let stats: ReadStats = if raw {
            read_raw(data, table, &mut check)
        } else {
            read_tlog(data, table, &mut check)
        };
        assert_eq!(stats.frames, records);
        assert_eq!(stats.unchecked, if raw { 0 } else { unchecked });
        assert!(stats.resynced <= stats.frames);
        assert!(stats.skipped_bytes + stats.truncated_bytes <= data.len() as u64);
        // Read a few bytes at a time, as from a file larger than memory: the same.
        let whole = read_chunked(data, table, raw, usize::MAX);
        for chunk in [1, 1 + usize::from(data.first().copied().unwrap_or(0)) % 300] {
            assert_eq!(
                read_chunked(data, table, raw, chunk),
                whole,
                "chunks of {chunk}"
            );
        }
        assert_eq!(whole.1, stats);
    }
}

/// Gives at most `.1` bytes a read.
struct Trickle<'a>(&'a [u8], usize);

impl std::io::Read for Trickle<'_> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let n = self.0.len().min(out.len()).min(self.1);
        out[..n].copy_from_slice(&self.0[..n]);
        self.0 = &self.0[n..];
        Ok(n)
    }
}

/// Every record (offset, timestamp, id) and the stats, read `chunk` bytes at a time.
type Read = (Vec<(usize, Option<u64>, u32)>, ReadStats);

fn read_chunked(data: &[u8], table: &[MessageMeta], raw: bool, chunk: usize) -> Read {
    let mut reader = LogReader::new_kind(Trickle(data, chunk), table, raw);
    let mut got = Vec::new();
    let stats = reader
        .read_all(|r| got.push((r.offset, r.t_us, r.frame.msg_id())))
        .expect("reading memory cannot fail");
    (got, stats)
}

fn round_trips(endpoint: &Endpoint) {
    let text = endpoint.to_string();
    assert_eq!(ENDPOINTS.endpoint(&text).as_ref(), Ok(endpoint), "{text}");
}

fn endpoints_round_trip(config: &FileConfig) {
    for e in &config.endpoints {
        round_trips(&e.endpoint);
    }
}

pub fn check_config(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    if let Ok(endpoint) = ENDPOINTS.endpoint(&text) {
        round_trips(&endpoint);
    }
    if let Ok(config) = from_toml(&text, std::path::Path::new(".")) {
        endpoints_round_trip(&config);
    }
    if let Ok(config) = from_main_conf(&text) {
        endpoints_round_trip(&config);
    }
}
