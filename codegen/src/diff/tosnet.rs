//! TosNet register maps: area layouts by name, nodes and registers by name.

use super::{type_name, Category, Findings, Kind, Subject};
use crate::ir::{AreaLayout, Ir, Ring};

pub(super) fn diff(old: &Ir, new: &Ir, out: &mut Findings) {
    for o in &old.rings {
        if let Some(n) = new.rings.iter().find(|n| n.name.wire == o.name.wire) {
            ring(o, n, out);
        }
    }
}

fn ring(o: &Ring, n: &Ring, out: &mut Findings) {
    for oa in &o.areas {
        match n.areas.iter().find(|a| a.name.wire == oa.name.wire) {
            Some(na) => area(oa, na, out),
            None => {
                let subject = Subject::new(Kind::Area, &oa.name.wire, oa.span.as_ref(), None);
                out.add(
                    &subject,
                    Category::Api,
                    "area-removed",
                    oa.len,
                    None::<usize>,
                    "area layout removed",
                );
            }
        }
    }
    for na in &n.areas {
        if !o.areas.iter().any(|a| a.name.wire == na.name.wire) {
            let subject = Subject::new(Kind::Area, &na.name.wire, None, na.span.as_ref());
            out.add(
                &subject,
                Category::Safe,
                "area-added",
                None::<usize>,
                na.len,
                "new area layout",
            );
        }
    }
    let area_name =
        |ring: &'_ Ring, index: Option<usize>| index.map(|i| ring.areas[i].name.wire.clone());
    for on in &o.nodes {
        let Some(nn) = n.nodes.iter().find(|x| x.name.wire == on.name.wire) else {
            let subject = Subject::new(Kind::Area, &on.name.wire, on.span.as_ref(), None);
            out.add(
                &subject,
                Category::Wire,
                "node-removed",
                on.id,
                None::<u8>,
                format!("node {} removed: nobody writes its areas", on.id),
            );
            continue;
        };
        let subject = Subject::new(
            Kind::Area,
            &nn.name.wire,
            on.id_span.as_ref(),
            nn.id_span.as_ref(),
        );
        if on.id != nn.id {
            out.add(
                &subject,
                Category::Wire,
                "node-id",
                on.id,
                nn.id,
                format!("node id changed from {} to {}", on.id, nn.id),
            );
        }
        for or in &on.registers {
            let name = format!("{}.{}", nn.name.wire, or.name.wire);
            let Some(nr) = nn.registers.iter().find(|r| r.name.wire == or.name.wire) else {
                let subject = Subject::new(Kind::Area, name, or.span.as_ref(), None);
                out.add(
                    &subject,
                    Category::Wire,
                    "register-removed",
                    or.index,
                    None::<u8>,
                    format!("register {} removed", or.index),
                );
                continue;
            };
            let subject = Subject::new(
                Kind::Area,
                name,
                or.index_span.as_ref(),
                nr.index_span.as_ref(),
            );
            if or.index != nr.index {
                out.add(
                    &subject,
                    Category::Wire,
                    "register-index",
                    or.index,
                    nr.index,
                    format!("register index changed from {} to {}", or.index, nr.index),
                );
            }
            for (dir, a, b) in [
                ("in", or.in_area, nr.in_area),
                ("out", or.out_area, nr.out_area),
            ] {
                let (a, b) = (area_name(o, a), area_name(n, b));
                if a != b {
                    out.add(
                        &subject,
                        Category::Wire,
                        "register-area",
                        a.clone(),
                        b.clone(),
                        format!(
                            "{dir} area changed from {} to {}",
                            a.as_deref().unwrap_or("none"),
                            b.as_deref().unwrap_or("none")
                        ),
                    );
                }
            }
        }
        for nr in &nn.registers {
            if !on.registers.iter().any(|r| r.name.wire == nr.name.wire) {
                let subject = Subject::new(
                    Kind::Area,
                    format!("{}.{}", nn.name.wire, nr.name.wire),
                    None,
                    nr.span.as_ref(),
                );
                out.add(
                    &subject,
                    Category::Safe,
                    "register-added",
                    None::<u8>,
                    nr.index,
                    format!("new register {}", nr.index),
                );
            }
        }
    }
    for nn in &n.nodes {
        if !o.nodes.iter().any(|x| x.name.wire == nn.name.wire) {
            let subject = Subject::new(Kind::Area, &nn.name.wire, None, nn.span.as_ref());
            out.add(
                &subject,
                Category::Safe,
                "node-added",
                None::<u8>,
                nn.id,
                format!("new node {}", nn.id),
            );
        }
    }
}

/// An area's fields by name: where each lies and what it holds.
fn area(o: &AreaLayout, n: &AreaLayout, out: &mut Findings) {
    let place = |f: &crate::ir::Field| format!("{} at byte {}", type_name(f), f.offset);
    for of in &o.fields {
        let name = format!("{}.{}", n.name.wire, of.name.wire);
        let Some(nf) = n.fields.iter().find(|f| f.name.wire == of.name.wire) else {
            let subject = Subject::new(Kind::Area, name, of.span.as_ref(), None);
            out.add(
                &subject,
                Category::Wire,
                "area-field-removed",
                place(of),
                None::<String>,
                format!(
                    "field removed: bytes {}..{} are no longer written",
                    of.offset,
                    of.offset + of.ty.size()
                ),
            );
            continue;
        };
        let subject = Subject::new(Kind::Area, name, of.span.as_ref(), nf.span.as_ref());
        if of.offset != nf.offset || of.ty != nf.ty {
            out.add(
                &subject,
                Category::Wire,
                "area-field",
                place(of),
                place(nf),
                format!("was {}, now {}", place(of), place(nf)),
            );
        }
        out.field_meaning(&subject, of, nf);
        out.rust_name(&subject, &of.name.rust, &nf.name.rust);
        out.description(&subject, &of.description, &nf.description);
    }
    for nf in &n.fields {
        if !o.fields.iter().any(|f| f.name.wire == nf.name.wire) {
            let subject = Subject::new(
                Kind::Area,
                format!("{}.{}", n.name.wire, nf.name.wire),
                None,
                nf.span.as_ref(),
            );
            let bytes = |f: &crate::ir::Field| f.offset..f.offset + f.ty.size();
            let overlapped = o.fields.iter().find(|of| {
                let (a, b) = (bytes(of), bytes(nf));
                a.start < b.end && b.start < a.end
            });
            match overlapped {
                Some(of) => out.add(
                    &subject,
                    Category::Wire,
                    "area-bytes-reused",
                    None::<String>,
                    place(nf),
                    format!(
                        "new field over bytes {}..{} that held {}",
                        nf.offset,
                        nf.offset + nf.ty.size(),
                        of.name.wire
                    ),
                ),
                None => out.add(
                    &subject,
                    Category::Safe,
                    "area-field-added",
                    None::<String>,
                    place(nf),
                    "new field in bytes nobody used",
                ),
            };
        }
    }
}
