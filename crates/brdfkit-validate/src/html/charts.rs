//! The report's charts as SVG strings (plotters' SVG backend: no system fonts, no
//! bitmap encoder; the browser lays out the text).

use super::ReportError;
use super::analysis::{AlbedoCurves, ResidualMap, Slice};
use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::ops::Range;

/// θh on MERL's √ axis: the coordinate is the bin index u = n √(θh / 90°), the ticks
/// sit at round angles and are labelled in degrees.
#[derive(Clone)]
struct SqrtThetaH {
    /// θh bins of the table.
    n: f64,
    /// Tick angles (degrees).
    ticks: Vec<f64>,
}

impl SqrtThetaH {
    fn new(bins: usize, ticks: &[f64]) -> Self {
        SqrtThetaH {
            n: bins as f64,
            ticks: ticks.to_vec(),
        }
    }
}

impl Ranged for SqrtThetaH {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = value / self.n;
        limit.0 + ((limit.1 - limit.0) as f64 * t).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks
                .iter()
                .map(|d| self.n * (d / 90.0).sqrt())
                .collect()
        }
    }

    fn range(&self) -> Range<f64> {
        0.0..self.n
    }
}

impl ValueFormatter<f64> for SqrtThetaH {
    fn format_ext(&self, u: &f64) -> String {
        format!("{:.0}", (u / self.n).powi(2) * 90.0)
    }
}

/// Model colours (Tableau 10, minus grey, which marks missing data); the table is
/// black. Index modulo the length for more models.
pub const MODEL_COLOURS: [(u8, u8, u8); 9] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (188, 189, 34),
    (23, 190, 207),
];

/// The colour of model `m`.
pub fn model_colour(m: usize) -> RGBColor {
    let (r, g, b) = MODEL_COLOURS[m % MODEL_COLOURS.len()];
    RGBColor(r, g, b)
}

/// `#rrggbb` of model `m`, for the HTML legend.
pub fn model_colour_hex(m: usize) -> String {
    let (r, g, b) = MODEL_COLOURS[m % MODEL_COLOURS.len()];
    format!("#{r:02x}{g:02x}{b:02x}")
}

pub(super) const CHANNELS: [&str; 3] = ["R", "G", "B"];

pub(super) fn err<E: std::fmt::Debug>(e: E) -> ReportError {
    ReportError::Chart(format!("{e:?}"))
}

/// The font whose metrics lay out the charts' text (the SVG names `sans-serif`; the
/// browser draws it): DejaVu Sans, bundled (`assets/README.md`).
static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Registers [`FONT`] as plotters' `sans-serif`, once.
fn register_font() -> Result<(), ReportError> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(ReportError::Chart("the bundled font does not load".into()))
    }
}

/// Draws into an SVG string of `size` pixels.
pub(super) fn svg(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<(), ReportError>,
) -> Result<String, ReportError> {
    register_font()?;
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, size).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        draw(&root)?;
        root.present().map_err(err)?;
    }
    Ok(s)
}

/// The frame of a captioned chart: the caption, the margin and the axis label areas
/// (the y one `y_labels` pixels wide).
pub(super) fn framed<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, Shift>,
    caption: impl AsRef<str>,
    y_labels: u32,
) -> ChartBuilder<'a, 'b, SVGBackend<'b>> {
    let mut b = ChartBuilder::on(area);
    b.caption(caption, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(34)
        .y_label_area_size(y_labels);
    b
}

/// The axis text of every chart: tick labels and axis descriptions.
pub(super) fn mesh<'m, 'a, 'b, X: Ranged, Y: Ranged, DB: DrawingBackend>(
    m: &'m mut MeshStyle<'a, 'b, X, Y, DB>,
) -> &'m mut MeshStyle<'a, 'b, X, Y, DB> {
    m.label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 13))
}

/// A log-scale y range covering `values` (positive ones), with a margin.
pub(super) fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for v in values.filter(|v| *v > 0.0 && v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !(lo.is_finite() && hi > 0.0) {
        return (1e-3, 1.0);
    }
    // A model's far tail can reach 1e-30 where the table holds 1e-3: the chart shows
    // at most 8 decades below the largest value, so the data stays readable.
    let lo = lo.max(hi * 1e-8);
    (lo / 1.5, hi * 1.5)
}

