//! Frontends: read dictionary files into IR parts, reporting every problem with its position.
//!
//! Inputs are told apart by extension: a `.toml` file by its top-level table (`[ring]`: a
//! TosNet register map, read by [`tosnet`]; `[module]` and `[robot]`: a ModRob-1 module
//! dictionary or robot, read by [`modrob`]), everything else as a MAVLink XML dialect
//! ([`mavlink`]).

pub mod mavlink;
#[cfg(feature = "toml")]
pub mod modrob;
#[cfg(feature = "toml")]
pub mod toml;
#[cfg(feature = "toml")]
pub mod tosnet;
pub mod xml;

use std::path::{Path, PathBuf};

use crate::diag::{Code, Diagnostics, SourceFile, Span};
use crate::ir::{FieldType, Primitive};

/// Every file a run reads, by format.
#[derive(Debug, Default)]
pub struct Loaded {
    /// MAVLink dialects and their includes.
    pub mavlink: mavlink::Loaded,
    /// TosNet register maps, in input order.
    #[cfg(feature = "toml")]
    pub rings: Vec<tosnet::ParsedRing>,
    /// ModRob-1 module dictionaries: those given, then those robots name, each once.
    #[cfg(feature = "toml")]
    pub modrob: Vec<modrob::ParsedModule>,
    /// ModRob-1 robots, in input order.
    #[cfg(feature = "toml")]
    pub robots: Vec<modrob::ParsedRobot>,
}

/// One TOML dictionary, by kind.
#[cfg(feature = "toml")]
enum TomlFile {
    Ring(tosnet::ParsedRing),
    Module(modrob::ParsedModule),
    Robot(modrob::ParsedRobot),
}

impl Loaded {
    /// Every path read, for `cargo:rerun-if-changed`.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        let paths = self.mavlink.paths();
        #[cfg(feature = "toml")]
        let paths = paths
            .chain(self.rings.iter().map(|r| r.source.path.as_path()))
            .chain(self.modrob.iter().map(|m| Path::new(&m.module.path)))
            .chain(self.robots.iter().map(|r| r.source.path.as_path()));
        paths
    }
}

/// How a file's text is read: from disk ([`read_file`]), or from memory for dictionaries built
/// into a program.
pub type Read<'a> = &'a dyn Fn(&Path) -> std::io::Result<String>;

/// Reads a file from disk.
pub fn read_file(path: &Path) -> std::io::Result<String> {
    std::fs::read_to_string(path)
}

/// Reads `inputs`: `.toml` files as TOML dictionaries, the rest as MAVLink XML (with their
/// includes), each file through `read`.
pub fn load(inputs: &[PathBuf], read: Read<'_>, diags: &mut Diagnostics) -> Loaded {
    let is_toml = |p: &PathBuf| p.extension().is_some_and(|e| e == "toml");
    let xml: Vec<PathBuf> = inputs.iter().filter(|p| !is_toml(p)).cloned().collect();
    let mut loaded = Loaded {
        mavlink: mavlink::load(&xml, read, diags),
        #[cfg(feature = "toml")]
        rings: Vec::new(),
        #[cfg(feature = "toml")]
        modrob: Vec::new(),
        #[cfg(feature = "toml")]
        robots: Vec::new(),
    };
    let toml: Vec<&PathBuf> = inputs.iter().filter(|p| is_toml(p)).collect();
    load_toml_inputs(&mut loaded, &toml, read, diags);
    loaded
}

/// Reads the TOML dictionaries, and the module dictionaries their robots name.
#[cfg(feature = "toml")]
fn load_toml_inputs(
    loaded: &mut Loaded,
    inputs: &[&PathBuf],
    read: Read<'_>,
    diags: &mut Diagnostics,
) {
    let mut seen = std::collections::HashSet::new();
    for &path in inputs {
        let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.clone());
        if !seen.insert(key.clone()) {
            continue;
        }
        match load_toml(path, key, read, diags) {
            Some(TomlFile::Ring(ring)) => loaded.rings.push(ring),
            Some(TomlFile::Module(module)) => loaded.modrob.push(module),
            Some(TomlFile::Robot(robot)) => loaded.robots.push(robot),
            None => {}
        }
    }
    let named: Vec<(modrob::Spanned, PathBuf)> = loaded
        .robots
        .iter()
        .flat_map(|r| r.dictionaries.iter().cloned())
        .collect();
    for (name, path) in named {
        if !seen.insert(path.clone()) {
            continue;
        }
        if !path.is_file() {
            diags.report(
                Code::IncludeNotFound,
                name.span,
                format!(
                    "dictionary `{}` is {}, which does not exist",
                    name.text,
                    path.display()
                ),
                "not found",
            );
            continue;
        }
        match load_toml(&path, path.clone(), read, diags) {
            Some(TomlFile::Module(module)) => loaded.modrob.push(module),
            Some(_) => {
                diags.report(
                    Code::UnknownKind,
                    name.span,
                    format!(
                        "dictionary `{}` is not a ModRob-1 module dictionary",
                        name.text
                    ),
                    "expected a file with a `[module]` table",
                );
            }
            None => {}
        }
    }
}

