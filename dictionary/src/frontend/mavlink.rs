//! The MAVLink XML dialect frontend: files, recursive includes, and the elements of
//! `mavschema.xsd` read into IR parts.
//!
//! Layout (wire order, offsets, CRC_EXTRA) and cross-file work (enum merging, references) happen
//! in [`crate::lower`]; this module only reads what each file says.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::xml::{self, Attr, Element};
use super::TypeSyntax;
use crate::diag::{Code, Diagnostics, SourceFile, Span};
use crate::ident;
use crate::ir::{Deprecation, Entry, Enum, Field, FieldType, Message, Name, Param, Primitive};

/// One parsed file.
#[derive(Debug)]
pub struct ParsedFile {
    /// The source.
    pub source: Arc<SourceFile>,
    /// Includes as indices into the loaded file list.
    pub includes: Vec<usize>,
    /// `<version>`.
    pub version: Option<u8>,
    /// `<dialect>`.
    pub dialect: Option<u32>,
    /// Enums as written in this file (not merged; `module` and `repr` unset).
    pub enums: Vec<Enum>,
    /// Messages as written (layout not computed).
    pub messages: Vec<Message>,
}

/// Every file a run reads, in dependency order (a file after everything it includes).
#[derive(Debug, Default)]
pub struct Loaded {
    /// The files.
    pub files: Vec<ParsedFile>,
    /// Indices of the files given as inputs.
    pub roots: Vec<usize>,
}

impl Loaded {
    /// Every path read, for `cargo:rerun-if-changed`.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|f| f.source.path.as_path())
    }
}

/// Reads `inputs` and, recursively, everything they include, each file through `read`.
pub fn load(inputs: &[PathBuf], read: super::Read<'_>, diags: &mut Diagnostics) -> Loaded {
    let mut loader = Loader {
        loaded: Loaded::default(),
        by_path: HashMap::new(),
        stack: Vec::new(),
        read,
    };
    for input in inputs {
        if let Some(i) = loader.load(input, None, diags) {
            if !loader.loaded.roots.contains(&i) {
                loader.loaded.roots.push(i);
            }
        }
    }
    loader.loaded
}

struct Loader<'r> {
    loaded: Loaded,
    read: super::Read<'r>,
    by_path: HashMap<PathBuf, usize>,
    stack: Vec<(PathBuf, Option<Span>)>,
}

impl Loader<'_> {
    fn load(&mut self, path: &Path, from: Option<&Span>, diags: &mut Diagnostics) -> Option<usize> {
        let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if let Some(pos) = self.stack.iter().position(|(p, _)| *p == key) {
            if let Some(span) = from {
                let chain: Vec<String> = self.stack[pos..]
                    .iter()
                    .map(|(p, _)| file_name(p))
                    .chain([file_name(&key)])
                    .collect();
                diags.report(
                    Code::IncludeCycle,
                    span.clone(),
                    format!("include cycle: {}", chain.join(" -> ")),
                    "this include closes the cycle",
                );
            }
            return None;
        }
        if let Some(&i) = self.by_path.get(&key) {
            return Some(i);
        }
        let text = match (self.read)(path) {
            Ok(t) => t,
            Err(e) => {
                match from {
                    Some(span) => {
                        diags.report(
                            Code::IncludeNotFound,
                            span.clone(),
                            format!("cannot read included file {}: {e}", path.display()),
                            "included here",
                        );
                    }
                    None => super::report_unreadable(path, &e, diags),
                }
                return None;
            }
        };
        let source = SourceFile::new(crate::diag::display_path(path), text);
        let root = xml::parse(&source, diags)?;
        self.stack.push((key.clone(), from.cloned()));
        let mut file = read_file(&source, &root, diags);
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        for (include, span) in include_paths(&root, &source) {
            if let Some(i) = self.load(&dir.join(&include), Some(&span), diags) {
                file.includes.push(i);
            }
        }
        self.stack.pop();
        let index = self.loaded.files.len();
        self.loaded.files.push(file);
        self.by_path.insert(key, index);
        Some(index)
    }
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

