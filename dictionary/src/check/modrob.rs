//! Checks of ModRob-1 module dictionaries and robots: VIs, names, units, limits, rates, info
//! texts, MIs, subscriptions and what each network can carry.

use std::collections::HashMap;

use crate::check::report_dup;
use crate::diag::{Code, Diagnostics, Span};
use crate::ir::{Direction, ModrobModule, ModrobVariable, Robot, RobotNetwork, Transport, VarRef};

/// The longest info text: 255 chunks of 7 bytes.
pub const MAX_INFO_LEN: usize = 255 * 7;

/// Bits one publication (or command) takes on a network, worst case, and how many a datagram
/// holds on Ethernet-1:
/// - CAN-1: an extended frame with 6 data bytes, 67 + 8·6 bits plus at most ⌊(54 + 8·6 − 1)/4⌋
///   stuff bits, inter-frame space included: 140 bits;
/// - UART.B-1: 12 bytes of 10 bits (8N1);
/// - SPI-1: 12 bytes of 8 bits with a 1-bit pause after each;
/// - Ethernet-1: 119 messages per 1472-byte datagram, 1538 bytes on the wire with the UDP, IP and
///   Ethernet headers, FCS, preamble and inter-frame gap, and a third of the bit rate usable under
///   collisions (the paper's model).
pub fn capacity(network: &RobotNetwork) -> f64 {
    let bitrate = f64::from(network.bitrate);
    match network.transport {
        Transport::Can => bitrate / 140.0,
        Transport::Uart => bitrate / 120.0,
        Transport::Spi => bitrate / 108.0,
        Transport::Ethernet => bitrate / 3.0 / (1538.0 * 8.0) * 119.0,
    }
}

/// Reports every problem in `modules` and `robots`.
pub fn check(modules: &[ModrobModule], robots: &[Robot], diags: &mut Diagnostics) {
    for module in modules {
        check_module(module, diags);
    }
    for robot in robots {
        check_robot(robot, modules, diags);
    }
}

fn span_of(span: &Option<Span>, fallback: &Option<Span>) -> Option<Span> {
    span.clone().or_else(|| fallback.clone())
}

fn check_module(module: &ModrobModule, diags: &mut Diagnostics) {
    let mut by_name: HashMap<&str, &Option<Span>> = HashMap::new();
    let mut by_rust: HashMap<&str, (&str, &Option<Span>)> = HashMap::new();
    let mut by_vi: HashMap<u16, (&str, &Option<Span>)> = HashMap::new();
    let mut total = 0usize;
    for v in &module.variables {
        let at = span_of(&v.spans.table, &module.span);
        if let Some(first) = by_name.insert(&v.name.wire, &v.spans.name) {
            let message = format!("variable `{}` is defined twice", v.name.wire);
            report_dup(
                diags,
                Code::DuplicateVariableName,
                v.spans.name.clone(),
                first,
                message,
            );
        } else if let Some((other, first)) =
            by_rust.insert(&v.name.rust, (&v.name.wire, &v.spans.name))
        {
            let message = format!(
                "variables `{}` and `{other}` both become `{}`",
                v.name.wire, v.name.rust
            );
            report_dup(
                diags,
                Code::NameCollision,
                v.spans.name.clone(),
                first,
                message,
            );
        }
        let last = u16::from(v.vi) + u16::from(v.count) - 1;
        if let Some(span) = span_of(&v.spans.vi, &at).filter(|_| last > 255) {
            diags.report(
                Code::TooManyVariables,
                span,
                format!(
                    "array `{}` takes VIs {}..={last}, past 255",
                    v.name.wire, v.vi
                ),
                "VIs are 0..=255",
            );
        }
        for vi in u16::from(v.vi)..=last.min(255) {
            if let Some((other, first)) = by_vi.insert(vi, (&v.name.wire, &v.spans.vi)) {
                let message = format!("`{}` and `{other}` both use VI {vi}", v.name.wire);
                report_dup(diags, Code::DuplicateVi, v.spans.vi.clone(), first, message);
                break;
            }
        }
        total += usize::from(v.count);
        check_variable(v, at, diags);
    }
    if total > 255 {
        if let Some(span) = module.span.clone() {
            diags.report(
                Code::TooManyVariables,
                span,
                format!("module `{}` has {total} variables", module.dictionary),
                "at most 255",
            );
        }
    }
    let info_problem = if module.info.len() > MAX_INFO_LEN {
        Some(format!(
            "the info text is {} bytes, over 255 chunks of 7",
            module.info.len()
        ))
    } else if module.info.contains('\0') {
        Some("the info text holds a NUL byte".to_string())
    } else {
        None
    };
    if let (Some(message), Some(span)) = (info_problem, span_of(&module.info_span, &module.span)) {
        diags.report(Code::BadInfo, span, message, "too long or has a NUL");
    }
}

