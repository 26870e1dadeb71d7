//! Compatibility between two versions of the same dictionaries: what a change breaks on the
//! wire, in meaning, or for the generated Rust, and what it changes safely.
//!
//! Both sides are loaded into the IR, then compared by wire name (a MAVLink message or a ModRob
//! module whose name is gone is also looked up by its id, to tell a rename from a removal).
//! Every [`Finding`] has a stable code, a category, the item's wire name, the old and new value,
//! a one-line reason and where the item is written in each version.
//!
//! The text, JSON-lines and GitHub-annotation forms of `ferrolink diff` are rendered here too.

mod mavlink;
mod modrob;
mod tosnet;

use std::fmt::Write as _;

use serde::Serialize;
use serde_json::Value;

use crate::diag::Span;
use crate::ir::{Deprecation, Field, Ir};

/// How much a change breaks, the worst first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Category {
    /// Devices built from the old and the new dictionary can no longer talk.
    Wire,
    /// The same bytes now mean something else.
    Semantic,
    /// Code written against the old generated Rust no longer compiles.
    Api,
    /// Nothing breaks: additions and descriptions.
    Safe,
}

impl Category {
    /// The lower-case name used in every output form and by `--fail-on`.
    pub const fn name(self) -> &'static str {
        match self {
            Category::Wire => "wire",
            Category::Semantic => "semantic",
            Category::Api => "api",
            Category::Safe => "safe",
        }
    }
}

/// What a finding is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// A MAVLink message (or NDLCom payload).
    Message,
    /// A message's field.
    Field,
    /// An enum or bitmask.
    Enum,
    /// An enum entry.
    Entry,
    /// A ModRob-1 module, instance or variable.
    Variable,
    /// A TosNet area, area field, node or register.
    Area,
}

/// Where an item is written: file, 1-based line and column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Position {
    /// The file, as it was read.
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column.
    pub col: usize,
}

impl Position {
    fn of(span: Option<&Span>) -> Option<Self> {
        let span = span?;
        let (line, col) = span.file.line_col(span.start);
        Some(Self {
            file: span.file.path.display().to_string(),
            line,
            col,
        })
    }
}

impl std::fmt::Display for Position {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.col)
    }
}

/// One difference between the old and the new dictionaries.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    /// How much it breaks.
    pub category: Category,
    /// A stable, kebab-case code (`crc-extra`, `entry-renamed`, ...).
    pub code: &'static str,
    /// What it is about.
    pub kind: Kind,
    /// The wire name: `HEARTBEAT`, `HEARTBEAT.type`, `MAV_STATE.MAV_STATE_ACTIVE`.
    pub name: String,
    /// The old value (`null` for an addition).
    pub old: Value,
    /// The new value (`null` for a removal).
    pub new: Value,
    /// One line saying what changed and why it matters.
    pub reason: String,
    /// CRC_EXTRA before and after, for `crc-extra` findings.
    pub crc_extra: Option<(u8, u8)>,
    /// Where the item is written in the old version.
    pub old_at: Option<Position>,
    /// Where the item is written in the new version.
    pub new_at: Option<Position>,
}

/// Every difference from `old` to `new`, the worst first, then by name.
pub fn diff(old: &Ir, new: &Ir) -> Vec<Finding> {
    let mut out = Findings::default();
    mavlink::diff(old, new, &mut out);
    modrob::diff(old, new, &mut out);
    tosnet::diff(old, new, &mut out);
    let mut findings = out.0;
    findings.sort_by(|a, b| {
        (a.category, &a.name, a.code, a.kind).cmp(&(b.category, &b.name, b.code, b.kind))
    });
    findings
}

/// Whether any finding is in `fail_on` or a worse category.
pub fn fails(findings: &[Finding], fail_on: Category) -> bool {
    findings.iter().any(|f| f.category <= fail_on)
}

/// An item of either version, paired with its namesake in the other.
enum Pair<'a, T> {
    /// On both sides: old, new.
    Both(&'a T, &'a T),
    /// Only in the old version.
    Gone(&'a T),
    /// Only in the new version.
    Added(&'a T),
}

/// Pairs `old` and `new` by `name`: the old side's items in order, paired or gone, then the new
/// side's items the old side lacks.
fn pair<'a, T>(old: &'a [T], new: &'a [T], name: impl Fn(&T) -> &str) -> Vec<Pair<'a, T>> {
    let mut pairs: Vec<Pair<'a, T>> = old
        .iter()
        .map(|o| match new.iter().find(|n| name(n) == name(o)) {
            Some(n) => Pair::Both(o, n),
            None => Pair::Gone(o),
        })
        .collect();
    pairs.extend(
        new.iter()
            .filter(|n| !old.iter().any(|o| name(o) == name(n)))
            .map(Pair::Added),
    );
    pairs
}

/// Collects findings; the protocol modules push through [`Findings::add`].
#[derive(Default)]
struct Findings(Vec<Finding>);

/// A finding under construction: what it is about and where.
struct Subject<'a> {
    kind: Kind,
    name: String,
    old: Option<&'a Span>,
    new: Option<&'a Span>,
}