/// θh slices, one chart per (slice, channel): the table (black dots) and each model
/// (lines), f_r on a log axis against θh on MERL's √ axis (the bin index).
pub fn slice_chart(
    s: &Slice,
    channel: usize,
    theta_h_bins: usize,
    labels: &[String],
) -> Result<String, ReportError> {
    let c = channel;
    let (lo, hi) = log_range(
        s.measured
            .iter()
            .map(|v| v[c])
            .chain(s.models.iter().flatten().map(|v| v[c])),
    );
    let axis = SqrtThetaH::new(theta_h_bins, &[0.0, 1.0, 5.0, 10.0, 20.0, 40.0, 60.0, 90.0]);
    let title = format!(
        "{} · θd = {:.1}°, φd = {:.0}°",
        CHANNELS[c],
        s.theta_d.to_degrees(),
        s.phi_d.to_degrees()
    );
    svg((420, 300), |root| {
        let mut chart = framed(root, title, 58)
            .build_cartesian_2d(axis, (lo..hi).log_scale())
            .map_err(err)?;
        mesh(&mut chart.configure_mesh())
            .x_desc("θh (degrees, √ axis)")
            .y_desc("f_r (1/sr)")
            // Label the decades only: the log axis puts a key point at every digit.
            .y_label_formatter(&|v| {
                let e = v.log10();
                if (e - e.round()).abs() < 1e-6 {
                    format!("1e{}", e.round() as i32)
                } else {
                    String::new()
                }
            })
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(err)?;
        let models = s
            .models
            .iter()
            .map(|vals| {
                s.theta_h_index
                    .iter()
                    .zip(vals)
                    .filter(|(_, v)| v[c] > 0.0)
                    .map(|(&i, v)| (i as f64, v[c].max(lo)))
                    .collect()
            })
            .collect();
        let measured = s
            .theta_h_index
            .iter()
            .zip(&s.measured)
            .filter(|(_, v)| v[c] > 0.0)
            .map(|(&i, v)| (i as f64, v[c]))
            .collect();
        let series = Series {
            models,
            labels,
            measured,
            dot: 2,
        };
        draw_series(&mut chart, &series)?;
        Ok(())
    })
}

/// The diverging colour of a residual t ∈ [−1, 1]: blue (model too dark) through white
/// to red (model too bright); the ends are ColorBrewer's RdBu.
pub fn diverging(t: f64) -> RGBColor {
    let t = t.clamp(-1.0, 1.0);
    let (end, a) = if t >= 0.0 {
        ((178.0, 24.0, 43.0), t)
    } else {
        ((33.0, 102.0, 172.0), -t)
    };
    let mix = |e: f64| (255.0 + (e - 255.0) * a).round() as u8;
    RGBColor(mix(end.0), mix(end.1), mix(end.2))
}

/// Grey of the cells that hold no measured value.
pub const MISSING: RGBColor = RGBColor(150, 150, 150);

/// The residual map of one model: blocks over (θh on MERL's √ axis, θd), coloured by
/// the log10 ratio on ±`scale`.
pub fn residual_chart(
    map: &ResidualMap,
    label: &str,
    theta_h_bins: usize,
    scale: f64,
) -> Result<String, ReportError> {
    let n = theta_h_bins as f64;
    let axis = SqrtThetaH::new(theta_h_bins, &[0.0, 1.0, 5.0, 20.0, 45.0, 90.0]);
    let bw = map.block[0] as f64;
    svg((330, 300), |root| {
        let mut chart = framed(root, label, 44)
            .build_cartesian_2d(axis, 0.0..90.0)
            .map_err(err)?;
        mesh(&mut chart.configure_mesh())
            .disable_mesh()
            .x_desc("θh (degrees, √ axis)")
            .y_desc("θd (degrees)")
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(err)?;
        // θd of bin j is j / nθd · 90°; the last block may be narrower.
        let nd = map.bins[1] as f64;
        let rects = (0..map.rows).flat_map(|r| {
            (0..map.cols).map(move |c| {
                let x0 = c as f64 * bw;
                let x1 = ((c + 1) as f64 * bw).min(n);
                let y0 = r as f64 * map.block[1] as f64 / nd * 90.0;
                let y1 = (((r + 1) * map.block[1]) as f64 / nd * 90.0).min(90.0);
                let col = match map.values[r * map.cols + c] {
                    Some(v) => diverging(v / scale),
                    None => MISSING,
                };
                Rectangle::new([(x0, y0), (x1, y1)], col.filled())
            })
        });
        chart.draw_series(rects).map_err(err)?;
        // A map white all over reads as empty: say that the fit is exact there.
        if let Some(text) = exact_label(map, scale) {
            // The verdict large, the figure below it.
            for (line, size, y) in [(&text[0], 22, 52.0), (&text[1], 12, 36.0)] {
                let style = ("sans-serif", size)
                    .into_font()
                    .color(&BLACK.mix(0.75))
                    .pos(Pos::new(HPos::Center, VPos::Center));
                chart
                    .draw_series(std::iter::once(Text::new(
                        line.clone(),
                        (n / 2.0, y),
                        &style,
                    )))
                    .map_err(err)?;
            }
        }
        Ok(())
    })
}

