//! The report's interactive panels: an incidence-plane plot, a θh–θd slice, a lit
//! sphere and the directional albedo, drawn in the page by its own script from values
//! brdfkit computed and embedded (the page has no model formula: one source of truth).
//!
//! The embedding. Every source (the measured table, each model, an NBRDF: anything a
//! [`Representation`] holds) is tabulated on the [`view_dims`] grid, MERL's half/difference
//! parameterisation at 45 θh × 45 θd × 90 φd (half MERL's resolution on each axis:
//! the measured table's nodes are every other MERL node, taken as they are), and each
//! channel stored as a 16-bit code of its logarithm:
//!
//! code = 0 for a missing cell, 1 for a value below `exp(lo)` (zero, or 10⁻⁹ of the
//! channel's largest value), else `2 + round((ln f − lo) / (hi − lo) · 65533)`;
//!
//! so the quantisation costs at most `exp((hi − lo) / 65533 / 2) − 1` relative
//! ([`SourcePrecision::quantisation`], ≈ 1.6·10⁻⁴ for a range of 10⁹). The page
//! looks the grid up with the multilinear interpolation of [`MerlTable::interpolated`]
//! (θh, θd held at their last node, φd wrapped, missing corners left out): on the
//! grid's nodes it returns `fit-brdf eval --interp linear` of the grid. The grid's
//! coarseness costs more than the quantisation; [`SourcePrecision`] is the whole cost
//! against the source's own evaluation (`fit-brdf eval`, a table with `--interp
//! linear`) on the incidence planes, and the page states it per source.
//! A five-model report's 6 × 45·45·90 cells × 3 channels × 2 bytes = 6.6 MB of codes are
//! packed (`pack`: differences along the grid, bytes split, zlib) to 0.44 MB (0.58 MB in
//! base64) on the demo's material; the page inflates them with the browser's
//! `DecompressionStream` (docs/report.md).

use super::charts::model_colour_hex;
use super::style::{PAGE_CSS, PANELS_CSS};
use crate::compare::{CompareError, Kind, Representation};
use base64::Engine;
use brdfkit_core::direction::spherical;
use brdfkit_core::{GeometryBatch, Rgb, Vec3};
use brdfkit_fit::Fitted;
use brdfkit_merl::{Dims, Lookup, MerlTable, cell_directions};
use maud::{Markup, PreEscaped, html};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

/// The panels' script (no module import: it runs from `file://`).
const SCRIPT: &str = include_str!("interactive.js");

/// Codes of the embedding.
const MISSING: u16 = 0;
const BELOW: u16 = 1;
const STEPS: f64 = 65533.0;
/// Values below this fraction of a channel's largest value are stored as [`BELOW`].
const FLOOR: f64 = 1e-9;

/// The grid the panels' values are embedded on: 45 θh × 45 θd × 90 φd.
pub fn view_dims() -> Dims {
    Dims::new(45, 45, 90).expect("valid dims")
}

/// One source of the panels, as the page shows it.
pub struct PanelSource<'a> {
    /// Its label (a model's label in the report, a file name).
    pub label: String,
    /// What it is, evaluated exactly for the precision.
    pub source: &'a Representation,
}

/// What the embedding costs for one source, against its own evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SourcePrecision {
    /// The source's label.
    pub label: String,
    /// Its kind.
    pub kind: Kind,
    /// Largest relative error of the 16-bit log quantisation alone.
    pub quantisation: f64,
    /// Relative error |page − eval| / eval of the embedded grid, interpolated as the page
    /// does, against the source's own evaluation, over the check pairs where eval > 0:
    /// median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest.
    pub max: f64,
    /// Channel values compared.
    pub values: usize,
}

/// The embedded panels: the page's markup and what they cost.
pub struct Panels {
    /// The panels' section (markup, data and script).
    pub markup: String,
    /// Per source, the precision of its embedding.
    pub precision: Vec<SourcePrecision>,
    /// Bytes of the embedded values (base64).
    pub embedded_bytes: usize,
}

