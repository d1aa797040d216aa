//! PNG plots without system fonts: plotters' bitmap backend draws into an RGB buffer,
//! text is rasterised by ab_glyph from the bundled DejaVu Sans, and `image` encodes the
//! PNG (plotters' own encoder would pull a second `image` version).

use crate::StudyError;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// The bundled font (DejaVu Sans, Bitstream Vera license; see `assets/README.md`).
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // A failure leaves text undrawable and surfaces as a drawing error below.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A set of points of one colour, optionally joined by a line.
#[derive(Debug, Clone)]
pub struct Series {
    /// Label in the legend.
    pub name: String,
    /// (x, y) points.
    pub points: Vec<(f64, f64)>,
    /// Draw a line through the points (in the given order) instead of markers.
    pub line: bool,
    /// Write the name beside each marker instead of a legend entry.
    pub tag: bool,
    /// Palette index.
    pub color: usize,
}

/// One panel: a title and its series.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Title above the panel.
    pub title: String,
    /// Its series.
    pub series: Vec<Series>,
}

/// Axis options shared by the panels of a figure.
#[derive(Debug, Clone)]
pub struct Axes {
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
}

/// Colour-blind-safe palette (Okabe & Ito 2008), then black.
pub fn color(i: usize) -> RGBColor {
    const P: [RGBColor; 8] = [
        RGBColor(0, 114, 178),
        RGBColor(213, 94, 0),
        RGBColor(0, 158, 115),
        RGBColor(204, 121, 167),
        RGBColor(230, 159, 0),
        RGBColor(86, 180, 233),
        RGBColor(240, 228, 66),
        RGBColor(0, 0, 0),
    ];
    P[i % P.len()]
}

fn range(v: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v.filter(|x| x.is_finite() && (!log || *x > 0.0)) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !lo.is_finite() {
        return (1.0, 10.0);
    }
    if log {
        // Half a decade of margin; an empty spread still gets a decade.
        let (l, h) = (lo.log10() - 0.25, hi.log10() + 0.25);
        let h = if h - l < 1.0 { l + 1.0 } else { h };
        (10f64.powf(l), 10f64.powf(h))
    } else {
        let pad = ((hi - lo) * 0.08).max(hi.abs() * 0.05).max(1e-12);
        (lo - pad, hi + pad)
    }
}

fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-2..1e4).contains(&a) {
        format!("{v:.0e}")
    } else if a >= 10.0 {
        format!("{v:.0}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    panel: &Panel,
    axes: &Axes,
) -> Result<(), String> {
    let pts = || panel.series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) = range(pts().map(|p| p.0), axes.log_x);
    let (y0, y1) = range(pts().map(|p| p.1), axes.log_y);
    let mut b = ChartBuilder::on(area);
    b.caption(&panel.title, ("sans-serif", 18))
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(64);
    // The four axis kinds are distinct types in plotters; one generic body draws them.
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart.map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc(axes.x_label.as_str())
                .y_desc(axes.y_label.as_str())
                .x_label_formatter(&|v| fmt_tick(*v))
                .y_label_formatter(&|v| fmt_tick(*v))
                .label_style(("sans-serif", 13))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| e.to_string())?;
            for s in &panel.series {
                let c = color(s.color);
                let ok = |p: &&(f64, f64)| {
                    p.0.is_finite()
                        && p.1.is_finite()
                        && (!axes.log_x || p.0 > 0.0)
                        && (!axes.log_y || p.1 > 0.0)
                };
                let p: Vec<(f64, f64)> = s.points.iter().filter(ok).copied().collect();
                if s.line {
                    chart
                        .draw_series(LineSeries::new(p, c.stroke_width(2)))
                        .map_err(|e| e.to_string())?
                        .label(s.name.as_str())
                        .legend(move |(x, y)| {
                            PathElement::new([(x, y), (x + 16, y)], c.stroke_width(2))
                        });
                } else if s.tag {
                    let style = ("sans-serif", 12).into_font().color(&c);
                    chart
                        .draw_series(p.into_iter().map(|q| {
                            EmptyElement::at(q)
                                + Circle::new((0, 0), 4, c.filled())
                                + Text::new(s.name.clone(), (7, -6), style.clone())
                        }))
                        .map_err(|e| e.to_string())?;
                } else {
                    chart
                        .draw_series(p.into_iter().map(|q| Circle::new(q, 4, c.filled())))
                        .map_err(|e| e.to_string())?
                        .label(s.name.as_str())
                        .legend(move |(x, y)| Circle::new((x + 8, y), 4, c.filled()));
                }
            }
            if panel.series.iter().all(|s| s.tag) {
                return Ok(());
            }
            chart
                .configure_series_labels()
                .label_font(("sans-serif", 12))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(|e| e.to_string())?;
        }};
    }
    let (xr, yr): (RangedCoordf64, RangedCoordf64) = ((x0..x1).into(), (y0..y1).into());
    match (axes.log_x, axes.log_y) {
        (true, true) => body!(b.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())),
        (true, false) => body!(b.build_cartesian_2d((x0..x1).log_scale(), yr)),
        (false, true) => body!(b.build_cartesian_2d(xr, (y0..y1).log_scale())),
        (false, false) => body!(b.build_cartesian_2d(xr, yr)),
    }
    Ok(())
}