/// The label of a residual map whose every block is white to the eye (|log10 ratio|
/// below 1 % of the colour scale), or None: "exact" when the largest |log10 ratio| is
/// round-off (below 1e-9, a ratio within 2.3e-9 of 1), "≈ exact" otherwise, and the
/// largest |log10 ratio| itself.
pub fn exact_label(map: &ResidualMap, scale: f64) -> Option<[String; 2]> {
    let max = map
        .values
        .iter()
        .flatten()
        .map(|v| v.abs())
        .reduce(f64::max)?;
    (max < 0.01 * scale).then(|| {
        let word = if max < 1e-9 { "exact" } else { "≈ exact" };
        [word.to_string(), format!("max |log10 ratio| {max:.1e}")]
    })
}

/// The colour bar of the residual maps: log10(f_model / f_measured) on ±`scale`.
pub fn colour_bar(scale: f64) -> Result<String, ReportError> {
    svg((110, 300), |root| {
        let mut chart = ChartBuilder::on(root)
            .margin_top(30)
            .margin_bottom(42)
            .margin_right(8)
            .y_label_area_size(58)
            .build_cartesian_2d(0.0..1.0, -scale..scale)
            .map_err(err)?;
        mesh(&mut chart.configure_mesh())
            .disable_mesh()
            .disable_x_axis()
            .y_desc("log10(model / measured)")
            .y_labels(5)
            .y_label_formatter(&|v| {
                if v.abs() < 1e-9 {
                    "0".into()
                } else {
                    format!("{v:+.2}")
                }
            })
            .draw()
            .map_err(err)?;
        let steps = 64;
        chart
            .draw_series((0..steps).map(|k| {
                let a = -scale + 2.0 * scale * k as f64 / steps as f64;
                let b = -scale + 2.0 * scale * (k + 1) as f64 / steps as f64;
                Rectangle::new(
                    [(0.0, a), (1.0, b)],
                    diverging((a + b) / (2.0 * scale)).filled(),
                )
            }))
            .map_err(err)?;
        Ok(())
    })
}

/// The albedo a(θo) of the table (black dots) and every model (lines), one channel.
/// The legend goes where it covers no dot and no line, with more headroom above the
/// curves if need be; when no place in the plot is free, it goes under the plot.
pub fn albedo_chart(
    a: &AlbedoCurves,
    channel: usize,
    labels: &[String],
) -> Result<String, ReportError> {
    for headroom in [1.15, 1.45] {
        let (svg, free) = albedo_svg(a, channel, labels, headroom, false)?;
        if free {
            return Ok(svg);
        }
    }
    Ok(albedo_svg(a, channel, labels, 1.15, true)?.0)
}

