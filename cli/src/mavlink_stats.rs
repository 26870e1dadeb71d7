//! `ferrolink mavlink stats`: per source, message rates and sequence loss of a telemetry log,
//! and a plot of both over time: a heat map of message rates (a row per source and message
//! type) above a panel of sequence loss per source, as SVG or PNG.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ferrolink_io::mavlink::tlog;
use ferrolink_runtime::mavlink::router::sequence_gap;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

type BoxResult<T> = Result<T, Box<dyn std::error::Error>>;

/// What drawing on a backend `DB` returns.
type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A sender: (sysid, compid).
type SourceId = (u8, u8);

#[derive(Default)]
struct Source {
    frames: u64,
    lost: u64,
    last_seq: Option<u8>,
    first_us: u64,
    last_us: u64,
    by_message: BTreeMap<String, u64>,
}

impl Source {
    /// Counts a frame with sequence number `seq` at `t_us`; returns how many frames its
    /// sequence number shows lost since the previous one. A number that goes back (a duplicate
    /// or a reordered frame) counts nothing and leaves the expected sequence where it was.
    fn count(&mut self, seq: u8, t_us: u64) -> u64 {
        if self.frames == 0 {
            self.first_us = t_us;
        }
        self.frames += 1;
        self.last_us = self.last_us.max(t_us);
        let gap = match self.last_seq {
            None => Some(0),
            Some(last) => sequence_gap(last, seq).map(u64::from),
        };
        if let Some(gap) = gap {
            self.last_seq = Some(seq);
            self.lost += gap;
        }
        gap.unwrap_or(0)
    }
}

/// Counts per second since the first frame, gathered while reading; binned when drawn.
#[derive(Default)]
struct Timeline {
    /// The first frame's timestamp.
    start_us: Option<u64>,
    /// Frames per second, per source and message name.
    frames: BTreeMap<(SourceId, String), BTreeMap<u64, u64>>,
    /// Per source, frames received and frames lost (by sequence gaps) per second.
    seq: BTreeMap<SourceId, BTreeMap<u64, (u64, u64)>>,
}

impl Timeline {
    /// Counts a frame `name` of `source` at `t_us` that showed `lost` frames missing before it.
    /// Timestamps before the first frame's count as its second.
    fn add(&mut self, source: SourceId, name: String, t_us: u64, lost: u64) {
        let start = *self.start_us.get_or_insert(t_us);
        let second = t_us.saturating_sub(start) / 1_000_000;
        *self
            .frames
            .entry((source, name))
            .or_default()
            .entry(second)
            .or_default() += 1;
        let cell = self
            .seq
            .entry(source)
            .or_default()
            .entry(second)
            .or_default();
        cell.0 += 1;
        cell.1 += lost;
    }

    /// One past the last second that holds a frame (at least 1).
    fn seconds(&self) -> u64 {
        self.seq
            .values()
            .filter_map(|s| s.keys().next_back())
            .max()
            .map_or(1, |s| s + 1)
    }
}

/// `ferrolink mavlink stats`: reads `file`, writes the plot to `plot` when asked (SVG or PNG by
/// its extension), then prints the table.
pub fn run(dialect: &[PathBuf], plot: Option<&Path>, file: &Path) -> BoxResult<ExitCode> {
    // Refuse an unusable plot before reading anything.
    let plot = plot
        .map(|path| PlotFormat::of(path).map(|format| (path, format)))
        .transpose()?;
    let dialects = crate::dialect::load(dialect, crate::dialect::DEFAULT)?;
    let failed = |e: std::io::Error| format!("{}: {e}", file.display());
    let mut sources: BTreeMap<SourceId, Source> = BTreeMap::new();
    let mut timeline = Timeline::default();
    let names = dialects.names();
    let mut reader = tlog::LogReader::open(file, &dialects.table[..], false)?;
    let stats = reader.read_all(|record| {
        let header = record.frame.header();
        let t = record.t_us.unwrap_or(0);
        let name = names
            .get(&record.frame.msg_id())
            .map_or_else(|| format!("#{}", record.frame.msg_id()), String::clone);
        let id = (header.sysid, header.compid);
        let source = sources.entry(id).or_default();
        let lost = source.count(header.seq, t);
        *source.by_message.entry(name.clone()).or_default() += 1;
        timeline.add(id, name, t, lost);
    });
    let stats = stats.map_err(failed)?;
    // The plot first: a closed stdout must not keep it from being written.
    if let Some((path, format)) = plot {
        let drawn =
            draw(path, format, file, &timeline).map_err(|e| format!("{}: {e}", path.display()))?;
        eprintln!("{}: plot written, {drawn}", path.display());
    }
    print_table(&mut std::io::stdout().lock(), &sources, &stats)?;
    Ok(ExitCode::SUCCESS)
}