fn include_paths(root: &Element, source: &Arc<SourceFile>) -> Vec<(String, Span)> {
    root.children_named("include")
        .map(|el| {
            let span = text_span(source, el);
            (el.text.clone(), span)
        })
        .collect()
}

/// The span of an element's text (falls back to the tag).
fn text_span(source: &Arc<SourceFile>, el: &Element) -> Span {
    let after = el.span.end;
    match source.text.get(after..).and_then(|t| t.find('<')) {
        Some(len) if len > 0 => Span::new(source, after, after + len),
        _ => el.span.clone(),
    }
}

fn read_file(source: &Arc<SourceFile>, root: &Element, diags: &mut Diagnostics) -> ParsedFile {
    let mut file = ParsedFile {
        source: source.clone(),
        includes: Vec::new(),
        version: None,
        dialect: None,
        enums: Vec::new(),
        messages: Vec::new(),
    };
    if root.name != "mavlink" {
        diags.report(
            Code::Missing,
            root.span.clone(),
            format!("the root element is <{}>, not <mavlink>", root.name),
            "expected <mavlink>",
        );
        return file;
    }
    check_attrs(root, &[], diags);
    for child in &root.children {
        match child.name.as_str() {
            "include" => {}
            "version" => {
                file.version = parse_int(&child.text, &text_span(source, child), diags)
                    .and_then(|v| in_range(v, u8::MAX as u64, &text_span(source, child), diags))
                    .map(|v| v as u8);
            }
            "dialect" => {
                file.dialect = parse_int(&child.text, &text_span(source, child), diags)
                    .and_then(|v| in_range(v, u32::MAX as u64, &text_span(source, child), diags))
                    .map(|v| v as u32);
            }
            "enums" => {
                for el in &child.children {
                    if el.name == "enum" {
                        if let Some(e) = read_enum(el, diags) {
                            file.enums.push(e);
                        }
                    } else {
                        unknown_element(el, "<enums>", diags);
                    }
                }
            }
            "messages" => {
                for el in &child.children {
                    if el.name == "message" {
                        if let Some(m) = read_message(el, diags) {
                            file.messages.push(m);
                        }
                    } else {
                        unknown_element(el, "<messages>", diags);
                    }
                }
            }
            _ => unknown_element(child, "<mavlink>", diags),
        }
    }
    file
}

fn unknown_element(el: &Element, parent: &str, diags: &mut Diagnostics) {
    diags.report(
        Code::UnknownElement,
        el.span.clone(),
        format!("unknown element <{}> in {parent}", el.name),
        "ignored",
    );
}

fn check_attrs(el: &Element, known: &[&str], diags: &mut Diagnostics) {
    for a in &el.attrs {
        if !known.contains(&a.name.as_str()) {
            diags.report(
                Code::UnknownAttribute,
                a.span.clone(),
                format!("unknown attribute `{}` on <{}>", a.name, el.name),
                "ignored",
            );
        }
    }
}

/// The `name` attribute, required and checked to be an identifier.
fn name_attr(el: &Element, diags: &mut Diagnostics) -> Option<String> {
    let attr = required(el, "name", diags)?;
    super::check_name(&attr.value, &attr.value_span, diags).then(|| attr.value.clone())
}

fn required<'a>(el: &'a Element, name: &str, diags: &mut Diagnostics) -> Option<&'a Attr> {
    let attr = el.attr(name);
    if attr.is_none() {
        diags.report(
            Code::Missing,
            el.span.clone(),
            format!("<{}> has no `{name}` attribute", el.name),
            format!("`{name}` is required"),
        );
    }
    attr
}

/// Parses decimal, `0x..`, `0b..` and `2**n` integers.
fn parse_int(text: &str, span: &Span, diags: &mut Diagnostics) -> Option<u64> {
    let t = text.trim();
    let parsed = if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        u64::from_str_radix(h, 16).ok()
    } else if let Some(b) = t.strip_prefix("0b").or_else(|| t.strip_prefix("0B")) {
        u64::from_str_radix(b, 2).ok()
    } else if let Some((base, exp)) = t.split_once("**") {
        match (base.trim().parse::<u64>(), exp.trim().parse::<u32>()) {
            (Ok(b), Ok(e)) => b.checked_pow(e),
            _ => None,
        }
    } else {
        t.parse::<u64>().ok()
    };
    if parsed.is_none() {
        diags.report(
            Code::BadNumber,
            span.clone(),
            format!("`{t}` is not a valid unsigned number"),
            "not a number",
        );
    }
    parsed
}

