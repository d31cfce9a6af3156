//! A small figure model (panels of labelled series, optional ±σ bands, log-log axes)
//! drawn with plotters to PNG and SVG. The font is embedded, so figures render the
//! same on any machine without system font libraries.

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        for style in [FontStyle::Normal, FontStyle::Bold] {
            // Registration only fails on an unreadable font, which is embedded and tested.
            let _ = plotters::style::register_font("sans-serif", style, FONT);
        }
    });
}

/// Line colours, in series order.
const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(90, 90, 90),
];

#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub xy: Vec<(f64, f64)>,
    /// ±1σ band as (x, low, high).
    pub band: Option<Vec<(f64, f64, f64)>>,
    /// Dashed (truth, model and commanded lines).
    pub dashed: bool,
    /// Index into the palette.
    pub color: usize,
}

impl Series {
    pub fn line(label: impl Into<String>, xy: Vec<(f64, f64)>, color: usize) -> Self {
        Series {
            label: label.into(),
            xy,
            band: None,
            dashed: false,
            color,
        }
    }

    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }

    pub fn with_band(mut self, band: Vec<(f64, f64, f64)>) -> Self {
        self.band = Some(band);
        self
    }
}

#[derive(Debug, Clone)]
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub log_log: bool,
}

impl Panel {
    pub fn new(title: impl Into<String>, x_label: &str, y_label: &str) -> Self {
        Panel {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            log_log: false,
        }
    }
}

#[derive(Debug, Clone)]
pub struct Figure {
    /// File stem: `<name>.png` and `<name>.svg`.
    pub name: String,
    pub title: String,
    pub panels: Vec<Panel>,
    /// Panels per row.
    pub cols: usize,
}

/// Keep at most `max` points, evenly strided (the plots need shape, not every sample).
pub fn decimate(xy: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
    if xy.len() <= max {
        return xy;
    }
    let step = xy.len().div_ceil(max);
    xy.into_iter().step_by(step).collect()
}

fn finite_range(vals: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { (1e-3, 1.0) } else { (-1.0, 1.0) };
    }
    if log {
        return (lo / 1.5, hi * 1.5);
    }
    let pad = if hi > lo {
        0.06 * (hi - lo)
    } else {
        lo.abs().max(1e-30) * 0.1
    };
    (lo - pad, hi + pad)
}

/// Axis tick text: plain for ordinary magnitudes, scientific otherwise. `span` is the
/// axis range (on a log axis, its upper end).
fn tick_label(v: f64, span: f64) -> String {
    let a = v.abs();
    // Far below the axis range: a rounding artefact of the zero tick's position.
    if a < 1e-9 * span.abs() {
        "0".into()
    } else if (1e-2..1e4).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.1e}")
    }
}

fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &Panel) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("cannot draw {:?}: {e:?}", p.title);
    let xs = p.series.iter().flat_map(|s| s.xy.iter().map(|v| v.0));
    let ys = p.series.iter().flat_map(|s| {
        s.xy.iter().map(|v| v.1).chain(
            s.band
                .iter()
                .flat_map(|b| b.iter().flat_map(|v| [v.1, v.2])),
        )
    });
    let (x0, x1) = finite_range(xs, p.log_log);
    let (y0, y1) = finite_range(ys, p.log_log);
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(&p.title, ("sans-serif", 17))
        .margin(8)
        .x_label_area_size(38)
        .y_label_area_size(78);
    let label_style = ("sans-serif", 14);
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(&p.x_label)
                .y_desc(&p.y_label)
                .axis_desc_style(label_style)
                .label_style(("sans-serif", 12))
                .y_label_formatter(&|v| tick_label(*v, y1 - y0))
                .x_label_formatter(&|v| {
                    if p.log_log {
                        format!("{v:.0e}")
                    } else {
                        format!("{v}")
                    }
                })
                .light_line_style(WHITE.mix(0.0))
                .draw()
                .map_err(e)?;
            for s in &p.series {
                let c = PALETTE[s.color % PALETTE.len()];
                if let Some(band) = &s.band {
                    let mut pts: Vec<(f64, f64)> = band.iter().map(|v| (v.0, v.2)).collect();
                    pts.extend(band.iter().rev().map(|v| (v.0, v.1)));
                    chart
                        .draw_series(std::iter::once(Polygon::new(pts, c.mix(0.18).filled())))
                        .map_err(e)?;
                }
                let style = c.stroke_width(if s.dashed { 2 } else { 1 });
                let pts = s.xy.iter().copied().filter(|v| {
                    v.0.is_finite() && v.1.is_finite() && (!p.log_log || (v.0 > 0.0 && v.1 > 0.0))
                });
                let anno = if s.dashed {
                    chart
                        .draw_series(DashedLineSeries::new(pts, 6, 4, style))
                        .map_err(e)?
                } else {
                    chart.draw_series(LineSeries::new(pts, style)).map_err(e)?
                };
                if !s.label.is_empty() {
                    anno.label(&s.label).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                    });
                }
            }
            if p.series.iter().filter(|s| !s.label.is_empty()).count() > 1 {
                chart
                    .configure_series_labels()
                    .position(SeriesLabelPosition::UpperRight)
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK.mix(0.4))
                    .label_font(("sans-serif", 12))
                    .draw()
                    .map_err(e)?;
            }
        }};
    }
    if p.log_log {
        body!(builder
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(e)?);
    } else {
        body!(builder.build_cartesian_2d(x0..x1, y0..y1).map_err(e)?);
    }
    Ok(())
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, f: &Figure) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("cannot draw {}: {e:?}", f.name);
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(&f.title, ("sans-serif", 22)).map_err(e)?;
    let rows = f.panels.len().div_ceil(f.cols);
    let areas = root.split_evenly((rows, f.cols));
    for (area, p) in areas.iter().zip(&f.panels) {
        draw_panel(area, p)?;
    }
    root.present().map_err(e)
}

/// Pixel size of a figure: 620 × 380 per panel.
fn size(f: &Figure) -> (u32, u32) {
    let rows = f.panels.len().div_ceil(f.cols) as u32;
    (620 * f.cols as u32, 380 * rows + 40)
}

/// Write `dir/<name>.png` and `dir/<name>.svg`.
pub fn write(f: &Figure, dir: &Path) -> Result<(), String> {
    register_font();
    let png = dir.join(format!("{}.png", f.name));
    let svg = dir.join(format!("{}.svg", f.name));
    draw(BitMapBackend::new(&png, size(f)).into_drawing_area(), f)?;
    draw(SVGBackend::new(&svg, size(f)).into_drawing_area(), f)?;
    Ok(())
}
