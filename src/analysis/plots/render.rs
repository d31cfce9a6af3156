//! A small figure model (panels of labelled series, optional ±σ bands, log-log or
//! symmetric-log axes) drawn with plotters to PNG and SVG. The font is embedded, so
//! figures render the same on any machine without system font libraries.

use super::PlotError;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::ops::Range;
use std::path::Path;

static FONT: &[u8] = include_bytes!("../../../assets/DejaVuSans.ttf");

pub(crate) fn register_font() {
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
/// Palette index of black (commanded and reference lines drawn over coloured data).
pub const BLACK_INDEX: usize = PALETTE.len();

fn colour(i: usize) -> RGBColor {
    if i == BLACK_INDEX {
        RGBColor(0, 0, 0)
    } else {
        PALETTE[i % PALETTE.len()]
    }
}

/// Width of every figure [px]: it fits a 1280 px browser window (less scroll bar and
/// margins) unscaled, so the report's HTML never has to shrink the labels.
pub const FIGURE_WIDTH: u32 = 1200;
/// Height of a row of panels [px].
const ROW_HEIGHT: u32 = 380;
const TITLE_HEIGHT: u32 = 40;
const PANEL_TITLE_HEIGHT: u32 = 26;
const LEGEND_ROW_HEIGHT: u32 = 17;
const MARGIN: u32 = 8;
const Y_LABEL_AREA: u32 = 78;
/// Legend sample line length [px].
const SAMPLE: i32 = 26;

/// How a ±1σ band is drawn: two overlapping filled bands blend into a third colour and
/// hide each other, so the second of a pair is drawn as its edges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BandStyle {
    Fill,
    Edges,
}

#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub xy: Vec<(f64, f64)>,
    /// ±1σ band as (x, low, high).
    pub band: Option<Vec<(f64, f64, f64)>>,
    pub band_style: BandStyle,
    /// Dashed (truth, model and commanded lines).
    pub dashed: bool,
    /// Dotted: a third line style beside solid and dashed, for a third variant of one
    /// colour (the plan figure's torque fractions), which width alone did not tell apart.
    pub dotted: bool,
    /// Line width [px].
    pub width: u32,
    /// Index into the palette, or [`BLACK_INDEX`].
    pub color: usize,
}

impl Series {
    pub fn line(label: impl Into<String>, xy: Vec<(f64, f64)>, color: usize) -> Self {
        Series {
            label: label.into(),
            xy,
            band: None,
            band_style: BandStyle::Fill,
            dashed: false,
            dotted: false,
            width: 1,
            color,
        }
    }

    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self.width = self.width.max(2);
        self
    }

    pub fn dotted(mut self) -> Self {
        self.dotted = true;
        self.dashed = false;
        self
    }

    pub fn width(mut self, px: u32) -> Self {
        self.width = px;
        self
    }

    pub fn with_band(mut self, band: Vec<(f64, f64, f64)>, style: BandStyle) -> Self {
        self.band = Some(band);
        self.band_style = style;
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
    /// Symmetric-log y axis, linear within ±this value (y ↦ asinh(y/c)): a start-up
    /// transient 10⁴ times the converged scatter and that scatter both stay readable.
    pub symlog_y: Option<f64>,
}