/// Without the `toml` feature a TOML dictionary is an error, reported at its first byte.
#[cfg(not(feature = "toml"))]
fn load_toml_inputs(_: &mut Loaded, inputs: &[&PathBuf], _: Read<'_>, diags: &mut Diagnostics) {
    for path in inputs {
        let file = SourceFile::new(path.as_path(), String::new());
        diags.report(
            Code::TomlNotBuilt,
            Span::new(&file, 0, 0),
            format!(
                "{} is a TOML dictionary, and this generator was built without its `toml` feature",
                path.display()
            ),
            "",
        );
    }
}

/// Reads one TOML dictionary and hands it to the reader its top-level table names.
#[cfg(feature = "toml")]
fn load_toml(
    path: &Path,
    canonical: PathBuf,
    read: Read<'_>,
    diags: &mut Diagnostics,
) -> Option<TomlFile> {
    let text = match read(path) {
        Ok(t) => t,
        Err(e) => {
            report_unreadable(path, &e, diags);
            return None;
        }
    };
    let source = SourceFile::new(crate::diag::display_path(path), text);
    let doc = toml::parse(&source, diags)?;
    let root = toml::Table::root(&source, &doc);
    if root.get("ring").is_some() {
        return Some(TomlFile::Ring(tosnet::read(&source, &root, diags)));
    }
    if root.get("module").is_some() {
        let module = modrob::read_module(&source, canonical, &root, diags);
        return Some(TomlFile::Module(module));
    }
    if root.get("robot").is_some() {
        let dir = path.parent().unwrap_or(Path::new(""));
        return Some(TomlFile::Robot(modrob::read_robot(
            &source, dir, &root, diags,
        )));
    }
    let first = root.entries().into_iter().next();
    let (span, label) = match &first {
        Some(item) => (
            item.key_span.clone(),
            format!("`{}` names no kind", item.key),
        ),
        None => (Span::new(&source, 0, 0), "empty file".to_string()),
    };
    diags.report(
        Code::UnknownKind,
        span,
        "this TOML file is not a dictionary of a known kind: it has no top-level `[ring]`, `[module]` or `[robot]` table",
        label,
    );
    None
}

/// Reports an input that cannot be read (E0001).
pub(crate) fn report_unreadable(path: &Path, e: &std::io::Error, diags: &mut Diagnostics) {
    let file = SourceFile::new(path, String::new());
    diags.report(
        Code::Io,
        Span::new(&file, 0, 0),
        format!("cannot read {}: {e}", path.display()),
        "",
    );
}

/// Which spellings of a field type a format accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TypeSyntax {
    /// MAVLink XML: also `uint8_t_mavlink_version` and the legacy `array[N]`.
    Mavlink,
    /// Formats that only take the plain types (TosNet TOML).
    #[cfg(feature = "toml")]
    Plain,
}

/// Parses a field type: `uint16_t`, `float[4]`, `char[16]`, legacy `uint8`, and for MAVLink
/// `uint8_t_mavlink_version` and `array[N]`. Problems are reported at `span`.
pub(crate) fn parse_type(
    text: &str,
    span: &Span,
    syntax: TypeSyntax,
    diags: &mut Diagnostics,
) -> Option<FieldType> {
    let text = text.trim();
    if syntax == TypeSyntax::Mavlink && text == "uint8_t_mavlink_version" {
        return Some(FieldType {
            primitive: Primitive::U8,
            array: None,
            mavlink_version: true,
        });
    }
    let (base, array) = match text.split_once('[') {
        Some((base, rest)) => {
            let len = rest
                .strip_suffix(']')
                .and_then(|n| n.trim().parse::<u64>().ok());
            match len {
                Some(n) if (1..=255).contains(&n) => (base, Some(n as u8)),
                _ => {
                    diags.report(
                        Code::BadArrayLength,
                        span.clone(),
                        format!("bad array length in `{text}`"),
                        "expected [1..=255]",
                    );
                    return None;
                }
            }
        }
        None => (text, None),
    };
    let primitive = if syntax == TypeSyntax::Mavlink && base == "array" && array.is_some() {
        Some(Primitive::I8)
    } else {
        Primitive::from_c(base)
    };
    match primitive {
        Some(primitive) => Some(FieldType {
            primitive,
            array,
            mavlink_version: false,
        }),
        None => {
            let label = match syntax {
                TypeSyntax::Mavlink => "not a MAVLink type",
                #[cfg(feature = "toml")]
                TypeSyntax::Plain => "not a field type",
            };
            diags.report(
                Code::UnknownType,
                span.clone(),
                format!("unknown field type `{base}`"),
                label,
            );
            None
        }
    }
}

/// An identifier-shaped name, reported as E0108 at `span` otherwise.
pub(crate) fn check_name(name: &str, span: &Span, diags: &mut Diagnostics) -> bool {
    if crate::ident::is_identifier(name) {
        return true;
    }
    diags.report(
        Code::InvalidName,
        span.clone(),
        format!("`{name}` is not a valid name"),
        "not an identifier",
    );
    false
}
