//! `ferrolink mavlink stats`: per source, message rates and sequence loss of a telemetry log,
//! and a plot of message rates over time.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ferrolink_io::mavlink::tlog;
use ferrolink_runtime::mavlink::find_meta;
use ferrolink_runtime::mavlink::router::sequence_gap;
use plotters::prelude::*;

use crate::dialect::Dialects;

#[derive(Default)]
struct Source {
    frames: u64,
    lost: u64,
    last_seq: Option<u8>,
    first_us: u64,
    last_us: u64,
    by_message: BTreeMap<String, u64>,
}

pub fn run(
    dialect: &[PathBuf],
    plot: Option<&Path>,
    file: &Path,
) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let dialects = Dialects::load(dialect)?;
    let data = std::fs::read(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let mut sources: BTreeMap<(u8, u8), Source> = BTreeMap::new();
    // Frames per message type per second since the first frame.
    let mut timeline: BTreeMap<String, BTreeMap<u64, u64>> = BTreeMap::new();
    let mut start_us = None;
    let stats = tlog::read_tlog(&data, dialects.table, |record| {
        let header = record.frame.header();
        let t = record.t_us.unwrap_or(0);
        let name = find_meta(dialects.table, record.frame.msg_id()).map_or_else(
            || format!("#{}", record.frame.msg_id()),
            |m| m.name.to_owned(),
        );
        let source = sources.entry((header.sysid, header.compid)).or_default();
        if source.frames == 0 {
            source.first_us = t;
        }
        source.frames += 1;
        source.last_us = source.last_us.max(t);
        if let Some(last) = source.last_seq {
            if let Some(gap) = sequence_gap(last, header.seq) {
                source.lost += u64::from(gap);
                source.last_seq = Some(header.seq);
            }
        } else {
            source.last_seq = Some(header.seq);
        }
        *source.by_message.entry(name.clone()).or_default() += 1;
        let start = *start_us.get_or_insert(t);
        *timeline
            .entry(name)
            .or_default()
            .entry(t.saturating_sub(start) / 1_000_000)
            .or_default() += 1;
    });
    println!(
        "{:<10} {:>9} {:>9} {:>9} {:>7} {:>7}",
        "source", "frames", "seconds", "per s", "lost", "loss %"
    );
    for ((sysid, compid), s) in &sources {
        let seconds = (s.last_us.saturating_sub(s.first_us)) as f64 / 1e6;
        let rate = |n: u64| {
            if seconds > 0.0 {
                n as f64 / seconds
            } else {
                0.0
            }
        };
        let loss = 100.0 * s.lost as f64 / (s.lost + s.frames) as f64;
        println!(
            "{:<10} {:>9} {:>9.1} {:>9.1} {:>7} {:>7.2}",
            format!("{sysid}/{compid}"),
            s.frames,
            seconds,
            rate(s.frames),
            s.lost,
            loss
        );
        for (name, n) in &s.by_message {
            println!("  {name:<34} {n:>9} {:>9.2} /s", rate(*n));
        }
    }
    println!(
        "{} frame(s), {} recovered after damage, {} bad CRC, {} bytes skipped, {} truncated",
        stats.frames, stats.resynced, stats.bad_crc, stats.skipped_bytes, stats.truncated_bytes
    );
    if let Some(path) = plot {
        draw(path, file, &timeline)?;
        eprintln!("{}: plot written", path.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// Message rate over time per message type, one line each, as SVG.
fn draw(
    path: &Path,
    log: &Path,
    timeline: &BTreeMap<String, BTreeMap<u64, u64>>,
) -> Result<(), Box<dyn std::error::Error>> {
    let seconds = timeline
        .values()
        .filter_map(|t| t.keys().next_back())
        .max()
        .copied()
        .unwrap_or(0)
        + 1;
    let peak = timeline
        .values()
        .flat_map(|t| t.values())
        .max()
        .copied()
        .unwrap_or(1);
    let root = SVGBackend::new(path, (1200, 700)).into_drawing_area();
    root.fill(&WHITE)?;
    let title = format!(
        "message rate per type: {}",
        log.file_name().unwrap_or_default().to_string_lossy()
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .right_y_label_area_size(0)
        .build_cartesian_2d(0u64..seconds, 0u64..peak + 1)?;
    chart
        .configure_mesh()
        .x_desc("seconds since the first frame")
        .y_desc("messages per second")
        .draw()?;
    for (i, (name, series)) in timeline.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let points = (0..seconds).map(|s| (s, series.get(&s).copied().unwrap_or(0)));
        chart
            .draw_series(LineSeries::new(points, color.stroke_width(1)))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 15, y)], color));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 11))
        .draw()?;
    root.present()?;
    Ok(())
}
