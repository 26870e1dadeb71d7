//! Lowering ModRob-1 dictionaries and robots: fingerprints computed, and every name in a robot
//! file resolved (dictionaries, networks, instances, `instance.variable`).
//!
//! A name that resolves to nothing is reported here (E0508), as only this stage resolves names;
//! an instance whose dictionary or network is unknown is dropped after its report, and later
//! references to it are not reported again. Every other problem is left to [`crate::check`].

use std::collections::{HashMap, HashSet};

use crate::diag::{Code, Diagnostics};
use crate::frontend::modrob::{ParsedModule, ParsedRobot, Spanned};
use crate::ident;
use crate::ir::{ModrobModule, Robot, RobotInstance, Setting, Subscription, VarRef};

/// Builds the module dictionaries and the robots.
pub fn lower(
    modules: Vec<ParsedModule>,
    robots: Vec<ParsedRobot>,
    diags: &mut Diagnostics,
) -> (Vec<ModrobModule>, Vec<Robot>) {
    let by_path: HashMap<_, usize> = modules
        .iter()
        .enumerate()
        .map(|(i, m)| (m.canonical.clone(), i))
        .collect();
    let dictionaries: Vec<ModrobModule> = modules
        .into_iter()
        .map(|p| {
            let mut m = p.module;
            m.fingerprint = fingerprint(&m);
            m
        })
        .collect();
    let robots = robots
        .into_iter()
        .map(|r| lower_robot(r, &dictionaries, &by_path, diags))
        .collect();
    (dictionaries, robots)
}

/// CRC-32 (ISO-HDLC) over what a stored image depends on: per VI its number, name, unit,
/// direction, limits and persist flag.
pub fn fingerprint(module: &ModrobModule) -> u32 {
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
    let mut digest = crc.digest();
    for v in &module.variables {
        for i in 0..v.count {
            let line = format!(
                "{} {}[{i}] {} {:?} {} {} {}\n",
                u16::from(v.vi) + u16::from(i),
                v.name.wire,
                v.unit,
                v.direction,
                v.min as f32,
                v.max as f32,
                v.persist
            );
            digest.update(line.as_bytes());
        }
    }
    digest.finalize()
}

fn unknown(what: &str, name: &Spanned, diags: &mut Diagnostics) {
    diags.report(
        Code::UnknownName,
        name.span.clone(),
        format!("unknown {what} `{}`", name.text),
        format!("no such {what}"),
    );
}

fn lower_robot(
    parsed: ParsedRobot,
    dictionaries: &[ModrobModule],
    by_path: &HashMap<std::path::PathBuf, usize>,
    diags: &mut Diagnostics,
) -> Robot {
    let dictionary_index: HashMap<&str, usize> = parsed
        .dictionaries
        .iter()
        .filter_map(|(name, path)| Some((name.text.as_str(), *by_path.get(path)?)))
        .collect();
    let named_dictionaries: HashSet<&str> = parsed
        .dictionaries
        .iter()
        .map(|(n, _)| n.text.as_str())
        .collect();
    let mut robot = Robot {
        name: ident::file_module_name(&parsed.source.path),
        path: parsed.source.path.display().to_string(),
        description: parsed.description,
        networks: parsed.networks,
        instances: Vec::new(),
        leader: 0,
        values: Vec::new(),
        rates: Vec::new(),
        subscriptions: Vec::new(),
        span: Some(parsed.span),
    };
    let mut dropped = HashSet::new();
    for inst in parsed.instances {
        let dictionary = dictionary_index.get(inst.dictionary.text.as_str()).copied();
        if dictionary.is_none() && !named_dictionaries.contains(inst.dictionary.text.as_str()) {
            unknown("dictionary", &inst.dictionary, diags);
        }
        let network = robot
            .networks
            .iter()
            .position(|n| n.name.wire == inst.network.text);
        if network.is_none() {
            unknown("network", &inst.network, diags);
        }
        let (Some(dictionary), Some(network)) = (dictionary, network) else {
            dropped.insert(inst.name.wire);
            continue;
        };
        let module = &dictionaries[dictionary];
        robot.instances.push(RobotInstance {
            name: inst.name,
            dictionary,
            module_id: inst.mi.as_ref().map_or(module.module_id, |m| m.0),
            uuid: inst.uuid.or(module.uuid),
            network,
            mi_span: Some(inst.mi.map_or(inst.span.clone(), |m| m.1)),
            span: Some(inst.span),
        });
    }
    if let Some(span) = robot
        .span
        .clone()
        .filter(|_| robot.instances.is_empty() && dropped.is_empty())
    {
        diags.report(
            Code::Missing,
            span,
            "the robot has no `[[instances]]`",
            "a robot needs at least its leader",
        );
    }
    let find = |name: &str| robot.instances.iter().position(|i| i.name.wire == name);
    if let Some(leader) = &parsed.leader {
        match find(&leader.text) {
            Some(i) => robot.leader = i,
            None if dropped.contains(&leader.text) => {}
            None => unknown("instance", leader, diags),
        }
    }
    let resolve = |name: &Spanned, diags: &mut Diagnostics| -> Option<VarRef> {
        let (instance, variable) = name.text.split_once('.')?;
        let Some(i) = find(instance) else {
            if !dropped.contains(instance) {
                let at = Spanned {
                    text: instance.to_string(),
                    span: name.span.clone(),
                };
                unknown("instance", &at, diags);
            }
            return None;
        };
        let module = &dictionaries[robot.instances[i].dictionary];
        match module.vi_of(variable) {
            Some((_, vi)) => Some(VarRef { instance: i, vi }),
            None => {
                diags.report(
                    Code::UnknownName,
                    name.span.clone(),
                    format!(
                        "instance `{instance}` ({}) has no variable `{variable}`",
                        module.dictionary
                    ),
                    "no such variable",
                );
                None
            }
        }
    };
    let settings = |list: Vec<(Spanned, f64)>, diags: &mut Diagnostics| -> Vec<Setting> {
        list.into_iter()
            .filter_map(|(name, value)| {
                let target = resolve(&name, diags)?;
                Some(Setting {
                    target,
                    value,
                    span: Some(name.span),
                })
            })
            .collect()
    };
    let values = settings(parsed.values, diags);
    let rates = settings(parsed.rates, diags);
    let mut subscriptions = Vec::new();
    for (target, source, span) in parsed.subscriptions {
        let target = resolve(&target, diags);
        let source = resolve(&source, diags);
        if let (Some(target), Some(source)) = (target, source) {
            subscriptions.push(Subscription {
                target,
                source,
                span: Some(span),
            });
        }
    }
    robot.values = values;
    robot.rates = rates;
    robot.subscriptions = subscriptions;
    robot
}