fn check_variable(v: &ModrobVariable, at: Option<Span>, diags: &mut Diagnostics) {
    let Some(at) = at else { return };
    if !unit_is_valid(&v.unit) {
        diags.report(
            Code::UnknownUnit,
            v.spans.unit.clone().unwrap_or_else(|| at.clone()),
            format!("variable `{}` has unknown unit `{}`", v.name.wire, v.unit),
            "not an SI unit or dimensionless kind",
        );
    }
    if v.min.is_nan() || v.max.is_nan() || v.min > v.max {
        diags.report(
            Code::LimitsReversed,
            v.spans.min.clone().unwrap_or_else(|| at.clone()),
            format!(
                "variable `{}` has min {} and max {}",
                v.name.wire, v.min, v.max
            ),
            "min must not exceed max",
        );
    } else if !(v.min..=v.max).contains(&v.default) {
        diags.report(
            Code::ValueOutsideLimits,
            v.spans.default.clone().unwrap_or_else(|| at.clone()),
            format!(
                "variable `{}` defaults to {}, outside {}..={}",
                v.name.wire, v.default, v.min, v.max
            ),
            "outside the limits",
        );
    }
    check_rate(
        v.rate,
        v.spans.rate.clone().unwrap_or(at),
        &v.name.wire,
        diags,
    );
}

fn check_rate(rate: f64, span: Span, name: &str, diags: &mut Diagnostics) -> bool {
    let ok = rate.is_finite() && rate >= 0.0;
    if !ok {
        diags.report(
            Code::BadRate,
            span,
            format!("`{name}` has publication rate {rate} Hz"),
            "expected a finite rate >= 0",
        );
    }
    ok
}

/// SI base and derived units (and `g`, for prefixes to attach to), the dimensionless kinds, and
/// `1` for a plain number.
const UNITS: &[&str] = &[
    "m", "g", "s", "A", "K", "mol", "cd", "rad", "sr", "Hz", "N", "Pa", "J", "W", "C", "V", "F",
    "ohm", "Ω", "S", "Wb", "T", "H", "degC", "°C", "lm", "lx", "Bq", "Gy", "Sv", "kat",
];
const KINDS: &[&str] = &["mode", "counter", "ratio", "1"];
const PREFIXES: &[&str] = &[
    "da", "Q", "R", "Y", "Z", "E", "P", "T", "G", "M", "k", "h", "d", "c", "m", "u", "µ", "n", "p",
    "f", "a", "z", "y", "r", "q",
];

/// Whether `unit` is a dimensionless kind or a product/quotient of prefixed SI units with integer
/// exponents: `m/s^2`, `N.m`, `N*m`, `kA`, `rad/s`, `m2`, `1/s`.
pub fn unit_is_valid(unit: &str) -> bool {
    let unit = unit.trim();
    if KINDS.contains(&unit) {
        return true;
    }
    if unit.is_empty() {
        return false;
    }
    let mut first = true;
    for part in unit.split(['/', '*', '.', '·']) {
        let ok = (first && part == "1") || factor_is_valid(part);
        if !ok {
            return false;
        }
        first = false;
    }
    true
}

fn factor_is_valid(factor: &str) -> bool {
    let symbol = factor
        .trim_end_matches(|c: char| c.is_ascii_digit())
        .trim_end_matches(['^', '-']);
    let exponent = &factor[symbol.len()..];
    let exponent_ok = exponent.is_empty()
        || exponent
            .trim_start_matches('^')
            .trim_start_matches('-')
            .parse::<u8>()
            .is_ok_and(|e| e > 0);
    if !exponent_ok {
        return false;
    }
    UNITS.contains(&symbol)
        || PREFIXES.iter().any(|p| {
            symbol
                .strip_prefix(p)
                .is_some_and(|rest| UNITS.contains(&rest) && rest != "°C" && rest != "degC")
        })
}