/// The text report: a line per source, a line per message type under it, and the reader's
/// counts. A write error (a closed pipe) ends it and is returned.
fn print_table(
    out: &mut impl Write,
    sources: &BTreeMap<SourceId, Source>,
    stats: &tlog::ReadStats,
) -> std::io::Result<()> {
    writeln!(
        out,
        "{:<10} {:>9} {:>9} {:>9} {:>7} {:>7}",
        "source", "frames", "seconds", "per s", "lost", "loss %"
    )?;
    for ((sysid, compid), s) in sources {
        let seconds = (s.last_us.saturating_sub(s.first_us)) as f64 / 1e6;
        let rate = |n: u64| {
            if seconds > 0.0 {
                n as f64 / seconds
            } else {
                0.0
            }
        };
        let loss = 100.0 * s.lost as f64 / (s.lost + s.frames) as f64;
        writeln!(
            out,
            "{:<10} {:>9} {:>9.1} {:>9.1} {:>7} {:>7.2}",
            format!("{sysid}/{compid}"),
            s.frames,
            seconds,
            rate(s.frames),
            s.lost,
            loss
        )?;
        for (name, n) in &s.by_message {
            writeln!(out, "  {name:<34} {n:>9} {:>9.2} /s", rate(*n))?;
        }
    }
    writeln!(
        out,
        "{} frame(s), {} recovered after damage, {} bad CRC, {} bytes skipped, {} truncated",
        stats.frames, stats.resynced, stats.bad_crc, stats.skipped_bytes, stats.truncated_bytes
    )?;
    out.flush()
}

// ---- The plot --------------------------------------------------------------------------------

/// The font family all text is drawn in; for PNG it is registered under this name.
const FONT: &str = "sans-serif";
/// Where a PNG plot looks for a TrueType font, in order.
const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// At most this many time bins (columns of the heat map).
const MAX_BINS: u64 = 600;
/// Outer margin, pixels.
const MARGIN: i32 = 10;
/// Height of a heat map row.
const ROW_PX: i32 = 14;
/// The heat map's least height, so that a few rows still leave room for the colour bar.
const MIN_HEAT_PX: i32 = 150;
/// Width of the data (both panels).
const DATA_PX: i32 = 960;
/// Width of the column right of the data: colour bar, legend.
const SIDE_PX: i32 = 240;
/// Height of the loss panel's data, at least.
const LOSS_PX: i32 = 160;
/// Height under a panel for the time axis's ticks, labels and title.
const AXIS_PX: i32 = 44;
/// A generous width of one character of a row label, to size the label column.
const CHAR_PX: i32 = 8;
/// Spacing of the loss legend's lines.
const LEGEND_ROW_PX: i32 = 18;
/// Font sizes.
const TITLE_SIZE: f64 = 18.0;
const TEXT_SIZE: f64 = 13.0;
const TICK_SIZE: f64 = 12.0;
/// Cells without frames.
const EMPTY: RGBColor = RGBColor(248, 248, 248);
const GREY: RGBColor = RGBColor(170, 170, 170);
const LIGHT_GREY: RGBColor = RGBColor(225, 225, 225);
/// Viridis (0xRRGGBB), evenly spaced from 0 to 1.
const VIRIDIS: [u32; 10] = [
    0x440154, 0x482878, 0x3E4A89, 0x31688E, 0x26828E, 0x1F9E89, 0x35B779, 0x6DCD59, 0xB4DE2C,
    0xFDE725,
];
/// Line colours of the loss panel, one per source (Tableau 10).
const LINES: [u32; 10] = [
    0x1F77B4, 0xFF7F0E, 0x2CA02C, 0xD62728, 0x9467BD, 0x8C564B, 0xE377C2, 0x7F7F7F, 0xBCBD22,
    0x17BECF,
];