impl<'a> Subject<'a> {
    fn new(
        kind: Kind,
        name: impl Into<String>,
        old: Option<&'a Span>,
        new: Option<&'a Span>,
    ) -> Self {
        Self {
            kind,
            name: name.into(),
            old,
            new,
        }
    }
}

impl Findings {
    fn add(
        &mut self,
        subject: &Subject<'_>,
        category: Category,
        code: &'static str,
        old: impl Into<Value>,
        new: impl Into<Value>,
        reason: impl Into<String>,
    ) -> &mut Finding {
        self.0.push(Finding {
            category,
            code,
            kind: subject.kind,
            name: subject.name.clone(),
            old: old.into(),
            new: new.into(),
            reason: reason.into(),
            crc_extra: None,
            old_at: Position::of(subject.old),
            new_at: Position::of(subject.new),
        });
        self.0.last_mut().expect("just pushed")
    }

    /// A changed description, as one `safe` finding.
    fn description(&mut self, subject: &Subject<'_>, old: &str, new: &str) {
        if old.trim() != new.trim() {
            self.add(
                subject,
                Category::Safe,
                "description",
                old,
                new,
                "description changed",
            );
        }
    }

    /// A changed deprecation marker: `safe`, since the item still means the same.
    fn deprecation(
        &mut self,
        subject: &Subject<'_>,
        old: &Option<Deprecation>,
        new: &Option<Deprecation>,
    ) {
        let show = |d: &Option<Deprecation>| match d {
            None => Value::Null,
            Some(d) => Value::String(format!(
                "{}{}{}",
                if d.superseded {
                    "superseded"
                } else {
                    "deprecated"
                },
                if d.since.is_empty() {
                    String::new()
                } else {
                    format!(" since {}", d.since)
                },
                if d.replaced_by.is_empty() {
                    String::new()
                } else {
                    format!(", replaced by {}", d.replaced_by)
                },
            )),
        };
        if old != new {
            let reason = match new {
                Some(_) if old.is_none() => "now deprecated",
                Some(_) => "deprecation changed",
                None => "no longer deprecated",
            };
            self.add(
                subject,
                Category::Safe,
                "deprecated",
                show(old),
                show(new),
                reason,
            );
        }
    }

    /// A Rust identifier that changed while the wire name stayed: `api`.
    fn rust_name(&mut self, subject: &Subject<'_>, old: &str, new: &str) {
        if old != new {
            self.add(
                subject,
                Category::Api,
                "rust-name",
                old,
                new,
                format!("the generated Rust name changed from `{old}` to `{new}`"),
            );
        }
    }

    /// What a field's attributes say about its meaning: units, multiplier and limits. Shared by
    /// MAVLink fields and TosNet area fields.
    fn field_meaning(&mut self, subject: &Subject<'_>, old: &Field, new: &Field) {
        for (attr, code, what) in [
            ("units", "units", "units"),
            ("multiplier", "multiplier", "multiplier"),
        ] {
            let (a, b) = (old.attr(attr), new.attr(attr));
            if a != b {
                self.add(
                    subject,
                    Category::Semantic,
                    code,
                    a,
                    b,
                    format!("{what} changed from {} to {}", shown(a), shown(b)),
                );
            }
        }
        let bound = |f: &Field, attr| f.attr(attr).and_then(|v| v.trim().parse::<f64>().ok());
        self.limits(
            subject,
            (bound(old, "minValue"), bound(old, "maxValue")),
            (bound(new, "minValue"), bound(new, "maxValue")),
        );
    }

    /// Limits: narrowed is `semantic` (values valid before are rejected now), widened `safe`.
    fn limits(
        &mut self,
        subject: &Subject<'_>,
        old: (Option<f64>, Option<f64>),
        new: (Option<f64>, Option<f64>),
    ) {
        if old == new {
            return;
        }
        let lower_raised = match (old.0, new.0) {
            (Some(a), Some(b)) => b > a,
            (None, Some(_)) => true,
            _ => false,
        };
        let upper_lowered = match (old.1, new.1) {
            (Some(a), Some(b)) => b < a,
            (None, Some(_)) => true,
            _ => false,
        };
        let range = |(lo, hi): (Option<f64>, Option<f64>)| {
            let end = |v: Option<f64>| v.map_or_else(|| "..".to_owned(), |v| v.to_string());
            format!("[{}, {}]", end(lo), end(hi))
        };
        let (a, b) = (range(old), range(new));
        if lower_raised || upper_lowered {
            self.add(
                subject,
                Category::Semantic,
                "limits-narrowed",
                a.clone(),
                b.clone(),
                format!(
                    "limits narrowed from {a} to {b}: values valid before are now out of range"
                ),
            );
        } else {
            self.add(
                subject,
                Category::Safe,
                "limits-widened",
                a.clone(),
                b.clone(),
                format!("limits widened from {a} to {b}"),
            );
        }
    }
}

