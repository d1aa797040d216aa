//! Which loss looks right (issue 12, item 6): measured proxies fitted with each loss
//! (l2, cosine, cbrt, log), the table and every fit rendered by the report's renderer
//! under the report's two lightings, and each (table, fit) image pair scored.
//!
//! Scores, over the sphere's pixels (lit in either image, the drawn outline left out):
//!
//! - **ΔE2000** between the two displayed images (the report's PNGs: tone-mapped sRGB at
//!   the table's exposure), each pixel taken to CIELAB (D65) by the `palette` crate:
//!   G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000 Color-Difference Formula:
//!   Implementation Notes, Supplementary Test Data, and Mathematical Observations",
//!   Color Research & Application 30(1), 2005, eqs. 1–22. The mean and the 95th
//!   percentile are kept.
//! - **display RMSE**: sqrt(mean over pixels and channels of (d_fit − d_table)²), d the
//!   displayed sRGB value in 0..1.
//! - **linear relative RMS**: the report's own figure, sqrt(Σ |L_fit − L_table|² /
//!   Σ |L_table|²) over the radiance before tone mapping
//!   ([`brdfkit_validate::html::renders::ImageDiff::rel_rms_radiance`]).
//!
//! The displayed images clip the highlight's core (the exposure puts the 90th
//! percentile of the lit pixels at 0.6 linear), so the first two scores judge what the
//! report shows; the third weighs the peak's radiance in full.

use crate::StudyError;
use crate::files::{write, write_csv, write_json};
use crate::markdown::{loss as fmt_loss, replace_section, secs};
use crate::measured::{median, read_categories};
use brdfkit_core::progress::{Event, Observe};
use brdfkit_fit::families::{FitSettings, Structure, families};
use brdfkit_fit::{FitData, Loss, fit};
use brdfkit_merl::Dims;
use brdfkit_validate::html::renders::{Lighting, OUTLINE, RenderOptions, Shown, render_set};
use palette::color_difference::Ciede2000;
use palette::{IntoColor, Lab, LinSrgb, Srgb, white_point::D65};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// The losses compared, in the order of the tables and the contact sheet.
pub const LOSSES: [Loss; 4] = [Loss::L2, Loss::Cosine, Loss::Cbrt, Loss::Log];

/// The default set: 25 proxies across the three databases and the five categories
/// (`data-measured/categories.csv`), the seven vendored in `data-measured/` among them
/// (chrome-steel, gold-paint, specular-red-phenolic, pink-fabric, blue-rubber,
/// acrylic_felt_green_rgb, bindercover).
pub const DEFAULT_MATERIALS: [&str; 25] = [
    // metal
    "chrome-steel",
    "aluminium",
    "brass",
    "tungsten-carbide",
    "steel",
    // paint
    "gold-paint",
    "dark-red-paint",
    "silver-metallic-paint",
    "paintedmetal",
    "cc_amber_citrine_rgb",
    "ilm_l3_37_dark_green_rgb",
    // plastic
    "specular-red-phenolic",
    "bindercover",
    "white-acrylic",
    "delrin",
    "colodur_azure_4e_rgb",
    "vch_golden_yellow_rgb",
    // fabric
    "pink-fabric",
    "acrylic_felt_green_rgb",
    "red-fabric2",
    "greencloth",
    "satin_blue_rgb",
    // other: rubber, wood, paper
    "blue-rubber",
    "cherry-235",
    "paper_red_rgb",
];

/// What the loss comparison runs on and where it writes.
#[derive(Debug, Clone)]
pub struct LossesConfig {
    /// Root of the proxies: `<root>/<database>/<name>_fc1.npy`, … (the layout of
    /// `../shared/measured-proxies` and `data-measured/`).
    pub proxies: PathBuf,
    /// `name,database,category` per proxy (`data-measured/categories.csv`): where
    /// each name's folder is, and its category in the tables.
    pub categories: PathBuf,
    /// The proxies (names).
    pub materials: Vec<String>,
    /// Model families fitted (`fit-brdf fit --model` names); the contact sheet shows
    /// the first.
    pub models: Vec<String>,
    /// Starts per fit (the command line's default: 8).
    pub starts: usize,
    /// The grid the proxies are resampled onto (MERL's for the real run; a coarse one
    /// keeps tests quick).
    pub dims: Dims,
    /// The renders (the report's defaults: 128 px, 16 spp under the environment).
    pub render: RenderOptions,
    /// Directory of the CSV, JSON and contact sheet (`docs/losses`).
    pub out: PathBuf,
    /// The Markdown page whose generated sections are replaced (`docs/losses.md`).
    pub report: PathBuf,
}

