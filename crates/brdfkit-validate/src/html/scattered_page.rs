//! The page of the report on scattered data ([`super::scattered`]): the input, the
//! summary, measured against model per sample, the residual profiles over θh and θd,
//! the spheres (a `.bsdf`'s from the file itself; none for samples, said plainly) and
//! the physical checks.

use super::ReportError;
use super::charts::{CHANNELS, err, framed, log_range, mesh, model_colour, svg};
use super::page::{png_uri, summary_table, swatch, verdict_class};
use super::scattered_data::{BAND_DEG, Band, ScatteredData};
use super::style::PAGE_CSS;
use brdfkit_core::Rgb;
use maud::{DOCTYPE, Markup, PreEscaped, html};
use plotters::prelude::*;

/// Measured (x) against model (y) values of one model, one dot per plotted sample and
/// channel (red, green, blue), on log axes with the diagonal a perfect fit lies on.
fn scatter_chart(label: &str, measured: &[Rgb], model: &[Rgb]) -> Result<String, ReportError> {
    let values = measured.iter().chain(model).flat_map(|v| v.0);
    let (lo, hi) = log_range(values);
    let colours = [
        RGBColor(200, 40, 40),
        RGBColor(40, 150, 40),
        RGBColor(40, 70, 200),
    ];
    svg((420, 360), |root| {
        let mut chart = framed(root, format!("{label}: model vs measured"), 58)
            .build_cartesian_2d((lo..hi).log_scale(), (lo..hi).log_scale())
            .map_err(err)?;
        mesh(&mut chart.configure_mesh())
            .x_desc("measured f_r (1/sr)")
            .y_desc("model f_r (1/sr)")
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new([(lo, lo), (hi, hi)], BLACK.mix(0.5)))
            .map_err(err)?;
        for (c, col) in colours.iter().enumerate() {
            let dots = measured
                .iter()
                .zip(model)
                .filter(|(m, f)| m.0[c] > 0.0 && f.0[c] > 0.0)
                .map(|(m, f)| Circle::new((m.0[c], f.0[c]), 2, col.mix(0.45).filled()));
            chart.draw_series(dots).map_err(err)?;
        }
        Ok(())
    })
}

/// The runs of adjacent bands that hold samples, as chart points (band centre, value):
/// a profile's line joins the bands of a run and not across a band without samples,
/// where there is no value to draw.
fn runs(bands: &[Band]) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut last_lo = f64::NEG_INFINITY;
    for b in bands {
        let Some(r) = b.mean_log10_ratio else {
            continue;
        };
        // 1.5 bands: adjacent bands' edges differ by one band up to round-off.
        if out.is_empty() || b.lo_deg - last_lo > 1.5 * BAND_DEG {
            out.push(Vec::new());
        }
        out.last_mut()
            .expect("pushed above")
            .push((b.lo_deg + 0.5 * BAND_DEG, r));
        last_lo = b.lo_deg;
    }
    out
}

/// Every model's residual profile over one angle (lines, in the models' colours, in
/// model order). The legend is the page's, above the charts: a legend inside the chart
/// covered the profile where it ends (at θd ≈ 70–90°, the bands that tell the models
/// apart), as the browser test found (crates/fit-brdf/tests/report_browser.rs).
fn profile_chart(axis: &str, profiles: &[&[Band]]) -> Result<String, ReportError> {
    let top = profiles
        .iter()
        .flat_map(|b| b.iter().filter_map(|b| b.mean_log10_ratio))
        .fold(0.05f64, |a, v| a.max(v.abs()))
        * 1.15;
    svg((420, 300), |root| {
        let mut chart = framed(root, format!("residual by {axis}"), 50)
            .build_cartesian_2d(0.0..90.0, -top..top)
            .map_err(err)?;
        // Whole degrees: "90.0" at the right end was cut off by the chart's edge.
        mesh(&mut chart.configure_mesh())
            .x_label_formatter(&|v| format!("{v:.0}"))
            .x_desc(format!("{axis} (degrees, {BAND_DEG:.0}° bands)"))
            .y_desc("mean log10(model / measured)")
            .draw()
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new([(0.0, 0.0), (90.0, 0.0)], BLACK.mix(0.4)))
            .map_err(err)?;
        for (m, bands) in profiles.iter().enumerate() {
            let col = model_colour(m);
            for run in runs(bands) {
                chart
                    .draw_series(LineSeries::new(run.clone(), col.stroke_width(2)))
                    .map_err(err)?;
                chart
                    .draw_series(run.into_iter().map(|p| Circle::new(p, 3, col.filled())))
                    .map_err(err)?;
            }
        }
        Ok(())
    })
}