/// The source on the view grid: a table resampled (its nodes at the grid's, linear
/// lookups between), a model or an NBRDF tabulated at the grid's cells. A model must be
/// isotropic (the grid has no φh); errors name `label` (the file in `fit-brdf view`).
fn on_view_grid(label: &str, r: &Representation) -> Result<MerlTable, CompareError> {
    let dims = view_dims();
    match r {
        Representation::Table(t) if t.dims() == dims => Ok((**t).clone()),
        Representation::Table(t) => Ok(t.resample(dims, Lookup::Interpolated)),
        Representation::Model(f) => {
            brdfkit_fit::score::check_isotropic(f).map_err(|source| {
                CompareError::Incompatible {
                    path: label.into(),
                    source,
                }
            })?;
            model_on_grid(f, dims).map_err(|source| CompareError::Tabulate {
                path: label.into(),
                dims,
                source,
            })
        }
        other => Ok(Arc::unwrap_or_clone(
            other.tabulate(Path::new(label), dims)?,
        )),
    }
}

/// A model tabulated at the cells of `dims` (those whose directions are above the
/// horizon; the others missing): [`Representation::tabulate`]'s table, with each
/// channel model evaluated through its batch path, a θh slab of cells at a time (in
/// parallel), instead of a pair at a time. The same directions ([`cell_directions`])
/// and the same values: a model's batch and pair paths agree to the bit.
fn model_on_grid(f: &Fitted, dims: Dims) -> Result<MerlTable, brdfkit_merl::TableError> {
    let slab = dims.theta_d() * dims.phi_d();
    let slabs: Vec<Vec<Option<Rgb>>> = (0..dims.theta_h())
        .into_par_iter()
        .map(|i| slab_values(f, dims, i, slab))
        .collect();
    MerlTable::from_fn(dims, |i, j, k| slabs[i][j * dims.phi_d() + k])
}

/// [`model_on_grid`]'s values of θh slab `i` (`slab` cells, in index order).
fn slab_values(f: &Fitted, dims: Dims, i: usize, slab: usize) -> Vec<Option<Rgb>> {
    let mut up = Vec::with_capacity(slab);
    let mut dirs = Vec::with_capacity(slab);
    for j in 0..dims.theta_d() {
        for k in 0..dims.phi_d() {
            let (_, wi, wo, above) = cell_directions(dims, i, j, k);
            up.push(above);
            if above {
                dirs.push(([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z]));
            }
        }
    }
    let mut geo = GeometryBatch::default();
    geo.fill_with(dirs.len(), |k| dirs[k]);
    let g = geo.as_slice();
    let mut vals = vec![Rgb::ZERO; dirs.len()];
    f.channel_model(0).eval_batch(&g, &mut vals);
    if !matches!(f, Fitted::Shared(_)) {
        // Channel c from the channel-c model.
        let mut tmp = vec![Rgb::ZERO; dirs.len()];
        for c in 1..3 {
            f.channel_model(c).eval_batch(&g, &mut tmp);
            for (o, v) in vals.iter_mut().zip(&tmp) {
                o[c] = v[c];
            }
        }
    }
    let mut next = vals.into_iter();
    up.into_iter()
        .map(|u| if u { next.next() } else { None })
        .collect()
}

/// Per channel, the log range (lo, hi) of the grid's positive values.
fn log_range(t: &MerlTable) -> [(f64, f64); 3] {
    let mut max = [0.0f64; 3];
    for idx in 0..t.dims().cells() {
        if let Some(v) = t.get_flat(idx) {
            for c in 0..3 {
                max[c] = max[c].max(v[c]);
            }
        }
    }
    max.map(|m| {
        if m > 0.0 && m.is_finite() {
            let hi = m.ln();
            (hi + FLOOR.ln(), hi)
        } else {
            (0.0, 0.0)
        }
    })
}