/// Draws `panels` on a `cols`-wide grid of `panel_w × panel_h` pixels and writes the PNG
/// atomically.
pub fn figure(
    path: &Path,
    title: &str,
    panels: &[Panel],
    axes: &Axes,
    cols: usize,
    (panel_w, panel_h): (u32, u32),
) -> Result<(), StudyError> {
    register_font();
    let cols = cols.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(cols).max(1);
    let head = if title.is_empty() { 0 } else { 36 };
    let (w, h) = (panel_w * cols as u32, panel_h * rows as u32 + head);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let err = |msg: String| StudyError::Plot {
        path: path.to_path_buf(),
        msg,
    };
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let body = if head > 0 {
            let (top, rest) = root.split_vertically(head);
            top.draw_text(
                title,
                &("sans-serif", 22).into_font().color(&BLACK),
                (12, 8),
            )
            .map_err(|e| err(e.to_string()))?;
            rest
        } else {
            root.clone()
        };
        let areas = body.split_evenly((rows, cols));
        for (a, p) in areas.iter().zip(panels) {
            draw_panel(a, p, axes).map_err(err)?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    write_png(path, buf, (w, h))
}

/// Encodes an RGB buffer of `w × h` pixels as PNG and writes it atomically.
fn write_png(path: &Path, buf: Vec<u8>, (w, h): (u32, u32)) -> Result<(), StudyError> {
    let err = |msg: String| StudyError::Plot {
        path: path.to_path_buf(),
        msg,
    };
    let img = image::RgbImage::from_raw(w, h, buf).ok_or_else(|| err("buffer size".into()))?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| err(e.to_string()))?;
    crate::files::write(path, &png)
}

/// Writes the RGB buffer `buf` (`w × h` pixels, e.g. a contact sheet of renders) as a
/// PNG with each text of `labels` drawn in black at its (x, y) pixel position.
pub fn label_png(
    path: &Path,
    mut buf: Vec<u8>,
    (w, h): (u32, u32),
    labels: &[(String, (i32, i32))],
) -> Result<(), StudyError> {
    register_font();
    let err = |msg: String| StudyError::Plot {
        path: path.to_path_buf(),
        msg,
    };
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let font = ("sans-serif", 14).into_font().color(&BLACK);
        for (text, at) in labels {
            root.draw_text(text, &font, *at)
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    write_png(path, buf, (w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_a_png_with_text_and_points() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.png");
        let panel = Panel {
            title: "panel".into(),
            series: vec![
                Series {
                    name: "a".into(),
                    points: vec![(0.1, 1e-3), (1.0, 1e-5), (10.0, 1e-9)],
                    line: false,
                    tag: false,
                    color: 0,
                },
                Series {
                    name: "front".into(),
                    points: vec![(0.1, 1e-3), (10.0, 1e-9)],
                    line: true,
                    tag: false,
                    color: 7,
                },
            ],
        };
        let axes = Axes {
            x_label: "time (s)".into(),
            y_label: "loss".into(),
            log_x: true,
            log_y: true,
        };
        figure(&p, "title", &[panel.clone(), panel], &axes, 2, (400, 300)).unwrap();
        let img = image::open(&p).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (800, 336));
        // Text and markers were drawn: many non-white pixels, some of the palette blue.
        let non_white = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(non_white > 2000, "{non_white}");
        assert!(img.pixels().any(|p| p.0 == [0, 114, 178]));
    }
}