fn in_range(v: u64, max: u64, span: &Span, diags: &mut Diagnostics) -> Option<u64> {
    if v > max {
        diags.report(
            Code::BadNumber,
            span.clone(),
            format!("{v} is out of range (at most {max})"),
            "too large",
        );
        return None;
    }
    Some(v)
}

fn read_deprecation(el: &Element, superseded: bool, diags: &mut Diagnostics) -> Deprecation {
    check_attrs(el, &["since", "replaced_by"], diags);
    Deprecation {
        since: el
            .attr("since")
            .map(|a| a.value.clone())
            .unwrap_or_default(),
        replaced_by: el
            .attr("replaced_by")
            .map(|a| a.value.clone())
            .unwrap_or_default(),
        note: el.text.clone(),
        superseded,
    }
}

fn read_enum(el: &Element, diags: &mut Diagnostics) -> Option<Enum> {
    check_attrs(el, &["name", "bitmask"], diags);
    let name = name_attr(el, diags)?;
    let mut e = Enum {
        name: Name {
            rust: ident::type_name(&name),
            wire: name.clone(),
        },
        bitmask: el.attr("bitmask").is_some_and(|a| a.value == "true"),
        description: String::new(),
        deprecated: None,
        entries: Vec::new(),
        module: 0,
        repr: Primitive::U8,
        span: Some(el.span.clone()),
    };
    let mut highest = 0u64;
    for child in &el.children {
        match child.name.as_str() {
            "description" => e.description = child.text.clone(),
            "deprecated" => e.deprecated = Some(read_deprecation(child, false, diags)),
            "superseded" => e.deprecated = Some(read_deprecation(child, true, diags)),
            // Schema-valid but carries nothing the bindings use.
            "wip" => {}
            "entry" => {
                if let Some(entry) = read_entry(child, &name, e.bitmask, highest, diags) {
                    highest = highest.max(entry.value);
                    e.entries.push(entry);
                }
            }
            _ => unknown_element(child, "<enum>", diags),
        }
    }
    Some(e)
}

fn read_entry(
    el: &Element,
    enum_name: &str,
    bitmask: bool,
    highest: u64,
    diags: &mut Diagnostics,
) -> Option<Entry> {
    check_attrs(
        el,
        &[
            "name",
            "value",
            "hasLocation",
            "isDestination",
            "missionOnly",
        ],
        diags,
    );
    let name = name_attr(el, diags)?;
    let (value, implicit) = match el.attr("value") {
        Some(a) => (parse_int(&a.value, &a.value_span, diags)?, false),
        // mavgen: an entry without a value takes the highest value so far + 1.
        None => (highest + 1, true),
    };
    let rust = if bitmask {
        ident::flag_name(enum_name, &name)
    } else {
        ident::variant_name(enum_name, &name)
    };
    let mut entry = Entry {
        name: Name { wire: name, rust },
        value,
        implicit,
        description: String::new(),
        deprecated: None,
        wip: false,
        params: Vec::new(),
        span: Some(el.span.clone()),
    };
    for child in &el.children {
        match child.name.as_str() {
            "description" => entry.description = child.text.clone(),
            "deprecated" => entry.deprecated = Some(read_deprecation(child, false, diags)),
            "superseded" => entry.deprecated = Some(read_deprecation(child, true, diags)),
            "wip" => entry.wip = true,
            "param" => {
                check_attrs(
                    child,
                    &[
                        "index",
                        "label",
                        "units",
                        "enum",
                        "decimalPlaces",
                        "increment",
                        "minValue",
                        "maxValue",
                        "reserved",
                        "default",
                        "multiplier",
                        "instance",
                    ],
                    diags,
                );
                let Some(index) = required(child, "index", diags) else {
                    continue;
                };
                let Some(i) = parse_int(&index.value, &index.value_span, diags)
                    .and_then(|v| in_range(v, 7, &index.value_span, diags))
                else {
                    continue;
                };
                entry.params.push(Param {
                    index: i as u8,
                    description: child.text.clone(),
                    attrs: child
                        .attrs
                        .iter()
                        .filter(|a| a.name != "index")
                        .map(|a| (a.name.clone(), a.value.clone()))
                        .collect(),
                });
            }
            _ => unknown_element(child, "<entry>", diags),
        }
    }
    Some(entry)
}

