//! The latest message of each type from each component of each system, as mavlink2rest keeps
//! them, and the tree `GET /v1/mavlink` shows.
//!
//! An entry holds the payload as received (decoded only when asked for) and when it came:
//! `status.time` gives `first_update` and `last_update` (RFC 3339, UTC), `counter` (messages
//! received: mavlink2rest counts the first one twice) and `frequency` (their mean rate since
//! the first, in Hz; 0 until there are two).

use std::collections::BTreeMap;
use std::time::SystemTime;

use axum::body::Bytes;
use ferrolink_traffic::PayloadDecoder;
use serde_json::{json, Map, Value as Json};

/// One message type's latest from one component.
#[derive(Debug, Clone)]
struct Entry {
    payload: Vec<u8>,
    first: SystemTime,
    last: SystemTime,
    counter: u64,
    /// Its pretty JSON, made by the first request after an update and served to the next ones.
    text: Option<Bytes>,
}

/// The most entries the store keeps: a vehicle sends a few hundred message types at most, and a
/// peer spoofing every system, component and message id must not take the memory (65,536
/// entries of a few hundred bytes: about 20 MB at worst).
pub const MAX_ENTRIES: usize = 65_536;

/// Systems → components → message ids → the latest entry.
#[derive(Debug, Default)]
pub struct Store {
    systems: BTreeMap<u8, BTreeMap<u8, BTreeMap<u32, Entry>>>,
    entries: usize,
    /// Messages not kept because the store was full (their type was new there).
    pub refused: u64,
}

fn time(t: SystemTime) -> String {
    humantime::format_rfc3339_nanos(t).to_string()
}

impl Entry {
    fn json(&self, decoder: &PayloadDecoder, id: u32) -> Option<Json> {
        let seconds = self
            .last
            .duration_since(self.first)
            .map_or(0.0, |d| d.as_secs_f64());
        let frequency = if self.counter > 1 && seconds > 0.0 {
            (self.counter - 1) as f64 / seconds
        } else {
            0.0
        };
        Some(json!({
            "message": decoder.to_rest(id, &self.payload)?,
            "status": {"time": {
                "counter": self.counter,
                "first_update": time(self.first),
                "frequency": frequency,
                "last_update": time(self.last),
            }},
        }))
    }
}

fn pretty(json: &Json) -> Bytes {
    serde_json::to_vec_pretty(json).unwrap_or_default().into()
}

/// Why a path names nothing.
pub type Missing = String;

impl Store {
    /// Takes message `id` from `(sysid, compid)`, received at `at`. A type new to a component
    /// is not kept once the store holds [`MAX_ENTRIES`] (counted in `refused`).
    pub fn update(&mut self, sysid: u8, compid: u8, id: u32, payload: &[u8], at: SystemTime) {
        let full = self.entries >= MAX_ENTRIES;
        let known = self
            .systems
            .get(&sysid)
            .and_then(|c| c.get(&compid))
            .is_some_and(|m| m.contains_key(&id));
        if full && !known {
            self.refused += 1;
            return;
        }
        if !known {
            self.entries += 1;
        }
        let entry = self
            .systems
            .entry(sysid)
            .or_default()
            .entry(compid)
            .or_default()
            .entry(id)
            .or_insert_with(|| Entry {
                payload: Vec::new(),
                first: at,
                last: at,
                counter: 0,
                text: None,
            });
        entry.payload.clear();
        entry.payload.extend_from_slice(payload);
        entry.last = at;
        entry.counter += 1;
        entry.text = None;
    }

    /// [`Store::lookup`] as pretty JSON text. A message's entry
    /// (`vehicles/S/components/C/messages/NAME`), what clients poll, is made once per update.
    pub fn text(&mut self, decoder: &PayloadDecoder, path: &str) -> Result<Bytes, Missing> {
        let segments: Vec<&str> = path.split('/').filter(|s| !s.is_empty()).collect();
        if let ["vehicles", sys, "components", comp, "messages", name] = segments.as_slice() {
            let entry = sys
                .parse::<u8>()
                .ok()
                .zip(comp.parse::<u8>().ok())
                .and_then(|(s, c)| self.systems.get_mut(&s)?.get_mut(&c))
                .and_then(|messages| {
                    messages
                        .iter_mut()
                        .find(|(id, _)| decoder.message(**id).is_some_and(|m| m.name.wire == *name))
                });
            if let Some((id, entry)) = entry {
                if entry.text.is_none() {
                    let json = entry.json(decoder, *id).ok_or("undecodable")?;
                    entry.text = Some(pretty(&json));
                }
                return Ok(entry.text.clone().unwrap_or_default());
            }
        }
        self.lookup(decoder, path).map(|json| pretty(&json))
    }

