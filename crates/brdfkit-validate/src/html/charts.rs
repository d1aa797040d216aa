//! The report's charts as SVG strings (plotters' SVG backend: no system fonts, no
//! bitmap encoder; the browser lays out the text).

use super::ReportError;
use super::analysis::{AlbedoCurves, ResidualMap, Slice};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::prelude::*;
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

const CHANNELS: [&str; 3] = ["R", "G", "B"];

fn err<E: std::fmt::Debug>(e: E) -> ReportError {
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
fn svg(
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

/// A log-scale y range covering `values` (positive ones), with a margin.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
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
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(58)
            .build_cartesian_2d(axis, (lo..hi).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
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
        for (m, vals) in s.models.iter().enumerate() {
            let col = model_colour(m);
            let pts: Vec<(f64, f64)> = s
                .theta_h_index
                .iter()
                .zip(vals)
                .filter(|(_, v)| v[c] > 0.0)
                .map(|(&i, v)| (i as f64, v[c].max(lo)))
                .collect();
            chart
                .draw_series(LineSeries::new(pts, col.stroke_width(2)))
                .map_err(err)?
                .label(labels[m].clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 14, y)], col.stroke_width(2))
                });
        }
        let pts: Vec<(f64, f64)> = s
            .theta_h_index
            .iter()
            .zip(&s.measured)
            .filter(|(_, v)| v[c] > 0.0)
            .map(|(&i, v)| (i as f64, v[c]))
            .collect();
        chart
            .draw_series(pts.into_iter().map(|p| Circle::new(p, 2, BLACK.filled())))
            .map_err(err)?
            .label("measured")
            .legend(|(x, y)| Circle::new((x + 7, y), 3, BLACK.filled()));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(err)?;
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
        let mut chart = ChartBuilder::on(root)
            .caption(label, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(44)
            .build_cartesian_2d(axis, 0.0..90.0)
            .map_err(err)?;
        chart
            .configure_mesh()
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
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
        Ok(())
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
        chart
            .configure_mesh()
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
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
pub fn albedo_chart(
    a: &AlbedoCurves,
    channel: usize,
    labels: &[String],
) -> Result<String, ReportError> {
    let c = channel;
    let deg: Vec<f64> = a.theta_o.iter().map(|t| t.to_degrees()).collect();
    let top = a
        .table
        .iter()
        .flatten()
        .map(|v| v[c])
        .chain(a.models.iter().flatten().map(|v| v[c]))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let top = if top > 0.0 { top * 1.15 } else { 1.0 };
    svg((380, 280), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(format!("albedo, {}", CHANNELS[c]), ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..90.0, 0.0..top)
            .map_err(err)?;
        chart
            .configure_mesh()
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
            .x_desc("θo (degrees)")
            .y_desc("a(θo) = ∫ f cos θi dωi")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(err)?;
        for (m, vals) in a.models.iter().enumerate() {
            let col = model_colour(m);
            let pts: Vec<(f64, f64)> = deg.iter().zip(vals).map(|(&x, v)| (x, v[c])).collect();
            chart
                .draw_series(LineSeries::new(pts, col.stroke_width(2)))
                .map_err(err)?
                .label(labels[m].clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 14, y)], col.stroke_width(2))
                });
        }
        let pts: Vec<(f64, f64)> = deg
            .iter()
            .zip(&a.table)
            .filter_map(|(&x, v)| v.map(|v| (x, v[c])))
            .collect();
        chart
            .draw_series(pts.into_iter().map(|p| Circle::new(p, 3, BLACK.filled())))
            .map_err(err)?
            .label("measured")
            .legend(|(x, y)| Circle::new((x + 7, y), 3, BLACK.filled()));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(err)?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diverging_map_ends_and_centre() {
        assert_eq!(diverging(0.0), RGBColor(255, 255, 255));
        assert_eq!(diverging(1.0), RGBColor(178, 24, 43));
        assert_eq!(diverging(-7.0), RGBColor(33, 102, 172));
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
