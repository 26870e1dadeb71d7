//! TosNet register maps: area layouts, nodes and registers, each by name.

use super::{pair, type_name, Category, Findings, Kind, Pair, Subject};
use crate::ir::{AreaLayout, Field, Ir, Ring};

pub(super) fn diff(old: &Ir, new: &Ir, out: &mut Findings) {
    for p in pair(&old.rings, &new.rings, |r| &r.name.wire) {
        if let Pair::Both(o, n) = p {
            ring(o, n, out);
        }
    }
}

fn ring(o: &Ring, n: &Ring, out: &mut Findings) {
    for p in pair(&o.areas, &n.areas, |a| &a.name.wire) {
        match p {
            Pair::Both(oa, na) => area(oa, na, out),
            Pair::Gone(oa) => {
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
            Pair::Added(na) => {
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
    }
    let area_name =
        |ring: &Ring, index: Option<usize>| index.map(|i| ring.areas[i].name.wire.clone());
    for p in pair(&o.nodes, &n.nodes, |x| &x.name.wire) {
        let (on, nn) = match p {
            Pair::Both(on, nn) => (on, nn),
            Pair::Gone(on) => {
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
            }
            Pair::Added(nn) => {
                let subject = Subject::new(Kind::Area, &nn.name.wire, None, nn.span.as_ref());
                out.add(
                    &subject,
                    Category::Safe,
                    "node-added",
                    None::<u8>,
                    nn.id,
                    format!("new node {}", nn.id),
                );
                continue;
            }
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
        for p in pair(&on.registers, &nn.registers, |r| &r.name.wire) {
            match p {
                Pair::Both(or, nr) => {
                    let name = format!("{}.{}", nn.name.wire, nr.name.wire);
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
                            let reason = format!(
                                "{dir} area changed from {} to {}",
                                a.as_deref().unwrap_or("none"),
                                b.as_deref().unwrap_or("none")
                            );
                            out.add(&subject, Category::Wire, "register-area", a, b, reason);
                        }
                    }
                }
                Pair::Gone(or) => {
                    let subject = Subject::new(
                        Kind::Area,
                        format!("{}.{}", nn.name.wire, or.name.wire),
                        or.span.as_ref(),
                        None,
                    );
                    out.add(
                        &subject,
                        Category::Wire,
                        "register-removed",
                        or.index,
                        None::<u8>,
                        format!("register {} removed", or.index),
                    );
                }
                Pair::Added(nr) => {
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
    }
}

/// An area's fields by name: where each lies and what it holds.
fn area(o: &AreaLayout, n: &AreaLayout, out: &mut Findings) {
    let place = |f: &Field| format!("{} at byte {}", type_name(f), f.offset);
    let bytes = |f: &Field| f.offset..f.offset + f.ty.size();
    for p in pair(&o.fields, &n.fields, |f| &f.name.wire) {
        match p {
            Pair::Both(of, nf) => {
                let name = format!("{}.{}", n.name.wire, nf.name.wire);
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
            Pair::Gone(of) => {
                let name = format!("{}.{}", n.name.wire, of.name.wire);
                let subject = Subject::new(Kind::Area, name, of.span.as_ref(), None);
                let b = bytes(of);
                out.add(
                    &subject,
                    Category::Wire,
                    "area-field-removed",
                    place(of),
                    None::<String>,
                    format!(
                        "field removed: bytes {}..{} are no longer written",
                        b.start, b.end
                    ),
                );
            }
            Pair::Added(nf) => {
                let name = format!("{}.{}", n.name.wire, nf.name.wire);
                let subject = Subject::new(Kind::Area, name, None, nf.span.as_ref());
                let b = bytes(nf);
                // Bytes an old field used: old writers still put that field there.
                match o
                    .fields
                    .iter()
                    .find(|of| bytes(of).start < b.end && b.start < bytes(of).end)
                {
                    Some(of) => out.add(
                        &subject,
                        Category::Wire,
                        "area-bytes-reused",
                        None::<String>,
                        place(nf),
                        format!(
                            "new field over bytes {}..{} that held {}",
                            b.start, b.end, of.name.wire
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
}
