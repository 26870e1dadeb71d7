//! Reading TOML dictionaries by hand, with a span for every key and value.
//!
//! `toml`'s recoverable parser turns the text into spanned tables ([`DeTable`]); readers walk
//! them through [`Table`] and [`Item`]. A value of the wrong type, a missing key or an unknown key
//! is reported at its position and reading goes on, so that one run reports every problem where
//! serde would stop at the first. Nothing here knows a particular format.

use std::sync::Arc;

use ::toml::de::{DeTable, DeValue};
use ::toml::Spanned;

use crate::diag::{Code, Diagnostics, SourceFile, Span};

/// A parsed document: its top-level table.
pub type Document<'i> = Spanned<DeTable<'i>>;

/// Parses `file`. Syntax errors are reported (E0002), the first of each line (the parser's later
/// errors on a line follow from its first), and then `None` is returned: a document the parser
/// had to repair is never read, as its problems would mislead.
pub fn parse<'f>(file: &'f Arc<SourceFile>, diags: &mut Diagnostics) -> Option<Document<'f>> {
    let (doc, errors) = DeTable::parse_recoverable(&file.text);
    if errors.is_empty() {
        return Some(doc);
    }
    let mut lines = std::collections::HashSet::new();
    for e in errors {
        let range = e.span().unwrap_or(0..0);
        if !lines.insert(file.line_col(range.start).0) {
            continue;
        }
        let message = e.message().split_whitespace().collect::<Vec<_>>().join(" ");
        diags.report(
            Code::Syntax,
            Span::new(file, range.start, range.end),
            format!("malformed TOML: {message}"),
            "here",
        );
    }
    None
}

/// `a`/`an` and TOML's name of a value's type, for messages.
fn a_type(value: &DeValue<'_>) -> String {
    let t = value.type_str();
    let article = if t.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    format!("{article} {t}")
}

/// A table being read.
#[derive(Debug, Clone)]
pub struct Table<'a, 'i> {
    file: &'a Arc<SourceFile>,
    table: &'a DeTable<'i>,
    /// The table's header (`[ring]`, `[[nodes]]`), its braces if inline, or the start of the
    /// file for the top level.
    pub span: Span,
    /// What the table is, for messages: "`[ring]`", "node `section1`".
    pub what: String,
}

impl<'a, 'i> Table<'a, 'i> {
    /// The top-level table of a document.
    pub fn root(file: &'a Arc<SourceFile>, doc: &'a Document<'i>) -> Self {
        Self {
            file,
            table: doc.get_ref(),
            span: Span::new(file, 0, 0),
            what: "the top level".into(),
        }
    }

    /// The same table under another description.
    pub fn described(mut self, what: impl Into<String>) -> Self {
        self.what = what.into();
        self
    }

    fn item(
        &self,
        key: &'a Spanned<::toml::de::DeString<'i>>,
        value: &'a Spanned<DeValue<'i>>,
    ) -> Item<'a, 'i> {
        let (k, v) = (key.span(), value.span());
        Item {
            file: self.file,
            key: key.get_ref(),
            key_span: Span::new(self.file, k.start, k.end),
            value: value.get_ref(),
            span: Span::new(self.file, v.start, v.end),
            what: format!("`{}` in {}", key.get_ref(), self.what),
        }
    }

    /// The value of `key`, if present.
    pub fn get(&self, key: &str) -> Option<Item<'a, 'i>> {
        self.table
            .iter()
            .find(|(k, _)| k.get_ref() == key)
            .map(|(k, v)| self.item(k, v))
    }

    /// Every key and value, in source order.
    pub fn entries(&self) -> Vec<Item<'a, 'i>> {
        let mut items: Vec<Item<'a, 'i>> =
            self.table.iter().map(|(k, v)| self.item(k, v)).collect();
        items.sort_by_key(|item| item.key_span.start);
        items
    }

