//! The HTML page (maud): sections in reading order, charts inline, images as data URIs.

use super::analysis::LOG_RATIO_FLOOR;
use super::charts::{self, model_colour_hex};
use super::style::{PAGE_CSS, PANELS_CSS};
use super::{ReportData, ReportError};
use crate::report::{deg, num};
use base64::Engine;
use brdfkit_fit::{Loss, LossReport};
use maud::{DOCTYPE, Markup, PreEscaped, html};
use serde_json::Value;

/// On load, records in the DOM whether every image decoded (naturalWidth > 0), how many
/// charts there are and whether the summary table has its rows: a headless browser's
/// `--dump-dom` shows it (the tests read `data-status`).
const CHECK_SCRIPT: &str = r#"
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); }).length;
  var svgs = document.querySelectorAll('svg').length;
  var rows = document.querySelectorAll('#summary-table tbody tr').length;
  var el = document.getElementById('page-check');
  el.setAttribute('data-images', imgs.length);
  el.setAttribute('data-broken', broken);
  el.setAttribute('data-svgs', svgs);
  el.setAttribute('data-summary-rows', rows);
  el.setAttribute('data-status', broken === 0 && imgs.length > 0 && rows > 0 ? 'ok' : 'broken');
  el.textContent = 'page check: ' + imgs.length + ' images (' + broken + ' broken), ' + svgs + ' charts, ' + rows + ' models in the summary';
});
"#;

pub(super) fn png_uri(png: &[u8]) -> String {
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

pub(super) fn verdict_class(label: &str) -> &'static str {
    match label {
        "PASS" => "pass",
        "FAIL" => "fail",
        _ => "inconclusive",
    }
}

/// `name = value` lines of a model's parameters (nested objects flattened).
pub(super) fn params_text(v: &Value) -> String {
    fn walk(prefix: &str, v: &Value, out: &mut Vec<String>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    let p = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&p, x, out);
                }
            }
            Value::Array(a) if a.iter().all(Value::is_number) => out.push(format!(
                "{prefix} = [{}]",
                a.iter()
                    .map(|x| num(x.as_f64().unwrap_or(f64::NAN)))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            Value::Array(a) => {
                for (k, x) in a.iter().enumerate() {
                    walk(&format!("{prefix}[{k}]"), x, out);
                }
            }
            Value::Number(n) => out.push(format!(
                "{prefix} = {}",
                num(n.as_f64().unwrap_or(f64::NAN))
            )),
            other => out.push(format!("{prefix} = {other}")),
        }
    }
    let mut out = Vec::new();
    if let Some(pc) = v.get("per_channel") {
        walk("", pc, &mut out);
    } else {
        walk("", v.get("params").unwrap_or(v), &mut out);
    }
    out.join("\n")
}

/// A round colour-scale bound ≥ x: 0.05, 0.1, 0.2, 0.5, 1, 2 … (log10 units).
fn nice_scale(x: f64) -> f64 {
    for s in [0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 3.0] {
        if x <= s {
            return s;
        }
    }
    -LOG_RATIO_FLOOR
}

pub(super) fn swatch(m: usize) -> Markup {
    html! { span.swatch style=(format!("background:{}", model_colour_hex(m))) {} }
}

/// The page.
pub(crate) fn page(
    d: &ReportData,
    theta_h_bins: usize,
    panels: &str,
) -> Result<String, ReportError> {
    let labels: Vec<String> = d.summary.models.iter().map(|m| m.label.clone()).collect();
    let t = &d.summary.table;
    // Charts first (they can fail).
    let mut slice_svgs = Vec::new();
    for s in &d.slices {
        let mut row = Vec::new();
        for c in 0..3 {
            row.push(charts::slice_chart(s, c, theta_h_bins, &labels)?);
        }
        slice_svgs.push(row);
    }
    let scale = residual_scale(d);
    let mut map_svgs = Vec::new();
    for m in &d.models {
        map_svgs.push(charts::residual_chart(
            &m.residual_map,
            &m.label,
            theta_h_bins,
            scale,
        )?);
    }
    let bar = charts::colour_bar(scale)?;
    let mut albedo_svgs = Vec::new();
    for c in 0..3 {
        albedo_svgs.push(charts::albedo_chart(&d.albedo, c, &labels)?);
    }
    let markup = html! {
        (DOCTYPE)
        html lang="en" {
            head {
                meta charset="utf-8";
                meta name="viewport" content="width=device-width, initial-scale=1";
                title { (d.options.title) " · " (t.name) }
                style { (PreEscaped(PAGE_CSS)) (PreEscaped(PANELS_CSS)) }
            }
            body {
                (meta_section(d))
                (summary_section(d))
                h2 id="interactive" { "Interactive views" }
                (PreEscaped(panels))
                (slices_section(d, &slice_svgs))
                (residuals_section(d, &map_svgs, &bar, scale))
                (renders_section(d, &labels))
                (albedo_section(d, &albedo_svgs, &labels))
                (checks_section(d))
                (details_section(d))
                p id="page-check" data-status="pending" { "page check: not run (the page's script did not run)" }
                script { (PreEscaped(CHECK_SCRIPT)) }
            }
        }
    };
    Ok(markup.into_string())
}