impl Panel {
    pub fn new(title: impl Into<String>, x_label: &str, y_label: &str) -> Self {
        Panel {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            log_log: false,
            symlog_y: None,
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

/// Superscript digits of an exponent: 4 → "⁴", -11 → "⁻¹¹".
fn superscript(e: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::new();
    if e < 0 {
        s.push('⁻');
    }
    for c in e.unsigned_abs().to_string().chars() {
        s.push(DIGITS[c.to_digit(10).unwrap_or(0) as usize]);
    }
    s
}

/// `a` (> 0) as "m×10ⁿ" with up to 3 significant digits, "10ⁿ" when m is 1.
fn scientific(a: f64) -> String {
    let mut e = a.log10().floor() as i32;
    let mut m = format!("{:.2}", a / 10f64.powi(e));
    if m.starts_with("10") {
        e += 1;
        m = "1.00".into();
    }
    let m = m.trim_end_matches('0').trim_end_matches('.');
    if m == "1" {
        format!("10{}", superscript(e))
    } else {
        format!("{m}×10{}", superscript(e))
    }
}

/// Tick text of a linear or symmetric-log axis: plain for ordinary magnitudes,
/// "8×10⁴" otherwise; "−" for negatives. `span` is the axis range: a value 10⁹ times
/// smaller is the zero tick's rounding artefact.
pub fn tick_label(v: f64, span: f64) -> String {
    let a = v.abs();
    if !a.is_finite() {
        return String::new();
    }
    if a == 0.0 || a < 1e-9 * span.abs() {
        return "0".into();
    }
    let sign = if v < 0.0 { "−" } else { "" };
    let body = if (1e-2..1e4).contains(&a) {
        let s = format!("{a:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        scientific(a)
    };
    format!("{sign}{body}")
}

/// Tick text of a time axis [s]: whole seconds stay plain up to 10⁶ s ("10000" among
/// "9000", not "10⁴").
pub fn time_tick_label(v: f64, span: f64) -> String {
    if v.abs() < 1e6 && v == v.round() {
        format!("{}{}", if v < 0.0 { "−" } else { "" }, v.abs() as u64)
    } else {
        tick_label(v, span)
    }
}

/// Tick text of a log axis: decades as "10ⁿ", others as "m×10ⁿ".
pub fn log_tick_label(v: f64) -> String {
    if v > 0.0 && v.is_finite() {
        scientific(v)
    } else {
        String::new()
    }
}

/// Log axis with its own ticks: decades, or 1-2-5, 1-2-3-5 or 1…9 times a decade when
/// the range holds too few decades, each value once (plotters' own log axis can repeat a
/// decade as a minor tick, and its labels then collide).
#[derive(Debug, Clone, Copy)]
pub struct LogAxis {
    pub lo: f64,
    pub hi: f64,
}

impl LogAxis {
    /// Tick values inside the range, at most `max` of them: the densest of decades,
    /// 1-2-5 and 1…9 that has no more than `max` (stopping at the first with three),
    /// every few decades when even the decades are too many.
    pub fn ticks(&self, max: usize) -> Vec<f64> {
        let max = max.max(2);
        let (e0, e1) = (
            self.lo.log10().floor() as i32,
            self.hi.log10().ceil() as i32,
        );
        let inside = |v: &f64| *v >= self.lo * (1.0 - 1e-9) && *v <= self.hi * (1.0 + 1e-9);
        let decades: Vec<f64> = (e0..=e1).map(|e| 10f64.powi(e)).filter(inside).collect();
        if decades.len() > max {
            let step = decades.len().div_ceil(max);
            return decades.into_iter().step_by(step).collect();
        }
        let mut best = decades;
        for mantissas in [&[1, 2, 5][..], &[1, 2, 3, 5], &[1, 2, 3, 4, 5, 6, 7, 8, 9]] {
            if best.len() >= 3 {
                break;
            }
            let t: Vec<f64> = (e0..=e1)
                .flat_map(|e| mantissas.iter().map(move |&m| m as f64 * 10f64.powi(e)))
                .filter(inside)
                .collect();
            if t.len() > max {
                break;
            }
            best = t;
        }
        best
    }
}

impl Ranged for LogAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let f = (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln());
        limit.0 + ((limit.1 - limit.0) as f64 * f).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        self.ticks(hint.max_num_points())
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

/// Symmetric-log axis: y ↦ asinh(y/c), linear within about ±c, logarithmic beyond.
#[derive(Debug, Clone, Copy)]
pub struct SymLogAxis {
    pub lo: f64,
    pub hi: f64,
    pub c: f64,
}

impl SymLogAxis {
    fn t(&self, v: f64) -> f64 {
        (v / self.c).asinh()
    }

    /// Zero and ±10ⁿ from the first decade clear of the linear part (≥ 2c, so its
    /// label does not touch the zero's), every decade or every few if `max` is small.
    pub fn ticks(&self, max: usize) -> Vec<f64> {
        let top = self.lo.abs().max(self.hi.abs());
        let mut e0 = (2.0 * self.c).log10().ceil() as i32;
        let e1 = top.log10().floor() as i32;
        if e1 < e0 {
            // Data within the linear part: the decade below still labels it.
            e0 = e1;
        }
        let inside = |v: &f64| *v >= self.lo && *v <= self.hi;
        for step in 1..=8 {
            let mut t: Vec<f64> = (e0..=e1)
                .step_by(step)
                .flat_map(|e| [-(10f64.powi(e)), 10f64.powi(e)])
                .chain([0.0])
                .filter(inside)
                .collect();
            if t.len() <= max.max(3) {
                t.sort_by(f64::total_cmp);
                return t;
            }
        }
        vec![0.0]
    }
}

impl Ranged for SymLogAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let f = (self.t(*v) - self.t(self.lo)) / (self.t(self.hi) - self.t(self.lo));
        limit.0 + ((limit.1 - limit.0) as f64 * f).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        self.ticks(hint.max_num_points())
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

/// Every finite value a panel draws on the y axis (lines and band edges), positive
/// only on a log axis.
fn y_values(p: &Panel) -> impl Iterator<Item = f64> + '_ {
    p.series
        .iter()
        .flat_map(|s| {
            s.xy.iter().map(|v| v.1).chain(
                s.band
                    .iter()
                    .flat_map(|b| b.iter().flat_map(|v| [v.1, v.2])),
            )
        })
        .filter(move |v| v.is_finite() && (!p.log_log || *v > 0.0))
}

fn x_values(p: &Panel) -> impl Iterator<Item = f64> + '_ {
    p.series
        .iter()
        .flat_map(|s| s.xy.iter().map(|v| v.0))
        .filter(move |v| v.is_finite() && (!p.log_log || *v > 0.0))
}

fn min_max(vals: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    vals.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// The axis ranges a panel is drawn with: x spans the data; y holds every line and band
/// point with a 6 % margin (in the axis's own scale), so nothing is clipped.
pub fn panel_ranges(p: &Panel) -> ((f64, f64), (f64, f64)) {
    let x = match min_max(x_values(p)) {
        None if p.log_log => (1e-3, 1.0),
        None => (0.0, 1.0),
        Some((lo, hi)) if hi > lo => (lo, hi),
        Some((lo, _)) if p.log_log => (lo / 2.0, lo * 2.0),
        Some((lo, _)) => (lo - 1.0, lo + 1.0),
    };
    let y = match min_max(y_values(p)) {
        None if p.log_log => (1e-3, 1.0),
        None => (-1.0, 1.0),
        Some((lo, hi)) if p.log_log => (lo / 1.5, hi * 1.5),
        Some((lo, hi)) => match p.symlog_y {
            Some(c) => {
                let (tl, th) = ((lo / c).asinh(), (hi / c).asinh());
                let pad = 0.06 * (th - tl).max(0.1);
                (c * (tl - pad).sinh(), c * (th + pad).sinh())
            }
            None => {
                let pad = if hi > lo {
                    0.06 * (hi - lo)
                } else {
                    lo.abs().max(1e-30) * 0.1
                };
                (lo - pad, hi + pad)
            }
        },
    };
    (x, y)
}

/// Lines of legend entries that fit `width` px, each entry at its x offset [px].
fn legend_rows<'a, DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[&'a Series],
    x0: i32,
    x1: i32,
) -> Vec<Vec<(i32, &'a Series)>> {
    let style = TextStyle::from(("sans-serif", 12));
    let mut rows: Vec<Vec<(i32, &Series)>> = vec![Vec::new()];
    let mut x = x0;
    for s in entries {
        let tw = area
            .estimate_text_size(&s.label, &style)
            .map(|v| v.0 as i32)
            .unwrap_or(7 * s.label.chars().count() as i32);
        let w = SAMPLE + 6 + tw;
        if x + w > x1 && x > x0 {
            rows.push(Vec::new());
            x = x0;
        }
        if let Some(r) = rows.last_mut() {
            r.push((x, s));
        }
        x += w + 20;
    }
    rows
}

/// Draw one legend sample (band, then line) centred on `y`, from `x`.
fn legend_sample<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    s: &Series,
    x: i32,
    y: i32,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let c = colour(s.color);
    if s.band.is_some() {
        match s.band_style {
            BandStyle::Fill => area.draw(&Rectangle::new(
                [(x, y - 6), (x + SAMPLE, y + 6)],
                c.mix(0.2).filled(),
            ))?,
            BandStyle::Edges => {
                for dy in [-6, 6] {
                    area.draw(&PathElement::new(
                        vec![(x, y + dy), (x + SAMPLE, y + dy)],
                        c.stroke_width(1),
                    ))?;
                }
            }
        }
    }
    let style = c.stroke_width(s.width.max(2));
    if s.dotted {
        for a in (0..SAMPLE).step_by(6) {
            area.draw(&PathElement::new(vec![(x + a, y), (x + a + 2, y)], style))?;
        }
    } else if s.dashed {
        for (a, b) in [(0, 8), (12, 20), (24, SAMPLE)] {
            area.draw(&PathElement::new(vec![(x + a, y), (x + b, y)], style))?;
        }
    } else {
        area.draw(&PathElement::new(vec![(x, y), (x + SAMPLE, y)], style))?;
    }
    Ok(())
}

