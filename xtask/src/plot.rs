//! Line and scatter charts written as SVG and PNG.
//!
//! PNG text is drawn with the bundled DejaVu Sans (`data/fonts`), registered through plotters'
//! `ab_glyph` feature, so no system fonts or fontconfig are needed on a fresh machine.

use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{Context, Result, anyhow};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

static FONT: &[u8] = include_bytes!("../../data/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    /// Polyline through the points in order.
    Line,
    /// One circle per point.
    Points,
}

/// One named data series.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// (x, y) pairs; non-finite pairs (and non-positive ones on a log axis) are skipped.
    pub points: Vec<(f64, f64)>,
    /// Line, points or both.
    pub mark: Mark,
}

/// A chart with one or more series.
#[derive(Clone, Debug)]
pub struct Chart {
    /// Caption above the plot.
    pub title: String,
    /// Label of the horizontal axis.
    pub x_label: String,
    /// Label of the vertical axis.
    pub y_label: String,
    /// Logarithmic horizontal axis.
    pub log_x: bool,
    /// Logarithmic vertical axis.
    pub log_y: bool,
    /// The data.
    pub series: Vec<Series>,
}

const SIZE: (u32, u32) = (900, 560);

/// Registers the bundled font for PNG text (once per process).
pub fn register_font() {
    REGISTER.call_once(|| {
        // The only failure is an invalid font file, which `include_bytes!` rules out in practice;
        // if it happens anyway, PNG text falls back to nothing rather than aborting the task.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Writes `stem.svg` and `stem.png`; returns both paths.
pub fn save(chart: &Chart, stem: &Path) -> Result<Vec<PathBuf>> {
    register_font();
    if let Some(dir) = stem.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let svg = stem.with_extension("svg");
    let png = stem.with_extension("png");
    draw(chart, SVGBackend::new(&svg, SIZE).into_drawing_area())
        .with_context(|| format!("drawing {}", svg.display()))?;
    draw(chart, BitMapBackend::new(&png, SIZE).into_drawing_area())
        .with_context(|| format!("drawing {}", png.display()))?;
    Ok(vec![svg, png])
}

/// Short tick labels: plain numbers in [1e-3, 1e4), one significant digit in e-notation
/// otherwise (log axes would print 9.999999999e-5).
fn tick(v: &f64) -> String {
    let a = v.abs();
    if a == 0.0 || (1e-3..1e4).contains(&a) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

fn keep(v: f64, log: bool) -> bool {
    v.is_finite() && (!log || v > 0.0)
}

fn bounds(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (lo, hi) = if hi / lo < 1.0 + 1e-9 {
            (lo / 2.0, hi * 2.0)
        } else {
            (lo, hi)
        };
        (lo / 1.3, hi * 1.3)
    } else {
        let pad = if hi > lo {
            0.05 * (hi - lo)
        } else {
            lo.abs().max(1.0) * 0.05
        };
        (lo - pad, hi + pad)
    }
}

fn draw<DB: DrawingBackend>(chart: &Chart, root: DrawingArea<DB, Shift>) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let pts = |s: &Series| -> Vec<(f64, f64)> {
        s.points
            .iter()
            .copied()
            .filter(|&(x, y)| keep(x, chart.log_x) && keep(y, chart.log_y))
            .collect()
    };
    let all: Vec<(f64, f64)> = chart.series.iter().flat_map(pts).collect();
    let (x0, x1) = bounds(all.iter().map(|p| p.0), chart.log_x);
    let (y0, y1) = bounds(all.iter().map(|p| p.1), chart.log_y);
    match (chart.log_x, chart.log_y) {
        (false, false) => draw_axes(chart, &root, x0..x1, y0..y1, pts),
        (true, false) => draw_axes(chart, &root, (x0..x1).log_scale(), y0..y1, pts),
        (false, true) => draw_axes(chart, &root, x0..x1, (y0..y1).log_scale(), pts),
        (true, true) => draw_axes(
            chart,
            &root,
            (x0..x1).log_scale(),
            (y0..y1).log_scale(),
            pts,
        ),
    }
}

fn draw_axes<DB, X, Y>(
    chart: &Chart,
    root: &DrawingArea<DB, Shift>,
    x: X,
    y: Y,
    pts: impl Fn(&Series) -> Vec<(f64, f64)>,
) -> Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("{e:?}");
    root.fill(&WHITE).map_err(err)?;
    let mut ctx = ChartBuilder::on(root)
        .caption(&chart.title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(x, y)
        .map_err(err)?;
    ctx.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(err)?;
    for (i, s) in chart.series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let data = pts(s);
        let legend = move |(x, y): (i32, i32)| PathElement::new(vec![(x, y), (x + 20, y)], color);
        if s.mark == Mark::Line {
            ctx.draw_series(LineSeries::new(data.clone(), color.stroke_width(2)))
                .map_err(err)?
                .label(&s.name)
                .legend(legend);
        }
        if s.mark == Mark::Points {
            ctx.draw_series(data.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(err)?
                .label(&s.name)
                .legend(legend);
        }
    }
    // On log–log charts (error vs cost) the lower left is empty: nothing beats the Pareto front.
    let position = if chart.log_x && chart.log_y {
        SeriesLabelPosition::LowerLeft
    } else {
        SeriesLabelPosition::MiddleRight
    };
    ctx.configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}