    /// The systems seen, each with its components.
    pub fn systems(&self) -> impl Iterator<Item = (u8, Vec<u8>)> + '_ {
        self.systems
            .iter()
            .map(|(s, components)| (*s, components.keys().copied().collect()))
    }

    fn messages(&self, decoder: &PayloadDecoder, messages: &BTreeMap<u32, Entry>) -> Json {
        let mut out = Map::new();
        for (id, entry) in messages {
            if let (Some(m), Some(json)) = (decoder.message(*id), entry.json(decoder, *id)) {
                out.insert(m.name.wire.clone(), json);
            }
        }
        Json::Object(out)
    }

    fn components(&self, decoder: &PayloadDecoder, sysid: u8) -> Json {
        let mut out = Map::new();
        for (compid, messages) in self.systems.get(&sysid).into_iter().flatten() {
            out.insert(
                compid.to_string(),
                json!({"id": compid, "messages": self.messages(decoder, messages)}),
            );
        }
        Json::Object(out)
    }

    fn vehicles(&self, decoder: &PayloadDecoder) -> Json {
        let mut out = Map::new();
        for sysid in self.systems.keys() {
            out.insert(
                sysid.to_string(),
                json!({"id": sysid, "components": self.components(decoder, *sysid)}),
            );
        }
        Json::Object(out)
    }

    /// What `path` (`vehicles/1/components/1/messages/ATTITUDE/message/roll`, or empty for the
    /// whole tree) names, rendering only the part it needs; `Err` says what is missing.
    pub fn lookup(&self, decoder: &PayloadDecoder, path: &str) -> Result<Json, Missing> {
        let segments: Vec<&str> = path.split('/').filter(|s| !s.is_empty()).collect();
        let number = |s: &str, what: &str| {
            s.parse::<u8>()
                .map_err(|_| format!("{what} {s:?}: expected 0 to 255"))
        };
        let (node, rest) = match segments.as_slice() {
            [] => (json!({"vehicles": self.vehicles(decoder)}), &[][..]),
            ["vehicles", rest @ ..] if rest.is_empty() => (self.vehicles(decoder), rest),
            ["vehicles", sys, rest @ ..] => {
                let sysid = number(sys, "vehicle")?;
                let components = self
                    .systems
                    .get(&sysid)
                    .ok_or_else(|| format!("no vehicle {sysid} has been heard"))?;
                match rest {
                    ["components", comp, rest @ ..] => {
                        let compid = number(comp, "component")?;
                        let messages = components.get(&compid).ok_or_else(|| {
                            format!("no component {compid} of vehicle {sysid} has been heard")
                        })?;
                        match rest {
                            ["messages", name, rest @ ..] => {
                                let (id, entry) = messages
                                    .iter()
                                    .find(|(id, _)| {
                                        decoder.message(**id).is_some_and(|m| m.name.wire == *name)
                                    })
                                    .ok_or_else(|| {
                                        format!(
                                            "no {name} has come from vehicle {sysid}, component \
                                             {compid}"
                                        )
                                    })?;
                                let json = entry.json(decoder, *id).ok_or("undecodable")?;
                                (json, rest)
                            }
                            _ => (
                                json!({"id": compid, "messages": self.messages(decoder, messages)}),
                                rest,
                            ),
                        }
                    }
                    _ => (
                        json!({"id": sysid, "components": self.components(decoder, sysid)}),
                        rest,
                    ),
                }
            }
            _ => return Err(format!("no {path:?}: paths start with vehicles")),
        };
        if rest.is_empty() {
            return Ok(node);
        }
        let pointer: String = rest.iter().map(|s| format!("/{s}")).collect();
        node.pointer(&pointer)
            .cloned()
            .ok_or_else(|| format!("nothing at {path:?}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn decoder() -> PayloadDecoder {
        ferrolink_traffic::Dialects::load(&["common".into()], "common")
            .expect("common")
            .decoder()
    }

    #[test]
    fn paths_name_what_was_heard_and_nothing_else() {
        let d = decoder();
        let mut store = Store::default();
        let t0 = SystemTime::UNIX_EPOCH + Duration::from_secs(1_700_000_000);
        let mut attitude = vec![0u8; 28];
        attitude[4..8].copy_from_slice(&0.5f32.to_le_bytes());
        store.update(1, 1, 30, &attitude, t0);
        store.update(1, 1, 30, &attitude, t0 + Duration::from_millis(500));
        store.update(1, 1, 30, &attitude, t0 + Duration::from_secs(1));
        let roll = store
            .lookup(&d, "vehicles/1/components/1/messages/ATTITUDE/message/roll")
            .unwrap();
        assert_eq!(roll, json!(0.5));
        let time = store
            .lookup(&d, "vehicles/1/components/1/messages/ATTITUDE/status/time")
            .unwrap();
        assert_eq!(
            time,
            json!({"counter": 3, "first_update": "2023-11-14T22:13:20.000000000Z",
                   "frequency": 2.0, "last_update": "2023-11-14T22:13:21.000000000Z"})
        );
        let tree = store.lookup(&d, "").unwrap();
        assert_eq!(tree["vehicles"]["1"]["components"]["1"]["id"], json!(1));
        // A full store keeps what it has and refuses new entries, counted.
        store.entries = MAX_ENTRIES;
        store.update(9, 9, 0, &[], t0);
        store.update(1, 1, 30, &attitude, t0 + Duration::from_secs(2));
        assert_eq!(store.refused, 1);
        assert!(store.lookup(&d, "vehicles/9").is_err());
        for missing in [
            "vehicles/2",
            "vehicles/1/components/9",
            "vehicles/1/components/1/messages/HEARTBEAT",
            "vehicles/1/components/1/messages/ATTITUDE/message/nope",
            "vehicles/x",
            "planes",
        ] {
            assert!(store.lookup(&d, missing).is_err(), "{missing}");
        }
    }
}