impl LossesConfig {
    /// The real run: [`DEFAULT_MATERIALS`], Cook-Torrance, 8 starts, the MERL grid, the
    /// report's render options.
    pub fn new(proxies: impl Into<PathBuf>, categories: impl Into<PathBuf>) -> Self {
        LossesConfig {
            proxies: proxies.into(),
            categories: categories.into(),
            materials: DEFAULT_MATERIALS.iter().map(|s| s.to_string()).collect(),
            models: vec![crate::ModelChoice::default_family().label],
            starts: 8,
            dims: Dims::MERL,
            render: RenderOptions::default(),
            out: PathBuf::from("docs/losses"),
            report: PathBuf::from("docs/losses.md"),
        }
    }
}

/// One (material, model, loss, lighting): the fit's figures and the image scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LossRow {
    /// The proxy.
    pub material: String,
    /// Its database.
    pub database: String,
    /// Its category.
    pub category: String,
    /// The model family.
    pub model: String,
    /// The loss the fit optimised.
    pub loss: String,
    /// `point` or `environment`.
    pub lighting: String,
    /// Mean ΔE2000 over the sphere's pixels (displayed images).
    pub delta_e_mean: f64,
    /// 95th percentile of ΔE2000.
    pub delta_e_p95: f64,
    /// RMSE of the displayed sRGB values (0..1).
    pub rmse_display: f64,
    /// Relative RMS of the linear radiance (the report's figure).
    pub rel_rms_linear: f64,
    /// Pixels scored.
    pub pixels: usize,
    /// The fit's cbrt loss on every valid cell.
    pub fit_cbrt: f64,
    /// Its l2 loss.
    pub fit_l2: f64,
    /// Its cosine loss.
    pub fit_cosine: f64,
    /// Its log loss.
    pub fit_log: f64,
    /// Wall time of the fit (s).
    pub fit_time_s: f64,
}

/// Scores of one image pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageScores {
    /// Mean ΔE2000.
    pub delta_e_mean: f64,
    /// 95th percentile of ΔE2000 (nearest rank).
    pub delta_e_p95: f64,
    /// RMSE of the display values.
    pub rmse_display: f64,
    /// Pixels scored.
    pub pixels: usize,
}

/// CIELAB (D65) of a displayed sRGB colour (components in 0..1).
fn lab(c: [f64; 3]) -> Lab<D65, f64> {
    let linear: LinSrgb<f64> = Srgb::new(c[0], c[1], c[2]).into_linear();
    linear.into_color()
}

/// Scores two displayed images given as sRGB values in 0..1, pixel by pixel (equal
/// lengths: the pixels to score, already selected).
pub fn score_display(table: &[[f64; 3]], fit: &[[f64; 3]]) -> ImageScores {
    let n = table.len().min(fit.len());
    let mut de: Vec<f64> = (0..n)
        .map(|k| lab(table[k]).difference(lab(fit[k])))
        .collect();
    let sq: f64 = (0..n)
        .flat_map(|k| (0..3).map(move |c| (fit[k][c] - table[k][c]).powi(2)))
        .sum();
    de.sort_unstable_by(f64::total_cmp);
    let mean = de.iter().sum::<f64>() / n.max(1) as f64;
    let p95 = if n == 0 {
        0.0
    } else {
        de[((n as f64 * 0.95).ceil() as usize).clamp(1, n) - 1]
    };
    ImageScores {
        delta_e_mean: mean,
        delta_e_p95: p95,
        rmse_display: if n == 0 {
            0.0
        } else {
            (sq / (3 * n) as f64).sqrt()
        },
        pixels: n,
    }
}

/// The sphere's pixels of two rendered PNGs (same size), as display values in 0..1:
/// those lit in either image (any channel above 0), less the outline ring both carry
/// (the report draws it outside the sphere, in [`OUTLINE`] grey).
pub fn sphere_pixels(
    table: &image::RgbImage,
    fit: &image::RgbImage,
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let f = |p: &image::Rgb<u8>| p.0.map(|v| v as f64 / 255.0);
    table
        .pixels()
        .zip(fit.pixels())
        .filter(|(t, m)| {
            let lit = t.0 != [0; 3] || m.0 != [0; 3];
            lit && !(t.0 == OUTLINE && m.0 == OUTLINE)
        })
        .map(|(t, m)| (f(t), f(m)))
        .unzip()
}

fn decode(png: &[u8], what: &str) -> Result<image::RgbImage, StudyError> {
    image::load_from_memory(png)
        .map(|i| i.to_rgb8())
        .map_err(|e| StudyError::Model {
            what: what.to_string(),
            msg: format!("cannot decode the render: {e}"),
        })
}

/// The images of one material under one lighting: the table's, then one per loss
/// (the first model's fits), for the contact sheet.
type Strip = Vec<image::RgbImage>;