/// The 16-bit code of `v` in the range (lo, hi); see the module doc.
fn encode(v: f64, (lo, hi): (f64, f64)) -> u16 {
    // A channel whose largest value is 0 has the range (0, 0): every value is 0.
    // NaN and values ≤ 0 included (`is_nan() || v <= 0`).
    if v.is_nan() || v <= 0.0 || hi <= lo || v.ln() < lo {
        return BELOW;
    }
    2 + (((v.ln() - lo) / (hi - lo)) * STEPS)
        .round()
        .clamp(0.0, STEPS) as u16
}

/// The value of a code (the page's decoding).
fn decode(q: u16, (lo, hi): (f64, f64)) -> Option<f64> {
    match q {
        MISSING => None,
        BELOW => Some(0.0),
        q => Some((lo + f64::from(q - 2) / STEPS * (hi - lo)).exp()),
    }
}

/// The codes, channel-major (plane R, then G, then B, each in the table's cell order).
fn quantise(t: &MerlTable, range: &[(f64, f64); 3]) -> Vec<u16> {
    let n = t.dims().cells();
    let mut out = vec![MISSING; 3 * n];
    for idx in 0..n {
        if let Some(v) = t.get_flat(idx) {
            for c in 0..3 {
                out[c * n + idx] = encode(v[c], range[c]);
            }
        }
    }
    out
}

/// zlib's level for the packed grids. Level 7, not 9: on the five-model report of
/// pink-fabric the six grids (6.56 MB) pack to 533,694 bytes instead of 526,228
/// (+1.4 %) in under half the time (miniz_oxide's level 9 searches 768 match
/// candidates a position, 7 256), the deflate having been the largest single part of
/// the report's CPU after the albedo integrals; the page inflates any level alike
/// (docs/performance.md, "Issue 28, session 11").
const PACK_LEVEL: u32 = 7;

/// The bytes the page carries: each plane's codes as differences from the previous cell
/// (mod 2¹⁶; neighbours along φd are close, so the differences are small), all low bytes
/// then all high bytes, zlib-compressed ([`PACK_LEVEL`]).
fn pack(codes: &[u16]) -> Vec<u8> {
    use std::io::Write;
    let n = codes.len() / 3;
    let mut delta = vec![0u16; codes.len()];
    for c in 0..3 {
        let plane = &codes[c * n..(c + 1) * n];
        let mut prev = 0u16;
        for (d, q) in delta[c * n..(c + 1) * n].iter_mut().zip(plane) {
            *d = q.wrapping_sub(prev);
            prev = *q;
        }
    }
    let mut bytes: Vec<u8> = delta.iter().map(|d| d.to_le_bytes()[0]).collect();
    bytes.extend(delta.iter().map(|d| d.to_le_bytes()[1]));
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::new(PACK_LEVEL));
    z.write_all(&bytes).expect("writing to memory");
    z.finish().expect("writing to memory")
}

/// The grid the page holds: the codes decoded.
fn dequantised(codes: &[u16], range: &[(f64, f64); 3]) -> Result<MerlTable, CompareError> {
    let dims = view_dims();
    let n = dims.cells();
    let q = |idx: usize, c: usize| codes[c * n + idx];
    MerlTable::from_fn(dims, |i, j, k| {
        let idx = dims.index(i, j, k);
        let v = [0, 1, 2].map(|c| decode(q(idx, c), range[c]));
        match v {
            [Some(r), Some(g), Some(b)] => Some(Rgb::new(r, g, b)),
            _ => None,
        }
    })
    .map_err(|source| CompareError::Tabulate {
        path: "view grid".into(),
        dims,
        source,
    })
}

