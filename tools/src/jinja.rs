//! The template environment for outputs that are not Rust (documentation sites, Wireshark
//! dissectors): minijinja with strict undefined behaviour, the templates of
//! `templates/` compiled in, and the filters they share.

use minijinja::{Environment, UndefinedBehavior, Value};

/// `(name, text)` pairs for files under `templates/`, compiled in.
macro_rules! compiled_in {
    ($($name:literal),* $(,)?) => {
        &[$(($name, include_str!(concat!("../templates/", $name)))),*]
    };
}
pub(super) use compiled_in;

/// Every template, by the name templates include it by.
const TEMPLATES: &[(&str, &str)] = compiled_in![
    "wireshark/dissectors.lua.j2",
    "wireshark/common.lua.j2",
    "wireshark/mavlink.lua.j2",
    "wireshark/ndlcom.lua.j2",
    "wireshark/modrob.lua.j2",
    "wireshark/tosnet.lua.j2",
    "docs/base.html.j2",
    "docs/macros.html.j2",
    "docs/index.html.j2",
    "docs/mavlink.html.j2",
    "docs/modrob.html.j2",
    "docs/robot.html.j2",
    "docs/tosnet.html.j2",
    "docs/search-index.js.j2",
];

/// An environment holding every template, with strict undefined behaviour and `lua_str`.
pub(crate) fn environment() -> Environment<'static> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    for (name, source) in TEMPLATES {
        env.add_template(name, source)
            .unwrap_or_else(|e| panic!("template {name} does not parse: {e:#}"));
    }
    env.add_filter("lua_str", lua_str);
    env
}

/// The IR as templates see it: its JSON form, exactly what `ferrolink ir` prints and the docs
/// site exports (so an unbounded ModRob-1 limit is `none`, as JSON has no infinity).
pub(crate) fn ir_value(ir: &crate::ir::Ir) -> Value {
    Value::from_serialize(serde_json::to_value(ir).expect("the IR serialises to JSON"))
}

/// A Lua string literal for any text: `\` and `"` escaped, every byte outside printable ASCII
/// as a decimal `\ddd` escape (which Lua 5.1 to 5.4 all read the same way).
pub(crate) fn lua_str(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for &b in text.as_bytes() {
        match b {
            b'\\' => out.push_str("\\\\"),
            b'"' => out.push_str("\\\""),
            0x20..=0x7e => out.push(char::from(b)),
            _ => out.push_str(&format!("\\{b:03}")),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lua_strings_escape_quotes_controls_and_non_ascii() {
        assert_eq!(lua_str("a \"b\" \\ c"), r#""a \"b\" \\ c""#);
        assert_eq!(lua_str("line\nnext"), r#""line\010next""#);
        assert_eq!(lua_str("µs"), r#""\194\181s""#);
    }

    #[test]
    fn every_template_parses() {
        let env = environment();
        assert!(env.templates().count() >= TEMPLATES.len());
    }
}