/// One scale for every residual map: the median over the models of each map's 95th
/// percentile of |log ratio|, so neither the worst nor the best model sets it alone.
fn residual_scale(d: &ReportData) -> f64 {
    let mut p95: Vec<f64> = d
        .models
        .iter()
        .map(|m| {
            let mut a: Vec<f64> = m
                .residual_map
                .values
                .iter()
                .flatten()
                .map(|v| v.abs())
                .collect();
            a.sort_unstable_by(f64::total_cmp);
            a.get(((a.len() as f64 * 0.95) as usize).min(a.len().saturating_sub(1)))
                .copied()
                .unwrap_or(0.0)
        })
        .collect();
    p95.sort_unstable_by(f64::total_cmp);
    nice_scale(p95.get(p95.len() / 2).copied().unwrap_or(0.05))
}

/// The title, the table and fit settings, the navigation.
fn meta_section(d: &ReportData) -> Markup {
    let t = &d.summary.table;
    let cfg = d.fit_config.as_ref();
    html! {
    h1 { (d.options.title) }
    p.meta {
        "Table " b { (t.name) } ": " (t.dims[0]) " × " (t.dims[1]) " × " (t.dims[2])
        " (θh × θd × φd), " (t.valid_cells) " valid cells of " (t.cells) ". "
        @if let Some(c) = cfg {
            "Fits: loss " b { (c.get_loss().name()) } ", " (c.get_weighting().name()) " weights, solver "
            (c.get_solver().name()) ", " (c.get_starts()) " start(s), sharing " (c.get_sharing().name())
            @if let Some(s) = c.get_subsample() { ", " (num(s * 100.0)) " % stratified subsample" }
            @if let Some(td) = c.get_theta_d_max() { ", θd ≤ " (deg(td.to_degrees())) }
            ". "
        }
        "Report computed in " (format!("{:.1}", d.timings.total_s)) " s. Every loss below is over all valid cells ("
        (d.summary.weighting.name()) " weights); how to read each section: docs/report.md."
    }
    nav {
        a href="#summary" { "Summary" } a href="#interactive" { "Interactive views" } a href="#slices" { "θh slices" } a href="#residuals" { "Residual maps" }
        a href="#renders" { "Renders" } a href="#albedo" { "Albedo" } a href="#checks" { "Physical checks" } a href="#details" { "Details" }
    }
    }
}

/// The summary table; the best value of each loss column is bold.
fn summary_section(d: &ReportData) -> Markup {
    html! {
    h2 id="summary" { "Summary" }
    p.note { "Weighted RMS losses of the fitted model against the table, overall (hover a value for R · G · B); the best value of each column is bold. Lower is better; the losses are on different scales, compare models within a column." }
    (summary_table(&d.summary.models))
    }
}