/// The plot's file format.
#[derive(Clone, Copy)]
enum PlotFormat {
    Svg,
    Png,
}

impl PlotFormat {
    /// The format `path`'s extension asks for. PNG text needs a font, so PNG also loads one.
    fn of(path: &Path) -> BoxResult<Self> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("svg") => Ok(Self::Svg),
            Some("png") => load_font().map(|()| Self::Png),
            _ => Err(format!(
                "{}: cannot tell the plot's format: name it FILE.svg or FILE.png",
                path.display()
            )
            .into()),
        }
    }
}

/// Registers the first usable font of [`FONT_PATHS`] as [`FONT`], once per process: the plotting
/// crate keeps a registered font for the life of the process.
fn load_font() -> BoxResult<()> {
    static LOADED: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    LOADED
        .get_or_init(|| register_font().map_err(|e| e.to_string()))
        .clone()
        .map_err(Into::into)
}

fn register_font() -> BoxResult<()> {
    for path in FONT_PATHS {
        let Ok(bytes) = std::fs::read(path) else {
            continue;
        };
        // Registered once (see `load_font`), for the life of the process.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        if plotters::style::register_font(FONT, FontStyle::Normal, bytes).is_ok() {
            return Ok(());
        }
    }
    Err(format!(
        "a PNG plot needs a TrueType font for its text, and none of these is there: {}\n  \
         hint: write the plot as .svg, which needs no font, or install one \
         (e.g. apt install fonts-dejavu-core)",
        FONT_PATHS.join(", ")
    )
    .into())
}

/// The plot's data: time bins, the heat map's rows and each source's loss, per bin.
struct Grid {
    /// Width of a bin, seconds.
    bin_s: u64,
    /// Number of bins.
    bins: usize,
    /// The heat map's rows, grouped by source.
    rows: Vec<Row>,
    /// Per source, frames received and lost per bin.
    loss: Vec<(SourceId, Vec<(u64, u64)>)>,
}

/// A heat map row: one message type of one source.
struct Row {
    source: SourceId,
    label: String,
    /// Frames per bin.
    counts: Vec<u64>,
}

impl Grid {
    /// Bins `timeline` into at most [`MAX_BINS`] bins of a round width.
    fn new(timeline: &Timeline) -> Self {
        let seconds = timeline.seconds();
        let bin_s = bin_width(seconds);
        let bins = seconds.div_ceil(bin_s).max(1) as usize;
        let bin = |second: u64| ((second / bin_s) as usize).min(bins - 1);
        let rows = timeline
            .frames
            .iter()
            .map(|((source, name), per_second)| {
                let mut counts = vec![0u64; bins];
                for (second, n) in per_second {
                    counts[bin(*second)] += *n;
                }
                let label = format!("{}/{} {name}", source.0, source.1);
                Row {
                    source: *source,
                    label,
                    counts,
                }
            })
            .collect();
        let loss = timeline
            .seq
            .iter()
            .map(|(source, per_second)| {
                let mut cells = vec![(0u64, 0u64); bins];
                for (second, (received, lost)) in per_second {
                    let cell = &mut cells[bin(*second)];
                    cell.0 += *received;
                    cell.1 += *lost;
                }
                (*source, cells)
            })
            .collect();
        Self {
            bin_s,
            bins,
            rows,
            loss,
        }
    }

    /// The time the bins cover, seconds.
    fn span_s(&self) -> f64 {
        (self.bins as u64 * self.bin_s) as f64
    }

    /// Heat map cells with frames.
    fn cells(&self) -> usize {
        let nonzero = |r: &Row| r.counts.iter().filter(|n| **n > 0).count();
        self.rows.iter().map(nonzero).sum()
    }

    /// The colour scale: from the least rate of a cell with frames to the greatest.
    fn scale(&self) -> Scale {
        let counts = self.rows.iter().flat_map(|r| r.counts.iter().copied());
        let (lo, hi) = counts
            .filter(|n| *n > 0)
            .fold((u64::MAX, 0), |(lo, hi), n| (lo.min(n), hi.max(n)));
        let per_s = |n: u64| n as f64 / self.bin_s as f64;
        let lo = per_s(lo.min(hi).max(1));
        let hi = per_s(hi).max(lo);
        // One rate only: show it at the dark end of a decade.
        let hi = if hi > lo * 1.000_001 { hi } else { lo * 10.0 };
        Scale { lo, hi }
    }
}

