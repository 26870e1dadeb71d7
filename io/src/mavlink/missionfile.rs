//! Mission files: the "QGC WPL 110" text format (MAVProxy, Mission Planner and QGroundControl
//! read and write it) and QGroundControl's `.plan` JSON.
//!
//! - **WPL 110**: a `QGC WPL 110` line, then one line per item, tab (or space) separated:
//!   `seq current frame command p1 p2 p3 p4 x y z autocontinue`. Line N is item N. x and y are
//!   degrees in global frames and metres in local ones; in MISSION_ITEM_INT they become
//!   `round(degrees × 10⁷)` (metres × 10⁴).
//! - **`.plan`**: the mission's `SimpleItem`s (`params` are p1 to p4, latitude, longitude,
//!   altitude; `null` is NaN), the geofence's polygons and circles as
//!   `MAV_CMD_NAV_FENCE_POLYGON_VERTEX_*` and `MAV_CMD_NAV_FENCE_CIRCLE_*` items, and the rally
//!   points as `MAV_CMD_NAV_RALLY_POINT`, as QGroundControl maps them.
//!
//! Which one a file is goes by its extension: `.plan` is QGroundControl's, anything else WPL.

use std::fmt::Write as _;

use ferrolink_runtime::mavlink::service::command::scale;
use ferrolink_runtime::mavlink::service::messages::{MavCmd, MavFrame, MavMissionType};
use ferrolink_runtime::mavlink::service::mission::Item;
use serde_json::{json, Value};

/// A mission file's problem, with its line (0: the file as a whole).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    /// 1-based line, 0 for the whole file.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            f.write_str(&self.message)
        } else {
            write!(f, "line {}: {}", self.line, self.message)
        }
    }
}

/// `v` in the frame's units, as MISSION_ITEM_INT's integer x or y.
fn to_int(frame: MavFrame, v: f64) -> i32 {
    let scaled = (v * scale(frame)).round();
    scaled.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
}

/// MISSION_ITEM_INT's integer x or y in the frame's units, as text that reads back exactly.
fn from_int(frame: MavFrame, v: i32) -> String {
    let s = scale(frame);
    let digits = if s == 1e7 {
        7
    } else if s == 1e4 {
        4
    } else {
        0
    };
    let sign = if v < 0 { "-" } else { "" };
    let abs = u64::from(v.unsigned_abs());
    if digits == 0 {
        return format!("{sign}{abs}");
    }
    let unit = 10u64.pow(digits);
    format!(
        "{sign}{}.{:0width$}",
        abs / unit,
        abs % unit,
        width = digits as usize
    )
}

/// A float as the shortest text that reads back as the same `f32` (`nan` for NaN).
fn float(v: f32) -> String {
    if v.is_nan() {
        "nan".into()
    } else {
        format!("{v:?}")
    }
}

/// Parses WPL 110 text; every bad line is reported.
pub fn parse_wpl(text: &str) -> Result<Vec<Item>, Vec<Error>> {
    let mut lines = text.lines().enumerate();
    let mut errors = Vec::new();
    match lines.next() {
        Some((_, first)) if first.trim().starts_with("QGC WPL 110") => {}
        _ => {
            return Err(vec![Error {
                line: 1,
                message: "the first line is not `QGC WPL 110`".into(),
            }])
        }
    }
    let mut items = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let error = |message: String| Error {
            line: i + 1,
            message,
        };
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.len() != 12 {
            errors.push(error(format!(
                "{} fields; an item has 12: seq current frame command p1 p2 p3 p4 x y z autocontinue",
                fields.len()
            )));
            continue;
        }
        let int = |k: usize, what: &str| -> Result<u64, Error> {
            fields[k]
                .parse::<u64>()
                .map_err(|_| error(format!("{what} `{}` is not a whole number", fields[k])))
        };
        let num = |k: usize| -> Result<f64, Error> {
            fields[k]
                .parse::<f64>()
                .map_err(|_| error(format!("`{}` is not a number", fields[k])))
        };
        let parsed = (|| {
            let seq = int(0, "seq")?;
            if seq != items.len() as u64 {
                return Err(error(format!(
                    "seq {seq} on the line of item {}: line N is item N",
                    items.len()
                )));
            }
            let frame = MavFrame::from_raw(
                u8::try_from(int(2, "frame")?).map_err(|_| error("frame above 255".into()))?,
            );
            let command = MavCmd::from_raw(
                u16::try_from(int(3, "command")?)
                    .map_err(|_| error("command above 65535".into()))?,
            );
            Ok(Item {
                frame,
                command,
                current: u8::from(int(1, "current")? != 0),
                autocontinue: u8::from(int(11, "autocontinue")? != 0),
                params: [
                    num(4)? as f32,
                    num(5)? as f32,
                    num(6)? as f32,
                    num(7)? as f32,
                ],
                x: to_int(frame, num(8)?),
                y: to_int(frame, num(9)?),
                z: num(10)? as f32,
            })
        })();
        match parsed {
            Ok(item) => items.push(item),
            Err(e) => errors.push(e),
        }
    }
    if errors.is_empty() {
        Ok(items)
    } else {
        Err(errors)
    }
}