/// The models' summary rows (`#summary-table`); the best value of each loss column is
/// bold. Shared with the report on scattered data.
pub(super) fn summary_table(models: &[super::ModelSummary]) -> Markup {
    let mut best = [f64::INFINITY; 4];
    for m in models {
        for (k, loss) in Loss::ALL.iter().enumerate() {
            best[k] = best[k].min(m.losses.get(*loss).overall);
        }
    }
    html! {
    table id="summary-table" {
        thead { tr {
            th.l { "model" } th { "cbrt" } th { "l2" } th { "cosine" } th { "log" }
            th { "fit time (s)" } th { "iterations" } th { "physical checks" } th.l { "parameters" }
        } }
        tbody {
            @for (m, s) in models.iter().enumerate() {
                tr {
                    td.l { (swatch(m)) (s.label) }
                    // Loss::ALL is l2, cosine, cbrt, log; the columns put cbrt first.
                    (loss_cells_ordered(&s.losses, &best))
                    td { @match s.fit_time_s { Some(x) => (format!("{x:.2}")), None => "–" } }
                    td { @match (s.iterations, s.converged) {
                        (Some(i), Some(true)) => (i),
                        (Some(i), _) => { (i) " (not converged)" },
                        _ => "–",
                    } }
                    td { @match s.physical_passed {
                        Some(true) => span.pass { "PASS" },
                        Some(false) => span.fail { "FAIL" },
                        None => "not run",
                    } }
                    td.l { code.params { (params_text(&s.params)) } }
                }
            }
        }
    }
    }
}

/// The θh slices, measured against fitted.
fn slices_section(d: &ReportData, slice_svgs: &[Vec<String>]) -> Markup {
    html! {
    h2 id="slices" { "θh slices: measured vs fitted" }
    p.note {
        "f_r along θh (the half-vector's angle from the normal) at fixed θd and φd = "
        (format!("{:.0}°", d.options.slice_phi_d.to_degrees()))
        ", per channel, on a log axis. Black dots: the table's cells; lines: each fitted model at the same cells. The θh axis is MERL's √ axis (the bin index), so the specular peak near θh = 0 is spread out. A line above the dots is a model too bright there."
    }
    @for row in slice_svgs {
        div.row { @for s in row { (PreEscaped(s)) } }
    }
    }
}

/// The residual maps and their colour bar.
fn residuals_section(d: &ReportData, map_svgs: &[String], bar: &str, scale: f64) -> Markup {
    html! {
    h2 id="residuals" { "Residual maps" }
    p.note {
        "log10(f_model / f_measured) averaged over φd and the three channels, per block of "
        @if let Some(m) = d.models.first() { (m.residual_map.block[0]) " θh × " (m.residual_map.block[1]) " θd bins" }
        ". Red: the model is too bright, blue: too dark, white: exact (a map white all over says so, with its largest |log10 ratio|); ±" (num(scale))
        " (a factor " (num(10f64.powf(scale))) ") saturates, the same scale for every model. Grey: no measured value (below the horizon or missing). Specular peak at the left edge, grazing angles at the top."
    }
    div.row {
        @for s in map_svgs { (PreEscaped(s)) }
        (PreEscaped(bar))
    }
    @let zeros: Vec<(String, usize)> = d.models.iter().filter(|m| m.residual_map.model_zero > 0).map(|m| (m.label.clone(), m.residual_map.model_zero)).collect();
    @if !zeros.is_empty() {
        p.note { "Cell channels where the model is exactly 0 and the table is not (entered at log10 ratio " (LOG_RATIO_FLOOR) "): "
            @for (l, n) in &zeros { (l) " " (n) "; " } }
    }
    }
}

/// The rendered spheres and their differences.
fn renders_section(d: &ReportData, labels: &[String]) -> Markup {
    html! {
    h2 id="renders" { "Rendered spheres" }
    @if d.renders.is_empty() {
        p.note { "Not rendered (renders were turned off)." }
    } @else {
        p.note {
            "The table (interpolated lookups) and each fitted model on a sphere, same camera, light, seed and exposure (set from the table's image), "
            (d.options.render.as_ref().map_or(0, |r| r.size)) " × " (d.options.render.as_ref().map_or(0, |r| r.size))
            " pixels. Difference (right of each fit): the fit's displayed image minus the table's, averaged over the channels; orange: the fit is brighter, blue: darker, black: equal; ±"
            (d.options.render.as_ref().map_or(0.0, |r| r.diff_scale) * 100.0) " % of the display range saturates. Figures: mean |Δ| over the sphere in display units, and the relative RMS radiance error. A thin grey ring just outside the sphere marks its outline on every image, so the side the point light leaves dark still reads as part of the sphere (the ring covers no sphere pixel and enters no figure)."
        }
        @for set in &d.renders {
            h3 { (set.lighting.title()) " (" (set.spp) " spp, exposure " (format!("{:+.2}", set.exposure)) " stops"
                @if set.table_misses > 0 { ", " (set.table_misses) " table lookups found no sample" } ")" }
            div.row {
                div.card { img src=(png_uri(&set.table_png)) alt="measured table"; "measured table" }
                @for (m, r) in set.models.iter().enumerate() {
                    div.card {
                        div.pair {
                            img src=(png_uri(&r.png)) alt=(format!("{} fit", labels[m]));
                            img src=(png_uri(&r.diff_png)) alt=(format!("{} difference", labels[m]));
                        }
                        (swatch(m)) b { (labels[m]) } br;
                        "mean |Δ| " (format!("{:.3}", r.diff.mean_abs_display)) " · rel. RMS " (format!("{:.1} %", r.diff.rel_rms_radiance * 100.0))
                    }
                }
            }
        }
    }
    }
}