fn shown(v: Option<&str>) -> String {
    v.map_or_else(|| "none".to_owned(), |v| format!("`{v}`"))
}

/// The C spelling of a field's type, with its array length: `uint8_t[4]`.
fn type_name(field: &Field) -> String {
    match field.ty.array {
        Some(n) => format!("{}[{n}]", field.ty.primitive.c_name()),
        None if field.ty.mavlink_version => "uint8_t_mavlink_version".to_owned(),
        None => field.ty.primitive.c_name().to_owned(),
    }
}

/// The output forms of `ferrolink diff`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// One finding per line with its positions under it, then a count per category.
    Text,
    /// One JSON object per line.
    Json,
    /// GitHub Actions workflow commands: an annotation per finding.
    Github,
}

/// Renders `findings` in `format`.
pub fn render(findings: &[Finding], format: Format) -> String {
    let mut out = String::new();
    match format {
        Format::Text => {
            for f in findings {
                let _ = writeln!(
                    out,
                    "{:<8} {:<20} {} {}: {}",
                    f.category.name(),
                    f.code,
                    kind_name(f.kind),
                    f.name,
                    f.reason
                );
                let at = |p: &Option<Position>| {
                    p.as_ref()
                        .map_or_else(|| "-".to_owned(), ToString::to_string)
                };
                let _ = writeln!(
                    out,
                    "{:29} old {}, new {}",
                    "",
                    at(&f.old_at),
                    at(&f.new_at)
                );
            }
            let count = |c| findings.iter().filter(|f| f.category == c).count();
            let _ = writeln!(
                out,
                "{} finding(s): {} wire, {} semantic, {} api, {} safe",
                findings.len(),
                count(Category::Wire),
                count(Category::Semantic),
                count(Category::Api),
                count(Category::Safe)
            );
        }
        Format::Json => {
            for f in findings {
                let mut object = serde_json::Map::new();
                object.insert("category".into(), f.category.name().into());
                object.insert("code".into(), f.code.into());
                object.insert("kind".into(), kind_name(f.kind).into());
                object.insert("name".into(), f.name.clone().into());
                object.insert("old".into(), f.old.clone());
                object.insert("new".into(), f.new.clone());
                object.insert("reason".into(), f.reason.clone().into());
                if let Some((old, new)) = f.crc_extra {
                    object.insert("old_crc_extra".into(), old.into());
                    object.insert("new_crc_extra".into(), new.into());
                }
                let _ = writeln!(out, "{}", Value::Object(object));
            }
        }
        Format::Github => {
            for f in findings {
                let level = match f.category {
                    Category::Wire => "error",
                    Category::Semantic | Category::Api => "warning",
                    Category::Safe => "notice",
                };
                let mut props = Vec::new();
                if let Some(p) = f.new_at.as_ref().or(f.old_at.as_ref()) {
                    props.push(format!("file={}", escape_property(&p.file)));
                    props.push(format!("line={}", p.line));
                    props.push(format!("col={}", p.col));
                }
                props.push(format!(
                    "title={}",
                    escape_property(&format!("{} {}", f.category.name(), f.code))
                ));
                let mut message = format!("{} {}: {}", kind_name(f.kind), f.name, f.reason);
                if let Some(p) = &f.old_at {
                    let _ = write!(message, " (old: {p})");
                }
                let _ = writeln!(
                    out,
                    "::{level} {}::{}",
                    props.join(","),
                    escape_data(&message)
                );
            }
        }
    }
    out
}

fn kind_name(kind: Kind) -> &'static str {
    match kind {
        Kind::Message => "message",
        Kind::Field => "field",
        Kind::Enum => "enum",
        Kind::Entry => "entry",
        Kind::Variable => "variable",
        Kind::Area => "area",
    }
}

/// GitHub's escaping of a workflow command's message.
fn escape_data(s: &str) -> String {
    s.replace('%', "%25")
        .replace('\r', "%0D")
        .replace('\n', "%0A")
}

/// GitHub's escaping of a workflow command's property value.
fn escape_property(s: &str) -> String {
    escape_data(s).replace(':', "%3A").replace(',', "%2C")
}