/// The albedo chart with its y axis up to `headroom` times the largest value and its
/// legend in the plot (or under it), and whether the legend covers nothing.
fn albedo_svg(
    a: &AlbedoCurves,
    c: usize,
    labels: &[String],
    headroom: f64,
    legend_under: bool,
) -> Result<(String, bool), ReportError> {
    let deg: Vec<f64> = a.theta_o.iter().map(|t| t.to_degrees()).collect();
    let top = a
        .table
        .iter()
        .flatten()
        .map(|v| v[c])
        .chain(a.models.iter().flatten().map(|v| v[c]))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let top = if top > 0.0 { top * headroom } else { 1.0 };
    let series = Series {
        models: a
            .models
            .iter()
            .map(|vals| deg.iter().zip(vals).map(|(&x, v)| (x, v[c])).collect())
            .collect(),
        labels,
        measured: deg
            .iter()
            .zip(&a.table)
            .filter_map(|(&x, v)| v.map(|v| (x, v[c])))
            .collect(),
        dot: 3,
    };
    let (w, h) = (380, 280);
    let under = if legend_under {
        legend_rows(&series, w)?
    } else {
        Vec::new()
    };
    let extra = (under.len() as u32) * LEGEND_ROW + if under.is_empty() { 0 } else { 12 };
    let mut free = false;
    let svg = svg((w, h + extra), |root| {
        let (plot, below) = root.split_vertically(h);
        let mut chart = framed(&plot, format!("albedo, {}", CHANNELS[c]), 50)
            .build_cartesian_2d(0.0..90.0, 0.0..top)
            .map_err(err)?;
        mesh(&mut chart.configure_mesh())
            .x_desc("θo (degrees)")
            .y_desc("a(θo) = ∫ f cos θi dωi")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(err)?;
        free = if under.is_empty() {
            draw_series(&mut chart, &series)?
        } else {
            draw_lines_and_dots(&mut chart, &series, false)?;
            draw_legend_under(&below, &under)?;
            true
        };
        Ok(())
    })?;
    Ok((svg, free))
}

/// Height of a row of the legend under a plot (pixels).
const LEGEND_ROW: u32 = 16;

/// One entry of a legend under a plot: its label, its model (None: the table's
/// dots) and its x offset (pixels).
type UnderEntry = (String, Option<usize>, i32);

/// The legend entries under a plot `width` pixels wide, in rows.
fn legend_rows(s: &Series, width: u32) -> Result<Vec<Vec<UnderEntry>>, ReportError> {
    let mut rows: Vec<Vec<UnderEntry>> = vec![Vec::new()];
    let mut x = LEGEND_MARGIN;
    for e in (0..s.labels.len()).map(Some).chain([None]) {
        let label = e.map_or("measured", |m| s.labels[m].as_str()).to_string();
        // Icon, gap, text, gap: as the legend in the plot.
        let w = legend_size(std::iter::once(label.as_str()))?.0 - 2 * LEGEND_MARGIN + 12;
        if x + w > width as i32 - LEGEND_MARGIN && !rows.last().expect("a row").is_empty() {
            rows.push(Vec::new());
            x = LEGEND_MARGIN;
        }
        rows.last_mut().expect("a row").push((label, e, x));
        x += w;
    }
    Ok(rows)
}

/// Draws the legend under a plot into `area`: a box as in the plot, the entries in rows.
fn draw_legend_under(
    area: &DrawingArea<SVGBackend, Shift>,
    rows: &[Vec<UnderEntry>],
) -> Result<(), ReportError> {
    let (w, _) = area.dim_in_pixel();
    let row = LEGEND_ROW as i32;
    let frame = [(4, 2), (w as i32 - 4, 8 + rows.len() as i32 * row)];
    area.draw(&Rectangle::new(frame, WHITE.mix(0.85).filled()))
        .map_err(err)?;
    area.draw(&Rectangle::new(frame, BLACK.mix(0.3)))
        .map_err(err)?;
    let font = LEGEND_FONT
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    for (r, entries) in rows.iter().enumerate() {
        let y = 5 + row * r as i32 + row / 2;
        for (label, e, x) in entries {
            match e {
                Some(m) => area.draw(&PathElement::new(
                    vec![(*x, y), (x + 14, y)],
                    model_colour(*m).stroke_width(2),
                )),
                None => area.draw(&Circle::new((x + 7, y), 3, BLACK.filled())),
            }
            .map_err(err)?;
            area.draw(&Text::new(label.clone(), (x + LEGEND_ICON - 10, y), &font))
                .map_err(err)?;
        }
    }
    Ok(())
}

