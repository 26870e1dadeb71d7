//! A small XML element tree with byte spans, read with `quick-xml`.
//!
//! Dialect readers walk this tree instead of the event stream, so that unknown elements and
//! attributes can be reported generically and every node keeps its position.

use std::sync::Arc;

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::diag::{Code, Diagnostics, SourceFile, Span};

/// An attribute with the spans of its name and value.
#[derive(Debug, Clone)]
pub struct Attr {
    /// Attribute name.
    pub name: String,
    /// Unescaped value.
    pub value: String,
    /// Where the attribute starts (its name) and ends (its closing quote).
    pub span: Span,
    /// The value, without quotes.
    pub value_span: Span,
}

/// An element.
#[derive(Debug, Clone)]
pub struct Element {
    /// Tag name.
    pub name: String,
    /// The start tag.
    pub span: Span,
    /// Attributes in source order.
    pub attrs: Vec<Attr>,
    /// Child elements.
    pub children: Vec<Element>,
    /// Unescaped text content directly inside this element, whitespace-trimmed.
    pub text: String,
}

impl Element {
    /// The attribute `name`, if present.
    pub fn attr(&self, name: &str) -> Option<&Attr> {
        self.attrs.iter().find(|a| a.name == name)
    }

    /// Children named `name`.
    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Element> + 'a {
        self.children.iter().filter(move |c| c.name == name)
    }

    /// The first child named `name`.
    pub fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }
}

/// Parses `file` into its root element. A syntax error is reported and yields `None`: a
/// half-read tree is never returned.
pub fn parse(file: &Arc<SourceFile>, diags: &mut Diagnostics) -> Option<Element> {
    let mut reader = Reader::from_str(&file.text);
    reader.config_mut().check_end_names = true;
    let mut stack: Vec<(Element, String)> = Vec::new();
    let mut root = None;
    loop {
        let before = reader.buffer_position() as usize;
        let event = match reader.read_event() {
            Ok(e) => e,
            Err(e) => {
                let at = (reader.error_position() as usize).min(file.text.len());
                let what = e.to_string();
                diags.report(
                    Code::Syntax,
                    Span::new(file, at, at + 1),
                    format!("malformed XML: {what}"),
                    "here",
                );
                return None;
            }
        };
        let after = reader.buffer_position() as usize;
        let tag_start = file.text[before..after]
            .find('<')
            .map_or(before, |i| before + i);
        match event {
            Event::Start(tag) => {
                stack.push((element(file, &tag, tag_start, after, diags), String::new()));
            }
            Event::Empty(tag) => {
                let el = element(file, &tag, tag_start, after, diags);
                match stack.last_mut() {
                    Some((parent, _)) => parent.children.push(el),
                    None => root = root.or(Some(el)),
                }
            }
            Event::End(_) => {
                let Some((mut el, text)) = stack.pop() else {
                    continue;
                };
                el.text = match quick_xml::escape::unescape(&text) {
                    Ok(t) => normalise_space(&t),
                    Err(_) => normalise_space(&text),
                };
                match stack.last_mut() {
                    Some((parent, _)) => parent.children.push(el),
                    None => root = root.or(Some(el)),
                }
            }
            Event::Text(t) => {
                if let Some((_, text)) = stack.last_mut() {
                    text.push_str(&String::from_utf8_lossy(&t));
                }
            }
            Event::GeneralRef(r) => {
                if let Some((_, text)) = stack.last_mut() {
                    text.push('&');
                    text.push_str(&String::from_utf8_lossy(&r));
                    text.push(';');
                }
            }
            Event::CData(t) => {
                if let Some((_, text)) = stack.last_mut() {
                    text.push_str(&quick_xml::escape::escape(String::from_utf8_lossy(&t)));
                }
            }
            Event::Eof => break,
            Event::Comment(_) | Event::Decl(_) | Event::PI(_) | Event::DocType(_) => {}
        }
    }
    if let Some((el, _)) = stack.last() {
        diags.report(
            Code::Syntax,
            el.span.clone(),
            format!("malformed XML: element <{}> is never closed", el.name),
            "opened here",
        );
        return None;
    }
    if root.is_none() {
        let end = file.text.len();
        diags.report(
            Code::Syntax,
            Span::new(file, end, end),
            "malformed XML: the file has no root element",
            "expected <mavlink>",
        );
    }
    root
}

