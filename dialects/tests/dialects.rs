//! The built-in dialects hold together: the crate's features enable what each file includes,
//! every file is built in, and each enabled dialect's generated table is what our dictionary
//! reads from its file. (That the files are pymavlink's, fact for fact and byte for byte, is
//! checked in `tests/conformance`.)

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use ferrolink_dialects::definitions;

fn standard() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../definitions/mavlink/standard")
}

/// The features of this crate's Cargo.toml, each with what it enables.
fn features() -> toml::Table {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml"))
        .expect("Cargo.toml");
    let manifest: toml::Table = text.parse().expect("Cargo.toml parses");
    manifest["features"].as_table().expect("[features]").clone()
}

#[test]
fn every_dialect_file_is_built_in() {
    let mut files: Vec<String> = std::fs::read_dir(standard())
        .expect("definitions/mavlink/standard")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    files.sort_by_key(|f| f.to_lowercase());
    let built_in: Vec<&str> = definitions::ALL.iter().map(|d| d.file).collect();
    assert_eq!(files, built_in);
    for d in definitions::ALL {
        let on_disk = std::fs::read_to_string(standard().join(d.file)).expect("read");
        assert_eq!(d.text, on_disk, "{}", d.file);
        assert_eq!(definitions::find(&d.name.to_uppercase()), Some(d));
        assert_eq!(definitions::find(d.file), Some(d));
    }
    assert_eq!(definitions::find("nosuch"), None);
}

/// A feature per dialect, named as its module, enabling exactly the dialects its file includes.
#[test]
fn features_enable_what_each_dialect_includes() {
    let features = features();
    let checked = ferrolink_dictionary::load(
        &definitions::ALL
            .iter()
            .map(|d| standard().join(d.file))
            .collect::<Vec<_>>(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let ir = &checked.ir;
    for module in &ir.modules {
        let feature = &module.name.rust;
        let enabled: BTreeSet<&str> = features[feature.as_str()]
            .as_array()
            .unwrap_or_else(|| panic!("no feature {feature}"))
            .iter()
            .map(|v| v.as_str().expect("feature name"))
            .collect();
        let includes: BTreeSet<&str> = module
            .includes
            .iter()
            .map(|&i| ir.modules[i].name.rust.as_str())
            .collect();
        assert_eq!(enabled, includes, "feature {feature}");
    }
    let dialects: BTreeSet<&str> = ir.modules.iter().map(|m| m.name.rust.as_str()).collect();
    let others: BTreeSet<&str> = features
        .keys()
        .map(String::as_str)
        .filter(|f| !dialects.contains(f))
        .collect();
    assert_eq!(others, BTreeSet::from(["default", "serde"]));
    // An enum is emitted where it is first defined; every dialect that uses or extends it must
    // include that file, or the dialect's feature alone would not compile.
    for e in &ir.enums {
        for (i, module) in ir.modules.iter().enumerate() {
            let uses = module
                .messages
                .iter()
                .flat_map(|m| &m.fields)
                .any(|f| f.enum_name.as_deref() == Some(e.name.wire.as_str()));
            if uses {
                assert!(
                    module.closure.contains(&e.module),
                    "{} uses {}, defined in {}, which it does not include",
                    ir.modules[i].name.wire,
                    e.name.wire,
                    ir.modules[e.module].name.wire
                );
            }
        }
    }
}

/// Each enabled dialect's generated table is what the dictionary reads from its file: every
/// message with its id, CRC_EXTRA, lengths and target offsets.
#[test]
fn generated_tables_are_the_files() {
    #[allow(unused_mut)]
    let mut tables: Vec<(&str, &[ferrolink_runtime::mavlink::MessageMeta])> = Vec::new();
    #[cfg(feature = "ardupilotmega")]
    tables.push((
        "ardupilotmega",
        <ferrolink_dialects::ardupilotmega::Message as ferrolink_runtime::mavlink::Dialect>::META,
    ));
    #[cfg(feature = "all")]
    tables.push((
        "all",
        <ferrolink_dialects::all::Message as ferrolink_runtime::mavlink::Dialect>::META,
    ));
    #[cfg(feature = "matrixpilot")]
    tables.push((
        "matrixpilot",
        <ferrolink_dialects::matrixpilot::Message as ferrolink_runtime::mavlink::Dialect>::META,
    ));
    for (name, meta) in tables {
        let d = definitions::find(name).expect("built in");
        let checked = ferrolink_dictionary::load(&[standard().join(d.file)])
            .unwrap_or_else(|e| panic!("{e}"));
        let table = ferrolink_traffic::message_table(&checked.ir);
        assert_eq!(meta, &table[..], "{name}");
        eprintln!("{name}: {} messages", meta.len());
    }
}

/// A message goes out and comes back through the runtime's frames, with ArduPilot's and
/// common's types mixed in one dialect.
#[cfg(feature = "ardupilotmega")]
#[test]
fn ardupilotmega_round_trips_a_frame() {
    use ferrolink_dialects::ardupilotmega::{Message, MountControl};
    use ferrolink_dialects::common::{Heartbeat, MavAutopilot, MavType};
    use ferrolink_runtime::mavlink::{find_meta, v2, AnyFrame, Dialect, Header};

    let heartbeat = Heartbeat {
        r#type: MavType::Quadrotor,
        autopilot: MavAutopilot::Ardupilotmega,
        custom_mode: 4,
        mavlink_version: 3, // always sent as the dialect's version
        ..Default::default()
    };
    let mount = MountControl {
        input_a: -1200,
        target_system: 1,
        target_component: 154,
        ..Default::default()
    };
    for message in [Message::from(heartbeat), Message::from(mount)] {
        let mut buf = [0u8; v2::MAX_FRAME_LEN];
        let n = v2::encode_dialect(Header::new(7, 255, 190), &message, &mut buf).expect("encode");
        let frame = AnyFrame::new_checked(&buf[..n]).expect("a whole frame");
        let meta = find_meta(Message::META, frame.msg_id()).expect("in the table");
        assert!(frame.check_crc(meta.crc_extra));
        assert_eq!(frame.decode::<Message>().expect("known id"), message);
    }
}