/// What a line chart shows: each model's line and the table's dots, in data units.
struct Series<'a> {
    /// Each model's points, in the order of `labels`.
    models: Vec<Vec<(f64, f64)>>,
    /// The models' names.
    labels: &'a [String],
    /// The table's points (black dots).
    measured: Vec<(f64, f64)>,
    /// Radius of the dots (pixels).
    dot: u32,
}

/// Legend layout of plotters (`SeriesLabelStyle::draw`): the icon column and the
/// margin around the text, pixels.
const LEGEND_ICON: i32 = 30;
const LEGEND_MARGIN: i32 = 10;
const LEGEND_FONT: (&str, u32) = ("sans-serif", 11);

/// Draws the models' lines, the table's dots and the legend where it covers the least
/// of them (see [`legend_place`]). Returns whether the legend covers nothing.
fn draw_series<'a, 'b: 'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<X, Y>>,
    s: &Series,
) -> Result<bool, ReportError>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    draw_lines_and_dots(chart, s, true)?;
    let r = s.dot;
    // Everything in backend pixels: the plotting area, the lines and the dots.
    let px = |pts: &[(f64, f64)]| -> Vec<(i32, i32)> {
        pts.iter().map(|p| chart.backend_coord(p)).collect()
    };
    let lines: Vec<Vec<(i32, i32)>> = s.models.iter().map(|p| px(p)).collect();
    let dots = px(&s.measured);
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let labels = s.labels.iter().map(String::as_str).chain(["measured"]);
    let size = legend_size(labels)?;
    let (at, cost) = legend_place((xr, yr), size, &lines, &dots, r as i32);
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::Coordinate(at.0, at.1))
        .legend_area_size(LEGEND_ICON)
        .margin(LEGEND_MARGIN)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(LEGEND_FONT)
        .draw()
        .map_err(err)?;
    Ok(cost == 0)
}

/// Draws the models' lines and the table's dots, registering their legend entries
/// when `legend` (the legend in the plot).
fn draw_lines_and_dots<'a, 'b: 'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<X, Y>>,
    s: &Series,
    legend: bool,
) -> Result<(), ReportError>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    for (m, pts) in s.models.iter().enumerate() {
        let col = model_colour(m);
        let anno = chart
            .draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))
            .map_err(err)?;
        if legend {
            anno.label(s.labels[m].clone()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 14, y)], col.stroke_width(2))
            });
        }
    }
    let r = s.dot;
    let anno = chart
        .draw_series(
            s.measured
                .iter()
                .map(|&p| Circle::new(p, r, BLACK.filled())),
        )
        .map_err(err)?;
    if legend {
        anno.label("measured")
            .legend(|(x, y)| Circle::new((x + 7, y), 3, BLACK.filled()));
    }
    Ok(())
}

/// The legend box's width and height (pixels) for these labels, as plotters lays it out.
fn legend_size<'a>(labels: impl Iterator<Item = &'a str>) -> Result<(i32, i32), ReportError> {
    let mut text = MultiLineText::<_, &str>::new((0, 0), LEGEND_FONT);
    for l in labels {
        text.push_line(l);
    }
    let (w, h) = text.estimate_dimension().map_err(err)?;
    Ok((w + LEGEND_ICON + 2 * LEGEND_MARGIN, h + 2 * LEGEND_MARGIN))
}