/// WPL 110 text for `items`.
pub fn write_wpl(items: &[Item]) -> String {
    let mut out = String::from("QGC WPL 110\n");
    for (seq, it) in items.iter().enumerate() {
        let [p1, p2, p3, p4] = it.params.map(float);
        let _ = writeln!(
            out,
            "{seq}\t{}\t{}\t{}\t{p1}\t{p2}\t{p3}\t{p4}\t{}\t{}\t{}\t{}",
            it.current,
            it.frame.raw(),
            it.command.raw(),
            from_int(it.frame, it.x),
            from_int(it.frame, it.y),
            float(it.z),
            it.autocontinue
        );
    }
    out
}

const FENCE_POLYGON_INCLUSION: u16 = 5001;
const FENCE_POLYGON_EXCLUSION: u16 = 5002;
const FENCE_CIRCLE_INCLUSION: u16 = 5003;
const FENCE_CIRCLE_EXCLUSION: u16 = 5004;
const RALLY_POINT: u16 = 5100;

fn plan_error(message: impl Into<String>) -> Vec<Error> {
    vec![Error {
        line: 0,
        message: message.into(),
    }]
}

fn num_or_nan(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

fn point(v: &Value) -> Option<(f64, f64, f64)> {
    let a = v.as_array()?;
    Some((
        a.first()?.as_f64()?,
        a.get(1)?.as_f64()?,
        a.get(2).and_then(Value::as_f64).unwrap_or(0.0),
    ))
}

fn global_item(command: u16, params: [f32; 4], lat: f64, lon: f64, alt: f32) -> Item {
    let frame = MavFrame::GlobalRelativeAlt;
    Item {
        frame,
        command: MavCmd::from_raw(command),
        current: 0,
        autocontinue: 1,
        params,
        x: to_int(frame, lat),
        y: to_int(frame, lon),
        z: alt,
    }
}

/// The items of `kind` in a QGroundControl `.plan`.
pub fn parse_plan(text: &str, kind: MavMissionType) -> Result<Vec<Item>, Vec<Error>> {
    let plan: Value = serde_json::from_str(text).map_err(|e| {
        vec![Error {
            line: e.line(),
            message: format!("not JSON: {e}"),
        }]
    })?;
    if plan.get("fileType").and_then(Value::as_str) != Some("Plan") {
        return Err(plan_error(
            "not a QGroundControl plan: `fileType` is not \"Plan\"",
        ));
    }
    let mut items = Vec::new();
    match kind {
        MavMissionType::Fence => {
            let fence = &plan["geoFence"];
            for polygon in fence["polygons"].as_array().into_iter().flatten() {
                let inclusion = polygon["inclusion"].as_bool().unwrap_or(true);
                let vertices: Vec<_> = polygon["polygon"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(point)
                    .collect();
                let command = if inclusion {
                    FENCE_POLYGON_INCLUSION
                } else {
                    FENCE_POLYGON_EXCLUSION
                };
                for (lat, lon, _) in &vertices {
                    let count = vertices.len() as f32;
                    items.push(global_item(
                        command,
                        [count, 0.0, 0.0, 0.0],
                        *lat,
                        *lon,
                        0.0,
                    ));
                }
            }
            for circle in fence["circles"].as_array().into_iter().flatten() {
                let inclusion = circle["inclusion"].as_bool().unwrap_or(true);
                let c = &circle["circle"];
                let (lat, lon, _) = point(&c["center"])
                    .ok_or_else(|| plan_error("a geofence circle without a center"))?;
                let radius = c["radius"].as_f64().unwrap_or(0.0) as f32;
                let command = if inclusion {
                    FENCE_CIRCLE_INCLUSION
                } else {
                    FENCE_CIRCLE_EXCLUSION
                };
                items.push(global_item(command, [radius, 0.0, 0.0, 0.0], lat, lon, 0.0));
            }
        }
        MavMissionType::Rally => {
            for p in plan["rallyPoints"]["points"]
                .as_array()
                .into_iter()
                .flatten()
            {
                let (lat, lon, alt) = point(p)
                    .ok_or_else(|| plan_error("a rally point that is not [lat, lon, alt]"))?;
                items.push(global_item(RALLY_POINT, [0.0; 4], lat, lon, alt as f32));
            }
        }
        _ => {
            for (i, it) in plan["mission"]["items"]
                .as_array()
                .into_iter()
                .flatten()
                .enumerate()
            {
                if it["type"].as_str() != Some("SimpleItem") {
                    return Err(plan_error(format!(
                        "mission item {i} is a {}; only SimpleItems are read (save the plan \
                         with complex items converted, or use a WPL file)",
                        it["type"]
                    )));
                }
                let p: Vec<f64> = it["params"]
                    .as_array()
                    .map(|a| a.iter().map(num_or_nan).collect())
                    .unwrap_or_default();
                if p.len() != 7 {
                    return Err(plan_error(format!("mission item {i} has not 7 params")));
                }
                let frame = MavFrame::from_raw(it["frame"].as_u64().unwrap_or(0) as u8);
                items.push(Item {
                    frame,
                    command: MavCmd::from_raw(it["command"].as_u64().unwrap_or(0) as u16),
                    current: 0,
                    autocontinue: u8::from(it["autoContinue"].as_bool().unwrap_or(true)),
                    params: [p[0] as f32, p[1] as f32, p[2] as f32, p[3] as f32],
                    x: to_int(frame, p[4]),
                    y: to_int(frame, p[5]),
                    z: p[6] as f32,
                });
            }
        }
    }
    Ok(items)
}

fn json_float(v: f32) -> Value {
    if v.is_nan() {
        Value::Null
    } else {
        // The shortest decimal of the f32, not of its f64 widening.
        format!("{v:?}")
            .parse::<f64>()
            .map_or(Value::Null, |f| json!(f))
    }
}

fn coordinate(frame: MavFrame, v: i32) -> Value {
    from_int(frame, v)
        .parse::<f64>()
        .map_or(Value::Null, |f| json!(f))
}

/// A QGroundControl `.plan` holding `items` as its `kind` (the other parts empty).
pub fn write_plan(items: &[Item], kind: MavMissionType) -> String {
    let mut mission = Vec::new();
    let mut polygons = Vec::new();
    let mut circles = Vec::new();
    let mut rally = Vec::new();
    let mut i = 0;
    while i < items.len() {
        let it = items[i];
        let lat = coordinate(it.frame, it.x);
        let lon = coordinate(it.frame, it.y);
        match (kind, it.command.raw()) {
            (MavMissionType::Fence, c @ (FENCE_POLYGON_INCLUSION | FENCE_POLYGON_EXCLUSION)) => {
                let n = (it.params[0] as usize).max(1).min(items.len() - i);
                let vertices: Vec<Value> = items[i..i + n]
                    .iter()
                    .map(|v| json!([coordinate(v.frame, v.x), coordinate(v.frame, v.y)]))
                    .collect();
                polygons.push(json!({"inclusion": c == FENCE_POLYGON_INCLUSION, "polygon": vertices, "version": 1}));
                i += n;
                continue;
            }
            (MavMissionType::Fence, c @ (FENCE_CIRCLE_INCLUSION | FENCE_CIRCLE_EXCLUSION)) => {
                circles.push(
                    json!({"inclusion": c == FENCE_CIRCLE_INCLUSION, "version": 1,
                    "circle": {"center": [lat, lon], "radius": json_float(it.params[0])}}),
                );
            }
            (MavMissionType::Rally, _) => rally.push(json!([lat, lon, json_float(it.z)])),
            _ => {
                let params: Vec<Value> = it
                    .params
                    .iter()
                    .map(|p| json_float(*p))
                    .chain([lat, lon, json_float(it.z)])
                    .collect();
                mission.push(json!({
                    "type": "SimpleItem",
                    "autoContinue": it.autocontinue != 0,
                    "command": it.command.raw(),
                    "doJumpId": mission.len() + 1,
                    "frame": it.frame.raw(),
                    "params": params,
                }));
            }
        }
        i += 1;
    }
    let plan = json!({
        "fileType": "Plan",
        "version": 1,
        "groundStation": "Ferrolink",
        "mission": {"version": 2, "firmwareType": 0, "vehicleType": 0, "cruiseSpeed": 15,
                    "hoverSpeed": 5, "plannedHomePosition": [0, 0, 0], "items": mission},
        "geoFence": {"version": 2, "polygons": polygons, "circles": circles},
        "rallyPoints": {"version": 2, "points": rally},
    });
    let mut text = serde_json::to_string_pretty(&plan).unwrap_or_default();
    text.push('\n');
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    const WPL: &str = "QGC WPL 110\n\
        0\t1\t0\t16\t0\t0\t0\t0\t47.3977419\t8.5455939\t488.0\t1\n\
        1\t0\t3\t22\t15.0\t0\t0\tnan\t47.3979\t8.5461\t10.0\t1\n\
        2\t0\t1\t16\t0\t0\t0\t0\t12.3456\t-7.5\t-3.0\t1\n";

    #[test]
    fn wpl_round_trips_exactly() {
        let items = parse_wpl(WPL).unwrap();
        assert_eq!(items.len(), 3);
        assert_eq!((items[0].x, items[0].y), (473_977_419, 85_455_939));
        assert_eq!(
            (items[2].x, items[2].y),
            (123_456, -75_000),
            "local frames are metres × 10⁴"
        );
        assert!(items[1].params[3].is_nan());
        let again = parse_wpl(&write_wpl(&items)).unwrap();
        assert!(items.iter().zip(&again).all(|(a, b)| a.same(b)));
        insta::assert_snapshot!(write_wpl(&items[..2]), @r"
        QGC WPL 110
        0	1	0	16	0.0	0.0	0.0	0.0	47.3977419	8.5455939	488.0	1
        1	0	3	22	15.0	0.0	0.0	nan	47.3979000	8.5461000	10.0	1
        ");
    }

    #[test]
    fn every_bad_wpl_line_is_reported() {
        let errors = parse_wpl("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n5\t0\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n2\t0\t0\n")
            .unwrap_err();
        let shown: Vec<String> = errors.iter().map(ToString::to_string).collect();
        insta::assert_snapshot!(shown.join("\n"), @r"
        line 3: seq 5 on the line of item 1: line N is item N
        line 4: 3 fields; an item has 12: seq current frame command p1 p2 p3 p4 x y z autocontinue
        ");
        assert_eq!(
            parse_wpl("hello").unwrap_err()[0].to_string(),
            "line 1: the first line is not `QGC WPL 110`"
        );
    }

    #[test]
    fn plans_round_trip_for_every_kind() {
        let mission = parse_wpl(WPL).unwrap();
        let back = parse_plan(
            &write_plan(&mission, MavMissionType::Mission),
            MavMissionType::Mission,
        )
        .unwrap();
        // A plan has no `current`.
        assert!(mission
            .iter()
            .zip(&back)
            .all(|(a, b)| Item { current: 0, ..*a }.same(b)));
        let fence = vec![
            global_item(
                FENCE_POLYGON_INCLUSION,
                [3.0, 0.0, 0.0, 0.0],
                47.1,
                8.1,
                0.0,
            ),
            global_item(
                FENCE_POLYGON_INCLUSION,
                [3.0, 0.0, 0.0, 0.0],
                47.2,
                8.1,
                0.0,
            ),
            global_item(
                FENCE_POLYGON_INCLUSION,
                [3.0, 0.0, 0.0, 0.0],
                47.2,
                8.2,
                0.0,
            ),
            global_item(
                FENCE_CIRCLE_EXCLUSION,
                [25.5, 0.0, 0.0, 0.0],
                47.15,
                8.15,
                0.0,
            ),
        ];
        let back = parse_plan(
            &write_plan(&fence, MavMissionType::Fence),
            MavMissionType::Fence,
        )
        .unwrap();
        assert!(fence.iter().zip(&back).all(|(a, b)| a.same(b)), "{back:?}");
        let rally = vec![global_item(RALLY_POINT, [0.0; 4], 47.3, 8.3, 50.0)];
        let back = parse_plan(
            &write_plan(&rally, MavMissionType::Rally),
            MavMissionType::Rally,
        )
        .unwrap();
        assert!(rally[0].same(&back[0]));
    }
}