/// Fits, renders and scores one material: its rows and, per lighting, its strip of
/// images.
fn measure(
    cfg: &LossesConfig,
    (name, database, category): (&str, &str, &str),
) -> Result<(Vec<LossRow>, Vec<Strip>), StudyError> {
    let err = |msg: String| StudyError::Model {
        what: name.to_string(),
        msg,
    };
    let net = brdfkit_nbrdf::Nbrdf::load(&cfg.proxies.join(database).join(name))
        .map_err(|e| err(e.to_string()))?;
    let table = Arc::new(net.to_table(cfg.dims).map_err(|e| err(e.to_string()))?.0);
    let data = FitData::from_table(&table).map_err(|e| err(e.to_string()))?;
    let mut rows = Vec::new();
    let mut strips = Vec::new();
    for (mi, label) in cfg.models.iter().enumerate() {
        let fam = families(label, &Structure::default())
            .map_err(|e| err(e.to_string()))?
            .remove(0);
        let mut fits = Vec::new();
        for l in LOSSES {
            let fc = FitSettings {
                loss: l,
                starts: cfg.starts,
                // The study's fits as before the settings had one set of defaults:
                // every start refined on all cells, all eight losses recorded.
                full_iters: brdfkit_fit::FullIters::All,
                losses: brdfkit_fit::LossSet::All,
                ..FitSettings::default()
            }
            .config()
            .map_err(|e| err(e.to_string()))?;
            let r = fit(&*fam.model, &data, &fc, None).map_err(|source| StudyError::Fit {
                what: format!("{name} {label} {}", l.name()),
                source,
            })?;
            fits.push(r);
        }
        let fitted: Vec<&brdfkit_fit::Fitted> = fits.iter().map(|r| &r.fitted).collect();
        for lighting in Lighting::ALL {
            let set = render_set(lighting, &cfg.render, Shown::Table(&table), &fitted)
                .map_err(|e| err(e.to_string()))?;
            let timg = decode(&set.table_png, name)?;
            let mut strip = vec![timg.clone()];
            for ((l, r), m) in LOSSES.iter().zip(&fits).zip(&set.models) {
                let fimg = decode(&m.png, name)?;
                let (a, b) = sphere_pixels(&timg, &fimg);
                let s = score_display(&a, &b);
                let lf = &r.record.losses_full;
                rows.push(LossRow {
                    material: name.to_string(),
                    database: database.to_string(),
                    category: category.to_string(),
                    model: label.clone(),
                    loss: l.name().to_string(),
                    lighting: lighting.key().to_string(),
                    delta_e_mean: s.delta_e_mean,
                    delta_e_p95: s.delta_e_p95,
                    rmse_display: s.rmse_display,
                    rel_rms_linear: m.diff.rel_rms_radiance,
                    pixels: s.pixels,
                    fit_cbrt: lf.cbrt.overall,
                    fit_l2: lf.l2.overall,
                    fit_cosine: lf.cosine.overall,
                    fit_log: lf.log.overall,
                    fit_time_s: r.record.wall_time_s,
                });
                strip.push(fimg);
            }
            if mi == 0 {
                strips.push(strip);
            }
        }
    }
    Ok((rows, strips))
}

/// The facts of a run, kept beside the scores.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LossesRun {
    /// Image size (pixels).
    pub size: usize,
    /// Samples per pixel under the environment.
    pub env_spp: usize,
    /// The resampling grid.
    pub dims: [usize; 3],
    /// Starts per fit.
    pub starts: usize,
    /// Wall time of the whole run (s).
    pub wall_s: f64,
    /// Load average (1 min) at the start and the end.
    pub load: [Option<f64>; 2],
    /// Every row.
    pub rows: Vec<LossRow>,
}