/// The panel's title and legend, above the plot; returns the area left for the plot.
fn draw_title_and_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
) -> Result<DrawingArea<DB, Shift>, PlotError> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| PlotError::draw(format!("{:?}", p.title), e);
    let (w, _) = area.dim_in_pixel();
    let (title, rest) = area.split_vertically(PANEL_TITLE_HEIGHT);
    title
        .draw_text(
            &p.title,
            &TextStyle::from(("sans-serif", 17)).pos(Pos::new(HPos::Center, VPos::Center)),
            (w as i32 / 2, PANEL_TITLE_HEIGHT as i32 / 2 + 2),
        )
        .map_err(e)?;
    // The legend sits above the plot, never on the data.
    let entries: Vec<&Series> = p.series.iter().filter(|s| !s.label.is_empty()).collect();
    let x0 = (MARGIN + Y_LABEL_AREA) as i32;
    let rows = if entries.len() > 1 {
        legend_rows(&rest, &entries, x0, w as i32 - MARGIN as i32)
    } else {
        Vec::new()
    };
    let (legend, plot) = rest.split_vertically(LEGEND_ROW_HEIGHT * rows.len() as u32 + 2);
    let text = TextStyle::from(("sans-serif", 12)).pos(Pos::new(HPos::Left, VPos::Center));
    for (i, row) in rows.iter().enumerate() {
        let y = (LEGEND_ROW_HEIGHT * i as u32 + LEGEND_ROW_HEIGHT / 2 + 1) as i32;
        for (x, s) in row {
            legend_sample(&legend, s, *x, y).map_err(e)?;
            legend
                .draw_text(&s.label, &text, (x + SAMPLE + 6, y))
                .map_err(e)?;
        }
    }
    Ok(plot)
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
) -> Result<(), PlotError> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| PlotError::draw(format!("{:?}", p.title), e);
    let plot = draw_title_and_legend(area, p)?;
    let ((x0, x1), (y0, y1)) = panel_ranges(p);
    let mut builder = ChartBuilder::on(&plot);
    builder
        .margin(MARGIN)
        .margin_top(4)
        .margin_right(24)
        .x_label_area_size(38)
        .y_label_area_size(Y_LABEL_AREA);
    let label_style = ("sans-serif", 14);
    let x_fmt = |v: &f64| {
        if p.log_log {
            log_tick_label(*v)
        } else {
            time_tick_label(*v, x1 - x0)
        }
    };
    let y_fmt = |v: &f64| {
        if p.log_log {
            log_tick_label(*v)
        } else {
            tick_label(*v, y1 - y0)
        }
    };
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(&p.x_label)
                .y_desc(&p.y_label)
                .axis_desc_style(label_style)
                .label_style(("sans-serif", 12))
                .y_label_formatter(&y_fmt)
                .x_label_formatter(&x_fmt)
                .light_line_style(WHITE.mix(0.0))
                .draw()
                .map_err(e)?;
            let visible = |v: &(f64, f64)| {
                v.0.is_finite() && v.1.is_finite() && (!p.log_log || (v.0 > 0.0 && v.1 > 0.0))
            };
            // Bands first, every line over every band.
            for s in &p.series {
                let (Some(band), c) = (&s.band, colour(s.color)) else {
                    continue;
                };
                match s.band_style {
                    BandStyle::Fill => {
                        let mut pts: Vec<(f64, f64)> = band.iter().map(|v| (v.0, v.2)).collect();
                        pts.extend(band.iter().rev().map(|v| (v.0, v.1)));
                        pts.retain(visible);
                        chart
                            .draw_series(std::iter::once(Polygon::new(pts, c.mix(0.2).filled())))
                            .map_err(e)?;
                    }
                    BandStyle::Edges => {
                        let edges: [fn(&(f64, f64, f64)) -> (f64, f64); 2] =
                            [|v| (v.0, v.1), |v| (v.0, v.2)];
                        for edge in edges {
                            let pts = band.iter().map(edge).filter(visible);
                            chart
                                .draw_series(LineSeries::new(pts, c.mix(0.8).stroke_width(1)))
                                .map_err(e)?;
                        }
                    }
                }
            }
            for s in &p.series {
                let style = colour(s.color).stroke_width(s.width);
                let pts = s.xy.iter().copied().filter(visible);
                if s.dotted {
                    chart
                        .draw_series(DashedLineSeries::new(pts, 2, 4, style))
                        .map_err(e)?;
                } else if s.dashed {
                    chart
                        .draw_series(DashedLineSeries::new(pts, 7, 5, style))
                        .map_err(e)?;
                } else {
                    chart.draw_series(LineSeries::new(pts, style)).map_err(e)?;
                }
            }
        }};
    }
    if p.log_log {
        body!(builder
            .build_cartesian_2d(LogAxis { lo: x0, hi: x1 }, LogAxis { lo: y0, hi: y1 })
            .map_err(e)?);
    } else if let Some(c) = p.symlog_y {
        body!(builder
            .build_cartesian_2d(x0..x1, SymLogAxis { lo: y0, hi: y1, c })
            .map_err(e)?);
    } else {
        body!(builder.build_cartesian_2d(x0..x1, y0..y1).map_err(e)?);
    }
    Ok(())
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, f: &Figure) -> Result<(), PlotError> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| PlotError::draw(f.name.clone(), e);
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(&f.title, ("sans-serif", 22)).map_err(e)?;
    let rows = f.panels.len().div_ceil(f.cols);
    let areas = root.split_evenly((rows, f.cols));
    for (area, p) in areas.iter().zip(&f.panels) {
        draw_panel(area, p)?;
    }
    root.present().map_err(e)
}