fn check_robot(robot: &Robot, modules: &[ModrobModule], diags: &mut Diagnostics) {
    let mut names: HashMap<&str, &Option<Span>> = HashMap::new();
    let mut mis: HashMap<u16, (&str, &Option<Span>)> = HashMap::new();
    let mut net_names: HashMap<&str, &Option<Span>> = HashMap::new();
    for n in &robot.networks {
        if let Some(first) = net_names.insert(&n.name.wire, &n.span) {
            let message = format!("network `{}` is defined twice", n.name.wire);
            report_dup(
                diags,
                Code::DuplicateRobotName,
                n.span.clone(),
                first,
                message,
            );
        }
    }
    for inst in &robot.instances {
        if let Some(first) = names.insert(&inst.name.wire, &inst.span) {
            let message = format!("instance `{}` is defined twice", inst.name.wire);
            report_dup(
                diags,
                Code::DuplicateRobotName,
                inst.span.clone(),
                first,
                message,
            );
            continue;
        }
        if let Some((other, first)) = mis.insert(inst.module_id, (&inst.name.wire, &inst.mi_span)) {
            let message = format!(
                "`{}` and `{other}` both have MI {:#06x}",
                inst.name.wire, inst.module_id
            );
            report_dup(
                diags,
                Code::DuplicateMi,
                inst.mi_span.clone(),
                first,
                message,
            );
        }
        let network = &robot.networks[inst.network];
        if network.transport == Transport::Ethernet && inst.uuid.is_none() {
            if let Some(span) = inst.span.clone() {
                diags.report(
                    Code::MissingUuid,
                    span,
                    format!(
                        "`{}` is on Ethernet-1 network `{}` but has no UUID",
                        inst.name.wire, network.name.wire
                    ),
                    "no `uuid`",
                );
            }
        }
    }
    for s in &robot.values {
        let Some((v, name)) = variable(robot, modules, s.target) else {
            continue;
        };
        if let Some(span) = s.span.clone() {
            if !(v.min..=v.max).contains(&s.value) {
                diags.report(
                    Code::ValueOutsideLimits,
                    span,
                    format!(
                        "stored value {} for `{name}` is outside {}..={}",
                        s.value, v.min, v.max
                    ),
                    "outside the limits",
                );
            }
        }
    }
    for sub in &robot.subscriptions {
        let (Some((source, source_name)), Some((target, target_name)), Some(span)) = (
            variable(robot, modules, sub.source),
            variable(robot, modules, sub.target),
            sub.span.clone(),
        ) else {
            continue;
        };
        if source.direction == Direction::Input {
            diags.report(
                Code::SubscriptionToInput,
                span,
                format!("`{target_name}` subscribes to `{source_name}`, an input"),
                "the source is an input",
            );
        } else if target.direction == Direction::Output {
            diags.report(
                Code::SubscriptionSetsOutput,
                span,
                format!("`{target_name}` is an output; publications of `{source_name}` will not change the module's state"),
                "the target is an output",
            );
        }
    }
    check_traffic(robot, modules, diags);
}

/// Each network's load in messages/s: its own modules' publications at their effective rates
/// (the robot's stored rate, else the dictionary's), plus those the leader forwards onto it for
/// subscribers on other networks. Stored rates that are not valid rates are left out.
pub fn network_loads(robot: &Robot, modules: &[ModrobModule]) -> Vec<f64> {
    let rates = effective_rates(robot, modules, |s, _| s.value.is_finite() && s.value >= 0.0);
    loads(robot, &rates)
}

/// Every variable's effective rate and the stored rate's span, if one was stored and `valid`
/// accepts it (it gets the variable's name).
fn effective_rates<'r>(
    robot: &'r Robot,
    modules: &[ModrobModule],
    mut valid: impl FnMut(&'r crate::ir::Setting, &str) -> bool,
) -> HashMap<VarRef, (f64, Option<Span>)> {
    let mut rates: HashMap<VarRef, (f64, Option<Span>)> = HashMap::new();
    for (i, inst) in robot.instances.iter().enumerate() {
        for v in &modules[inst.dictionary].variables {
            for k in 0..v.count {
                let vi = v.vi.saturating_add(k);
                rates.insert(VarRef { instance: i, vi }, (v.rate, None));
            }
        }
    }
    for s in &robot.rates {
        let Some((_, name)) = variable(robot, modules, s.target) else {
            continue;
        };
        if valid(s, &name) {
            rates.insert(s.target, (s.value, s.span.clone()));
        }
    }
    rates
}

