//! Diagnostics: every problem found in a dictionary, with a stable code, a position, the source
//! line with a caret, and a hint.
//!
//! All stages push into one [`Diagnostics`] accumulator so that a run reports every problem at
//! once; the pipeline stops before emitting code if any error was reported.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A loaded source file.
#[derive(Debug)]
pub struct SourceFile {
    /// The path as given (or as resolved from an include).
    pub path: PathBuf,
    /// The file's text.
    pub text: String,
    line_starts: Vec<usize>,
}

impl SourceFile {
    /// Wraps a file's text.
    pub fn new(path: impl Into<PathBuf>, text: String) -> Arc<Self> {
        let line_starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        Arc::new(Self {
            path: path.into(),
            text,
            line_starts,
        })
    }

    /// 1-based line and column (in characters) of a byte offset.
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let line = self.line_starts.partition_point(|&s| s <= offset) - 1;
        let start = self.line_starts[line];
        let col = self
            .text
            .get(start..offset)
            .map_or(0, |s| s.chars().count());
        (line + 1, col + 1)
    }

    /// The text of 1-based line `line`, without its line break.
    pub fn line_text(&self, line: usize) -> &str {
        let start = self.line_starts.get(line - 1).copied().unwrap_or(0);
        let end = self
            .line_starts
            .get(line)
            .copied()
            .unwrap_or(self.text.len());
        self.text
            .get(start..end)
            .unwrap_or("")
            .trim_end_matches(['\n', '\r'])
    }
}

/// A byte range in a source file.
#[derive(Debug, Clone)]
pub struct Span {
    /// The file.
    pub file: Arc<SourceFile>,
    /// Start byte offset.
    pub start: usize,
    /// End byte offset (exclusive); at least `start`.
    pub end: usize,
}

impl Span {
    /// A span of `len` bytes at `start`.
    pub fn new(file: &Arc<SourceFile>, start: usize, end: usize) -> Self {
        Self {
            file: file.clone(),
            start,
            end: end.max(start),
        }
    }

    /// `path:line:col`.
    pub fn location(&self) -> String {
        let (line, col) = self.file.line_col(self.start);
        format!("{}:{line}:{col}", self.file.path.display())
    }
}

/// How bad a diagnostic is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Severity {
    /// Code is still generated.
    Warning,
    /// No code is generated.
    Error,
}

