//! NDLCom encode and stream-decode throughput against a plain `copy_from_slice` (memcpy) of the
//! same number of bytes.
//!
//! ```text
//! cargo bench -p ferrolink-bench --bench ndlcom            # every case
//! cargo bench -p ferrolink-bench --bench ndlcom -- decode  # cases whose name has "decode"
//! ```
//!
//! Cases: payloads of 20 and 250 bytes, once uniformly random (fixed seed) and once all 0x7E,
//! the worst case, where every payload byte is escaped.
//!
//! - **encode**: header + payload -> frame, with [`encode`] into a max-size buffer. Throughput
//!   counts payload bytes; the baseline copies as many bytes, one call per frame.
//! - **decode**: a stream of about `STREAM_BYTES` of such frames, one after the other with
//!   changing headers, fed whole to a [`Parser`] that hands out every frame (FCS checked).
//!   Throughput counts stream (wire) bytes; the baseline copies the whole stream.
//!
//! The same small harness as `mavlink.rs`: each operation and its baseline are calibrated to
//! batches of about `BATCH_TARGET`, then run alternating batches (so load from other processes
//! hits both alike), and the median batch of each is reported. The ratio is the operation's
//! throughput over memcpy's: encode/memcpy and decode/memcpy. The runtime is built with its `fast-crc` feature (8 KiB table).

#[allow(dead_code)]
mod harness;

use harness::{compare, BATCHES, BATCH_TARGET};
use std::hint::black_box;

use ferrolink_runtime::ndlcom::{encode, max_encoded_len, storage_len, Header, Parser};

/// Size of the stream-decoding input.
const STREAM_BYTES: usize = 1 << 20;
/// Seed of the payload bytes.
const SEED: u64 = 0x4E44_4C43_6F6D_2016;

// ---------------------------------------------------------------------------------------------
// Inputs.
// ---------------------------------------------------------------------------------------------

/// SplitMix64: a fixed, dependency-free byte source.
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn fill(&mut self, out: &mut [u8]) {
        for chunk in out.chunks_mut(8) {
            let word = self.next_u64().to_le_bytes();
            chunk.copy_from_slice(&word[..chunk.len()]);
        }
    }
}

/// What payload bytes a case has.
#[derive(Clone, Copy)]
enum Fill {
    Random,
    AllFlags,
}

/// `frames` payloads of `len` bytes each.
fn payloads(len: usize, fill: Fill, frames: usize, rng: &mut SplitMix) -> Vec<Vec<u8>> {
    (0..frames)
        .map(|_| match fill {
            Fill::AllFlags => vec![0x7e; len],
            Fill::Random => {
                let mut p = vec![0; len];
                rng.fill(&mut p);
                p
            }
        })
        .collect()
}

/// The header of the `k`-th frame of a stream.
fn header(k: usize, len: usize) -> Header {
    Header::new(
        0x10 + (k % 7) as u8,
        0x20 + (k % 5) as u8,
        k as u8,
        len as u8,
    )
}

/// Encodes one frame into a fresh `Vec`.
fn frame(header: &Header, payload: &[u8]) -> Vec<u8> {
    let mut out = vec![0; max_encoded_len(payload.len())];
    let n = encode(header, payload, &mut out).expect("encode");
    out.truncate(n);
    out
}

/// About `STREAM_BYTES` of back-to-back frames with `len`-byte payloads, and their payloads.
fn stream(len: usize, fill: Fill, rng: &mut SplitMix) -> (Vec<u8>, Vec<Vec<u8>>) {
    let per_frame = frame(&header(0, len), &payloads(len, fill, 1, rng)[0]).len();
    let sent = payloads(len, fill, STREAM_BYTES.div_ceil(per_frame), rng);
    let mut bytes = Vec::with_capacity(STREAM_BYTES + max_encoded_len(len));
    for (k, payload) in sent.iter().enumerate() {
        bytes.extend_from_slice(&frame(&header(k, len), payload));
    }
    (bytes, sent)
}

// ---------------------------------------------------------------------------------------------
// The operations. Each takes its input through `black_box` and hands its result to
// `black_box`, so neither can be folded away.
// ---------------------------------------------------------------------------------------------