fn element(
    file: &Arc<SourceFile>,
    tag: &BytesStart<'_>,
    start: usize,
    end: usize,
    diags: &mut Diagnostics,
) -> Element {
    let name = String::from_utf8_lossy(tag.name().as_ref()).into_owned();
    let span = Span::new(file, start, end);
    let mut attrs = Vec::new();
    // Attribute values are located in the raw tag text so that each gets its own span.
    let raw_tag = &file.text[start..end];
    let mut search_from = 0;
    for attr in tag.attributes() {
        let attr = match attr {
            Ok(a) => a,
            Err(e) => {
                diags.report(
                    Code::Syntax,
                    span.clone(),
                    format!("malformed XML attribute: {e}"),
                    "in this tag",
                );
                continue;
            }
        };
        let key = String::from_utf8_lossy(attr.key.as_ref()).into_owned();
        let value = match attr.unescape_value() {
            Ok(v) => v.into_owned(),
            Err(_) => String::from_utf8_lossy(&attr.value).into_owned(),
        };
        let (a_start, v_start, v_end) = locate_attr(raw_tag, &key, search_from)
            .map(|(a, v, e)| (start + a, start + v, start + e))
            .unwrap_or((start, start, end));
        search_from = v_end.saturating_sub(start);
        attrs.push(Attr {
            name: key,
            value,
            span: Span::new(file, a_start, (v_end + 1).min(file.text.len())),
            value_span: Span::new(file, v_start, v_end),
        });
    }
    Element {
        name,
        span,
        attrs,
        children: Vec::new(),
        text: String::new(),
    }
}

/// Finds `key = "value"` in a raw tag from `from` on; returns (key start, value start, value end).
fn locate_attr(raw: &str, key: &str, from: usize) -> Option<(usize, usize, usize)> {
    let mut at = from;
    while let Some(i) = raw.get(at..)?.find(key) {
        let k = at + i;
        let before_ok = raw[..k].ends_with(|c: char| c.is_whitespace());
        let rest = raw[k + key.len()..].trim_start();
        if before_ok && rest.starts_with('=') {
            let after_eq = rest[1..].trim_start();
            let quote = after_eq.chars().next()?;
            if quote == '"' || quote == '\'' {
                let v_start = raw.len() - after_eq.len() + 1;
                let v_len = raw[v_start..].find(quote)?;
                return Some((k, v_start, v_start + v_len));
            }
        }
        at = k + key.len();
    }
    None
}

/// Collapses runs of whitespace, as descriptions are wrapped freely in the XML.
fn normalise_space(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(text: &str) -> (Option<Element>, Diagnostics) {
        let file = SourceFile::new("t.xml", text.to_string());
        let mut d = Diagnostics::default();
        (parse(&file, &mut d), d)
    }

    #[test]
    fn spans_point_at_attribute_values() {
        let text = "<a>\n  <b x=\"1\" name = 'two'>t &amp; u</b>\n</a>";
        let (root, d) = parse_str(text);
        assert!(d.items().is_empty());
        let b = &root.unwrap().children[0];
        assert_eq!(b.text, "t & u");
        let name = b.attr("name").unwrap();
        assert_eq!(name.value, "two");
        assert_eq!(&text[name.value_span.start..name.value_span.end], "two");
        assert_eq!(name.value_span.location(), "t.xml:2:20");
    }

    #[test]
    fn malformed_xml_is_one_error_and_no_tree() {
        let (root, d) = parse_str("<a>\n<b></c>\n</a>");
        assert!(root.is_none());
        assert_eq!(d.items().len(), 1);
        assert_eq!(d.items()[0].code, Code::Syntax);
        assert!(d.items()[0].span.location().starts_with("t.xml:2:"));
    }

    #[test]
    fn unclosed_element() {
        let (root, d) = parse_str("<a><b>");
        assert!(root.is_none());
        assert!(d.has_errors());
    }
}
