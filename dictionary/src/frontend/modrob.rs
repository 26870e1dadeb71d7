//! The ModRob-1 frontend: module dictionaries (a top-level `[module]` table) and robot files (a
//! top-level `[robot]` table), both TOML.
//!
//! ```toml
//! [module]
//! name = "drive"
//! kind = "drive"
//! mi = 0x0110
//! info = "Wheel drive, 24 V, 10 A"
//!
//! [[variables]]
//! vi = 0
//! name = "speed_setpoint"
//! unit = "rad/s"
//! direction = "input"
//! min = -30.0
//! max = 30.0
//! ```
//!
//! ```toml
//! [robot]
//! leader = "motion"
//!
//! [dictionaries]
//! drive = "drive.toml"
//!
//! [[networks]]
//! name = "body"
//! transport = "can"
//! bitrate = 1_000_000
//!
//! [[instances]]
//! name = "drive_fl"
//! dictionary = "drive"
//! mi = 0x0111
//! network = "body"
//!
//! [config]
//! subscriptions = ["drive_fl.speed_setpoint <- motion.wheel_fl"]
//! values = { "drive_fl.gain" = 1.5 }
//! rates = { "drive_fl.speed" = 100 }
//! ```
//!
//! This module only reads what the files say. Names in a robot are resolved in
//! [`crate::lower::modrob`]; limits, units and rates are checked in [`crate::check`].

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::toml::{Item, Table};
use crate::diag::{Code, Diagnostics, SourceFile, Span};
use crate::ident;
use crate::ir::{
    Direction, ModrobModule, ModrobVariable, Name, RobotNetwork, Transport, VariableSpans,
};

const MODULE_ROOT_KEYS: &[&str] = &["module", "variables"];
const MODULE_KEYS: &[&str] = &["name", "kind", "mi", "uuid", "info", "description"];
const VARIABLE_KEYS: &[&str] = &[
    "vi",
    "name",
    "count",
    "unit",
    "direction",
    "min",
    "max",
    "default",
    "persist",
    "rate",
    "description",
];
const ROBOT_ROOT_KEYS: &[&str] = &["robot", "dictionaries", "networks", "instances", "config"];
const ROBOT_KEYS: &[&str] = &["description", "leader"];
const NETWORK_KEYS: &[&str] = &["name", "transport", "bitrate"];
const INSTANCE_KEYS: &[&str] = &["name", "dictionary", "mi", "uuid", "network"];
const CONFIG_KEYS: &[&str] = &["values", "rates", "subscriptions"];

/// A module dictionary as read; its fingerprint is computed by lowering.
#[derive(Debug)]
pub struct ParsedModule {
    /// The file, canonicalised, to match the robots that name it.
    pub canonical: PathBuf,
    /// The dictionary.
    pub module: ModrobModule,
}

/// A name with where it is written.
#[derive(Debug, Clone)]
pub struct Spanned {
    /// The text.
    pub text: String,
    /// Where.
    pub span: Span,
}

/// A robot file as read.
#[derive(Debug)]
pub struct ParsedRobot {
    /// The source.
    pub source: Arc<SourceFile>,
    /// `[robot] description`.
    pub description: String,
    /// The `[robot]` header.
    pub span: Span,
    /// `[robot] leader`, an instance name.
    pub leader: Option<Spanned>,
    /// `[dictionaries]`: name and canonical path.
    pub dictionaries: Vec<(Spanned, PathBuf)>,
    /// `[[networks]]`.
    pub networks: Vec<RobotNetwork>,
    /// `[[instances]]`.
    pub instances: Vec<ParsedInstance>,
    /// `[config] values`: dotted variable name and value.
    pub values: Vec<(Spanned, f64)>,
    /// `[config] rates`: dotted variable name and rate.
    pub rates: Vec<(Spanned, f64)>,
    /// `[config] subscriptions`: target, source and the whole entry.
    pub subscriptions: Vec<(Spanned, Spanned, Span)>,
}

/// An instance as written.
#[derive(Debug)]
pub struct ParsedInstance {
    /// Its name.
    pub name: Name,
    /// Its dictionary's name.
    pub dictionary: Spanned,
    /// `mi`, if written (else the dictionary's).
    pub mi: Option<(u16, Span)>,
    /// `uuid`.
    pub uuid: Option<[u8; 16]>,
    /// Its network's name.
    pub network: Spanned,
    /// Its table.
    pub span: Span,
}