/// Where the legend goes, relative to the plotting area (`area`, backend pixels): the
/// first of the four corners, then the edges' middles, that covers no dot and no line;
/// else the place covering the fewest (a dot counts as ten line segments). Returns the
/// place and what it covers.
fn legend_place(
    area: (Range<i32>, Range<i32>),
    size: (i32, i32),
    lines: &[Vec<(i32, i32)>],
    dots: &[(i32, i32)],
    dot: i32,
) -> ((i32, i32), usize) {
    let (xr, yr) = area;
    let (w, h) = size;
    // plotters' own insets: 5 pixels from the area's edges.
    let (left, right, centre) = (5, xr.end - xr.start - w - 5, (xr.end - xr.start - w) / 2);
    let (upper, lower, middle) = (5, yr.end - yr.start - h - 5, (yr.end - yr.start - h) / 2);
    let places = [
        (right, upper),
        (left, upper),
        (right, lower),
        (left, lower),
        (centre, upper),
        (centre, lower),
        (right, middle),
        (left, middle),
    ];
    let cost = |&(x, y): &(i32, i32)| {
        // The box in backend pixels, with a 2-pixel clearance (and a dot's radius).
        let (x0, y0) = (xr.start + x - 2, yr.start + y - 2);
        let (x1, y1) = (x0 + w + 4, y0 + h + 4);
        let inside = |(px, py): (i32, i32), r: i32| {
            px >= x0 - r && px <= x1 + r && py >= y0 - r && py <= y1 + r
        };
        let covered_dots = dots.iter().filter(|&&p| inside(p, dot)).count();
        let covered_segments = lines
            .iter()
            .flat_map(|l| l.windows(2))
            .filter(|seg| {
                let (a, b) = (seg[0], seg[1]);
                let n = (a.0 - b.0).abs().max((a.1 - b.1).abs()).max(1);
                (0..=n).any(|k| {
                    let t = k as f64 / n as f64;
                    let p = (
                        a.0 + ((b.0 - a.0) as f64 * t).round() as i32,
                        a.1 + ((b.1 - a.1) as f64 * t).round() as i32,
                    );
                    inside(p, 1)
                })
            })
            .count();
        10 * covered_dots + covered_segments
    };
    places
        .iter()
        .map(|p| (*p, cost(p)))
        .min_by_key(|(_, c)| *c)
        .expect("eight places")
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_core::Rgb;

    #[test]
    fn diverging_map_ends_and_centre() {
        assert_eq!(diverging(0.0), RGBColor(255, 255, 255));
        assert_eq!(diverging(1.0), RGBColor(178, 24, 43));
        assert_eq!(diverging(-7.0), RGBColor(33, 102, 172));
    }

    /// The value of attribute `name` in an SVG element's text.
    fn attr(el: &str, name: &str) -> Option<f64> {
        let key = format!(" {name}=\"");
        let start = el.find(&key)? + key.len();
        el[start..].split('"').next()?.parse().ok()
    }

    /// The legend's box (x0, y0, x1, y1) and the black dots drawn before it (cx, cy, r),
    /// read back from the SVG: the legend's background is the one rectangle with
    /// opacity 0.85, and its own icons come after it.
    fn legend_and_dots(svg: &str) -> ([f64; 4], Vec<[f64; 3]>) {
        let at = svg.find("opacity=\"0.85\"").expect("a legend");
        let start = svg[..at].rfind('<').unwrap();
        let el = &svg[start..start + svg[start..].find('>').unwrap()];
        let (x, y) = (attr(el, "x").unwrap(), attr(el, "y").unwrap());
        let (w, h) = (attr(el, "width").unwrap(), attr(el, "height").unwrap());
        let dots = svg[..start]
            .split("<circle")
            .skip(1)
            .filter(|c| c.contains("fill=\"#000000\""))
            .map(|c| ["cx", "cy", "r"].map(|a| attr(c, a).unwrap()))
            .collect();
        ([x, y, x + w, y + h], dots)
    }

    #[test]
    fn the_albedo_legend_covers_no_measured_dot() {
        // Curves of every shape: rising to grazing (a Fresnel-like specular material:
        // the case where a fixed lower-left legend covered the dots), falling, flat near
        // the top, a hump, and one close to every corner.
        let theta: Vec<f64> = [0.0f64, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0]
            .map(f64::to_radians)
            .to_vec();
        let shapes: [fn(f64) -> f64; 5] = [
            |t| 0.05 + 0.9 * t.powi(4),
            |t| 0.9 - 0.8 * t * t,
            |_| 0.7,
            |t| 0.2 + 0.6 * (std::f64::consts::PI * t).sin(),
            |t| {
                if (0.2..0.8).contains(&t) {
                    0.5
                } else {
                    0.95 * (1.0 - t) + 0.02
                }
            },
        ];
        let labels: Vec<String> = [
            "lambert",
            "plausible-phong",
            "ward",
            "lafortune",
            "cook-torrance",
        ]
        .map(String::from)
        .to_vec();
        for (k, f) in shapes.iter().enumerate() {
            let curve = |scale: f64| -> Vec<Rgb> {
                theta
                    .iter()
                    .map(|t| Rgb::splat(scale * f(t / std::f64::consts::FRAC_PI_2)))
                    .collect()
            };
            let a = AlbedoCurves {
                theta_o: theta.clone(),
                table: curve(1.0).into_iter().map(Some).collect(),
                table_missing_weight: vec![0.0; theta.len()],
                models: [0.6, 0.8, 0.95, 1.05, 1.0].map(curve).to_vec(),
            };
            let svg = albedo_chart(&a, 0, &labels).unwrap();
            for l in labels.iter().map(String::as_str).chain(["measured"]) {
                assert!(
                    svg.contains(&format!(">\n{l}\n<")),
                    "shape {k}: no legend entry {l}"
                );
            }
            let ([x0, y0, x1, y1], dots) = legend_and_dots(&svg);
            assert_eq!(dots.len(), theta.len(), "shape {k}: every dot drawn");
            for [cx, cy, r] in dots {
                let clear = cx + r < x0 || cx - r > x1 || cy + r < y0 || cy - r > y1;
                assert!(
                    clear,
                    "shape {k}: dot ({cx}, {cy}) under the legend {x0},{y0}..{x1},{y1}"
                );
            }
        }
    }

    #[test]
    fn legend_place_takes_the_first_free_corner_and_else_the_least_covered() {
        let area = (0..300, 0..200);
        // Nothing drawn: the upper right.
        assert_eq!(
            legend_place(area.clone(), (80, 40), &[], &[], 3),
            ((215, 5), 0)
        );
        // A dot in the upper right and one in the upper left: the lower right.
        let dots = [(280, 20), (20, 20)];
        assert_eq!(
            legend_place(area.clone(), (80, 40), &[], &dots, 3).0,
            (215, 155)
        );
        // A line across the whole top and the whole bottom: a middle place.
        let lines = vec![vec![(0, 20), (300, 20)], vec![(0, 180), (300, 180)]];
        assert_eq!(
            legend_place(area.clone(), (80, 40), &lines, &[], 3),
            ((215, 80), 0)
        );
        // Everything covered: the fewest dots win over lines.
        let lines = vec![vec![(0, 100), (300, 100)]];
        let dots: Vec<(i32, i32)> = (0..30)
            .flat_map(|x| [(x * 10, 20), (x * 10, 180)])
            .collect();
        let (_, cost) = legend_place(area, (80, 160), &lines, &dots, 3);
        assert!(cost > 0);
    }

    #[test]
    fn a_white_residual_map_says_exact() {
        let map = |v: f64| ResidualMap {
            cols: 3,
            rows: 2,
            block: [2, 2],
            bins: [6, 4],
            values: vec![Some(v), Some(-v), None, Some(v / 2.0), Some(0.0), Some(v)],
            model_zero: 0,
        };
        let text = |v: f64| residual_chart(&map(v), "cook-torrance", 6, 0.5).unwrap();
        let exact = text(3e-16);
        assert!(exact.contains(">\nexact\n<"), "{exact}");
        assert!(exact.contains("max |log10 ratio| 3.0e-16"), "{exact}");
        let near = text(2e-3);
        assert!(
            near.contains(">\n≈ exact\n<") && near.contains("2.0e-3"),
            "{near}"
        );
        // A visible residual (a tenth of the scale) or no value at all: no label.
        assert!(!text(0.05).contains("exact"));
        let empty = ResidualMap {
            values: vec![None; 6],
            ..map(0.0)
        };
        assert_eq!(exact_label(&empty, 0.5), None);
    }

    #[test]
    fn colour_bar_is_svg_with_its_labels() {
        let s = colour_bar(0.5).unwrap();
        assert!(s.starts_with("<svg"), "{}", &s[..40]);
        assert!(s.contains("log10(model / measured)"), "{s}");
        assert!(
            s.contains(">\n+0.20\n<") && s.contains(">\n-0.20\n<") && s.contains(">\n0\n<"),
            "{s}"
        );
        // 64 colour steps, from blue to red.
        for t in [-63.0 / 64.0, 63.0 / 64.0] {
            let c = diverging(t);
            assert!(
                s.contains(&format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)),
                "{s}"
            );
        }
    }
}