/// The check pairs of [`SourcePrecision`]: the incidence planes at θi = 0, 10, …, 80° and
/// plane azimuths 0, 45 and 90° (the panel's geometry), θo from −85 to 85° in 5° steps.
pub fn check_pairs() -> Vec<(Vec3, Vec3)> {
    let mut pairs = Vec::new();
    for ti in (0..=80).step_by(10) {
        let wi = spherical((ti as f64).to_radians(), std::f64::consts::PI);
        for phi in [0.0f64, 45.0, 90.0] {
            for to in (-85..=85).step_by(5) {
                let (t, p) = (to as f64, if to < 0 { phi + 180.0 } else { phi });
                pairs.push((wi, spherical(t.abs().to_radians(), p.to_radians())));
            }
        }
    }
    pairs
}

/// The source's own value at each pair (what `fit-brdf eval` prints; a table with
/// `--interp linear`).
pub fn exact(r: &Representation, pairs: &[(Vec3, Vec3)]) -> Vec<Option<Rgb>> {
    match r {
        Representation::Table(t) => pairs.iter().map(|(i, o)| t.interpolated(i, o)).collect(),
        Representation::Model(f) => pairs
            .iter()
            .map(|(i, o)| {
                let v = [0, 1, 2].map(|c| f.channel_model(c).eval(i, o)[c]);
                Some(Rgb::new(v[0], v[1], v[2]))
            })
            .collect(),
        Representation::Nbrdf(n) => n.eval_pairs(pairs).into_iter().map(Some).collect(),
        // The page holds a `.bsdf` as its table does (the weighted mean of both orders of each
        // pair, `RglBsdf::to_table`): that mean is what the embedding is checked against.
        Representation::RglBsdf(b) => pairs.iter().map(|(i, o)| Some(b.symmetric(i, o))).collect(),
    }
}