/// The albedo curves and the largest difference per model.
fn albedo_section(d: &ReportData, albedo_svgs: &[String], labels: &[String]) -> Markup {
    html! {
    h2 id="albedo" { "Albedo: fit vs table" }
    p.note { "The directional albedo a(θo) = ∫ f(wi, wo) cos θi dωi, the fraction of light reflected towards the viewer at θo from a uniform white sky, by converged quadrature (the table's with interpolated lookups). Dots: the table; lines: the models. A model whose curve lies below the dots loses energy the material reflects." }
    div.row { @for s in albedo_svgs { (PreEscaped(s)) } }
    table {
        thead { tr { th.l { "model" } th { "max |fit − table| (R, G, B)" } th { "at θo" } } }
        tbody {
            @for (m, vals) in d.albedo.models.iter().enumerate() {
                @let worst = vals.iter().zip(&d.albedo.table).zip(&d.albedo.theta_o)
                    .filter_map(|((f, t), th)| t.map(|t| ((0..3).map(|c| (f[c] - t[c]).abs()).fold(0.0, f64::max), *th, (*f - t))))
                    .max_by(|a, b| a.0.total_cmp(&b.0));
                tr {
                    td.l { (swatch(m)) (labels[m]) }
                    @match worst {
                        Some((_, th, diff)) => {
                            td { (num(diff[0])) ", " (num(diff[1])) ", " (num(diff[2])) }
                            td { (deg(th.to_degrees())) }
                        },
                        None => { td { "–" } td { "–" } },
                    }
                }
            }
        }
    }
    }
}

/// The physical checks of the fitted models.
fn checks_section(d: &ReportData) -> Markup {
    html! {
    h2 id="checks" { "Physical checks of the fitted models" }
    @match &d.options.checks {
        None => p.note { "Not run." },
        Some(co) => {
            p.note {
                "brdfkit-validate's check_model on each fitted model (each channel's model for a per-channel fit): non-negativity and reciprocity over a "
                (co.dense_theta) " × " (co.dense_theta) " polar grid × " (co.dense_phi) " azimuths plus " (co.random_pairs)
                " random pairs (thresholds f ≥ " (num(-co.thresholds.negativity)) ", relative asymmetry ≤ " (num(co.thresholds.reciprocity))
                "); energy: the directional albedo in both readings at θ = "
                (co.albedo_thetas.iter().map(|t| deg(t.to_degrees())).collect::<Vec<_>>().join(", "))
                " (≤ 1 + " (num(co.thresholds.energy)) ", quadrature converged to " (num(co.thresholds.convergence))
                "); isotropy under rotations about the normal (≤ " (num(co.thresholds.isotropy))
                ", required of isotropic models); finiteness of values and gradients over the hard cases (normal, grazing, horizon, mirror). A coarser set than `fit-brdf check`, which runs the full one."
            }
            table {
                thead { tr { th.l { "model" } th { "non-negativity" } th { "reciprocity" } th { "energy (max albedo)" } th { "isotropy" } th { "finiteness" } th { "time (s)" } } }
                tbody {
                    @for (m, md) in d.models.iter().enumerate() {
                        @for (k, p) in md.physical.iter().enumerate() {
                            tr {
                                td.l { (swatch(m)) (md.label) @if md.physical.len() == 3 { " (" (["R", "G", "B"][k]) ")" } }
                                td { span class=(verdict_class(p.non_negativity.verdict.label())) { (p.non_negativity.verdict.label()) } " min " (num(p.non_negativity.min_value)) }
                                td { span class=(verdict_class(p.reciprocity.verdict.label())) { (p.reciprocity.verdict.label()) } " " (num(p.reciprocity.max_rel_error)) }
                                td { span class=(verdict_class(p.energy.verdict.label())) { (p.energy.verdict.label()) } " " (num(p.energy.max_albedo)) " at " (deg(p.energy.max_theta.to_degrees())) }
                                td { span class=(verdict_class(p.isotropy.verdict.label())) { (p.isotropy.verdict.label()) } " " (num(p.isotropy.max_rel_change)) }
                                td { span class=(verdict_class(p.finiteness.verdict.label())) { (p.finiteness.verdict.label()) } }
                                td { @if k == 0 { (format!("{:.2}", md.physical_time_s)) } }
                            }
                        }
                    }
                }
            }
        },
    }
    }
}