/// Pixel size of a figure: [`FIGURE_WIDTH`] wide, [`ROW_HEIGHT`] per row of panels.
pub fn size(f: &Figure) -> (u32, u32) {
    let rows = f.panels.len().div_ceil(f.cols.max(1)) as u32;
    (FIGURE_WIDTH, ROW_HEIGHT * rows + TITLE_HEIGHT)
}

/// Write `dir/<name>.png` and `dir/<name>.svg`.
pub fn write(f: &Figure, dir: &Path) -> Result<(), PlotError> {
    register_font();
    let png = dir.join(format!("{}.png", f.name));
    let svg = dir.join(format!("{}.svg", f.name));
    draw(BitMapBackend::new(&png, size(f)).into_drawing_area(), f)?;
    draw(SVGBackend::new(&svg, size(f)).into_drawing_area(), f)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_and_small_ticks_read_as_powers_of_ten() {
        assert_eq!(tick_label(8e4, 1e5), "8×10⁴");
        assert_eq!(tick_label(-2e4, 1e5), "−2×10⁴");
        assert_eq!(tick_label(1e-11, 1e-11), "10⁻¹¹");
        assert_eq!(tick_label(2.5e-10, 1e-9), "2.5×10⁻¹⁰");
        assert_eq!(tick_label(1e5, 1e5), "10⁵");
        // Rounding the mantissa up carries into the exponent.
        assert_eq!(tick_label(9.999e4, 1e5), "10⁵");
    }

    #[test]
    fn ordinary_ticks_stay_plain_and_zero_is_zero() {
        assert_eq!(tick_label(20.0, 100.0), "20");
        assert_eq!(tick_label(-0.25, 1.0), "−0.25");
        assert_eq!(tick_label(1000.0, 4000.0), "1000");
        // The zero tick computed as 1e-15 on a ±50 axis.
        assert_eq!(tick_label(1e-15, 100.0), "0");
        assert_eq!(time_tick_label(10000.0, 10000.0), "10000");
        assert_eq!(time_tick_label(2.5, 10.0), "2.5");
        assert_eq!(log_tick_label(1.0), "10⁰");
        assert_eq!(log_tick_label(2e-12), "2×10⁻¹²");
    }

    #[test]
    fn log_axis_labels_are_unique_and_ascending() {
        // The SRP ASD panel's range, a one-decade range, and many decades.
        for (lo, hi) in [
            (8e-13, 3e-11),
            (6.5e-15, 3.1e-14),
            (7e-8, 2.9e-7),
            (1e-20, 1.0),
        ] {
            let ticks = LogAxis { lo, hi }.ticks(11);
            assert!(
                ticks.len() >= 2 && ticks.len() <= 11,
                "{lo:e}..{hi:e}: {ticks:?}"
            );
            let labels: Vec<String> = ticks.iter().map(|v| log_tick_label(*v)).collect();
            let mut unique = labels.clone();
            unique.sort();
            unique.dedup();
            assert_eq!(unique.len(), labels.len(), "{labels:?}");
            assert!(ticks.windows(2).all(|w| w[0] < w[1]), "{ticks:?}");
            assert!(ticks.iter().all(|v| *v >= lo * 0.999 && *v <= hi * 1.001));
        }
        let srp: Vec<String> = LogAxis {
            lo: 8e-13,
            hi: 3e-11,
        }
        .ticks(11)
        .iter()
        .map(|v| log_tick_label(*v))
        .collect();
        assert!(srp.contains(&"10⁻¹¹".to_string()) && srp.contains(&"10⁻¹²".to_string()));
    }

    #[test]
    fn symlog_axis_shows_the_transient_and_the_converged_scatter() {
        let axis = SymLogAxis {
            lo: -3e4,
            hi: 9e4,
            c: 12.0,
        };
        let ticks = axis.ticks(11);
        assert!(ticks.contains(&0.0) && ticks.contains(&1e4) && ticks.contains(&-1e4));
        // No label crowds the zero's: the first decade is clear of the linear part.
        assert!(
            ticks.iter().all(|v| *v == 0.0 || v.abs() >= 2.0 * axis.c),
            "{ticks:?}"
        );
        // ±c (the final σ) gets a visible share of the height, not a pixel.
        let px = |v: f64| axis.map(&v, (0, 300));
        assert!(
            px(axis.c) - px(-axis.c) >= 20,
            "{}",
            px(axis.c) - px(-axis.c)
        );
        assert!(px(9e4) == 300 && px(-3e4) == 0);
    }

    #[test]
    fn panel_y_range_holds_every_line_and_band_point() {
        let mut p = Panel::new("t", "time [s]", "a [m/s²]");
        p.series.push(Series::line(
            "square",
            (0..100)
                .map(|i| (i as f64, if i % 20 < 10 { 4.3e-10 } else { -3.7e-10 }))
                .collect(),
            0,
        ));
        p.series.push(
            Series::line("b", vec![(0.0, 0.0), (99.0, 0.0)], 1).with_band(
                vec![(0.0, -5e-10, 6e-10), (99.0, -1e-11, 1e-11)],
                BandStyle::Edges,
            ),
        );
        for symlog in [None, Some(1e-11)] {
            p.symlog_y = symlog;
            let ((x0, x1), (y0, y1)) = panel_ranges(&p);
            assert!(x0 <= 0.0 && x1 >= 99.0);
            assert!(y0 < -5e-10 && y1 > 6e-10, "{symlog:?}: {y0:e}..{y1:e}");
        }
    }
}