/// Encodes `payloads[i % n]` with a changing header into a reused max-size buffer.
fn encoder(payloads: Vec<Vec<u8>>) -> impl FnMut(u64) {
    let mut out = [0u8; max_encoded_len(255)];
    move |i| {
        let payload = &payloads[i as usize % payloads.len()];
        let h = header(i as usize, payload.len());
        let n = encode(black_box(&h), black_box(payload), &mut out).expect("encode");
        black_box(out.get(..n));
    }
}

/// Parses every frame of `stream`; returns how many there were.
fn decode_stream(stream: &[u8]) -> usize {
    let mut parser = Parser::new([0u8; storage_len(255)]);
    parser.feed_all(stream, |frame| {
        black_box((frame.header(), frame.payload()));
    })
}

/// Copies `len` bytes with `copy_from_slice`, the baseline.
fn memcpy(len: usize) -> impl FnMut(u64) {
    let src: Vec<u8> = (0..len).map(|i| i as u8).collect();
    let mut dst = vec![0u8; len];
    move |_| {
        dst.copy_from_slice(black_box(&src));
        black_box(&mut dst);
    }
}

/// Runs the cases whose name contains one of the filters (all when there are none) and
/// prints one table row each.
struct Runner {
    filters: Vec<String>,
}

impl Runner {
    fn wanted(&self, case: &str) -> bool {
        self.filters.is_empty() || self.filters.iter().any(|f| case.contains(f.as_str()))
    }

    /// Times `op`, which handles `frames` frames and `bytes` counted bytes (`wire` of them on
    /// the wire) per call, against a memcpy of `bytes` bytes.
    fn against_memcpy(
        &self,
        case: &str,
        frames: usize,
        bytes: usize,
        wire: usize,
        op: impl FnMut(u64),
    ) {
        if !self.wanted(case) {
            return;
        }
        let (t_op, t_copy) = compare(op, memcpy(bytes));
        let mb = |s: f64| bytes as f64 / s / 1e6;
        println!(
            "| {case} | {bytes} | {wire} | {:.1} | {:.0} | {:.0} | **{:.3}** |",
            t_op * 1e9 / frames as f64,
            mb(t_op),
            mb(t_copy),
            t_copy / t_op,
        );
    }
}

fn main() {
    println!("machine: {}", harness::machine());
    // `cargo bench` passes `--bench`; other arguments select cases by substring.
    let runner = Runner {
        filters: std::env::args()
            .skip(1)
            .filter(|a| !a.starts_with("--"))
            .collect(),
    };
    let cases = [
        ("20 B random", 20, Fill::Random),
        ("250 B random", 250, Fill::Random),
        ("20 B all 0x7E", 20, Fill::AllFlags),
        ("250 B all 0x7E", 250, Fill::AllFlags),
    ];
    let mut rng = SplitMix(SEED);

    println!(
        "Median of {BATCHES} alternating batches of ~{BATCH_TARGET:?} each; MB/s = 10^6 bytes \
         per second of the counted bytes; ratio = throughput / memcpy's throughput.\n"
    );
    println!("| case | bytes counted | wire bytes | ns/frame | MB/s | memcpy MB/s | ratio |");
    println!("|---|---:|---:|---:|---:|---:|---:|");

    for (name, len, fill) in cases {
        // 64 different payloads per case, so the branch predictor cannot learn one.
        let sent = payloads(len, fill, 64, &mut rng);
        let wire = frame(&header(0, len), &sent[0]).len();
        runner.against_memcpy(&format!("encode {name}"), 1, len, wire, encoder(sent));
    }

    for (name, len, fill) in cases {
        let case = format!("decode {name}");
        if !runner.wanted(&case) {
            continue;
        }
        let (bytes, sent) = stream(len, fill, &mut rng);
        // Cross-check: the parser hands out every frame, intact and in order.
        let mut parser = Parser::new([0u8; storage_len(255)]);
        let mut k = 0;
        parser.feed_all(&bytes, |f| {
            assert_eq!(f.header(), header(k, len), "{case}: header {k}");
            assert_eq!(f.payload(), &sent[k][..], "{case}: payload {k}");
            k += 1;
        });
        assert_eq!(k, sent.len(), "{case}: frame count");
        assert_eq!(parser.stats().dropped() + parser.stats().crc_failures, 0);

        let case = format!("{case} ({} frames)", sent.len());
        let n = bytes.len();
        runner.against_memcpy(&case, sent.len(), n, n, |_| {
            black_box(decode_stream(black_box(&bytes)));
        });
    }
}