/// The narrowest round bin width (seconds) that covers `seconds` in at most [`MAX_BINS`] bins.
fn bin_width(seconds: u64) -> u64 {
    const ROUND: [u64; 15] = [
        1, 2, 5, 10, 15, 20, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200,
    ];
    ROUND
        .into_iter()
        .find(|w| seconds.div_ceil(*w) <= MAX_BINS)
        .unwrap_or_else(|| seconds.div_ceil(MAX_BINS))
}

/// The heat map's log colour scale, in messages per second.
struct Scale {
    lo: f64,
    hi: f64,
}

impl Scale {
    /// Where `rate` falls on the scale, 0 to 1.
    fn position(&self, rate: f64) -> f64 {
        let (lo, hi) = (self.lo.log10(), self.hi.log10());
        ((rate.log10() - lo) / (hi - lo)).clamp(0.0, 1.0)
    }

    /// Round rates to label the scale with: the powers of ten within it, with 2 and 5 times
    /// them when the powers alone are fewer than three; its ends when nothing round falls in.
    fn ticks(&self) -> Vec<f64> {
        let (first, last) = (
            self.lo.log10().floor() as i32,
            self.hi.log10().ceil() as i32,
        );
        let within = |v: f64| (self.lo * 0.999_999..=self.hi * 1.000_001).contains(&v);
        for multiples in [&[1.0] as &[f64], &[1.0, 2.0, 5.0]] {
            let ticks: Vec<f64> = (first..=last)
                .flat_map(move |k| multiples.iter().map(move |m| m * 10f64.powi(k)))
                .filter(|v| within(*v))
                .collect();
            if ticks.len() >= 3 || (multiples.len() > 1 && !ticks.is_empty()) {
                return ticks;
            }
        }
        vec![self.lo, self.hi]
    }
}

/// The colour 0xRRGGBB.
fn rgb(hex: u32) -> RGBColor {
    let [_, r, g, b] = hex.to_be_bytes();
    RGBColor(r, g, b)
}