macro_rules! codes {
    ($( $(#[$doc:meta])* $name:ident = $code:literal, $sev:ident, $hint:literal; )*) => {
        /// Every diagnostic the generator can report. Codes are stable.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[non_exhaustive]
        pub enum Code {
            $( $(#[$doc])* $name, )*
        }

        impl Code {
            /// Every code, for documentation and tests.
            pub const ALL: &'static [Code] = &[$(Code::$name),*];

            /// The stable code, e.g. `"E0101"`.
            pub const fn as_str(self) -> &'static str {
                match self { $( Code::$name => $code, )* }
            }

            /// Whether this stops code generation.
            pub const fn severity(self) -> Severity {
                match self { $( Code::$name => Severity::$sev, )* }
            }

            /// What to do about it.
            pub const fn hint(self) -> &'static str {
                match self { $( Code::$name => $hint, )* }
            }
        }
    };
}

codes! {
    /// The file could not be read.
    Io = "E0001", Error, "check the path and permissions";
    /// The XML or TOML is not well-formed.
    Syntax = "E0002", Error, "fix the syntax at the marked position; nothing else in the file is checked until it parses";
    /// A TOML file whose top-level table names no kind of dictionary the generator reads.
    UnknownKind = "E0003", Error, "a TOML dictionary names its kind in a top-level table: `[ring]` for a TosNet register map, `[module]` for a ModRob-1 module dictionary, `[robot]` for a ModRob-1 robot";
    /// A TOML dictionary given to a generator built without its `toml` feature.
    TomlNotBuilt = "E0004", Error, "enable ferrolink-codegen's `toml` feature (on by default), which reads TosNet register maps and ModRob-1 dictionaries";
    /// An element the dialect format does not have.
    UnknownElement = "W0101", Warning, "mavgen ignores it too; check the spelling";
    /// An attribute the element does not have.
    UnknownAttribute = "W0102", Warning, "mavgen ignores it too; check the spelling";
    /// A key the TOML format does not have.
    UnknownKey = "W0103", Warning, "it is ignored; check the spelling against the format in docs/tosnet.md or docs/modrob.md";
    /// A required attribute, element or key is missing.
    Missing = "E0103", Error, "add it; see the formats in docs/generator.md, docs/tosnet.md and docs/modrob.md";
    /// A value of the wrong type, or a number that does not parse or is out of range.
    BadNumber = "E0104", Error, "write a value of the type it takes; numbers in range, as decimal, 0x.. or 0b.. (or 2**n in XML)";
    /// A field type that is not one of the MAVLink types.
    UnknownType = "E0105", Error, "use one of int8_t..uint64_t, float, double, char, each optionally with [N]";
    /// An array length of 0 or over 255, or a malformed one.
    BadArrayLength = "E0106", Error, "array lengths are 1..=255, written as type[N]";
    /// A message id above 2^24-1.
    IdOutOfRange = "E0107", Error, "message ids are 0..=16777215 (24 bits)";
    /// A name that is not an identifier.
    InvalidName = "E0108", Error, "names are ASCII letters, digits and `_`, not starting with a digit";
    /// An include that cannot be found.
    IncludeNotFound = "E0201", Error, "include paths are relative to the including file";
    /// An include cycle.
    IncludeCycle = "E0202", Error, "remove one of the includes in the cycle";
    /// Two messages with the same id.
    DuplicateMessageId = "E0301", Error, "every message id must be unique in a dialect and its includes";
    /// Two messages with the same name.
    DuplicateMessageName = "E0302", Error, "every message name must be unique in a dialect and its includes";
    /// Two fields of a message with the same name.
    DuplicateField = "E0303", Error, "rename one of the fields";
    /// Two entries of an enum with the same name.
    DuplicateEntryName = "E0304", Error, "rename or remove one of the entries";
    /// Two entries of an enum with the same value.
    DuplicateEntryValue = "E0305", Error, "give each entry its own value";
    /// A field names an enum that does not exist.
    MissingEnum = "E0306", Error, "define the enum or fix the name in `enum=`";
    /// The payload is over 255 bytes.
    PayloadTooLong = "E0307", Error, "MAVLink payloads are at most 255 bytes; split the message";
    /// A message without fields.
    EmptyMessage = "E0308", Error, "a message needs at least one field";
    /// More than 64 fields.
    TooManyFields = "E0309", Error, "a message has at most 64 fields";
    /// Two names that become the same Rust name.
    NameCollision = "E0310", Error, "rename one of them; names are compared after case conversion";
    /// A message id that does not fit the carrier's type field (NDLCom: one byte).
    CarrierIdTooLarge = "E0311", Error, "NDLCom names a payload's message in one byte: give the message an id below 256, or do not send it over NDLCom";
    /// A message that, with the carrier's own bytes, exceeds the carrier's payload.
    CarrierPayloadTooLong = "E0312", Error, "NDLCom payloads are at most 255 bytes including the id byte: shorten the message to 254 bytes";
    /// A TosNet area field that ends past the 16-byte area.
    AreaTooLong = "E0401", Error, "a TosNet area holds 16 bytes: shorten or move the fields, or spread them over two registers";
    /// A TosNet node id over 15.
    NodeIdOutOfRange = "E0402", Error, "TosNet node ids are 0..=15";
    /// Two nodes of a ring with the same id.
    DuplicateNodeId = "E0403", Error, "give every node of the ring its own id";
    /// More than 15 nodes in a ring.
    TooManyNodes = "E0404", Error, "a TosNet ring has at most 15 nodes";
    /// Two fields of an area that share bytes.
    OverlappingFields = "E0405", Error, "give the fields offsets that do not overlap, or leave `offset` out to place a field right after the previous one";
    /// More than 8 registers on a node.
    TooManyRegisters = "E0406", Error, "a TosNet node has at most 8 registers";
    /// A register index over 7.
    RegisterIndexOutOfRange = "E0407", Error, "TosNet register indices are 0..=7";
    /// Two registers of a node with the same index.
    DuplicateRegisterIndex = "E0408", Error, "give every register of the node its own index";
    /// Two fields of an area with the same name.
    DuplicateAreaField = "E0409", Error, "rename one of the fields";
    /// Two nodes of a ring with the same name.
    DuplicateNodeName = "E0410", Error, "give every node of the ring its own name";
    /// Two registers of a node with the same name.
    DuplicateRegisterName = "E0411", Error, "give every register of the node its own name";
    /// A register names an area that is not defined.
    UnknownArea = "E0412", Error, "define the area as `[areas.NAME]`, fix the name, or write the area inline as `{ fields = [...] }`";
    /// Two variables of a ModRob-1 module with the same VI (arrays take one VI per element).
    DuplicateVi = "E0501", Error, "give every variable its own VI; an array variable takes `count` consecutive VIs";
    /// Two variables of a ModRob-1 module with the same name.
    DuplicateVariableName = "E0502", Error, "rename one of the variables";
    /// A ModRob-1 module with more than 255 variables, or an array that runs past VI 255.
    TooManyVariables = "E0503", Error, "a ModRob-1 module has at most 255 variables, with VIs 0..=255; split the module";
    /// A unit that is not an SI unit or a dimensionless kind.
    UnknownUnit = "E0504", Error, "write an SI base or derived unit with an optional prefix (m, km, rad/s, m/s^2, N.m, kA), `1` for a plain number, or one of the dimensionless kinds `mode`, `counter`, `ratio`";
    /// `min` above `max`.
    LimitsReversed = "E0505", Error, "swap `min` and `max`";
    /// A default or stored value outside the variable's limits.
    ValueOutsideLimits = "E0506", Error, "change the value or widen the variable's `min`/`max`";
    /// Two instances of a robot with the same MI.
    DuplicateMi = "E0507", Error, "give every module of the robot its own `mi`; an instance without one takes its dictionary's";
    /// A name in a robot file that names nothing: an instance, variable, dictionary or network.
    UnknownName = "E0508", Error, "use a name defined in the robot file or the instance's dictionary; variables are written `instance.variable` (`instance.array[i]` for an array element)";
    /// A subscription whose source is an input variable.
    SubscriptionToInput = "E0509", Error, "subscribe to an output: inputs are set from outside, outputs are what a module produces";
    /// A publication rate the instance's network cannot carry.
    RateTooHigh = "E0510", Error, "lower the rate, or put the module on a faster network";
    /// A negative, infinite or NaN publication rate.
    BadRate = "E0511", Error, "rates are finite and >= 0 Hz; 0 publishes nothing";
    /// A subscription that is not `"instance.variable <- instance.variable"`.
    BadSubscription = "E0512", Error, "write subscriptions as \"target.variable <- source.variable\"";
    /// An info text that does not fit 255 piecewise chunks or holds a NUL byte.
    BadInfo = "E0513", Error, "info texts are at most 1785 bytes (255 chunks of 7) and hold no NUL byte";
    /// Two instances or networks of a robot with the same name.
    DuplicateRobotName = "E0514", Error, "rename one of them";
    /// A module on an Ethernet-1 network without a UUID.
    MissingUuid = "W0515", Warning, "give the instance (or its dictionary) a `uuid`; without one the module id is all zeros";
    /// A subscription whose target is an output.
    SubscriptionSetsOutput = "W0516", Warning, "setting an output from outside changes no state; subscribe an input instead";
    /// The configured traffic on a network exceeds what it carries.
    NetworkOverloaded = "W0517", Warning, "lower rates on this network or move modules to another";
}

/// One problem.
#[derive(Debug, Clone)]
pub struct Diagnostic {
    /// What kind.
    pub code: Code,
    /// The message.
    pub message: String,
    /// Where.
    pub span: Span,
    /// What the caret points at.
    pub label: String,
    /// Other places that take part (e.g. the first definition of a duplicate).
    pub notes: Vec<(Span, String)>,
}

impl Diagnostic {
    /// Severity from the code.
    pub fn severity(&self) -> Severity {
        self.code.severity()
    }

    /// Adds a secondary place.
    pub fn note(mut self, span: Span, text: impl Into<String>) -> Self {
        self.notes.push((span, text.into()));
        self
    }
}

fn render_snippet(f: &mut fmt::Formatter<'_>, span: &Span, label: &str) -> fmt::Result {
    let (line, col) = span.file.line_col(span.start);
    let text = span.file.line_text(line);
    let width = line.to_string().len();
    let line_chars = text.chars().count();
    let (_, end_col) = span.file.line_col(span.end);
    let (end_line, _) = span.file.line_col(span.end);
    let carets = if end_line == line && end_col > col {
        end_col - col
    } else {
        line_chars.saturating_sub(col - 1).max(1)
    };
    writeln!(f, "{:width$} |", "")?;
    writeln!(f, "{line:width$} | {text}")?;
    writeln!(
        f,
        "{:width$} | {}{} {label}",
        "",
        " ".repeat(col - 1),
        "^".repeat(carets.clamp(1, 80))
    )
}

impl fmt::Display for Diagnostic {
    /// rustc-like rendering:
    ///
    /// ```text
    /// error[E0306]: field `type` names enum `MAV_TYPO`, which does not exist
    ///   --> dialect.xml:12:7
    ///    |
    /// 12 |       <field type="uint8_t" name="type" enum="MAV_TYPO">...</field>
    ///    |                                         ^^^^^^^^^^^^^^^ no such enum
    ///    = hint: define the enum or fix the name in `enum=`
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sev = match self.severity() {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        writeln!(f, "{sev}[{}]: {}", self.code.as_str(), self.message)?;
        writeln!(f, "  --> {}", self.span.location())?;
        render_snippet(f, &self.span, &self.label)?;
        for (span, text) in &self.notes {
            writeln!(f, "  note: {}", span.location())?;
            render_snippet(f, span, text)?;
        }
        write!(f, "   = hint: {}", self.code.hint())
    }
}

/// The accumulator every stage reports into.
#[derive(Debug, Default)]
pub struct Diagnostics {
    items: Vec<Diagnostic>,
}

impl Diagnostics {
    /// Reports a problem.
    pub fn report(
        &mut self,
        code: Code,
        span: Span,
        message: impl Into<String>,
        label: impl Into<String>,
    ) -> &mut Diagnostic {
        self.items.push(Diagnostic {
            code,
            message: message.into(),
            span,
            label: label.into(),
            notes: Vec::new(),
        });
        self.items.last_mut().expect("just pushed")
    }

    /// Whether any error (not warning) was reported.
    pub fn has_errors(&self) -> bool {
        self.items.iter().any(|d| d.severity() == Severity::Error)
    }

    /// All diagnostics, in file order.
    pub fn into_vec(mut self) -> Vec<Diagnostic> {
        self.sort();
        self.items
    }

    /// All diagnostics so far.
    pub fn items(&self) -> &[Diagnostic] {
        &self.items
    }

    fn sort(&mut self) {
        self.items.sort_by(|a, b| {
            (&a.span.file.path, a.span.start).cmp(&(&b.span.file.path, b.span.start))
        });
    }
}

/// The error a failed run returns: every diagnostic, warnings included.
#[derive(Debug)]
pub struct Failed(pub Vec<Diagnostic>);

impl fmt::Display for Failed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let errors = self
            .0
            .iter()
            .filter(|d| d.severity() == Severity::Error)
            .count();
        for d in &self.0 {
            writeln!(f, "{d}\n")?;
        }
        write!(f, "{errors} error(s)")
    }
}

impl std::error::Error for Failed {}

/// Displays a path relative to the current directory where possible, so that diagnostics and
/// snapshots do not depend on where the project lives.
pub fn display_path(path: &Path) -> PathBuf {
    std::env::current_dir()
        .ok()
        .and_then(|cwd| path.strip_prefix(cwd).ok().map(Path::to_path_buf))
        .unwrap_or_else(|| path.to_path_buf())
}