/// Reads a module dictionary (a file with a top-level `[module]` table).
pub fn read_module(
    source: &Arc<SourceFile>,
    canonical: PathBuf,
    root: &Table<'_, '_>,
    diags: &mut Diagnostics,
) -> ParsedModule {
    root.check_keys(MODULE_ROOT_KEYS, diags);
    let name = ident::file_module_name(&source.path);
    let header = root
        .get("module")
        .and_then(|m| m.as_table("`[module]`", diags));
    let mut module = ModrobModule {
        dictionary: name.wire.clone(),
        name,
        path: source.path.display().to_string(),
        kind: String::new(),
        module_id: 0,
        uuid: None,
        info: String::new(),
        description: String::new(),
        variables: Vec::new(),
        fingerprint: 0,
        span: Some(Span::new(source, 0, 0)),
        info_span: None,
    };
    if let Some(t) = header {
        t.check_keys(MODULE_KEYS, diags);
        module.span = Some(t.span.clone());
        if let Some(name) = t.required("name", diags).and_then(|i| i.as_name(diags)) {
            module.dictionary = name.to_string();
        }
        module.kind = t
            .required("kind", diags)
            .and_then(|i| i.as_name(diags))
            .unwrap_or_default()
            .to_string();
        if let Some(mi) = t.required("mi", diags) {
            module.module_id = mi.as_uint(u16::MAX.into(), diags).unwrap_or(0) as u16;
        }
        module.uuid = t.get("uuid").and_then(|u| uuid(&u, diags));
        if let Some(info) = t.get("info") {
            module.info = info.as_str(diags).unwrap_or_default().to_string();
            module.info_span = Some(info.span.clone());
        }
        module.description = t
            .optional_str("description", diags)
            .unwrap_or_default()
            .to_string();
    } else {
        root.required("module", diags);
    }
    if let Some(vars) = root.get("variables").and_then(|v| v.as_array(diags)) {
        for item in vars {
            if let Some(v) = read_variable(&item, diags) {
                module.variables.push(v);
            }
        }
    }
    ParsedModule { canonical, module }
}

fn read_variable(item: &Item<'_, '_>, diags: &mut Diagnostics) -> Option<ModrobVariable> {
    let t = item.as_table(item.what.replace("`variables`", "a variable"), diags)?;
    let name_item = t.required("name", diags);
    let name = name_item.as_ref().and_then(|i| i.as_name(diags));
    let t = t.described(match name {
        Some(n) => format!("variable `{n}`"),
        None => "a variable".to_string(),
    });
    t.check_keys(VARIABLE_KEYS, diags);
    let vi_item = t.required("vi", diags);
    let vi = vi_item
        .as_ref()
        .and_then(|i| i.as_uint(u8::MAX.into(), diags));
    let count = match t.get("count") {
        Some(c) => c.as_uint(u8::MAX.into(), diags),
        None => Some(1),
    };
    let unit_item = t.required("unit", diags);
    let unit = unit_item.as_ref().and_then(|i| i.as_str(diags));
    let direction = t
        .required("direction", diags)
        .and_then(|d| match d.as_str(diags)? {
            "input" => Some(Direction::Input),
            "output" => Some(Direction::Output),
            other => {
                diags.report(
                    Code::BadNumber,
                    d.text_span(),
                    format!("{} is `{other}`", d.what),
                    "expected `input` or `output`",
                );
                None
            }
        });
    let number = |key: &str, default: f64, diags: &mut Diagnostics| match t.get(key) {
        Some(i) => (i.as_float(diags), Some(i.span.clone())),
        None => (Some(default), None),
    };
    let (min, min_span) = number("min", f64::NEG_INFINITY, diags);
    let (max, _) = number("max", f64::INFINITY, diags);
    let (default, default_span) = number("default", 0.0, diags);
    let (rate, rate_span) = number("rate", 0.0, diags);
    let persist = match t.get("persist") {
        Some(p) => p.as_bool(diags),
        None => Some(false),
    };
    let description = t.optional_str("description", diags).unwrap_or_default();
    if count == Some(0) {
        if let Some(c) = t.get("count") {
            diags.report(
                Code::BadArrayLength,
                c.span.clone(),
                format!("{} is 0", c.what),
                "an array variable has 1..=255 elements",
            );
        }
        return None;
    }
    let name = name?;
    Some(ModrobVariable {
        name: Name {
            wire: name.to_string(),
            rust: ident::type_name(name),
        },
        vi: vi? as u8,
        count: count? as u8,
        unit: unit?.to_string(),
        direction: direction?,
        min: min?,
        max: max?,
        default: default?,
        persist: persist?,
        rate: rate?,
        description: description.to_string(),
        spans: VariableSpans {
            table: Some(t.span.clone()),
            vi: vi_item.map(|i| i.span),
            name: name_item.map(|i| i.text_span()),
            unit: unit_item.map(|i| i.text_span()),
            min: min_span.or(Some(t.span.clone())),
            default: default_span.or(Some(t.span.clone())),
            rate: rate_span.or(Some(t.span.clone())),
        },
    })
}