/// Runs the comparison: fits, renders and scores every material, writes
/// `out/scores.csv`, `out/scores.json`, `out/sheet.png` and the generated sections of
/// the report (`<!-- study:losses-NAME -->`; the hand-written reading around them is
/// kept). Returns the rows.
pub fn run(cfg: &LossesConfig, progress: &dyn Observe) -> Result<Vec<LossRow>, StudyError> {
    if cfg.materials.is_empty() || cfg.models.is_empty() {
        return Err(StudyError::Config {
            option: "losses",
            msg: "at least one material and one model".into(),
        });
    }
    let cats = read_categories(&cfg.categories)?;
    // Every name is checked before the first fit.
    let picks: Vec<(&str, &(String, String))> = cfg
        .materials
        .iter()
        .map(|m| {
            cats.get(m)
                .map(|c| (m.as_str(), c))
                .ok_or_else(|| StudyError::Config {
                    option: "loss-materials",
                    msg: format!("`{m}` is not in {}", cfg.categories.display()),
                })
        })
        .collect::<Result<_, _>>()?;
    std::fs::create_dir_all(&cfg.out).map_err(|e| StudyError::io(&cfg.out, e))?;
    let t0 = Instant::now();
    let load0 = crate::load_average();
    let mut rows = Vec::new();
    let mut sheet = Vec::new();
    for (k, (name, (db, cat))) in picks.iter().enumerate() {
        progress.observe(&Event::Step(format!(
            "losses: {}/{} {name} ({db}, {cat})",
            k + 1,
            picks.len()
        )));
        let (r, strips) = measure(cfg, (name, db, cat))?;
        rows.extend(r);
        sheet.push((name.to_string(), strips));
    }
    let run = LossesRun {
        size: cfg.render.size,
        env_spp: cfg.render.env_spp,
        dims: [cfg.dims.theta_h(), cfg.dims.theta_d(), cfg.dims.phi_d()],
        starts: cfg.starts,
        wall_s: t0.elapsed().as_secs_f64(),
        load: [load0, crate::load_average()],
        rows: rows.clone(),
    };
    write_csv(&cfg.out.join("scores.csv"), &rows)?;
    write_json(&cfg.out.join("scores.json"), &run)?;
    contact_sheet(&cfg.out.join("sheet.png"), &sheet)?;
    write_report(cfg, &run)?;
    Ok(rows)
}

/// The contact sheet: one row per material, its name, then the table and the fit of
/// each loss under the point light, then the same under the environment.
fn contact_sheet(path: &Path, sheet: &[(String, Vec<Strip>)]) -> Result<(), StudyError> {
    let Some(px) = sheet
        .first()
        .and_then(|(_, s)| s.first())
        .and_then(|s| s.first())
        .map(|i| i.width())
    else {
        return Ok(());
    };
    let cols = sheet[0].1.iter().map(Vec::len).sum::<usize>() as u32;
    let (label_w, head, gap) = (200u32, 28u32, 6u32);
    let w = label_w + cols * px + gap;
    let h = head + sheet.len() as u32 * px;
    let mut buf = vec![255u8; (w * h * 3) as usize];
    for (r, (_, strips)) in sheet.iter().enumerate() {
        let mut x0 = label_w;
        for (si, strip) in strips.iter().enumerate() {
            if si > 0 {
                x0 += gap;
            }
            for img in strip {
                for (x, y, p) in img.enumerate_pixels() {
                    let (gx, gy) = (x0 + x, head + r as u32 * px + y);
                    let o = ((gy * w + gx) * 3) as usize;
                    buf[o..o + 3].copy_from_slice(&p.0);
                }
                x0 += px;
            }
        }
    }
    let mut labels = Vec::new();
    let mut x = label_w;
    for (si, strip) in sheet[0].1.iter().enumerate() {
        let light = if si == 0 { "point" } else { "env" };
        for (c, _) in strip.iter().enumerate() {
            let what = if c == 0 {
                "table".to_string()
            } else {
                LOSSES[c - 1].name().to_string()
            };
            labels.push((format!("{light}: {what}"), (x as i32 + 4, 6)));
            x += px;
        }
        x += gap;
    }
    for (r, (name, _)) in sheet.iter().enumerate() {
        labels.push((
            name.clone(),
            (6, (head + r as u32 * px + px / 2 - 8) as i32),
        ));
    }
    crate::plot::label_png(path, buf, (w, h), &labels)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// A score of a row, by name.
#[derive(Debug, Clone, Copy)]
pub struct Metric {
    /// Column title.
    pub title: &'static str,
    /// How the figure is printed.
    pub digits: usize,
    /// The score (lower is better).
    pub get: fn(&LossRow) -> f64,
}

/// A metric of the tables.
const fn metric(title: &'static str, digits: usize, get: fn(&LossRow) -> f64) -> Metric {
    Metric { title, digits, get }
}

/// The metrics of the tables, perceptual first.
pub const METRICS: [Metric; 4] = [
    metric("mean ΔE2000", 2, |r| r.delta_e_mean),
    metric("95th-percentile ΔE2000", 2, |r| r.delta_e_p95),
    metric("display RMSE (sRGB 0..1)", 4, |r| r.rmse_display),
    metric("linear relative RMS", 3, |r| r.rel_rms_linear),
];

/// For each (material, model, lighting), the loss with the lowest score (the first in
/// [`LOSSES`] order on a tie): win counts per loss name.
pub fn wins(rows: &[&LossRow], metric: &Metric) -> BTreeMap<String, usize> {
    let mut groups: BTreeMap<(&str, &str, &str), Vec<&LossRow>> = BTreeMap::new();
    for r in rows {
        groups
            .entry((&r.material, &r.model, &r.lighting))
            .or_default()
            .push(r);
    }
    let mut out: BTreeMap<String, usize> = LOSSES.iter().map(|l| (l.name().into(), 0)).collect();
    for g in groups.values() {
        let best = LOSSES.iter().filter_map(|l| {
            g.iter()
                .find(|r| r.loss == l.name())
                .map(|r| (l.name(), (metric.get)(r)))
        });
        if let Some((name, _)) =
            best.filter(|(_, v)| v.is_finite())
                .fold(None::<(&str, f64)>, |acc, (n, v)| match acc {
                    Some((_, b)) if b <= v => acc,
                    _ => Some((n, v)),
                })
        {
            *out.entry(name.to_string()).or_default() += 1;
        }
    }
    out
}

/// Per loss: wins, mean and median of `metric` under each lighting.
fn metric_table(rows: &[&LossRow], metric: &Metric) -> String {
    let mut s = format!(
        "**{}** (lower is better)\n\n| loss | wins, point | wins, environment | mean, point | median, point | mean, environment | median, environment |\n|---|---:|---:|---:|---:|---:|---:|\n",
        metric.title
    );
    let by_light =
        |l: &str| -> Vec<&LossRow> { rows.iter().copied().filter(|r| r.lighting == l).collect() };
    let (pt, env) = (
        by_light(Lighting::Point.key()),
        by_light(Lighting::Environment.key()),
    );
    let (wp, we) = (wins(&pt, metric), wins(&env, metric));
    let d = metric.digits;
    for l in LOSSES {
        let vals = |rs: &[&LossRow]| -> Vec<f64> {
            rs.iter()
                .filter(|r| r.loss == l.name())
                .map(|r| (metric.get)(r))
                .collect()
        };
        let (p, e) = (vals(&pt), vals(&env));
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.d$} | {:.d$} | {:.d$} | {:.d$} |",
            l.name(),
            wp[l.name()],
            we[l.name()],
            mean(&p),
            median(p.clone()),
            mean(&e),
            median(e.clone()),
        );
    }
    s
}