/// The losses by band, the relative errors and the fit record, per model.
fn details_section(d: &ReportData) -> Markup {
    html! {
    h2 id="details" { "Details per model" }
    p.note { "Where each model fails: the losses by band of θh (the specular peak is θh ≈ 0) and of θd (grazing is θd → 90°), and the relative error |f − f̂| / f̂ over the cells. Everything is also in report.json." }
    @for (m, md) in d.models.iter().enumerate() {
        details {
            summary { (swatch(m)) (md.label) }
            div.row {
                @for (what, bands) in [("θh", &md.quality.theta_h_bands), ("θd", &md.quality.theta_d_bands)] {
                    table {
                        thead { tr { th.l { (what) " band" } th { "cells" } th { "cbrt" } th { "log" } th { "l2" } } }
                        tbody { @for b in bands { tr {
                            td.l { (deg(b.lo.to_degrees())) "–" (deg(b.hi.to_degrees())) }
                            td { (b.cells) }
                            @match &b.losses {
                                Some(l) => { td { (num(l.cbrt.overall)) } td { (num(l.log.overall)) } td { (num(l.l2.overall)) } },
                                None => { td { "–" } td { "–" } td { "–" } },
                            }
                        } } }
                    }
                }
                table {
                    thead { tr { th.l { "relative error" } th { "50 %" } th { "90 %" } th { "99 %" } } }
                    tbody {
                        @for (name, p) in [("all channels", &md.quality.relative_error.overall), ("R", &md.quality.relative_error.channels[0]), ("G", &md.quality.relative_error.channels[1]), ("B", &md.quality.relative_error.channels[2])] {
                            tr { td.l { (name) } @match p {
                                Some(p) => { td { (num(p.p50)) } td { (num(p.p90)) } td { (num(p.p99)) } },
                                None => { td { "–" } td { "–" } td { "–" } },
                            } }
                        }
                    }
                }
                @if let Some(r) = &md.record {
                    table {
                        thead { tr { th.l { "fit" } th.l { "" } } }
                        tbody {
                            tr { td.l { "cells fitted / all" } td.l { (r.cells_fit) " / " (r.cells_full) } }
                            tr { td.l { "starts" } td.l { (r.starts.len()) } }
                            tr { td.l { "termination" } td.l { (r.termination) } }
                            tr { td.l { "iterations · cost passes · Jacobian passes" } td.l { (r.iterations) " · " (r.cost_evals) " · " (r.jacobian_evals) } }
                            tr { td.l { "free parameters" } td.l { (r.free_params.join(", ")) } }
                        }
                    }
                }
            }
        }
    }
    }
}

/// The summary's loss cells in the column order cbrt, l2, cosine, log; `best` is
/// indexed like [`Loss::ALL`] (l2, cosine, cbrt, log).
pub(super) fn loss_cells_ordered(l: &LossReport, best: &[f64; 4]) -> Markup {
    html! {
        @for k in [2usize, 0, 1, 3] {
            @let loss = Loss::ALL[k];
            @let c = l.get(loss);
            td class=(if c.overall <= best[k] { "best" } else { "" })
               title=(format!("{}: R {} · G {} · B {}", loss.name(), num(c.channels[0]), num(c.channels[1]), num(c.channels[2]))) { (num(c.overall)) }
        }
    }
}
