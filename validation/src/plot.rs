//! Log-log PNG plots with `plotters`' bitmap backend.
//!
//! Text is drawn with `ab_glyph` from a font registered at run time ([`register_font`]), so no
//! system font library is needed. When no font file is found the plots are still drawn, without
//! any text (no caption, tick labels or legend).

use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::OnceLock;

/// The font file registered for plot text when it exists.
pub const FONT_PATH: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// Registers [`FONT_PATH`] as the `sans-serif` family (once per process). Returns whether a font
/// is available for text.
pub fn register_font() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED.get_or_init(|| match std::fs::read(FONT_PATH) {
        Ok(bytes) => {
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
        }
        Err(_) => false,
    })
}

/// One data series: a label and its `(x, y)` points (both positive for a log-log plot).
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points; non-positive or non-finite ones are skipped.
    pub points: Vec<(f64, f64)>,
    /// Draw as a dashed line without markers (for fitted or reference slopes).
    pub dashed: bool,
}

/// What to draw in one log-log plot.
#[derive(Clone, Debug)]
pub struct LogLogPlot {
    /// Caption above the plot.
    pub title: String,
    /// x-axis description.
    pub x_label: String,
    /// y-axis description.
    pub y_label: String,
    /// Data series.
    pub series: Vec<Series>,
    /// Put the legend in the upper right corner instead of the lower right.
    pub legend_top_right: bool,
}

fn log_range(values: impl Iterator<Item = f64>) -> Option<std::ops::Range<f64>> {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !(lo.is_finite() && hi > 0.0) {
        return None;
    }
    // Pad by a factor 1.25 on each side (more when all values coincide), and start the axis just
    // below a power of ten: plotters places log-axis ticks from the first power of ten in the
    // range, so values below it would get no tick.
    let pad = if hi / lo < 1.01 { 4.0 } else { 1.25 };
    Some(0.999 * 10f64.powf((lo / pad).log10().floor())..hi * pad)
}

/// Tick label of a log axis spanning `decades` decades: over more than one decade only the
/// values 1, 2 and 5 × 10^k are labelled (plotters puts ticks at every multiple), so labels do not
/// overlap.
fn tick_label(v: f64, decades: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return String::new();
    }
    let exp = v.log10().floor();
    let mantissa = v / 10f64.powf(exp);
    let m = mantissa.round();
    let near = (mantissa - m).abs() < 1e-6 * mantissa.max(1.0);
    let keep = if decades > 4.0 {
        near && m == 1.0
    } else if decades > 1.2 {
        near && (m == 1.0 || m == 2.0 || m == 5.0)
    } else {
        true
    };
    if !keep {
        String::new()
    } else if (1e-3..1e4).contains(&v) {
        let s = format!("{v:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{mantissa:.0}e{exp}")
    }
}

const COLORS: [RGBColor; 5] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
];

/// Draws `plot` into a PNG at `path` (800 × 600 px). With `text` false, no text is drawn.
pub fn draw_loglog(
    path: &Path,
    plot: &LogLogPlot,
    text: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let valid = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite() && p.0 > 0.0 && p.1 > 0.0;
    let all = || {
        plot.series
            .iter()
            .flat_map(|s| s.points.iter().filter(valid))
    };
    let xr = log_range(all().map(|p| p.0)).unwrap_or(0.1..10.0);
    let yr = log_range(all().map(|p| p.1)).unwrap_or(0.1..10.0);

    let (x_decades, y_decades) = ((xr.end / xr.start).log10(), (yr.end / yr.start).log10());
    let root = BitMapBackend::new(path, (800, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut builder = ChartBuilder::on(&root);
    builder.margin(20);
    if text {
        builder
            .caption(&plot.title, ("sans-serif", 22))
            .x_label_area_size(50)
            .y_label_area_size(80);
    }
    let mut chart = builder.build_cartesian_2d(xr.log_scale(), yr.log_scale())?;
    let x_fmt = |v: &f64| tick_label(*v, x_decades);
    let y_fmt = |v: &f64| tick_label(*v, y_decades);
    {
        let mut mesh = chart.configure_mesh();
        if text {
            // Enough tick candidates for every 1..9 × 10^k; `tick_label` keeps 1, 2 and 5.
            let ticks = |decades: f64| 10 * decades.ceil() as usize + 10;
            mesh.x_labels(ticks(x_decades))
                .y_labels(ticks(y_decades))
                .max_light_lines(0)
                .bold_line_style(BLACK.mix(0.12))
                .x_desc(plot.x_label.as_str())
                .y_desc(plot.y_label.as_str())
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&y_fmt)
                .label_style(("sans-serif", 14));
        } else {
            mesh.disable_axes()
                .max_light_lines(0)
                .bold_line_style(BLACK.mix(0.12));
        }
        mesh.draw()?;
    }
    if !text {
        // Frame the plot area, which the axes would otherwise draw.
        let (x, y) = (chart.x_range(), chart.y_range());
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x.start, y.start), (x.end, y.end)],
            BLACK.stroke_width(1),
        )))?;
    }
    for (k, s) in plot.series.iter().enumerate() {
        let color = COLORS[k % COLORS.len()];
        let pts: Vec<(f64, f64)> = s.points.iter().filter(valid).copied().collect();
        if pts.is_empty() {
            continue;
        }
        let style = color.stroke_width(2);
        let anno = if s.dashed {
            chart.draw_series(DashedLineSeries::new(pts.clone(), 10, 6, style))?
        } else {
            chart.draw_series(LineSeries::new(pts.clone(), style))?;
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 5, color.filled())))?
        };
        if text {
            anno.label(s.label.as_str()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        }
    }
    if text {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .position(if plot.legend_top_right {
                SeriesLabelPosition::UpperRight
            } else {
                SeriesLabelPosition::LowerRight
            })
            .draw()?;
    }
    root.present()?;
    Ok(())
}