/// Per category: the wins of each loss by mean ΔE2000 and display RMSE (both
/// lightings together) and its median mean ΔE2000.
fn category_table(rows: &[&LossRow]) -> String {
    let mut cats: BTreeMap<&str, Vec<&LossRow>> = BTreeMap::new();
    for r in rows {
        cats.entry(&r.category).or_default().push(r);
    }
    let mut s = String::from("| category | materials |");
    for l in LOSSES {
        let _ = write!(s, " {} wins ΔE / RMSE | {} median ΔE |", l.name(), l.name());
    }
    s.push_str("\n|---|---:|");
    s.push_str(&"---:|---:|".repeat(LOSSES.len()));
    s.push('\n');
    let mut line = |c: &str, rs: &[&LossRow]| {
        let n = rs
            .iter()
            .map(|r| r.material.as_str())
            .collect::<std::collections::BTreeSet<_>>()
            .len();
        let (we, wr) = (wins(rs, &METRICS[0]), wins(rs, &METRICS[2]));
        let _ = write!(s, "| {c} | {n} |");
        for l in LOSSES {
            let de: Vec<f64> = rs
                .iter()
                .filter(|r| r.loss == l.name())
                .map(|r| r.delta_e_mean)
                .collect();
            let _ = write!(
                s,
                " {} / {} | {:.2} |",
                we[l.name()],
                wr[l.name()],
                median(de)
            );
        }
        s.push('\n');
    };
    for (c, rs) in &cats {
        line(c, rs);
    }
    line("**all**", rows);
    s
}

/// Per material and lighting: the mean ΔE2000 of each loss, the lowest in bold.
fn material_table(rows: &[&LossRow]) -> String {
    let mut s = String::from("| material | database | category | lighting |");
    for l in LOSSES {
        let _ = write!(s, " {} |", l.name());
    }
    s.push_str("\n|---|---|---|---|");
    s.push_str(&"---:|".repeat(LOSSES.len()));
    s.push('\n');
    let mut seen: Vec<(&str, &str)> = Vec::new();
    for r in rows {
        if !seen.contains(&(&r.material, &r.lighting)) {
            seen.push((&r.material, &r.lighting));
        }
    }
    for (m, light) in seen {
        let g: Vec<&LossRow> = rows
            .iter()
            .copied()
            .filter(|r| r.material == m && r.lighting == light)
            .collect();
        let Some(first) = g.first() else { continue };
        let best = g
            .iter()
            .map(|r| r.delta_e_mean)
            .fold(f64::INFINITY, f64::min);
        let _ = write!(
            s,
            "| {m} | {} | {} | {light} |",
            first.database, first.category
        );
        for l in LOSSES {
            match g.iter().find(|r| r.loss == l.name()) {
                Some(r) if r.delta_e_mean == best => {
                    let _ = write!(s, " **{:.2}** |", r.delta_e_mean);
                }
                Some(r) => {
                    let _ = write!(s, " {:.2} |", r.delta_e_mean);
                }
                None => s.push_str(" — |"),
            }
        }
        s.push('\n');
    }
    s
}