/// A UUID in any of the usual text forms (E0104 otherwise).
fn uuid(item: &Item<'_, '_>, diags: &mut Diagnostics) -> Option<[u8; 16]> {
    let text = item.as_str(diags)?;
    let hex: String = text.chars().filter(|c| *c != '-').collect();
    let bytes = (hex.len() == 32 && hex.chars().all(|c| c.is_ascii_hexdigit())).then(|| {
        let mut out = [0u8; 16];
        for (i, b) in out.iter_mut().enumerate() {
            *b = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap_or(0);
        }
        out
    });
    if bytes.is_none() {
        diags.report(
            Code::BadNumber,
            item.text_span(),
            format!("{} is not a UUID", item.what),
            "expected 32 hex digits, e.g. 6f1c2a4e-0d3b-4c52-9a57-3e8f5b1d2c01",
        );
    }
    bytes
}

fn spanned(item: &Item<'_, '_>, diags: &mut Diagnostics) -> Option<Spanned> {
    Some(Spanned {
        text: item.as_str(diags)?.to_string(),
        span: item.text_span(),
    })
}

/// Reads a robot file (a file with a top-level `[robot]` table). Dictionary paths are relative
/// to the robot file.
pub fn read_robot(
    source: &Arc<SourceFile>,
    dir: &Path,
    root: &Table<'_, '_>,
    diags: &mut Diagnostics,
) -> ParsedRobot {
    root.check_keys(ROBOT_ROOT_KEYS, diags);
    let mut robot = ParsedRobot {
        source: source.clone(),
        description: String::new(),
        span: Span::new(source, 0, 0),
        leader: None,
        dictionaries: Vec::new(),
        networks: Vec::new(),
        instances: Vec::new(),
        values: Vec::new(),
        rates: Vec::new(),
        subscriptions: Vec::new(),
    };
    if let Some(t) = root
        .get("robot")
        .and_then(|r| r.as_table("`[robot]`", diags))
    {
        t.check_keys(ROBOT_KEYS, diags);
        robot.span = t.span.clone();
        robot.description = t
            .optional_str("description", diags)
            .unwrap_or_default()
            .to_string();
        robot.leader = t.required("leader", diags).and_then(|l| spanned(&l, diags));
    }
    if let Some(t) = root
        .get("dictionaries")
        .and_then(|d| d.as_table("`[dictionaries]`", diags))
    {
        for item in t.entries() {
            if let Some(path) = item.as_str(diags) {
                let path = dir.join(path);
                let canonical = std::fs::canonicalize(&path).unwrap_or(path);
                let name = Spanned {
                    text: item.key.to_string(),
                    span: item.key_span.clone(),
                };
                robot.dictionaries.push((name, canonical));
            }
        }
    }
    for t in tables(root, "networks", "a network", diags) {
        t.check_keys(NETWORK_KEYS, diags);
        let name = t.required("name", diags).and_then(|n| n.as_name(diags));
        let transport = t.required("transport", diags).and_then(|i| {
            Some(match i.as_str(diags)? {
                "can" => Transport::Can,
                "uart" => Transport::Uart,
                "spi" => Transport::Spi,
                "ethernet" => Transport::Ethernet,
                other => {
                    diags.report(
                        Code::BadNumber,
                        i.text_span(),
                        format!("{} is `{other}`", i.what),
                        "expected `can`, `uart`, `spi` or `ethernet`",
                    );
                    return None;
                }
            })
        });
        let bitrate = t
            .required("bitrate", diags)
            .and_then(|b| b.as_uint(u32::MAX.into(), diags));
        if let (Some(name), Some(transport), Some(bitrate)) = (name, transport, bitrate) {
            robot.networks.push(RobotNetwork {
                name: Name {
                    wire: name.to_string(),
                    rust: ident::const_name(name),
                },
                transport,
                bitrate: bitrate.max(1) as u32,
                span: Some(t.span.clone()),
            });
        }
    }
    for t in tables(root, "instances", "an instance", diags) {
        t.check_keys(INSTANCE_KEYS, diags);
        let name = t.required("name", diags).and_then(|n| n.as_name(diags));
        let dictionary = t
            .required("dictionary", diags)
            .and_then(|d| spanned(&d, diags));
        let network = t
            .required("network", diags)
            .and_then(|n| spanned(&n, diags));
        let mi = t.get("mi").and_then(|m| {
            let value = m.as_uint(u16::MAX.into(), diags)?;
            Some((value as u16, m.span.clone()))
        });
        let uuid = t.get("uuid").and_then(|u| uuid(&u, diags));
        if let (Some(name), Some(dictionary), Some(network)) = (name, dictionary, network) {
            robot.instances.push(ParsedInstance {
                name: Name {
                    wire: name.to_string(),
                    rust: ident::const_name(name),
                },
                dictionary,
                mi,
                uuid,
                network,
                span: t.span.clone(),
            });
        }
    }
    if let Some(config) = root
        .get("config")
        .and_then(|c| c.as_table("`[config]`", diags))
    {
        config.check_keys(CONFIG_KEYS, diags);
        robot.values = settings(&config, "values", diags);
        robot.rates = settings(&config, "rates", diags);
        if let Some(subs) = config.get("subscriptions").and_then(|s| s.as_array(diags)) {
            for item in subs {
                if let Some(sub) = subscription(&item, diags) {
                    robot.subscriptions.push(sub);
                }
            }
        }
    }
    robot
}

