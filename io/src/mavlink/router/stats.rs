//! The router's statistics: the JSON line of `--stats-json` and the table of `--stats`, from
//! the routing state.

use super::*;

pub(super) fn counters_json(c: &LinkCounters) -> serde_json::Value {
    let d = &c.drops;
    json!({
        "rx_frames": c.rx_frames, "rx_bytes": c.rx_bytes,
        "tx_frames": c.tx_frames, "tx_bytes": c.tx_bytes,
        "unchecked": c.unchecked, "crc_failures": c.crc_failures,
        "garbage_bytes": c.garbage_bytes, "truncated_datagrams": c.truncated_datagrams,
        "drops": {
            "unsigned": d.unsigned, "bad_signature": d.bad_signature,
            "duplicate": d.duplicate, "filtered_in": d.filtered_in,
            "no_route": d.no_route, "filtered_out": d.filtered_out, "late": d.late,
        },
    })
}

pub(super) fn sorted_links(links: &HashMap<PeerId, Link>) -> Vec<&Link> {
    let mut sorted: Vec<&Link> = links.values().collect();
    sorted.sort_by_key(|l| l.slot);
    sorted
}

/// The line of statistics `--stats-json` writes.
pub(super) fn stats_line(state: &State) -> String {
    stats_json(state).to_string()
}

/// The statistics: per link, per source, and the router's own counts.
pub(super) fn stats_json(state: &State) -> serde_json::Value {
    let (router, links, refused) = (&state.router, &state.links, state.refused);
    let links_json: Vec<_> = sorted_links(links)
        .into_iter()
        .filter_map(|l| {
            let mut c = counters_json(router.link_counters(l.slot)?);
            c["link"] = l.name.clone().into();
            c["tx_errors"] = l.tx_errors.into();
            c["tx_dropped"] = l.sender.dropped().into();
            Some(c)
        })
        .collect();
    let sources: Vec<_> = router
        .sources()
        .map(|s| {
            json!({"sysid": s.sysid, "compid": s.compid, "rx_frames": s.rx_frames,
                   "rx_bytes": s.rx_bytes, "tx_frames": s.tx_frames, "lost": s.lost})
        })
        .collect();
    let r = router.counters();
    let closed = &state.closed;
    let mut closed_json = counters_json(&closed.counters);
    closed_json["links"] = closed.links.into();
    closed_json["tx_errors"] = closed.tx_errors.into();
    closed_json["tx_dropped"] = closed.tx_dropped.into();
    let mut line = json!({
        "t_us": unix_us(),
        "links": links_json,
        "closed": closed_json,
        "sources": sources,
        "routes": router.routes().count(),
        "routes_evicted": r.routes_evicted,
        "sources_evicted": r.sources_evicted,
        "links_refused": refused,
        "junk_datagrams": state.junk_datagrams,
    });
    if let Some(log) = &state.tlog {
        line["tlog_records"] = log.records().into();
        line["tlog_dropped"] = log.dropped().into();
    }
    line
}

/// The statistics table, as `--stats` prints it.
pub(super) fn table(state: &State) -> String {
    use std::fmt::Write as _;

    let (router, links) = (&state.router, &state.links);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<44} {:>9} {:>9} {:>6} {:>8} {:>8} {:>8}",
        "link", "rx", "tx", "crc", "dropped", "tx err", "tx drop"
    );
    for l in sorted_links(links) {
        let Some(c) = router.link_counters(l.slot) else {
            continue;
        };
        let _ = writeln!(
            out,
            "{:<44} {:>9} {:>9} {:>6} {:>8} {:>8} {:>8}",
            l.name,
            c.rx_frames,
            c.tx_frames,
            c.crc_failures,
            c.drops.inbound(),
            l.tx_errors,
            l.sender.dropped()
        );
    }
    let closed = &state.closed;
    if closed.links > 0 {
        let c = &closed.counters;
        let _ = writeln!(
            out,
            "{:<44} {:>9} {:>9} {:>6} {:>8} {:>8} {:>8}",
            format!(
                "({} closed link{})",
                closed.links,
                if closed.links == 1 { "" } else { "s" }
            ),
            c.rx_frames,
            c.tx_frames,
            c.crc_failures,
            c.drops.inbound(),
            closed.tx_errors,
            closed.tx_dropped
        );
    }
    let _ = writeln!(
        out,
        "{:<12} {:>9} {:>9} {:>6}",
        "source", "rx", "tx", "lost"
    );
    for s in router.sources() {
        let _ = writeln!(
            out,
            "{:<12} {:>9} {:>9} {:>6}",
            format!("{}/{}", s.sysid, s.compid),
            s.rx_frames,
            s.tx_frames,
            s.lost
        );
    }
    out.truncate(out.trim_end().len());
    out
}