/// The generated sections of the page, per model family.
pub fn sections(cfg: &LossesConfig, run: &LossesRun) -> Vec<(String, String)> {
    let dir = cfg
        .out
        .file_name()
        .map_or(String::new(), |d| d.to_string_lossy().into_owned());
    let mats: std::collections::BTreeSet<(&str, &str)> = run
        .rows
        .iter()
        .map(|r| (r.material.as_str(), r.database.as_str()))
        .collect();
    let mut dbs: BTreeMap<&str, usize> = BTreeMap::new();
    for (_, d) in &mats {
        *dbs.entry(d).or_default() += 1;
    }
    let models: Vec<&str> = {
        let mut v: Vec<&str> = Vec::new();
        for r in &run.rows {
            if !v.contains(&r.model.as_str()) {
                v.push(&r.model);
            }
        }
        v
    };
    let fit_times: Vec<f64> = run
        .rows
        .iter()
        .filter(|r| r.lighting == Lighting::Point.key())
        .map(|r| r.fit_time_s)
        .collect();
    let load = |x: Option<f64>| x.map_or("?".into(), |v| format!("{v:.1}"));
    let runtext = format!(
        "{} proxies ({}), model{} {}, losses {}; {} fits, median fit {}. Proxies resampled \
         onto {}×{}×{}; fits with {} starts (the command line's defaults otherwise); renders \
         {}×{} px, {} spp under the environment (the report's). Whole run {} (load average \
         {} at the start, {} at the end).\n\nFiles: [scores.csv]({dir}/scores.csv) (one row \
         per material, model, loss and lighting; the fits' own losses on every cell too), \
         [scores.json]({dir}/scores.json).\n",
        mats.len(),
        dbs.iter()
            .map(|(d, n)| format!("{n} {d}"))
            .collect::<Vec<_>>()
            .join(", "),
        if models.len() > 1 { "s" } else { "" },
        models.join(", "),
        LOSSES.map(|l| l.name()).join(", "),
        fit_times.len(),
        secs(median(fit_times.clone())),
        run.dims[0],
        run.dims[1],
        run.dims[2],
        run.starts,
        run.size,
        run.size,
        run.env_spp,
        secs(run.wall_s),
        load(run.load[0]),
        load(run.load[1]),
    );
    let mut out = vec![("losses-run".to_string(), runtext)];
    for model in models {
        let rows: Vec<&LossRow> = run.rows.iter().filter(|r| r.model == model).collect();
        let mut overall = String::new();
        for m in &METRICS {
            let _ = writeln!(overall, "{}", metric_table(&rows, m));
        }
        // The fits' own losses: what each optimised and what it gives up.
        let _ = writeln!(
            overall,
            "**The fits' losses on every valid cell** (median over the materials)\n\n| loss fitted | cbrt | l2 | cosine | log |\n|---|---:|---:|---:|---:|"
        );
        for l in LOSSES {
            let pick = |f: fn(&LossRow) -> f64| {
                median(
                    rows.iter()
                        .filter(|r| r.loss == l.name() && r.lighting == Lighting::Point.key())
                        .map(|r| f(r))
                        .collect(),
                )
            };
            let _ = writeln!(
                overall,
                "| {} | {} | {} | {} | {} |",
                l.name(),
                fmt_loss(pick(|r| r.fit_cbrt)),
                fmt_loss(pick(|r| r.fit_l2)),
                fmt_loss(pick(|r| r.fit_cosine)),
                fmt_loss(pick(|r| r.fit_log)),
            );
        }
        out.push((format!("losses-{model}-overall"), overall));
        out.push((format!("losses-{model}-categories"), category_table(&rows)));
        out.push((format!("losses-{model}-materials"), material_table(&rows)));
    }
    out.push((
        "losses-sheet".to_string(),
        format!(
            "![Each material's table and its fits (l2, cosine, cbrt, log) under the point \
             light and the environment]({dir}/sheet.png)\n"
        ),
    ));
    out
}

