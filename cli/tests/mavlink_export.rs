//! `ferrolink mavlink export FILE... --parquet DIR`: logs written here (and every real capture in
//! `../shared/captures/` when it is there), read back with the Parquet crate: a file per
//! message type, a row per frame, every field a column, the `log` column naming each row's
//! file. The Python package's tests query the same files with DuckDB against pymavlink.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use arrow_array::cast::AsArray;
use arrow_array::types::{Float32Type, UInt32Type};
use arrow_array::RecordBatch;
use common::ferrolink;
use ferrolink_io::mavlink::tlog;
use ferrolink_runtime::mavlink::{v2, Header};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

fn export(args: &[&str]) -> Output {
    Command::new(ferrolink())
        .args(["mavlink", "export"])
        .args(args)
        .output()
        .expect("run ferrolink")
}

/// A log of `n` ATTITUDE frames (id 30, CRC_EXTRA 39), `time_boot_ms` = i, roll = i / 2, and
/// a HEARTBEAT (id 0, CRC_EXTRA 50) after every tenth.
fn write_log(path: &Path, n: u32) {
    let mut out = Vec::new();
    let mut log = tlog::Writer::new(&mut out);
    let mut frame = [0u8; v2::MAX_FRAME_LEN];
    for i in 0..n {
        let mut payload = [0u8; 28];
        payload[..4].copy_from_slice(&i.to_le_bytes());
        payload[4..8].copy_from_slice(&(i as f32 / 2.0).to_le_bytes());
        let len =
            v2::encode_raw(Header::new(i as u8, 1, 1), 30, 39, &payload, &mut frame).expect("fits");
        log.write(1_700_000_000_000_000 + u64::from(i) * 20_000, &frame[..len])
            .expect("write");
        if i % 10 == 9 {
            let heartbeat = [0, 0, 0, 0, 2, 3, 81, 4, 3];
            let len = v2::encode_raw(Header::new(i as u8, 1, 1), 0, 50, &heartbeat, &mut frame)
                .expect("fits");
            log.write(1_700_000_000_000_000 + u64::from(i) * 20_000, &frame[..len])
                .expect("write");
        }
    }
    drop(log);
    std::fs::write(path, out).expect("write the log");
}

fn read(path: &Path) -> RecordBatch {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .expect("a Parquet file")
        .build()
        .expect("a reader");
    let batches: Vec<RecordBatch> = reader.map(|b| b.expect("a batch")).collect();
    arrow_select::concat::concat_batches(&batches[0].schema(), &batches).expect("one schema")
}

#[test]
fn logs_become_one_parquet_file_per_message_type() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (a, b) = (dir.path().join("a.tlog"), dir.path().join("b.tlog"));
    write_log(&a, 100_000);
    write_log(&b, 50);
    let out = dir.path().join("parquet");
    let done = export(&[
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--parquet",
        out.to_str().unwrap(),
    ]);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let summary = String::from_utf8_lossy(&done.stdout);
    assert!(summary.contains("\"rows\":110000"), "{summary}");

    let attitude = read(&out.join("ATTITUDE.parquet"));
    assert_eq!(attitude.num_rows(), 100_050);
    let names: Vec<String> = attitude
        .schema()
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect();
    assert_eq!(
        names,
        [
            "timestamp",
            "sysid",
            "compid",
            "log",
            "time_boot_ms",
            "roll",
            "pitch",
            "yaw",
            "rollspeed",
            "pitchspeed",
            "yawspeed"
        ]
    );
    let time = attitude.column(4).as_primitive::<UInt32Type>();
    let roll = attitude.column(5).as_primitive::<Float32Type>();
    assert_eq!((time.value(99_999), roll.value(99_999)), (99_999, 49_999.5));
    assert_eq!(time.value(100_000), 0, "b.tlog's rows follow a.tlog's");
    let log = attitude.column(3).as_any_dictionary();
    let logs = log.values().as_string::<i32>();
    let key = |row: usize| log.normalized_keys()[row];
    assert_eq!(logs.value(key(0)), a.to_str().unwrap());
    assert_eq!(logs.value(key(100_049)), b.to_str().unwrap());
    assert_eq!(read(&out.join("HEARTBEAT.parquet")).num_rows(), 10_005);
    assert_eq!(std::fs::read_dir(&out).expect("the directory").count(), 2);
}

#[test]
fn types_filter_and_errors_name_what_is_wrong() {
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("a.tlog");
    write_log(&log, 20);
    let out = dir.path().join("only");
    let done = export(&[
        log.to_str().unwrap(),
        "--parquet",
        out.to_str().unwrap(),
        "--types",
        "heartbeat",
    ]);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let files: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(files, ["HEARTBEAT.parquet"]);

    let bad = export(&[
        log.to_str().unwrap(),
        "--parquet",
        out.to_str().unwrap(),
        "--types",
        "ATTITUDEE",
    ]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && err.contains("unknown message type \"ATTITUDEE\""),
        "{err}"
    );
    assert!(
        err.contains("ATTITUDE,") || err.contains("ATTITUDE)"),
        "{err}"
    );
    let missing = export(&["nope.tlog", "--parquet", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&missing.stderr);
    assert!(
        !missing.status.success() && err.contains("nope.tlog"),
        "{err}"
    );
}

#[test]
fn real_captures_export_every_decoded_frame() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/captures");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!(
            "note: {} is absent; the real captures are not exported",
            dir.display()
        );
        return;
    };
    let logs: Vec<_> = entries
        .map(|e| e.expect("an entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "tlog"))
        .collect();
    assert!(!logs.is_empty());
    let out = tempfile::tempdir().expect("tempdir");
    let mut args: Vec<&str> = logs.iter().map(|p| p.to_str().unwrap()).collect();
    args.extend(["--parquet", out.path().to_str().unwrap()]);
    let done = export(&args);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    // Every row a log's summary counts is in a file.
    let stdout = String::from_utf8_lossy(&done.stdout);
    let total = |key: &str| -> u64 {
        stdout
            .lines()
            .filter(|l| l.contains(key))
            .filter_map(|l| {
                let v: serde_json::Value = serde_json::from_str(l).ok()?;
                v["rows"].as_u64()
            })
            .sum()
    };
    assert_eq!(total("\"log\""), total("\"file\""));
    assert!(total("\"file\"") > 10_000);
}