    /// The value of `key`; reports E0103 if it is missing.
    pub fn required(&self, key: &str, diags: &mut Diagnostics) -> Option<Item<'a, 'i>> {
        let item = self.get(key);
        if item.is_none() {
            diags.report(
                Code::Missing,
                self.span.clone(),
                format!("{} has no `{key}`", self.what),
                format!("`{key}` is required"),
            );
        }
        item
    }

    /// A string under `key`, if present; reports a value of another type.
    pub fn optional_str(&self, key: &str, diags: &mut Diagnostics) -> Option<&'a str> {
        self.get(key).and_then(|item| item.as_str(diags))
    }

    /// Reports every key that is not one of `known` (W0103).
    pub fn check_keys(&self, known: &[&str], diags: &mut Diagnostics) {
        for item in self.entries() {
            if !known.contains(&item.key) {
                diags.report(
                    Code::UnknownKey,
                    item.key_span.clone(),
                    format!("unknown key `{}` in {}", item.key, self.what),
                    "ignored",
                );
            }
        }
    }
}

/// A value with its key, both spanned.
#[derive(Debug, Clone)]
pub struct Item<'a, 'i> {
    file: &'a Arc<SourceFile>,
    /// The key (for an array element, its array's key).
    pub key: &'a str,
    /// Where the key is written.
    pub key_span: Span,
    /// The value.
    pub value: &'a DeValue<'i>,
    /// Where the value is written.
    pub span: Span,
    /// What the value is, for messages: "`id` in node `section1`".
    pub what: String,
}

impl<'a, 'i> Item<'a, 'i> {
    /// Reports a value of the wrong type (E0104); `expected` is e.g. "an integer".
    pub fn wrong_type(&self, expected: &str, diags: &mut Diagnostics) {
        diags.report(
            Code::BadNumber,
            self.span.clone(),
            format!(
                "{} must be {expected}, not {}",
                self.what,
                a_type(self.value)
            ),
            format!("expected {expected}"),
        );
    }