/// The viridis colour at `x`, 0 (dark) to 1 (bright).
fn viridis(x: f64) -> RGBColor {
    let at = x.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let i = (at.floor() as usize).min(VIRIDIS.len() - 2);
    let f = at - i as f64;
    let (a, b) = (rgb(VIRIDIS[i]), rgb(VIRIDIS[i + 1]));
    let mix = |a: u8, b: u8| (f64::from(a) + (f64::from(b) - f64::from(a)) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// A rate as a tick label: as many decimals as its first significant digit needs.
fn rate_label(v: f64) -> String {
    if v >= 1.0 {
        format!("{v:.0}")
    } else {
        let decimals = (-v.log10().floor()).max(0.0) as usize;
        format!("{:.*}", decimals, v)
    }
}

/// A round step (1, 2 or 5 times a power of ten) that cuts `span` into at most `parts` parts.
fn tick_step(span: f64, parts: f64) -> f64 {
    let raw = span / parts;
    let magnitude = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * magnitude)
}

/// Share of a bin's frames lost, percent; `None` for a bin without frames.
fn loss_percent((received, lost): (u64, u64)) -> Option<f64> {
    match received + lost {
        0 => None,
        sent => Some(100.0 * lost as f64 / sent as f64),
    }
}

/// The `i`th of `n + 1` evenly spaced positions from `from` to `to`.
fn edge(from: i32, to: i32, i: usize, n: usize) -> i32 {
    from + (f64::from(to - from) * i as f64 / n.max(1) as f64).round() as i32
}

/// Where things go, in pixels.
struct Layout {
    width: u32,
    height: u32,
    /// The data's left and right edges (both panels).
    left: i32,
    right: i32,
    heat_top: i32,
    heat_bottom: i32,
    loss_top: i32,
    loss_bottom: i32,
}

impl Layout {
    /// Room for every row label and heat map row, and for every source in the loss legend.
    fn new(grid: &Grid) -> Self {
        let label_chars = grid.rows.iter().map(|r| r.label.chars().count()).max();
        let label_px = (label_chars.unwrap_or(0) as i32 * CHAR_PX).max(60);
        let left = MARGIN + label_px + 8;
        let right = left + DATA_PX;
        let heat_top = MARGIN + 48;
        let heat_bottom = heat_top + (grid.rows.len() as i32 * ROW_PX).max(MIN_HEAT_PX);
        let loss_top = heat_bottom + AXIS_PX + 36;
        let legend_px = grid.loss.len() as i32 * LEGEND_ROW_PX + 10;
        let loss_bottom = loss_top + LOSS_PX.max(legend_px);
        Self {
            width: (right + SIDE_PX + MARGIN) as u32,
            height: (loss_bottom + AXIS_PX + MARGIN) as u32,
            left,
            right,
            heat_top,
            heat_bottom,
            loss_top,
            loss_bottom,
        }
    }

    /// The x of the left edge of bin `i` of `bins` (`i == bins`: the right edge of the data).
    fn column(&self, i: usize, bins: usize) -> i32 {
        edge(self.left, self.right, i, bins)
    }

    /// The x of the middle of bin `i` of `bins`.
    fn centre(&self, i: usize, bins: usize) -> i32 {
        edge(self.left, self.right, 2 * i + 1, 2 * bins)
    }

    /// The x of `t` seconds on a time axis `span` seconds long.
    fn time(&self, t: f64, span: f64) -> i32 {
        self.left + (t / span * f64::from(self.right - self.left)).round() as i32
    }
}

/// Draws the plot of `timeline`, read from `log`, into `path`; says what it drew.
fn draw(path: &Path, format: PlotFormat, log: &Path, timeline: &Timeline) -> BoxResult<String> {
    let grid = Grid::new(timeline);
    let layout = Layout::new(&grid);
    let size = (layout.width, layout.height);
    let title = format!(
        "{}: message rates and sequence loss",
        log.file_name().unwrap_or_default().to_string_lossy()
    );
    let (grid, layout) = (&grid, &layout);
    match format {
        PlotFormat::Svg => {
            let root = SVGBackend::new(path, size).into_drawing_area();
            Painter { root, grid, layout }.paint(&title)?;
        }
        PlotFormat::Png => {
            let root = BitMapBackend::new(path, size).into_drawing_area();
            Painter { root, grid, layout }.paint(&title)?;
        }
    }
    Ok(format!(
        "{}x{} px, {} rows, {} bins of {} s, {} cells",
        layout.width,
        layout.height,
        grid.rows.len(),
        grid.bins,
        grid.bin_s,
        grid.cells()
    ))
}

/// Draws a [`Grid`] laid out by a [`Layout`] on a backend.
struct Painter<'a, DB: DrawingBackend> {
    root: DrawingArea<DB, Shift>,
    grid: &'a Grid,
    layout: &'a Layout,
}

