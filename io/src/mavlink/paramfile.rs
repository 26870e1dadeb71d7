//! Parameter files: QGroundControl's `.params` and MAVProxy's `.parm`.
//!
//! - `.params`: tab (or space) separated `sysid compid name value type` lines, `type` a
//!   MAV_PARAM_TYPE number (1 to 10: the 64-bit types too, which PARAM_EXT_* carry whole);
//!   `#` starts a comment line.
//! - `.parm`: `name value` lines (space, tab or comma between), `#` comments; the type is
//!   REAL32 unless the caller knows better.
//!
//! Which one a file is goes by its extension: `.params` is QGroundControl's, anything else
//! MAVProxy's.

use std::fmt::Write as _;
use std::path::Path;

use ferrolink_runtime::mavlink::service::messages::MavParamType;
use ferrolink_runtime::mavlink::service::param::{Name, Param, Value};

/// A parameter file's problem, with its line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    /// The file.
    pub path: String,
    /// 1-based line, 0 for the file as a whole.
    pub line: usize,
    /// What is wrong, and what to do.
    pub message: String,
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.path, self.message)
        } else {
            write!(f, "{}:{}: {}", self.path, self.line, self.message)
        }
    }
}

impl std::error::Error for Error {}

/// The MAV_PARAM_TYPE for a name: UINT8, INT8, UINT16, INT16, UINT32, INT32, REAL32, UINT64,
/// INT64 or REAL64, with or without the `MAV_PARAM_TYPE_` prefix, any case.
pub fn param_type(name: &str) -> Option<MavParamType> {
    let upper = name.to_ascii_uppercase();
    let short = upper.strip_prefix("MAV_PARAM_TYPE_").unwrap_or(&upper);
    Some(match short {
        "UINT8" => MavParamType::Uint8,
        "INT8" => MavParamType::Int8,
        "UINT16" => MavParamType::Uint16,
        "INT16" => MavParamType::Int16,
        "UINT32" => MavParamType::Uint32,
        "INT32" => MavParamType::Int32,
        "REAL32" => MavParamType::Real32,
        "UINT64" => MavParamType::Uint64,
        "INT64" => MavParamType::Int64,
        "REAL64" => MavParamType::Real64,
        _ => return None,
    })
}

/// The short name of a type, as `param_type` takes it (`"INT32"`).
pub fn type_name(ty: MavParamType) -> &'static str {
    match ty {
        MavParamType::Uint8 => "UINT8",
        MavParamType::Int8 => "INT8",
        MavParamType::Uint16 => "UINT16",
        MavParamType::Int16 => "INT16",
        MavParamType::Uint32 => "UINT32",
        MavParamType::Int32 => "INT32",
        MavParamType::Real32 => "REAL32",
        MavParamType::Uint64 => "UINT64",
        MavParamType::Int64 => "INT64",
        MavParamType::Real64 => "REAL64",
        _ => "UNKNOWN",
    }
}

/// Parses a value written as text into type `ty`: exactly, or not at all. Integers may be
/// written as integral floats (`3.0`, `1e3`).
pub fn parse_value(ty: MavParamType, text: &str) -> Option<Value> {
    match ty {
        MavParamType::Real32 => text.parse::<f32>().ok().map(Value::F32),
        MavParamType::Real64 => text.parse::<f64>().ok().map(Value::F64),
        _ => match text.parse::<i128>() {
            // Integers exactly, whatever their size (an f64 holds 53 bits).
            Ok(n) => match i64::try_from(n) {
                Ok(i) => Value::I64(i).convert(ty),
                Err(_) => Value::U64(u64::try_from(n).ok()?).convert(ty),
            },
            Err(_) => Value::F64(text.parse().ok()?).convert(ty),
        },
    }
}

/// Reads a parameter file; every bad line is reported, not only the first.
pub fn read(path: &Path) -> Result<Vec<Param>, Vec<Error>> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| {
        vec![Error {
            path: shown.clone(),
            line: 0,
            message: format!("cannot read it: {e}"),
        }]
    })?;
    let qgc = path.extension().is_some_and(|e| e == "params");
    parse(&shown, &text, qgc)
}