/// The tables of an array of tables (`[[networks]]`), each described as `what`.
fn tables<'a, 'i>(
    root: &Table<'a, 'i>,
    key: &str,
    what: &str,
    diags: &mut Diagnostics,
) -> Vec<Table<'a, 'i>> {
    let items = root
        .get(key)
        .and_then(|i| i.as_array(diags))
        .unwrap_or_default();
    items
        .iter()
        .filter_map(|i| i.as_table(what, diags))
        .collect()
}

/// `[config] values` or `rates`: a table of `"instance.variable" = number`.
fn settings(config: &Table<'_, '_>, key: &str, diags: &mut Diagnostics) -> Vec<(Spanned, f64)> {
    let Some(table) = config
        .get(key)
        .and_then(|t| t.as_table(format!("`[config.{key}]`"), diags))
    else {
        return Vec::new();
    };
    table
        .entries()
        .into_iter()
        .filter_map(|item| {
            let value = item.as_float(diags)?;
            let name = Spanned {
                text: item.key.to_string(),
                span: item.key_span.clone(),
            };
            Some((name, value))
        })
        .collect()
}

/// `"target.variable <- source.variable"`; E0512 if it is not of that form.
fn subscription(item: &Item<'_, '_>, diags: &mut Diagnostics) -> Option<(Spanned, Spanned, Span)> {
    let text = item.as_str(diags)?;
    let whole = item.text_span();
    let parts = text.split_once("<-").map(|(target, source)| {
        let start = whole.start;
        let trimmed = |part: &str, offset: usize| {
            let lead = part.len() - part.trim_start().len();
            let t = part.trim().trim_matches('"');
            let quote = usize::from(part.trim().starts_with('"'));
            let begin = start + offset + lead + quote;
            Spanned {
                text: t.to_string(),
                span: Span::new(&whole.file, begin, begin + t.len()),
            }
        };
        let source_offset = target.len() + 2;
        (trimmed(target, 0), trimmed(source, source_offset))
    });
    let valid = |s: &Spanned| {
        s.text
            .split_once('.')
            .is_some_and(|(a, b)| !a.is_empty() && !b.is_empty())
    };
    match parts {
        Some((target, source)) if valid(&target) && valid(&source) => Some((target, source, whole)),
        _ => {
            diags.report(
                Code::BadSubscription,
                whole,
                format!("{} is not a subscription", item.what),
                "expected \"instance.variable <- instance.variable\"",
            );
            None
        }
    }
}