fn loads(robot: &Robot, rates: &HashMap<VarRef, (f64, Option<Span>)>) -> Vec<f64> {
    let mut load = vec![0.0f64; robot.networks.len()];
    let mut sorted: Vec<_> = rates.iter().collect();
    sorted.sort_by_key(|(r, _)| (r.instance, r.vi));
    for (r, (rate, _)) in sorted {
        load[robot.instances[r.instance].network] += rate;
    }
    for sub in &robot.subscriptions {
        let from = robot.instances[sub.source.instance].network;
        let to = robot.instances[sub.target.instance].network;
        if from != to {
            load[to] += rates.get(&sub.source).map_or(0.0, |r| r.0);
        }
    }
    load
}

/// Every variable's effective rate (stored rate, else its default) against its network, and each
/// network's total against what it carries.
fn check_traffic(robot: &Robot, modules: &[ModrobModule], diags: &mut Diagnostics) {
    let rates = effective_rates(robot, modules, |s, name| match s.span.clone() {
        Some(span) => check_rate(s.value, span, name, diags),
        None => false,
    });
    let mut sorted: Vec<_> = rates.iter().collect();
    sorted.sort_by_key(|(r, _)| (r.instance, r.vi));
    for (r, (rate, span)) in sorted {
        let net = &robot.networks[robot.instances[r.instance].network];
        let cap = capacity(net);
        if *rate > cap {
            let inst_span = robot.instances[r.instance].span.clone();
            let name = variable(robot, modules, *r).map_or_else(String::new, |(_, n)| n);
            if let Some(span) = span.clone().or(inst_span) {
                diags.report(
                    Code::RateTooHigh,
                    span,
                    format!(
                        "`{name}` is published at {rate} Hz, but network `{}` ({} at {} bit/s) carries at most {cap:.0} messages/s",
                        net.name.wire,
                        transport_name(net.transport),
                        net.bitrate
                    ),
                    "more than the network carries",
                );
            }
        }
    }
    let load = loads(robot, &rates);
    for (net, total) in robot.networks.iter().zip(load) {
        let cap = capacity(net);
        if total > cap {
            if let Some(span) = net.span.clone() {
                diags.report(
                    Code::NetworkOverloaded,
                    span,
                    format!(
                        "network `{}` is configured for {total:.0} messages/s, {:.0} % of the {cap:.0} it carries",
                        net.name.wire,
                        100.0 * total / cap
                    ),
                    "overloaded",
                );
            }
        }
    }
}

/// The variable `r` names, and its name as a robot file writes it (`drive_fl.speed`,
/// `planar.x0[3]`).
fn variable<'m>(
    robot: &Robot,
    modules: &'m [ModrobModule],
    r: VarRef,
) -> Option<(&'m ModrobVariable, String)> {
    let inst = robot.instances.get(r.instance)?;
    let (v, i) = modules.get(inst.dictionary)?.variable_at(r.vi)?;
    let name = if v.count > 1 {
        format!("{}.{}[{i}]", inst.name.wire, v.name.wire)
    } else {
        format!("{}.{}", inst.name.wire, v.name.wire)
    };
    Some((v, name))
}

fn transport_name(t: Transport) -> &'static str {
    match t {
        Transport::Can => "CAN-1",
        Transport::Uart => "UART.B-1",
        Transport::Spi => "SPI-1",
        Transport::Ethernet => "Ethernet-1",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units() {
        for ok in [
            "m", "km", "m/s", "m/s^2", "m/s2", "rad/s", "N.m", "N*m", "kA", "mA", "V", "degC",
            "1/s", "mode", "counter", "ratio", "1", "kg", "mm", "µs", "Pa", "ohm", "kohm",
        ] {
            assert!(unit_is_valid(ok), "{ok}");
        }
        for bad in [
            "", "meter", "m/", "s^0", "km/h/", "%", "rpm", "kdegC", "xm", "1.5", "m^x",
        ] {
            assert!(!unit_is_valid(bad), "{bad}");
        }
    }

    #[test]
    fn capacities_match_the_paper_figures() {
        let net = |transport, bitrate| RobotNetwork {
            name: crate::ir::Name {
                wire: "n".into(),
                rust: "N".into(),
            },
            transport,
            bitrate,
            span: None,
        };
        assert_eq!(capacity(&net(Transport::Can, 1_000_000)).floor(), 7142.0);
        assert_eq!(capacity(&net(Transport::Uart, 115_200)).floor(), 960.0);
        assert_eq!(capacity(&net(Transport::Spi, 1_000_000)).floor(), 9259.0);
        assert_eq!(
            capacity(&net(Transport::Ethernet, 10_000_000)).floor(),
            32238.0
        );
    }
}
