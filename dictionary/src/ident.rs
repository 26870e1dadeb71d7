//! Name handling, in one place: dictionary names to Rust identifiers.
//!
//! Keywords become raw identifiers (`type` -> `r#type`); the few that cannot be raw (`self`,
//! `Self`, `super`, `crate`) get a trailing underscore; a leading digit gets a prefix; an enum's
//! own name is stripped from its entries.

use heck::{ToShoutySnakeCase, ToSnakeCase, ToUpperCamelCase};

const KEYWORDS: &[&str] = &[
    "as", "break", "const", "continue", "else", "enum", "extern", "false", "fn", "for", "if",
    "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return", "static",
    "struct", "trait", "true", "type", "unsafe", "use", "where", "while", "async", "await", "dyn",
    "abstract", "become", "box", "do", "final", "macro", "override", "priv", "typeof", "unsized",
    "virtual", "yield", "try", "gen",
];
const NOT_RAW: &[&str] = &["self", "Self", "super", "crate", "_"];

/// Makes `name` a valid identifier: raw for keywords, `_` suffix where raw is not allowed,
/// `prefix` before a leading digit.
fn escape(name: String, prefix: &str) -> String {
    if NOT_RAW.contains(&name.as_str()) {
        format!("{name}_")
    } else if KEYWORDS.contains(&name.as_str()) {
        format!("r#{name}")
    } else if name.starts_with(|c: char| c.is_ascii_digit()) || name.is_empty() {
        format!("{prefix}{name}")
    } else {
        name
    }
}

/// Upper camel case that keeps an underscore between two digit groups, so that `CR_7_5_M` and
/// `CR_75_M` stay apart (`Cr7_5M`, `Cr75M`).
fn camel(wire: &str) -> String {
    if wire.chars().any(|c| c.is_lowercase()) {
        return wire.to_upper_camel_case();
    }
    let mut out = String::new();
    for word in wire.split('_').filter(|w| !w.is_empty()) {
        if out.ends_with(|c: char| c.is_ascii_digit())
            && word.starts_with(|c: char| c.is_ascii_digit())
        {
            out.push('_');
        }
        out.push_str(&word.to_upper_camel_case());
    }
    out
}

/// A type name: `HEARTBEAT` -> `Heartbeat`, `MAV_TYPE` -> `MavType`.
pub fn type_name(wire: &str) -> String {
    escape(camel(wire), "T")
}

/// A field or module name: `type` -> `r#type`, `targetSystem` -> `target_system`.
pub fn value_name(wire: &str) -> String {
    escape(wire.to_snake_case(), "f_")
}

/// A constant name: `motor1` -> `MOTOR1`, `gripperState` -> `GRIPPER_STATE`.
pub fn const_name(wire: &str) -> String {
    escape(wire.to_shouty_snake_case(), "C_")
}

/// The accessor and the setter of one area of a TosNet register: `motor1`, `out` ->
/// (`motor1_out`, `set_motor1_out`).
pub fn register_fns(register_wire: &str, area: &str) -> (String, String) {
    (
        value_name(&format!("{register_wire}_{area}")),
        value_name(&format!("set_{register_wire}_{area}")),
    )
}

/// Whether a dictionary name is usable at all: ASCII letters, digits and `_`, not starting with a
/// digit.
pub fn is_identifier(name: &str) -> bool {
    name.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// The part of an entry name after its enum's prefix (`MAV_TYPE_GENERIC` -> `GENERIC`), or the
/// whole name. A rest that starts with a digit keeps the prefix's last word
/// (`GPS_FIX_TYPE_2D_FIX` -> `TYPE_2D_FIX`).
fn strip_enum_prefix<'a>(enum_wire: &str, entry_wire: &'a str) -> std::borrow::Cow<'a, str> {
    let Some(rest) = entry_wire
        .strip_prefix(enum_wire)
        .and_then(|r| r.strip_prefix('_'))
        .filter(|r| !r.is_empty())
    else {
        return entry_wire.into();
    };
    if rest.starts_with(|c: char| c.is_ascii_digit()) {
        let last = enum_wire.rsplit('_').next().unwrap_or(enum_wire);
        format!("{last}_{rest}").into()
    } else {
        rest.into()
    }
}

/// The catch-all variant every generated enum has for values it does not name.
pub const UNKNOWN_VARIANT: &str = "Unknown";

/// An enum variant: `MAV_TYPE_GENERIC` in `MAV_TYPE` -> `Generic`. An entry that would be
/// called `Unknown` becomes `Unknown_`, as `Unknown(raw)` is the catch-all.
pub fn variant_name(enum_wire: &str, entry_wire: &str) -> String {
    let name = escape(camel(&strip_enum_prefix(enum_wire, entry_wire)), "V");
    if name == UNKNOWN_VARIANT {
        format!("{name}_")
    } else {
        name
    }
}

/// A flag constant: `MAV_MODE_FLAG_SAFETY_ARMED` in `MAV_MODE_FLAG` -> `SAFETY_ARMED`.
pub fn flag_name(enum_wire: &str, entry_wire: &str) -> String {
    escape(
        strip_enum_prefix(enum_wire, entry_wire).to_shouty_snake_case(),
        "F_",
    )
}

/// A dictionary file's module name: its file stem, and that as a Rust value name.
pub fn file_module_name(path: &std::path::Path) -> crate::ir::Name {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    crate::ir::Name {
        rust: value_name(&stem),
        wire: stem,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert_eq!(type_name("HEARTBEAT"), "Heartbeat");
        assert_eq!(type_name("GPS_RAW_INT"), "GpsRawInt");
        assert_eq!(type_name("MAV_TYPE"), "MavType");
        assert_eq!(value_name("type"), "r#type");
        assert_eq!(value_name("self"), "self_");
        assert_eq!(value_name("targetSystem"), "target_system");
        assert_eq!(value_name("ASLUAV"), "asluav");
        assert_eq!(variant_name("MAV_TYPE", "MAV_TYPE_GENERIC"), "Generic");
        assert_eq!(
            variant_name("GPS_FIX_TYPE", "GPS_FIX_TYPE_2D_FIX"),
            "Type2dFix"
        );
        assert_eq!(variant_name("MAV_CMD", "OTHER_NAME"), "OtherName");
        assert_eq!(variant_name("X", "X_SELF"), "Self_");
        assert_eq!(
            flag_name("MAV_MODE_FLAG", "MAV_MODE_FLAG_SAFETY_ARMED"),
            "SAFETY_ARMED"
        );
        assert_eq!(flag_name("A", "A_1"), "A_1");
        assert_eq!(variant_name("X", "X_CR_7_5_M"), "Cr7_5M");
        assert_eq!(variant_name("X", "X_CR_75_M"), "Cr75M");
        assert_eq!(
            variant_name("FENCE_MITIGATE", "FENCE_MITIGATE_UNKNOWN"),
            "Unknown_"
        );
        assert_eq!(const_name("motor1"), "MOTOR1");
        assert_eq!(const_name("gripperState"), "GRIPPER_STATE");
        assert_eq!(
            register_fns("gripperState", "in"),
            ("gripper_state_in".into(), "set_gripper_state_in".into())
        );
        assert!(is_identifier("_a1") && is_identifier("motor_1"));
        assert!(!is_identifier("1a") && !is_identifier("a-b") && !is_identifier(""));
    }
}