const FIELD_ATTRS: &[&str] = &[
    "type",
    "name",
    "enum",
    "units",
    "display",
    "instance",
    "invalid",
    "multiplier",
    "print_format",
    "default",
    "increment",
    "minValue",
    "maxValue",
];

fn read_message(el: &Element, diags: &mut Diagnostics) -> Option<Message> {
    check_attrs(el, &["id", "name"], diags);
    let name = name_attr(el, diags);
    let id_attr = required(el, "id", diags);
    let id = id_attr.and_then(|a| {
        let v = parse_int(&a.value, &a.value_span, diags)?;
        if v > 0xFF_FFFF {
            diags.report(
                Code::IdOutOfRange,
                a.value_span.clone(),
                format!("message id {v} is out of range"),
                "more than 24 bits",
            );
            return None;
        }
        Some(v as u32)
    });
    let mut msg = Message {
        name: Name {
            rust: ident::type_name(name.as_deref().unwrap_or("")),
            wire: name.clone().unwrap_or_default(),
        },
        id: id.unwrap_or(0),
        description: String::new(),
        deprecated: None,
        wip: false,
        fields: Vec::new(),
        wire_order: Vec::new(),
        min_len: 0,
        max_len: 0,
        crc_extra: 0,
        target_system: None,
        target_component: None,
        span: Some(el.span.clone()),
        id_span: id_attr.map(|a| a.value_span.clone()),
    };
    let mut extension = false;
    for child in &el.children {
        match child.name.as_str() {
            "description" => msg.description = child.text.clone(),
            "deprecated" => msg.deprecated = Some(read_deprecation(child, false, diags)),
            "superseded" => msg.deprecated = Some(read_deprecation(child, true, diags)),
            "wip" => msg.wip = true,
            "extensions" => extension = true,
            "field" => msg.fields.extend(read_field(child, extension, diags)),
            _ => unknown_element(child, "<message>", diags),
        }
    }
    // A message with a bad field type keeps that field (see `read_field`) and is checked like any
    // other, so that its other problems (duplicate fields, missing enums, a duplicate id) are
    // reported in the same run; errors were reported, so no code is generated from it.
    (name.is_some() && id.is_some()).then_some(msg)
}

fn read_field(el: &Element, extension: bool, diags: &mut Diagnostics) -> Option<Field> {
    check_attrs(el, FIELD_ATTRS, diags);
    let name = name_attr(el, diags);
    let ty = required(el, "type", diags).and_then(|a| parse_type(a, diags));
    // A field whose type is missing or bad was reported; it stays, as one byte, so that the
    // checks on its name and enum still run.
    let ty = ty.unwrap_or(FieldType {
        primitive: Primitive::U8,
        array: None,
        mavlink_version: false,
    });
    let name = name?;
    let enum_attr = el.attr("enum").filter(|a| !a.value.is_empty());
    Some(Field {
        name: Name {
            rust: ident::value_name(&name),
            wire: name,
        },
        ty,
        extension,
        offset: 0,
        enum_name: enum_attr.map(|a| a.value.clone()),
        description: el.text.clone(),
        attrs: el
            .attrs
            .iter()
            .filter(|a| !matches!(a.name.as_str(), "type" | "name" | "enum"))
            .map(|a| (a.name.clone(), a.value.clone()))
            .collect(),
        span: Some(el.span.clone()),
        enum_span: enum_attr.map(|a| a.value_span.clone()),
    })
}

/// `uint16_t`, `float[4]`, `char[16]`, `uint8_t_mavlink_version`, legacy `uint8` and `array[N]`.
fn parse_type(attr: &Attr, diags: &mut Diagnostics) -> Option<FieldType> {
    super::parse_type(&attr.value, &attr.value_span, TypeSyntax::Mavlink, diags)
}