/// Parses a file's text: QGroundControl's form if `qgc`, else MAVProxy's.
pub fn parse(path: &str, text: &str, qgc: bool) -> Result<Vec<Param>, Vec<Error>> {
    let mut params: Vec<Param> = Vec::new();
    let mut errors = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let error = |message: String| Error {
            path: path.to_string(),
            line: i + 1,
            message,
        };
        let fields: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || (!qgc && c == ','))
            .filter(|f| !f.is_empty())
            .collect();
        let parsed = if qgc {
            match fields[..] {
                [_sys, _comp, name, value, ty] => {
                    let ty = ty
                        .parse::<u8>()
                        .ok()
                        .map(MavParamType::from_raw)
                        .filter(|t| type_name(*t) != "UNKNOWN");
                    match ty {
                        None => Err(error(format!(
                            "type `{}` is not one of 1 to 10 (UINT8 to INT64, REAL32, REAL64)",
                            fields[4]
                        ))),
                        Some(ty) => parse_value(ty, value).map(|v| (name, v)).ok_or_else(|| {
                            error(format!(
                                "`{value}` is not a value of type {}",
                                type_name(ty)
                            ))
                        }),
                    }
                }
                _ => Err(error(
                    "expected five fields: sysid, compid, name, value, type".into(),
                )),
            }
        } else {
            match fields[..] {
                [name, value] => parse_value(MavParamType::Real32, value)
                    .map(|v| (name, v))
                    .ok_or_else(|| error(format!("`{value}` is not a number"))),
                _ => Err(error("expected a name and a value".into())),
            }
        };
        match parsed {
            Ok((name, _)) if name.len() > 16 => {
                errors.push(error(format!("`{name}` is longer than 16 bytes")));
            }
            Ok((name, value)) => {
                let name = Name::from(name);
                match params.iter_mut().find(|p| p.name == name) {
                    Some(p) => p.value = value,
                    None => params.push(Param { name, value }),
                }
            }
            Err(e) => errors.push(e),
        }
    }
    if errors.is_empty() {
        Ok(params)
    } else {
        Err(errors)
    }
}

/// A value as text: integers as integers, floats as the shortest text that reads back the same.
pub fn format_value(value: Value) -> String {
    value.to_string()
}

/// QGroundControl's `.params` text for `params` of system `sysid`, component `compid`.
pub fn write_qgc(params: &[Param], sysid: u8, compid: u8) -> String {
    let mut out = String::from("# Vehicle-Id Component-Id Name Value Type\n");
    for p in params {
        let _ = writeln!(
            out,
            "{sysid}\t{compid}\t{}\t{}\t{}",
            p.name,
            format_value(p.value),
            p.value.param_type().raw()
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qgc_params_files_keep_their_types() {
        let text = "# Onboard parameters for Vehicle 1\n#\n# Vehicle-Id Component-Id Name Value Type\n1\t1\tACC_MAX\t4.000000000000000000\t9\n1\t1\tCOM_ARM_WO_GPS\t1\t6\n1\t1\tSYS_AUTOSTART\t4001\t6\n1\t1\tMAV_TYPE\t2\t1\n";
        let params = parse("x.params", text, true).unwrap();
        assert_eq!(params.len(), 4);
        assert_eq!(params[0].value, Value::F32(4.0));
        assert_eq!(params[2].value, Value::I32(4001));
        assert_eq!(params[3].value, Value::U8(2));
        let again = parse("y.params", &write_qgc(&params, 1, 1), true).unwrap();
        assert_eq!(again, params);
    }

    #[test]
    fn mavproxy_parm_files_are_real32() {
        let params = parse(
            "x.parm",
            "# comment\nARMING_CHECK 1\nRC1_MIN,1100.5\n",
            false,
        )
        .unwrap();
        assert_eq!(params[0].value, Value::F32(1.0));
        assert_eq!(params[1].value, Value::F32(1100.5));
    }

    #[test]
    fn every_bad_line_is_reported() {
        let errors = parse(
            "x.params",
            "1\t1\tA\t1.5\t6\n1\t1\tB\t1\t11\nshort line\n1\t1\tOK\t1\t6\n1\t1\tC\t-1\t7\n",
            true,
        )
        .unwrap_err();
        let shown: Vec<String> = errors.iter().map(ToString::to_string).collect();
        insta::assert_snapshot!(shown.join("\n"), @r"
        x.params:1: `1.5` is not a value of type INT32
        x.params:2: type `11` is not one of 1 to 10 (UINT8 to INT64, REAL32, REAL64)
        x.params:3: expected five fields: sysid, compid, name, value, type
        x.params:5: `-1` is not a value of type UINT64
        ");
    }

    #[test]
    fn the_64_bit_types_are_read_exactly() {
        let params = parse(
            "x.params",
            "1\t1\tU\t18446744073709551615\t7\n1\t1\tI\t-9007199254740993\t8\n\
             1\t1\tD\t0.1\t10\n1\t1\tE\t1e3\t8\n",
            true,
        )
        .unwrap();
        let values: Vec<Value> = params.iter().map(|p| p.value).collect();
        assert_eq!(
            values,
            [
                Value::U64(u64::MAX),
                Value::I64(-9_007_199_254_740_993),
                Value::F64(0.1),
                Value::I64(1000)
            ]
        );
        let text = write_qgc(&params, 1, 1);
        assert_eq!(parse("y.params", &text, true).unwrap(), params);
        assert_eq!(parse_value(MavParamType::Uint8, "256"), None);
        assert_eq!(parse_value(MavParamType::Int8, "-1.0"), Some(Value::I8(-1)));
    }
}