/// The page.
pub(crate) fn page(d: &ScatteredData, title: &str) -> Result<String, ReportError> {
    let mut scatter = Vec::new();
    for m in &d.models {
        scatter.push(scatter_chart(&m.label, &d.plotted_measured, &m.plotted)?);
    }
    let th: Vec<&[Band]> = d.models.iter().map(|m| &m.by_theta_h[..]).collect();
    let td: Vec<&[Band]> = d.models.iter().map(|m| &m.by_theta_d[..]).collect();
    let profiles = [profile_chart("θh", &th)?, profile_chart("θd", &td)?];
    let i = &d.summary.input;
    let markup = html! {
        (DOCTYPE)
        html lang="en" {
            head {
                meta charset="utf-8";
                title { (title) " · " (i.path) }
                style { (PreEscaped(PAGE_CSS)) }
            }
            body {
                h1 { (title) }
                p.meta id="input" data-kind=(i.kind) {
                    "Input: " b { (i.text()) } ". "
                    span id="not-resampled" { "Nothing on this page is resampled: every figure is taken at the samples' own directions, with their weights (" (d.summary.weighting.name()) ")." }
                    " The table report's θh slices, residual maps, albedo and interactive views need a full MERL grid, which scattered data do not have; how to read this page: docs/report.md."
                }
                h2 id="summary" { "Summary" }
                p.note { "Weighted RMS losses of each model against the samples, overall (hover a value for R · G · B); the best value of each column is bold." }
                (summary_table(&d.summary.models))
                h2 id="scatter" { "Model against measured, per sample" }
                p.note { (d.plotted) " of " (i.cells) " samples drawn (every k-th in the input's order), each channel a dot (red, green, blue); a perfect fit lies on the diagonal." }
                div.row { @for s in &scatter { (PreEscaped(s)) } }
                h2 id="profiles" { "Residuals by θh and θd" }
                p.note { "The weighted mean of log10(model / measured) over the samples in each " (BAND_DEG) "° band of the half vector's angle θh and of the difference angle θd (above 0: the model is too bright)." }
                p.note id="profiles-legend" { @for (m, md) in d.models.iter().enumerate() { (swatch(m)) (md.label) " " } }
                div.row { @for s in &profiles { (PreEscaped(s)) } }
                (renders_section(d))
                (checks_section(d))
            }
        }
    };
    Ok(markup.into_string())
}

/// The spheres: the `.bsdf` from the file itself, or the plain statement that
/// scattered samples have none.
fn renders_section(d: &ScatteredData) -> Markup {
    html! {
    h2 id="renders" { "Rendered spheres" }
    @match &d.summary.measured_sphere {
        None => p.note id="no-measured-sphere" {
            "No measured sphere: the data are " (d.summary.input.cells) " scattered samples, and nothing measured can be evaluated between them without resampling, which this report does not do. Compare the models against the samples above."
        },
        Some(src) if d.renders.is_empty() => p.note { "Not rendered (renders were turned off); the measured side would be " (src) "." },
        Some(src) => {
            p.note id="measured-sphere" { "Measured: " (src) ", not a resampled table; each model beside it with the same camera, light, seed and exposure, and its difference (orange: brighter, blue: darker)." }
            @for set in &d.renders {
                h3 { (set.lighting.title()) " (" (set.spp) " spp)" }
                div.row {
                    div.card { img src=(png_uri(&set.table_png)) alt="measured (.bsdf file)"; "measured (.bsdf file)" }
                    @for (m, r) in set.models.iter().enumerate() {
                        div.card {
                            div.pair { img src=(png_uri(&r.png)) alt="model"; img src=(png_uri(&r.diff_png)) alt="difference"; }
                            (swatch(m)) b { (d.models[m].label) } br;
                            "rel. RMS " (format!("{:.1} %", r.diff.rel_rms_radiance * 100.0))
                        }
                    }
                }
            }
        }
    }
    }
}

/// The physical checks' verdicts per model and channel model.
fn checks_section(d: &ScatteredData) -> Markup {
    html! {
    h2 id="checks" { "Physical checks of the models" }
    @if d.models.iter().all(|m| m.physical.is_empty()) {
        p.note { "Not run." }
    } @else {
        p.note { "The table report's bounded set (docs/report.md); `fit-brdf check` runs the full one." }
        table {
            thead { tr { th.l { "model" } th { "non-negativity" } th { "reciprocity" } th { "energy" } th { "isotropy" } th { "finiteness" } } }
            tbody {
                @for (m, md) in d.models.iter().enumerate() {
                    @for (k, p) in md.physical.iter().enumerate() {
                        tr {
                            td.l { (swatch(m)) (md.label) @if md.physical.len() == 3 { " (" (CHANNELS[k]) ")" } }
                            @for v in [&p.non_negativity.verdict, &p.reciprocity.verdict, &p.energy.verdict, &p.isotropy.verdict, &p.finiteness.verdict] {
                                td { span class=(verdict_class(v.label())) { (v.label()) } }
                            }
                        }
                    }
                }
            }
        }
    }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn band(lo_deg: f64, r: Option<f64>) -> Band {
        Band {
            lo_deg,
            samples: usize::from(r.is_some()),
            mean_log10_ratio: r,
        }
    }

    /// An empty band, listed or left out, splits the line; adjacent bands stay joined.
    #[test]
    fn a_line_does_not_cross_an_empty_band() {
        let bands = [
            band(0.0, Some(0.1)),
            band(5.0, Some(0.2)),
            band(10.0, None),
            band(15.0, Some(0.3)),
            band(30.0, Some(0.4)),
            band(35.0, Some(0.5)),
        ];
        let r = runs(&bands);
        let x: Vec<Vec<f64>> = r
            .iter()
            .map(|run| run.iter().map(|p| p.0).collect())
            .collect();
        assert_eq!(x, vec![vec![2.5, 7.5], vec![17.5], vec![32.5, 37.5]]);
        assert!(runs(&[band(0.0, None)]).is_empty());
    }
}