/// Writes the generated sections into the report (created with a title when missing).
pub fn write_report(cfg: &LossesConfig, run: &LossesRun) -> Result<(), StudyError> {
    let mut doc = std::fs::read_to_string(&cfg.report)
        .unwrap_or_else(|_| "# Which loss looks right\n".into());
    for (name, body) in sections(cfg, run) {
        doc = replace_section(&doc, &name, &body);
    }
    write(&cfg.report, doc.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// sRGB display value of CIE L* on the neutral axis, from the closed forms:
    /// Y = ((L* + 16) / 116)³ (CIE 1976, L* > 8), then the sRGB transfer curve
    /// (IEC 61966-2-1): 1.055 Y^(1/2.4) − 0.055.
    fn grey(l: f64) -> [f64; 3] {
        let y = ((l + 16.0) / 116.0).powi(3);
        [1.055 * y.powf(1.0 / 2.4) - 0.055; 3]
    }

    #[test]
    fn identical_images_score_zero() {
        let img: Vec<[f64; 3]> = (0..50)
            .map(|k| [k as f64 / 50.0, 0.3, 1.0 - k as f64 / 60.0])
            .collect();
        let s = score_display(&img, &img);
        assert_eq!(s.pixels, 50);
        assert!(s.delta_e_mean.abs() < 1e-9, "{s:?}");
        assert!(s.delta_e_p95.abs() < 1e-9, "{s:?}");
        assert_eq!(s.rmse_display, 0.0);
    }

    #[test]
    fn a_known_shift_gives_the_known_scores() {
        // Neutral greys L* = 45 and 55: a* = b* = 0, so CIEDE2000 reduces to
        // ΔL' / S_L with S_L = 1 + 0.015 (L̄ − 50)² / sqrt(20 + (L̄ − 50)²) = 1 at
        // L̄ = 50 (Sharma et al. 2005, eqs. 16–18): ΔE00 = 10 exactly.
        let (a, b) = (grey(45.0), grey(55.0));
        let s = score_display(&[a; 8], &[b; 8]);
        assert!((s.delta_e_mean - 10.0).abs() < 1e-3, "{s:?}");
        assert!((s.delta_e_p95 - 10.0).abs() < 1e-3, "{s:?}");
        assert!((s.rmse_display - (b[0] - a[0])).abs() < 1e-12, "{s:?}");
        // Around L̄ = 70 the lightness weight is S_L = 1 + 0.015·400 / sqrt(420):
        // a step of 10 in L* counts for less.
        let s = score_display(&[grey(65.0)], &[grey(75.0)]);
        let sl = 1.0 + 0.015 * 400.0 / 420f64.sqrt();
        assert!((s.delta_e_mean - 10.0 / sl).abs() < 1e-3, "{s:?} {sl}");
        // A uniform shift of 0.1 in every display channel: RMSE 0.1.
        let t: Vec<[f64; 3]> = (0..20).map(|k| [0.2 + k as f64 * 0.01, 0.5, 0.3]).collect();
        let f: Vec<[f64; 3]> = t.iter().map(|p| p.map(|v| v + 0.1)).collect();
        assert!((score_display(&t, &f).rmse_display - 0.1).abs() < 1e-12);
        // Half the pixels off by ΔE 10: the mean is 5 and the 95th percentile 10.
        let s = score_display(&[a; 10], &[[a; 5], [b; 5]].concat());
        assert!((s.delta_e_mean - 5.0).abs() < 1e-3, "{s:?}");
        assert!((s.delta_e_p95 - 10.0).abs() < 1e-3, "{s:?}");
    }

    #[test]
    fn the_sphere_mask_drops_the_background_and_the_outline() {
        let mut t = image::RgbImage::new(4, 1);
        let mut f = image::RgbImage::new(4, 1);
        // 0: background in both; 1: the outline in both; 2: lit in the table only;
        // 3: lit in both.
        t.put_pixel(1, 0, image::Rgb(OUTLINE));
        f.put_pixel(1, 0, image::Rgb(OUTLINE));
        t.put_pixel(2, 0, image::Rgb([255, 0, 0]));
        t.put_pixel(3, 0, image::Rgb([51, 51, 51]));
        f.put_pixel(3, 0, image::Rgb([102, 51, 51]));
        let (a, b) = sphere_pixels(&t, &f);
        assert_eq!(a, vec![[1.0, 0.0, 0.0], [0.2, 0.2, 0.2]]);
        assert_eq!(b, vec![[0.0, 0.0, 0.0], [0.4, 0.2, 0.2]]);
    }

    fn row(m: &str, loss: Loss, light: &str, de: f64, rmse: f64) -> LossRow {
        LossRow {
            material: m.into(),
            database: "merl".into(),
            category: "metal".into(),
            model: "cook-torrance".into(),
            loss: loss.name().into(),
            lighting: light.into(),
            delta_e_mean: de,
            delta_e_p95: de,
            rmse_display: rmse,
            rel_rms_linear: rmse,
            pixels: 1,
            fit_cbrt: 0.1,
            fit_l2: 0.1,
            fit_cosine: 0.1,
            fit_log: 0.1,
            fit_time_s: 0.5,
        }
    }

    #[test]
    fn wins_count_the_lowest_score_per_material_and_lighting() {
        let rows = [
            row("a", Loss::L2, "point", 3.0, 0.1),
            row("a", Loss::Cbrt, "point", 1.0, 0.2),
            row("a", Loss::Log, "point", 2.0, 0.05),
            row("a", Loss::L2, "environment", 1.0, 0.1),
            row("a", Loss::Cbrt, "environment", 1.0, 0.2),
            row("b", Loss::Log, "point", f64::NAN, 0.2),
            row("b", Loss::Cosine, "point", 4.0, 0.3),
        ];
        let r: Vec<&LossRow> = rows.iter().collect();
        let w = wins(&r, &METRICS[0]);
        // a/point: cbrt; a/environment: a tie, the first in order (l2); b/point: cosine
        // (a NaN never wins).
        assert_eq!((w["l2"], w["cosine"], w["cbrt"], w["log"]), (1, 1, 1, 0));
        let w = wins(&r, &METRICS[2]);
        assert_eq!((w["l2"], w["cosine"], w["cbrt"], w["log"]), (1, 0, 0, 2));
        let t = metric_table(&r, &METRICS[0]);
        // cbrt under the point light: one value, 1.00; l2: mean and median of {3}.
        assert!(
            t.contains("| cbrt | 1 | 0 | 1.00 | 1.00 | 1.00 | 1.00 |"),
            "{t}"
        );
        assert!(
            t.contains("| l2 | 0 | 1 | 3.00 | 3.00 | 1.00 | 1.00 |"),
            "{t}"
        );
        let m = material_table(&r);
        assert!(
            m.contains("| a | merl | metal | point | 3.00 | — | **1.00** | 2.00 |"),
            "{m}"
        );
    }

    /// Two vendored proxies on a coarse grid, one start, small renders: the whole part
    /// end to end (fits, renders, scores, CSV, sheet, page).
    #[test]
    fn the_part_runs_end_to_end_on_two_proxies() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-measured");
        let d = tempfile::tempdir().unwrap();
        let report = d.path().join("losses.md");
        std::fs::write(&report, "# Losses\n\nHand-written reading.\n").unwrap();
        let cfg = LossesConfig {
            materials: vec!["gold-paint".into(), "pink-fabric".into()],
            starts: 1,
            dims: Dims::new(16, 16, 32).unwrap(),
            render: RenderOptions {
                size: 24,
                env_spp: 2,
                ..RenderOptions::default()
            },
            out: d.path().join("losses"),
            report: report.clone(),
            ..LossesConfig::new(&root, root.join("categories.csv"))
        };
        let rows = run(&cfg, &()).unwrap();
        assert_eq!(rows.len(), 2 * LOSSES.len() * 2);
        for r in &rows {
            assert!(r.pixels > 100, "{r:?}");
            assert!(r.delta_e_mean.is_finite() && r.delta_e_mean >= 0.0, "{r:?}");
            assert!(
                r.rel_rms_linear.is_finite() && r.rel_rms_linear > 0.0,
                "{r:?}"
            );
            assert!(r.fit_cbrt.is_finite() && r.fit_cbrt > 0.0, "{r:?}");
        }
        // Each fit is the lowest of the four on its own loss (or within round-off of a
        // fit of another loss that reached the same optimum).
        for m in ["gold-paint", "pink-fabric"] {
            let of = |l: Loss| {
                rows.iter()
                    .find(|r| r.material == m && r.loss == l.name())
                    .unwrap()
            };
            let best = LOSSES
                .iter()
                .map(|l| of(*l).fit_cbrt)
                .fold(f64::INFINITY, f64::min);
            assert!(of(Loss::Cbrt).fit_cbrt <= best * 1.01, "{m}");
            let best = LOSSES
                .iter()
                .map(|l| of(*l).fit_l2)
                .fold(f64::INFINITY, f64::min);
            assert!(of(Loss::L2).fit_l2 <= best * 1.01, "{m}");
        }
        let csv = std::fs::read_to_string(cfg.out.join("scores.csv")).unwrap();
        assert_eq!(csv.lines().count(), 1 + rows.len());
        let sheet = image::open(cfg.out.join("sheet.png")).unwrap();
        assert_eq!(sheet.height(), 28 + 2 * 24);
        let doc = std::fs::read_to_string(&report).unwrap();
        assert!(
            doc.starts_with("# Losses\n\nHand-written reading."),
            "{doc}"
        );
        assert!(
            doc.contains("<!-- study:losses-cook-torrance-overall -->"),
            "{doc}"
        );
        assert!(doc.contains("2 proxies (2 merl)"), "{doc}");
        // An unknown name is refused before any work.
        let bad = LossesConfig {
            materials: vec!["no-such-proxy".into()],
            ..cfg
        };
        let e = run(&bad, &()).unwrap_err();
        assert!(e.to_string().contains("`no-such-proxy`"), "{e}");
    }
}