    /// The string, or `None` after reporting a value of another type.
    pub fn as_str(&self, diags: &mut Diagnostics) -> Option<&'a str> {
        match self.value {
            DeValue::String(s) => Some(s.as_ref()),
            _ => {
                self.wrong_type("a string", diags);
                None
            }
        }
    }

    /// The span of a string's text, without its quotes (the whole value otherwise).
    pub fn text_span(&self) -> Span {
        let raw = self
            .file
            .text
            .get(self.span.start..self.span.end)
            .unwrap_or("");
        let quotes = ["\"\"\"", "'''", "\"", "'"]
            .into_iter()
            .find(|q| raw.len() >= 2 * q.len() && raw.starts_with(q) && raw.ends_with(q))
            .map_or(0, str::len);
        Span::new(self.file, self.span.start + quotes, self.span.end - quotes)
    }

    /// A string that is a valid name (E0108 otherwise).
    pub fn as_name(&self, diags: &mut Diagnostics) -> Option<&'a str> {
        let name = self.as_str(diags)?;
        super::check_name(name, &self.text_span(), diags).then_some(name)
    }

    /// A non-negative integer of at most `max`; anything else is reported (E0104).
    pub fn as_uint(&self, max: u64, diags: &mut Diagnostics) -> Option<u64> {
        let DeValue::Integer(i) = self.value else {
            self.wrong_type("an integer", diags);
            return None;
        };
        let value = i64::from_str_radix(i.as_str(), i.radix()).ok();
        match value
            .and_then(|v| u64::try_from(v).ok())
            .filter(|&v| v <= max)
        {
            Some(v) => Some(v),
            None => {
                let shown = value.map_or_else(|| i.to_string(), |v| v.to_string());
                diags.report(
                    Code::BadNumber,
                    self.span.clone(),
                    format!("{} is {shown}, out of range", self.what),
                    format!("expected 0..={max}"),
                );
                None
            }
        }
    }

    /// A number, integer or float (`inf` and `nan` included); anything else is reported
    /// (E0104).
    pub fn as_float(&self, diags: &mut Diagnostics) -> Option<f64> {
        let parsed = match self.value {
            DeValue::Float(f) => f.as_str().replace('_', "").parse::<f64>().ok(),
            DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix())
                .ok()
                .map(|v| v as f64),
            _ => None,
        };
        if parsed.is_none() {
            self.wrong_type("a number", diags);
        }
        parsed
    }

    /// A boolean; anything else is reported (E0104).
    pub fn as_bool(&self, diags: &mut Diagnostics) -> Option<bool> {
        match self.value {
            DeValue::Boolean(b) => Some(*b),
            _ => {
                self.wrong_type("a boolean", diags);
                None
            }
        }
    }

    /// The table, described as `what` in later messages; reports a value of another type.
    pub fn as_table(
        &self,
        what: impl Into<String>,
        diags: &mut Diagnostics,
    ) -> Option<Table<'a, 'i>> {
        match self.value {
            DeValue::Table(table) => Some(Table {
                file: self.file,
                table,
                span: self.span.clone(),
                what: what.into(),
            }),
            _ => {
                self.wrong_type("a table", diags);
                None
            }
        }
    }

    /// The elements of an array; reports a value of another type.
    pub fn as_array(&self, diags: &mut Diagnostics) -> Option<Vec<Item<'a, 'i>>> {
        let DeValue::Array(array) = self.value else {
            self.wrong_type("an array", diags);
            return None;
        };
        Some(
            array
                .iter()
                .enumerate()
                .map(|(n, v)| {
                    let r = v.span();
                    Item {
                        file: self.file,
                        key: self.key,
                        key_span: self.key_span.clone(),
                        value: v.get_ref(),
                        span: Span::new(self.file, r.start, r.end),
                        what: format!("element {} of {}", n + 1, self.what),
                    }
                })
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with_doc(text: &str, f: impl FnOnce(&Table<'_, '_>, &mut Diagnostics)) -> Diagnostics {
        let file = SourceFile::new("t.toml", text.to_string());
        let mut diags = Diagnostics::default();
        let doc = parse(&file, &mut diags).expect("parses");
        f(&Table::root(&file, &doc), &mut diags);
        diags
    }

    #[test]
    fn spans_point_at_keys_and_string_text() {
        let text = "[t]\nname = \"abc\"\nn = 0x10\n";
        let d = with_doc(text, |root, d| {
            let t = root.get("t").unwrap().as_table("`[t]`", d).unwrap();
            assert_eq!(t.span.location(), "t.toml:1:1");
            let name = t.get("name").unwrap();
            assert_eq!(name.key_span.location(), "t.toml:2:1");
            let inner = name.text_span();
            assert_eq!(&text[inner.start..inner.end], "abc");
            assert_eq!(t.get("n").unwrap().as_uint(255, d), Some(16));
        });
        assert!(d.items().is_empty());
    }

    #[test]
    fn every_problem_is_reported() {
        let text = "a = \"x\"\nb = -1\nc = [1, \"two\"]\nd = 1\n";
        let d = with_doc(text, |root, d| {
            assert_eq!(root.get("a").unwrap().as_uint(9, d), None);
            assert_eq!(root.get("b").unwrap().as_uint(9, d), None);
            let c = root.get("c").unwrap().as_array(d).unwrap();
            assert_eq!(c[1].as_uint(9, d), None);
            assert!(root.required("e", d).is_none());
            root.check_keys(&["a", "b", "c"], d);
        });
        let codes: Vec<&str> = d.items().iter().map(|x| x.code.as_str()).collect();
        assert_eq!(codes, ["E0104", "E0104", "E0104", "E0103", "W0103"]);
        assert!(
            d.items()[2].message.contains("element 2 of `c`"),
            "{}",
            d.items()[2].message
        );
    }

    #[test]
    fn syntax_errors_yield_no_document() {
        let file = SourceFile::new("t.toml", "a = \nb = [1,\n".to_string());
        let mut diags = Diagnostics::default();
        assert!(parse(&file, &mut diags).is_none());
        assert!(!diags.items().is_empty());
        assert!(diags.items().iter().all(|d| d.code == Code::Syntax));
    }
}
