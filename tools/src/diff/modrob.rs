//! ModRob-1 module dictionaries (by `[module] name`) and robots (by file name).

use super::{pair, Category, Findings, Kind, Pair, Subject};
use crate::diag::Span;
use crate::ir::{Direction, Ir, ModrobModule, ModrobVariable, Robot};

pub(super) fn diff(old: &Ir, new: &Ir, out: &mut Findings) {
    for p in pair(&old.modrob, &new.modrob, |m| &m.dictionary) {
        match p {
            Pair::Both(o, n) => module(o, n, out),
            Pair::Gone(o) => {
                let subject = Subject::new(Kind::Variable, &o.dictionary, o.span.as_ref(), None);
                out.add(
                    &subject,
                    Category::Api,
                    "module-removed",
                    o.module_id,
                    None::<u16>,
                    "module dictionary removed",
                );
            }
            Pair::Added(n) => {
                let subject = Subject::new(Kind::Variable, &n.dictionary, None, n.span.as_ref());
                out.add(
                    &subject,
                    Category::Safe,
                    "module-added",
                    None::<u16>,
                    n.module_id,
                    format!("new module dictionary, MI {}", n.module_id),
                );
            }
        }
    }
    for p in pair(&old.robots, &new.robots, |r| &r.name.wire) {
        if let Pair::Both(o, n) = p {
            robot(old, o, new, n, out);
        }
    }
}

fn span(v: &ModrobVariable) -> Option<&Span> {
    v.spans.table.as_ref()
}

fn module(o: &ModrobModule, n: &ModrobModule, out: &mut Findings) {
    let subject = Subject::new(
        Kind::Variable,
        &n.dictionary,
        o.span.as_ref(),
        n.span.as_ref(),
    );
    if o.module_id != n.module_id {
        out.add(
            &subject,
            Category::Wire,
            "module-id",
            o.module_id,
            n.module_id,
            format!("default MI changed from {} to {}", o.module_id, n.module_id),
        );
    }
    out.description(&subject, &o.description, &n.description);
    for p in pair(&o.variables, &n.variables, |v| &v.name.wire) {
        match p {
            Pair::Both(ov, nv) => variable(&n.dictionary, ov, nv, out),
            Pair::Gone(ov) => {
                let subject = Subject::new(
                    Kind::Variable,
                    format!("{}.{}", n.dictionary, ov.name.wire),
                    span(ov),
                    None,
                );
                out.add(
                    &subject,
                    Category::Api,
                    "variable-removed",
                    ov.vi,
                    None::<u8>,
                    format!("variable removed (VI {})", ov.vi),
                );
            }
            Pair::Added(nv) => {
                let subject = Subject::new(
                    Kind::Variable,
                    format!("{}.{}", n.dictionary, nv.name.wire),
                    None,
                    span(nv),
                );
                // A VI an old variable held and no longer holds: old peers mean that variable.
                let before = (0..nv.count)
                    .find_map(|k| o.variable_at(nv.vi.saturating_add(k)))
                    .filter(|(before, _)| {
                        !n.variables
                            .iter()
                            .any(|v| v.name.wire == before.name.wire && v.vi == before.vi)
                    });
                match before {
                    Some((before, _)) => out.add(
                        &subject,
                        Category::Wire,
                        "vi-reused",
                        before.name.wire.as_str(),
                        nv.name.wire.as_str(),
                        format!(
                            "VI {} held {} and now holds {}",
                            nv.vi, before.name.wire, nv.name.wire
                        ),
                    ),
                    None => out.add(
                        &subject,
                        Category::Safe,
                        "variable-added",
                        None::<u8>,
                        nv.vi,
                        format!("new variable, VI {}", nv.vi),
                    ),
                };
            }
        }
    }
}

fn variable(dictionary: &str, ov: &ModrobVariable, nv: &ModrobVariable, out: &mut Findings) {
    let subject = Subject::new(
        Kind::Variable,
        format!("{dictionary}.{}", nv.name.wire),
        span(ov),
        span(nv),
    );
    if ov.vi != nv.vi {
        out.add(
            &subject,
            Category::Wire,
            "vi-changed",
            ov.vi,
            nv.vi,
            format!("VI changed from {} to {}", ov.vi, nv.vi),
        );
    }
    if ov.count != nv.count {
        out.add(
            &subject,
            Category::Wire,
            "array-length",
            ov.count,
            nv.count,
            format!(
                "array length changed from {} to {}: the VIs after it moved",
                ov.count, nv.count
            ),
        );
    }
    if ov.unit != nv.unit {
        out.add(
            &subject,
            Category::Semantic,
            "units",
            ov.unit.as_str(),
            nv.unit.as_str(),
            format!("unit changed from `{}` to `{}`", ov.unit, nv.unit),
        );
    }
    if ov.direction != nv.direction {
        let dir = |d: Direction| {
            if d == Direction::Input {
                "input"
            } else {
                "output"
            }
        };
        out.add(
            &subject,
            Category::Semantic,
            "direction",
            dir(ov.direction),
            dir(nv.direction),
            format!("now an {}", dir(nv.direction)),
        );
    }
    out.limits(
        &subject,
        (Some(ov.min), Some(ov.max)),
        (Some(nv.min), Some(nv.max)),
    );
    for (code, a, b) in [
        ("default", ov.default, nv.default),
        ("rate", ov.rate, nv.rate),
    ] {
        if a != b {
            out.add(
                &subject,
                Category::Safe,
                code,
                a,
                b,
                format!("{code} changed from {a} to {b}"),
            );
        }
    }
    out.rust_name(&subject, &ov.name.rust, &nv.name.rust);
    out.description(&subject, &ov.description, &nv.description);
}

fn robot(old_ir: &Ir, o: &Robot, new_ir: &Ir, n: &Robot, out: &mut Findings) {
    for p in pair(&o.instances, &n.instances, |i| &i.name.wire) {
        match p {
            Pair::Both(oi, ni) => {
                let subject = Subject::new(
                    Kind::Variable,
                    format!("{}.{}", n.name.wire, ni.name.wire),
                    oi.span.as_ref(),
                    ni.span.as_ref(),
                );
                if oi.module_id != ni.module_id {
                    out.add(
                        &subject,
                        Category::Wire,
                        "module-id",
                        oi.module_id,
                        ni.module_id,
                        format!("MI changed from {} to {}", oi.module_id, ni.module_id),
                    );
                }
                let (od, nd) = (
                    &old_ir.modrob[oi.dictionary].dictionary,
                    &new_ir.modrob[ni.dictionary].dictionary,
                );
                if od != nd {
                    out.add(
                        &subject,
                        Category::Wire,
                        "instance-dictionary",
                        od.as_str(),
                        nd.as_str(),
                        format!("now a {nd} module (was {od})"),
                    );
                }
            }
            Pair::Gone(oi) => {
                let subject = Subject::new(
                    Kind::Variable,
                    format!("{}.{}", n.name.wire, oi.name.wire),
                    oi.span.as_ref(),
                    None,
                );
                out.add(
                    &subject,
                    Category::Api,
                    "instance-removed",
                    oi.module_id,
                    None::<u16>,
                    "module instance removed",
                );
            }
            Pair::Added(ni) => {
                let subject = Subject::new(
                    Kind::Variable,
                    format!("{}.{}", n.name.wire, ni.name.wire),
                    None,
                    ni.span.as_ref(),
                );
                out.add(
                    &subject,
                    Category::Safe,
                    "instance-added",
                    None::<u16>,
                    ni.module_id,
                    format!("new module instance, MI {}", ni.module_id),
                );
            }
        }
    }
}