impl<DB: DrawingBackend> Painter<'_, DB> {
    /// The whole plot: title, heat map with its colour bar, loss panel with its legend.
    fn paint(&self, title: &str) -> DrawResult<DB> {
        self.root.fill(&WHITE)?;
        let anchor = (HPos::Left, VPos::Top);
        self.text(title, (MARGIN, MARGIN), TITLE_SIZE, anchor)?;
        let scale = self.grid.scale();
        self.heat_map(&scale)?;
        self.colour_bar(&scale)?;
        self.loss_panel()?;
        self.root.present()
    }

    /// Draws `s` at `pos`, anchored there by `anchor`, in black.
    fn text(&self, s: &str, pos: (i32, i32), size: f64, anchor: (HPos, VPos)) -> DrawResult<DB> {
        let style = TextStyle::from((FONT, size).into_font())
            .color(&BLACK)
            .pos(Pos::new(anchor.0, anchor.1));
        self.root.draw_text(s, &style, pos)
    }

    /// A straight line from `a` to `b`.
    fn line(&self, a: (i32, i32), b: (i32, i32), style: ShapeStyle) -> DrawResult<DB> {
        self.root.draw(&PathElement::new(vec![a, b], style))
    }

    /// A rectangle from corner `a` to corner `b`, filled or outlined as `style` says.
    fn rect(&self, a: (i32, i32), b: (i32, i32), style: ShapeStyle) -> DrawResult<DB> {
        self.root.draw(&Rectangle::new([a, b], style))
    }

    /// Panel 1: a row per source and message type, labelled at the left, a cell per time bin
    /// coloured by the rate in it; a line between sources.
    fn heat_map(&self, scale: &Scale) -> DrawResult<DB> {
        let (grid, layout) = (self.grid, self.layout);
        let (top, bottom) = (layout.heat_top, layout.heat_bottom);
        let caption = "messages per second, per source (sysid/compid) and message type";
        let anchor = (HPos::Left, VPos::Bottom);
        self.text(caption, (layout.left, top - 6), TEXT_SIZE, anchor)?;
        let (corner, far) = ((layout.left, top), (layout.right, bottom));
        self.rect(corner, far, EMPTY.filled())?;
        let n = grid.rows.len();
        for (i, row) in grid.rows.iter().enumerate() {
            let (y0, y1) = (edge(top, bottom, i, n), edge(top, bottom, i + 1, n));
            for (j, count) in row.counts.iter().enumerate().filter(|(_, c)| **c > 0) {
                let x0 = layout.column(j, grid.bins);
                let x1 = layout.column(j + 1, grid.bins).max(x0 + 1);
                let colour = viridis(scale.position(*count as f64 / grid.bin_s as f64));
                self.rect((x0, y0), (x1, y1), colour.filled())?;
            }
            let anchor = (HPos::Right, VPos::Center);
            let at = (layout.left - 6, (y0 + y1) / 2);
            self.text(&row.label, at, TEXT_SIZE, anchor)?;
            if i > 0 && grid.rows[i - 1].source != row.source {
                self.line((MARGIN, y0), (layout.right, y0), GREY.stroke_width(1))?;
            }
        }
        if n == 0 {
            let middle = ((layout.left + layout.right) / 2, (top + bottom) / 2);
            let anchor = (HPos::Center, VPos::Center);
            self.text("no frames", middle, TEXT_SIZE, anchor)?;
        }
        self.rect(corner, far, GREY.stroke_width(1))?;
        self.time_axis(bottom)
    }

    /// The heat map's colour scale, right of it: msg/s on a log scale.
    fn colour_bar(&self, scale: &Scale) -> DrawResult<DB> {
        let layout = self.layout;
        let (x0, x1) = (layout.right + 20, layout.right + 36);
        let top = layout.heat_top;
        let bottom = top + (layout.heat_bottom - top).min(320);
        let anchor = (HPos::Left, VPos::Bottom);
        self.text("msg/s", (x0, top - 6), TEXT_SIZE, anchor)?;
        let height = f64::from(bottom - top);
        for y in top..bottom {
            let colour = viridis(1.0 - f64::from(y - top) / height);
            self.rect((x0, y), (x1, y + 1), colour.filled())?;
        }
        self.rect((x0, top), (x1, bottom), GREY.stroke_width(1))?;
        for tick in scale.ticks() {
            let y = bottom - (scale.position(tick) * height).round() as i32;
            self.line((x1, y), (x1 + 4, y), BLACK.stroke_width(1))?;
            let anchor = (HPos::Left, VPos::Center);
            self.text(&rate_label(tick), (x1 + 7, y), TICK_SIZE, anchor)?;
        }
        Ok(())
    }

    /// Panel 2: per source, the share of its frames lost in each bin as a line (broken where
    /// the source sent nothing), with a legend right of it.
    fn loss_panel(&self) -> DrawResult<DB> {
        let (grid, layout) = (self.grid, self.layout);
        let (top, bottom) = (layout.loss_top, layout.loss_bottom);
        let caption = "sequence loss per bin, % of the frames each source sent";
        let anchor = (HPos::Left, VPos::Bottom);
        self.text(caption, (layout.left, top - 6), TEXT_SIZE, anchor)?;
        let all = grid
            .loss
            .iter()
            .flat_map(|(_, cells)| cells.iter().copied());
        let peak = all.filter_map(loss_percent).fold(0.0, f64::max);
        let y_max = tick_step(peak.max(1.0), 1.0).min(100.0);
        let y = |percent: f64| bottom - (percent / y_max * f64::from(bottom - top)).round() as i32;
        self.loss_axis(y_max, &y)?;
        for (i, (source, cells)) in grid.loss.iter().enumerate() {
            let colour = rgb(LINES[i % LINES.len()]);
            let mut run = Vec::new();
            for (j, cell) in cells.iter().enumerate() {
                match loss_percent(*cell) {
                    Some(percent) => run.push((layout.centre(j, grid.bins), y(percent))),
                    None => self.draw_run(&mut run, colour)?,
                }
            }
            self.draw_run(&mut run, colour)?;
            let sum = |(r, l): (u64, u64), (received, lost): &(u64, u64)| (r + received, l + lost);
            let (received, lost) = cells.iter().fold((0u64, 0u64), sum);
            let percent = loss_percent((received, lost)).unwrap_or(0.0);
            let label = format!("{}/{}: {lost} lost ({percent:.1} %)", source.0, source.1);
            let (x, at) = (layout.right + 20, top + 8 + i as i32 * LEGEND_ROW_PX);
            self.line((x, at), (x + 20, at), colour.stroke_width(3))?;
            let anchor = (HPos::Left, VPos::Center);
            self.text(&label, (x + 26, at), TICK_SIZE, anchor)?;
        }
        let (corner, far) = ((layout.left, top), (layout.right, bottom));
        self.rect(corner, far, GREY.stroke_width(1))?;
        self.time_axis(bottom)
    }

    /// The loss panel's y axis: grid lines and percent labels from 0 to `y_max`, placed by `y`.
    fn loss_axis(&self, y_max: f64, y: &dyn Fn(f64) -> i32) -> DrawResult<DB> {
        let layout = self.layout;
        let step = tick_step(y_max, 4.0);
        let decimals = usize::from(step < 1.0);
        for k in 0..=(y_max / step + 1e-9).floor() as u32 {
            let percent = f64::from(k) * step;
            let at = y(percent);
            let style = LIGHT_GREY.stroke_width(1);
            self.line((layout.left, at), (layout.right, at), style)?;
            let label = format!("{:.*}", decimals, percent);
            let anchor = (HPos::Right, VPos::Center);
            self.text(&label, (layout.left - 6, at), TICK_SIZE, anchor)?;
        }
        Ok(())
    }

    /// Draws the points of `run` joined by a line (one point alone as a short dash), and
    /// empties it.
    fn draw_run(&self, run: &mut Vec<(i32, i32)>, colour: RGBColor) -> DrawResult<DB> {
        let style = colour.stroke_width(2);
        match run.as_slice() {
            [] => {}
            [(x, y)] => self.line((x - 2, *y), (x + 2, *y), style)?,
            points => self.root.draw(&PathElement::new(points.to_vec(), style))?,
        }
        run.clear();
        Ok(())
    }

    /// The time axis under a panel whose bottom edge is `y`: ticks, their labels and a title
    /// that says the bin width.
    fn time_axis(&self, y: i32) -> DrawResult<DB> {
        let (grid, layout) = (self.grid, self.layout);
        let span = grid.span_s();
        // As many ticks as their labels leave room for, at most ten.
        let label_px = format!("{span:.0}").len() as f64 * 8.0 + 24.0;
        let parts = (f64::from(layout.right - layout.left) / label_px).clamp(2.0, 10.0);
        let step = tick_step(span, parts).max(1.0);
        for k in 0..=(span / step + 1e-9).floor() as u64 {
            let t = k as f64 * step;
            let x = layout.time(t, span);
            self.line((x, y), (x, y + 4), BLACK.stroke_width(1))?;
            let anchor = (HPos::Center, VPos::Top);
            self.text(&format!("{t:.0}"), (x, y + 6), TICK_SIZE, anchor)?;
        }
        let bins = match grid.bin_s {
            1 => "1 s bins".to_owned(),
            s => format!("bins of {s} s"),
        };
        let title = format!("seconds since the first frame ({bins})");
        let middle = ((layout.left + layout.right) / 2, y + 24);
        self.text(&title, middle, TICK_SIZE, (HPos::Center, VPos::Top))
    }
}
