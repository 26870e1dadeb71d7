//! A static documentation site for a run's dictionaries: one page per MAVLink file, ModRob-1
//! module dictionary, robot and TosNet ring, an index with an offline search, and the IR as
//! `dictionary.json`.
//!
//! Pages are rendered from `tools/templates/docs/` with the IR, the page list, the checkers'
//! models (each robot network's load, each ring's cycle rate) and two helpers: `url_of(NAME)`
//! (where a message, enum or entry is documented) and the `linkify` filter (HTML-escaped text
//! whose upper-case names that `url_of` knows become links).

use std::collections::HashMap;
use std::sync::Arc;

use minijinja::{context, Value};
use serde::Serialize;

use crate::check::modrob::{capacity, network_loads};
use crate::ir::Ir;
use crate::write::GeneratedFile;

/// Files of the site that are not templates, copied as they are.
const STATIC: &[(&str, &str)] = super::jinja::compiled_in!["docs/style.css", "docs/search.js"];

#[derive(Debug, Clone, Serialize)]
struct Page {
    kind: &'static str,
    index: usize,
    file: String,
    title: String,
}

/// Every file of the site for `ir`, by path relative to the site's folder.
pub fn generate(ir: &Ir) -> Result<Vec<GeneratedFile>, minijinja::Error> {
    let mut env = super::jinja::environment();
    let urls = Arc::new(urls(ir));
    let lookup = urls.clone();
    env.add_function("url_of", move |name: &str| lookup.get(name).cloned());
    env.add_filter("linkify", move |text: &str| {
        Value::from_safe_string(linkify(text, &urls))
    });

    let mut pages = vec![Page {
        kind: "index",
        index: 0,
        file: "index.html".into(),
        title: "Index".into(),
    }];
    let mut add = |kind, names: Vec<&str>| {
        for (index, name) in names.into_iter().enumerate() {
            pages.push(Page {
                kind,
                index,
                file: format!("{kind}-{name}.html"),
                title: name.to_owned(),
            });
        }
    };
    add(
        "mavlink",
        ir.modules.iter().map(|m| m.name.wire.as_str()).collect(),
    );
    add(
        "modrob",
        ir.modrob.iter().map(|m| m.name.wire.as_str()).collect(),
    );
    add(
        "robot",
        ir.robots.iter().map(|r| r.name.wire.as_str()).collect(),
    );
    add(
        "tosnet",
        ir.rings.iter().map(|r| r.name.wire.as_str()).collect(),
    );

    let models = context! {
        robots => ir.robots.iter().map(|robot| {
            let loads = network_loads(robot, &ir.modrob);
            let networks: Vec<Value> = robot.networks.iter().zip(loads)
                .map(|(net, load)| context! { load => load, capacity => capacity(net) })
                .collect();
            context! { networks => networks }
        }).collect::<Vec<_>>(),
        rings => ir.rings.iter().map(|ring| {
            use ferrolink_runtime::tosnet::{model_rate, PAPER_BITRATE, PAPER_NODE_DELAY_NS};
            context! {
                cycle_hz => model_rate(ring.nodes.len(), ring.enabled_registers(), PAPER_BITRATE, PAPER_NODE_DELAY_NS),
                bitrate => PAPER_BITRATE as u64,
                node_delay_us => PAPER_NODE_DELAY_NS / 1e3,
            }
        }).collect::<Vec<_>>(),
    };
    let ir_value = super::jinja::ir_value(ir);
    let version = env!("CARGO_PKG_VERSION");
    let mut files = Vec::new();
    for page in &pages {
        let ctx = context! { ir => ir_value, version, page, pages, models };
        let content = env
            .get_template(&format!("docs/{}.html.j2", page.kind))?
            .render(ctx)?;
        files.push(GeneratedFile {
            name: page.file.clone(),
            content,
        });
    }
    let ctx = context! { ir => ir_value, version, page => &pages[0], pages, models };
    let content = env.get_template("docs/search-index.js.j2")?.render(ctx)?;
    files.push(GeneratedFile {
        name: "search-index.js".into(),
        content,
    });
    for (path, content) in STATIC {
        let name = path.trim_start_matches("docs/");
        files.push(GeneratedFile {
            name: name.into(),
            content: (*content).into(),
        });
    }
    let json = serde_json::to_string_pretty(ir).map_err(|e| {
        minijinja::Error::new(
            minijinja::ErrorKind::InvalidOperation,
            "the IR does not serialise",
        )
        .with_source(e)
    })?;
    files.push(GeneratedFile {
        name: "dictionary.json".into(),
        content: json + "\n",
    });
    Ok(files)
}

/// Where each MAVLink message, enum and enum entry is documented, by wire name.
fn urls(ir: &Ir) -> HashMap<String, String> {
    let mut urls = HashMap::new();
    for module in &ir.modules {
        let page = format!("mavlink-{}.html", module.name.wire);
        for m in &module.messages {
            urls.entry(m.name.wire.clone())
                .or_insert_with(|| format!("{page}#msg-{}", m.name.wire));
        }
    }
    for e in &ir.enums {
        let page = format!("mavlink-{}.html", ir.modules[e.module].name.wire);
        urls.entry(e.name.wire.clone())
            .or_insert_with(|| format!("{page}#enum-{}", e.name.wire));
        for entry in &e.entries {
            urls.entry(entry.name.wire.clone())
                .or_insert_with(|| format!("{page}#{}", entry.name.wire));
        }
    }
    urls
}

/// `text` HTML-escaped, with every upper-case name of three or more characters (`[A-Z][A-Z0-9_]+`,
/// whole words) that `urls` knows turned into a link.
fn linkify(text: &str, urls: &HashMap<String, String>) -> String {
    let is_word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find(is_word) {
        escape_into(&mut out, &rest[..start]);
        let word_len = rest[start..]
            .find(|c: char| !is_word(c))
            .unwrap_or(rest.len() - start);
        let word = &rest[start..start + word_len];
        let name_like = word.len() >= 3
            && word.starts_with(|c: char| c.is_ascii_uppercase())
            && word
                .chars()
                .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_');
        match urls.get(word).filter(|_| name_like) {
            Some(url) => {
                out.push_str("<a href=\"");
                escape_into(&mut out, url);
                out.push_str("\">");
                out.push_str(word);
                out.push_str("</a>");
            }
            None => out.push_str(word),
        }
        rest = &rest[start + word_len..];
    }
    escape_into(&mut out, rest);
    out
}

fn escape_into(out: &mut String, text: &str) {
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linkify_escapes_and_links_known_names_only() {
        let urls = HashMap::from([(
            "HEARTBEAT".to_owned(),
            "mavlink-common.html#msg-HEARTBEAT".to_owned(),
        )]);
        assert_eq!(
            linkify("See HEARTBEAT <1s> & NOT_KNOWN, HEARTBEATS", &urls),
            "See <a href=\"mavlink-common.html#msg-HEARTBEAT\">HEARTBEAT</a> &lt;1s&gt; &amp; NOT_KNOWN, HEARTBEATS"
        );
    }
}