/// The precision of one embedding: `page` (the decoded grid) against `r` at
/// [`check_pairs`].
fn precision(
    label: &str,
    r: &Representation,
    page: &MerlTable,
    range: &[(f64, f64); 3],
) -> SourcePrecision {
    let pairs = check_pairs();
    let truth = exact(r, &pairs);
    let mut rel: Vec<f64> = pairs
        .iter()
        .zip(&truth)
        .filter_map(|((i, o), t)| Some((page.interpolated(i, o)?, (*t)?)))
        .flat_map(|(p, t)| {
            (0..3)
                .filter(move |&c| t[c] > 0.0)
                .map(move |c| (p[c] - t[c]).abs() / t[c])
        })
        .collect();
    rel.sort_unstable_by(f64::total_cmp);
    let at = |q: f64| {
        rel.get(((rel.len() as f64 * q) as usize).min(rel.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0.0)
    };
    let quantisation = range
        .iter()
        .map(|(lo, hi)| ((hi - lo) / STEPS / 2.0).exp_m1())
        .fold(0.0, f64::max);
    SourcePrecision {
        label: label.to_string(),
        kind: r.kind(),
        quantisation,
        p50: at(0.5),
        p95: at(0.95),
        max: rel.last().copied().unwrap_or(0.0),
        values: rel.len(),
    }
}

/// The data one source embeds.
#[derive(Serialize)]
struct Embedded {
    label: String,
    kind: Kind,
    colour: String,
    lo: [f64; 3],
    hi: [f64; 3],
    data: String,
    precision: SourcePrecision,
}

/// Embeds `sources` (the first is the reference of ratios and differences: the
/// measured table in a report) and builds the panels.
pub fn panels(sources: &[PanelSource<'_>]) -> Result<Panels, CompareError> {
    let embedded: Vec<Embedded> = sources
        .par_iter()
        .enumerate()
        .map(|(k, s)| {
            let grid = on_view_grid(&s.label, s.source)?;
            let range = log_range(&grid);
            let codes = quantise(&grid, &range);
            let page = dequantised(&codes, &range)?;
            Ok(Embedded {
                label: s.label.clone(),
                kind: s.source.kind(),
                // The first source black, the others in the report's model colours.
                colour: match k {
                    0 => "#111111".to_string(),
                    k => model_colour_hex(k - 1),
                },
                lo: range.map(|r| r.0),
                hi: range.map(|r| r.1),
                data: base64::engine::general_purpose::STANDARD.encode(pack(&codes)),
                precision: precision(&s.label, s.source, &page, &range),
            })
        })
        .collect::<Result<_, CompareError>>()?;
    let embedded_bytes = embedded.iter().map(|e| e.data.len()).sum();
    let d = view_dims();
    let json = serde_json::json!({
        "dims": [d.theta_h(), d.theta_d(), d.phi_d()],
        "floor": FLOOR,
        "sources": embedded,
    });
    // `</` cannot end the script element early: JSON escapes it as `<\/`.
    let json = json.to_string().replace("</", "<\\/");
    let precision = embedded
        .into_iter()
        .map(|e| e.precision)
        .collect::<Vec<_>>();
    let markup = markup(&json, &precision, embedded_bytes).into_string();
    Ok(Panels {
        markup,
        precision,
        embedded_bytes,
    })
}

/// A `<select>` of the sources.
fn source_select(id: &str, sources: &[SourcePrecision], first: usize) -> Markup {
    html! {
        select id=(id) {
            @for (k, s) in sources.iter().enumerate() {
                option value=(k) selected[k == first] { (s.label) }
            }
        }
    }
}

/// A labelled range input `id` over `[min, max, step, value]`, with its read-out
/// `<output id="{id}-out">` showing `shown` until the script updates it.
fn slider(id: &str, label: &str, [min, max, step, value]: [f64; 4], shown: &str) -> Markup {
    html! {
        label {
            (label) " "
            input id=(id) type="range" min=(min) max=(max) step=(step) value=(value);
            output id=(format!("{id}-out")) { (shown) }
        }
    }
}

fn channel_select(id: &str) -> Markup {
    html! { select id=(id) { option value="0" { "R" } option value="1" selected { "G" } option value="2" { "B" } } }
}

/// One panel of the view: a title, its controls, what the script draws into (`view`)
/// and a note on what it shows.
fn panel(id: &str, title: &str, controls: Markup, view: Markup, note: &str) -> Markup {
    html! {
        div.panel id=(id) {
            h3 { (title) }
            div.controls { (controls) }
            (view)
            p.note { (note) }
        }
    }
}

/// The incidence-plane plot of f_r.
fn incidence_panel() -> Markup {
    let controls = html! {
        (slider("inc-theta", "θi", [0.0, 89.0, 1.0, 45.0], "45°"))
        (slider("inc-phi", "φ", [0.0, 180.0, 1.0, 0.0], "0°"))
        label { "scale " select #inc-scale { option value="log" { "log" } option value="linear" { "linear" } } }
        label { "channel " (channel_select("inc-channel")) }
    };
    let view = html! {
        canvas #inc-canvas width="720" height="360" {}
        div.legend #inc-legend {}
    };
    let note = "f_r (no cosine) along the plane at azimuth φ from the incidence plane: wi at (θi, 180°), wo at (θo, φ) for θo ≥ 0 and (|θo|, φ + 180°) for θo < 0. At φ = 0 the mirror direction is at θo = θi; the dashed line marks it. Click a legend entry to hide or show that source.";
    panel("panel-incidence", "Incidence plane", controls, view, note)
}

/// The θh–θd image of one source at a chosen φd.
fn slice_panel(p: &[SourcePrecision]) -> Markup {
    let controls = html! {
        (slider("slice-phi", "φd", [0.0, 180.0, 1.0, 90.0], "90°"))
        label { "source " (source_select("slice-source", p, 0)) }
        label { "show " select #slice-mode { option value="value" { "log10 f_r" } option value="ratio" { "log10(source / first source)" } } }
        label { "channel " (channel_select("slice-channel")) }
    };
    let view = html! {
        canvas #slice-canvas width="520" height="414" {}
        div.readout #slice-readout { "move the cursor over the image" }
    };
    let note = "θh (x, 0 to 90°, √ axis as MERL's bins) and θd (y, 0 at the top, 90° at the bottom) at the chosen φd. The ratio is against the first source (the measured table in a report): red, the source is brighter; blue, darker; ±1 (a factor 10) saturates. Grey: no value (below the horizon).";
    panel("panel-slice", "θh–θd slice", controls, view, note)
}

/// A lit sphere of one source, alone or against the first.
fn sphere_panel(p: &[SourcePrecision], model: usize) -> Markup {
    let controls = html! {
        label { "source " (source_select("sphere-source", p, model)) }
        label { "mode " select #sphere-mode { option value="single" { "single" } option value="side" { "side by side with the first source" } option value="diff" { "difference from the first source" } } }
        (slider("sphere-exposure", "exposure", [-6.0, 6.0, 0.25, 0.0], "+0 EV"))
        span { "drag on a sphere to move the light" }
    };
    let view = html! {
        div.row { canvas #sphere-a width="256" height="256" {} canvas #sphere-b width="256" height="256" style="display:none" {} }
        div.readout #sphere-readout {}
    };
    let note = "A sphere under one directional light of unit irradiance at normal incidence (radiance = f_r · cos θi · π, so a white Lambertian facing the light is 1), seen from straight above (orthographic), exposure 2^EV, then sRGB. The difference is |Δ| of the displayed values ×4, averaged over the channels.";
    panel("panel-sphere", "Lit sphere", controls, view, note)
}

/// The directional albedo of every source against θo.
fn albedo_panel() -> Markup {
    let controls = html! {
        (slider("albedo-theta", "θo", [0.0, 89.0, 1.0, 30.0], "30°"))
        label { "channel " (channel_select("albedo-channel")) }
    };
    let view = html! {
        canvas #albedo-canvas width="720" height="300" {}
        table id="albedo-table" {}
    };
    let note = "a(θo) = ∫ f_r(wi, wo) cos θi dωi over the hemisphere, by a midpoint rule in cos²θi (40 steps) and φi (96 steps) on the embedded values (the curve at θo = 0, 10, …, 80, 85°): the fraction of a uniform white sky's light reflected towards θo. The table gives R, G, B at the chosen θo.";
    panel("panel-albedo", "Directional albedo", controls, view, note)
}

/// The panels' markup; the script fills the canvases.
fn markup(json: &str, p: &[SourcePrecision], bytes: usize) -> Markup {
    let model = usize::from(p.len() > 1);
    html! {
        p.note {
            "Drawn in this page from values brdfkit computed: every source tabulated on a 45 θh × 45 θd × 90 φd grid of MERL's half/difference angles, "
            "16-bit log codes (" (format!("{:.2}", bytes as f64 / 1e6)) " MB embedded, packed), interpolated multilinearly as `fit-brdf eval --interp linear` does. What that costs against `fit-brdf eval` of each source "
            "(relative error on the incidence planes θi = 0…80°, φ = 0, 45, 90°): "
        }
        table id="view-precision" {
            thead { tr { th.l { "source" } th.l { "kind" } th { "median" } th { "95 %" } th { "max" } th { "quantisation" } } }
            tbody { @for s in p { tr {
                td.l { (s.label) } td.l { (format!("{:?}", s.kind).to_lowercase()) }
                td { (format!("{:.2} %", s.p50 * 100.0)) } td { (format!("{:.2} %", s.p95 * 100.0)) }
                td { (format!("{:.1} %", s.max * 100.0)) } td { (format!("{:.1e}", s.quantisation)) }
            } } }
        }
        (incidence_panel())
        (slice_panel(p))
        (sphere_panel(p, model))
        (albedo_panel())
        details {
            summary { "Test hook" }
            p.note { "window.brdfkitView: ready (true once drawn), sources (labels), eval(source, wi, wo) → [r, g, b] or null (the embedded lookup), plotted.incidence / .slice / .sphere / .albedo (the values each panel drew last, with their directions), albedoCurveReady, timings (ms of the last draw of each panel; script_start, inflated, decode, load: ms from navigation to each step, load = ready). docs/report.md describes each. Used by the browser test (crates/fit-brdf/tests/report_browser.rs)." }
        }
        script id="view-data" type="application/json" { (PreEscaped(json)) }
        script { (PreEscaped(SCRIPT)) }
    }
}

/// The page of `fit-brdf view`: the panels alone for `sources` (anything a
/// [`Representation`] holds, overlaid; the first is the reference of ratios and
/// differences), nothing fitted, one self-contained file.
pub fn view_page(title: &str, sources: &[PanelSource<'_>]) -> Result<String, CompareError> {
    let p = panels(sources)?;
    let page = html! {
        (maud::DOCTYPE)
        html lang="en" {
            head {
                meta charset="utf-8";
                meta name="viewport" content="width=device-width, initial-scale=1";
                title { (title) }
                style { (PreEscaped(PAGE_CSS)) (PreEscaped(PANELS_CSS)) }
            }
            body {
                h1 { (title) }
                p.meta { "Sources, overlaid (the first is the reference of the ratios and differences): "
                    @for (k, s) in p.precision.iter().enumerate() {
                        @if k > 0 { "; " } b { (s.label) } " (" (format!("{:?}", s.kind).to_lowercase()) ")"
                    }
                    ". Nothing is fitted; how to read each panel: docs/report.md." }
                (PreEscaped(&p.markup))
            }
        }
    };
    Ok(page.into_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_within_the_stated_step() {
        let range = (1e-6f64.ln(), 1e3f64.ln());
        let half_step = ((range.1 - range.0) / STEPS / 2.0).exp_m1();
        for v in [1e-6, 3.3e-5, 0.1, 0.3, 7.0, 999.0, 1e3] {
            let back = decode(encode(v, range), range).unwrap();
            assert!((back - v).abs() / v <= half_step * 1.0001, "{v} -> {back}");
        }
        assert_eq!(decode(encode(0.0, range), range), Some(0.0));
        assert_eq!(decode(encode(1e-7, range), range), Some(0.0));
        assert_eq!(decode(MISSING, range), None);
    }

    /// What the page's script undoes: zlib, then the byte split, then the differences.
    fn unpack(z: &[u8]) -> Vec<u16> {
        use std::io::Read;
        let mut bytes = Vec::new();
        flate2::read::ZlibDecoder::new(z)
            .read_to_end(&mut bytes)
            .unwrap();
        let (lo, hi) = bytes.split_at(bytes.len() / 2);
        let n = lo.len() / 3;
        let mut out = Vec::with_capacity(lo.len());
        for c in 0..3 {
            let mut prev = 0u16;
            for j in c * n..(c + 1) * n {
                prev = prev.wrapping_add(u16::from_le_bytes([lo[j], hi[j]]));
                out.push(prev);
            }
        }
        out
    }

    #[test]
    fn packed_codes_unpack_to_themselves_and_shrink() {
        let model: brdfkit_fit::Fitted = brdfkit_fit::Fitted::from_json(&serde_json::json!({
            "model": "cook-torrance",
            "params": {"rho_d": [0.4, 0.1, 0.05], "rho_s": 1.0, "alpha": 0.1}
        }))
        .unwrap();
        let grid = on_view_grid("ct", &Representation::Model(model)).unwrap();
        let range = log_range(&grid);
        let codes = quantise(&grid, &range);
        let z = pack(&codes);
        assert_eq!(unpack(&z), codes);
        assert!(z.len() * 5 < codes.len() * 2, "{} bytes packed", z.len());
    }
}
