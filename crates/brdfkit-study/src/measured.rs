//! The whole measured database, fitted and ranked (issue 12, item 4): reads the
//! per-table JSON of a `fit-brdf batch --nbrdf` run and writes `docs/measured.md`'s
//! generated sections, the losses and fitted parameters as CSV, the ranking figure and
//! the thumbnails of the best and the worst fits.
//!
//! The ranking follows A. Ngan, F. Durand, W. Matusik, "Experimental Analysis of BRDF
//! Models", EGSR 2005, fig. 6: materials sorted by the loss of the best model, one curve
//! per model, the loss on a log axis. Which model wins a category (metal, paint,
//! plastic, fabric, other) is counted from the lowest loss per material; categories come
//! from a hand-written file (`data-measured/categories.csv`: `name,database,category`).

use crate::StudyError;
use crate::files::write;
use crate::markdown::{loss, replace_section, secs};
use crate::plot::{Axes, Panel, Series, figure};
use brdfkit_core::progress::{Event, Observe};
use brdfkit_core::text::read_utf8;
use brdfkit_fit::Fitted;
use brdfkit_merl::Dims;
use brdfkit_validate::html::renders::{Lighting, RenderOptions, Shown, render_set};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where the database run is and where its documents go.
#[derive(Debug, Clone)]
pub struct MeasuredConfig {
    /// The batch's output directory (`<name>.json` per proxy).
    pub fits: PathBuf,
    /// Directory of the CSV files and images (`docs/measured`).
    pub out: PathBuf,
    /// The Markdown document whose generated sections are replaced (`docs/measured.md`).
    pub report: PathBuf,
    /// `name,database,category` per proxy.
    pub categories: PathBuf,
    /// How many of the best and of the worst fitted materials get thumbnails.
    pub thumbnails: usize,
    /// Thumbnail size in pixels.
    pub thumb_size: usize,
}

impl MeasuredConfig {
    /// The study of the batch in `fits`, written into the Markdown document `report` and
    /// the folder beside it of the same name without extension (`docs/measured.md` and
    /// `docs/measured/`), with `thumbnails` best and worst materials drawn at 96 pixels.
    pub fn new(fits: PathBuf, report: PathBuf, categories: PathBuf, thumbnails: usize) -> Self {
        MeasuredConfig {
            fits,
            out: report.with_extension(""),
            report,
            categories,
            thumbnails,
            thumb_size: 96,
        }
    }
}

/// One fit of one material, as the batch recorded it.
#[derive(Debug, Clone)]
pub struct MeasuredFit {
    /// The family's label.
    pub model: String,
    /// Optimised loss (cbrt by default) and the others, on all valid cells.
    pub losses: [f64; 4],
    /// Iterations.
    pub iterations: u64,
    /// Converged.
    pub converged: bool,
    /// Wall time of the fit.
    pub time_s: f64,
    /// The fitted model (JSON contract).
    pub params: Value,
}

/// One material of the run.
#[derive(Debug, Clone)]
pub struct MeasuredMaterial {
    /// The proxy's name.
    pub name: String,
    /// The proxy's stem path.
    pub path: PathBuf,
    /// Its database (`merl`, `rgl-isotropic`, `nielsen`).
    pub database: String,
    /// Its category.
    pub category: String,
    /// Its fits in the batch's order.
    pub fits: Vec<MeasuredFit>,
    /// Wall time of the table (resampling and every fit).
    pub wall_time_s: f64,
}

impl MeasuredMaterial {
    /// The index of the fit with the lowest cbrt loss.
    pub fn best(&self) -> Option<usize> {
        (0..self.fits.len())
            .filter(|&k| self.fits[k].losses[0].is_finite())
            .min_by(|&a, &b| self.fits[a].losses[0].total_cmp(&self.fits[b].losses[0]))
    }
}

const LOSSES: [&str; 4] = ["cbrt", "l2", "cosine", "log"];

fn bad(path: &Path, msg: impl Into<String>) -> StudyError {
    StudyError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, msg.into()),
    }
}

/// The categories file: name → (database, category).
pub fn read_categories(path: &Path) -> Result<BTreeMap<String, (String, String)>, StudyError> {
    let mut m = BTreeMap::new();
    for (k, line) in read_utf8(path, "the categories file")?.lines().enumerate() {
        let line = line.trim();
        if k == 0 || line.is_empty() || line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 3 {
            return Err(bad(
                path,
                format!("line {}: expected name,database,category", k + 1),
            ));
        }
        m.insert(f[0].to_string(), (f[1].to_string(), f[2].to_string()));
    }
    Ok(m)
}

/// Every finished table of the batch directory, by name; a proxy missing from the
/// categories is an error (every proxy must be assigned).
pub fn read_fits(
    dir: &Path,
    cats: &BTreeMap<String, (String, String)>,
) -> Result<Vec<MeasuredMaterial>, StudyError> {
    let mut out = Vec::new();
    let entries = std::fs::read_dir(dir).map_err(|e| StudyError::io(dir, e))?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    paths.sort();
    for p in paths {
        let v: Value = serde_json::from_str(&read_utf8(&p, "a fit record")?)
            .map_err(|e| bad(&p, format!("not JSON: {e}")))?;
        if v["format"] != brdfkit_fit::batch::FORMAT {
            continue;
        }
        let name = v["table"]["name"].as_str().unwrap_or_default().to_string();
        let path = PathBuf::from(v["table"]["path"].as_str().unwrap_or_default());
        let (database, category) = cats
            .get(&name)
            .cloned()
            .ok_or_else(|| bad(&p, format!("`{name}` is not in the categories file")))?;
        let fits = v["fits"]
            .as_array()
            .map(|a| a.as_slice())
            .unwrap_or_default()
            .iter()
            .map(|f| {
                let r = &f["record"];
                MeasuredFit {
                    model: f["label"].as_str().unwrap_or_default().to_string(),
                    losses: LOSSES
                        .map(|l| r["losses_full"][l]["overall"].as_f64().unwrap_or(f64::NAN)),
                    iterations: r["iterations"].as_u64().unwrap_or(0),
                    converged: r["converged"].as_bool().unwrap_or(false),
                    time_s: r["wall_time_s"].as_f64().unwrap_or(f64::NAN),
                    params: f["params"].clone(),
                }
            })
            .collect();
        out.push(MeasuredMaterial {
            name,
            path,
            database,
            category,
            fits,
            wall_time_s: v["wall_time_s"].as_f64().unwrap_or(f64::NAN),
        });
    }
    Ok(out)
}

/// The model labels in the order of the first material.
fn models(mats: &[MeasuredMaterial]) -> Vec<String> {
    mats.first()
        .map(|m| m.fits.iter().map(|f| f.model.clone()).collect())
        .unwrap_or_default()
}

/// The median of the finite values (NaN when there is none).
pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_unstable_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// `losses.csv`: one row per material and model.
pub fn losses_csv(mats: &[MeasuredMaterial]) -> String {
    let mut s = String::from(
        "material,database,category,model,cbrt,l2,cosine,log,iterations,converged,fit_time_s\n",
    );
    for m in mats {
        for f in &m.fits {
            let l = f.losses.map(|x| {
                if x.is_finite() {
                    format!("{x:e}")
                } else {
                    String::new()
                }
            });
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{:.4}",
                m.name,
                m.database,
                m.category,
                f.model,
                l[0],
                l[1],
                l[2],
                l[3],
                f.iterations,
                f.converged,
                f.time_s
            );
        }
    }
    s
}

/// `params.csv`: one row per material, model and fitted parameter (flat names of the
/// model contract, e.g. `terms[1].alpha`).
pub fn params_csv(mats: &[MeasuredMaterial]) -> Result<String, StudyError> {
    let mut s = String::from("material,model,param,value\n");
    for m in mats {
        for f in &m.fits {
            let model = brdfkit_models::from_json(&f.params).map_err(|e| StudyError::Model {
                what: format!("{} {}", m.name, f.model),
                msg: e.to_string(),
            })?;
            for (spec, x) in model.param_specs().iter().zip(model.params()) {
                let _ = writeln!(s, "{},{},{},{x:e}", m.name, f.model, spec.name);
            }
        }
    }
    Ok(s)
}

/// Materials sorted by their best model's loss (ascending).
fn ranked(mats: &[MeasuredMaterial]) -> Vec<&MeasuredMaterial> {
    let mut v: Vec<&MeasuredMaterial> = mats.iter().filter(|m| m.best().is_some()).collect();
    let key = |m: &MeasuredMaterial| m.best().map_or(f64::INFINITY, |b| m.fits[b].losses[0]);
    v.sort_by(|a, b| key(a).total_cmp(&key(b)));
    v
}

/// The ranking figure (Ngan et al. 2005, fig. 6).
fn ranking_figure(path: &Path, mats: &[MeasuredMaterial]) -> Result<(), StudyError> {
    let r = ranked(mats);
    let series: Vec<Series> = models(mats)
        .iter()
        .enumerate()
        .map(|(k, name)| Series {
            name: name.clone(),
            points: r
                .iter()
                .enumerate()
                .filter_map(|(i, m)| {
                    let f = m.fits.iter().find(|f| &f.model == name)?;
                    Some((i as f64, f.losses[0]))
                })
                .collect(),
            line: true,
            tag: false,
            color: k,
        })
        .collect();
    figure(
        path,
        "Measured materials sorted by the best model's loss",
        &[Panel {
            title: format!("{} proxies, every model family", r.len()),
            series,
        }],
        &Axes {
            x_label: "material (sorted by the best fit's cbrt loss)".into(),
            y_label: "cbrt loss (weighted RMS, all valid cells)".into(),
            log_x: false,
            log_y: true,
        },
        1,
        (1100, 620),
    )
}

/// Per model: median loss, wins, median time, over `mats`.
fn model_table(mats: &[&MeasuredMaterial], names: &[String]) -> String {
    let mut s = String::from(
        "| model | wins | median cbrt loss | median loss / best | median time per fit |\n|---|---:|---:|---:|---:|\n",
    );
    for name in names {
        let fits = || {
            mats.iter()
                .filter_map(|m| m.fits.iter().find(|f| &f.model == name).map(|f| (m, f)))
        };
        let wins = mats
            .iter()
            .filter(|m| m.best().is_some_and(|b| &m.fits[b].model == name))
            .count();
        let rel = median(
            fits()
                .map(|(m, f)| f.losses[0] / m.best().map_or(f64::NAN, |b| m.fits[b].losses[0]))
                .collect(),
        );
        let _ = writeln!(
            s,
            "| {name} | {wins} | {} | {rel:.2} | {} |",
            loss(median(fits().map(|(_, f)| f.losses[0]).collect())),
            secs(median(fits().map(|(_, f)| f.time_s).collect()))
        );
    }
    s
}

fn sections(
    cfg: &MeasuredConfig,
    mats: &[MeasuredMaterial],
    thumbs: &str,
) -> Vec<(&'static str, String)> {
    let names = models(mats);
    let all: Vec<&MeasuredMaterial> = mats.iter().collect();
    let fits: usize = mats.iter().map(|m| m.fits.len()).sum();
    let fit_time: f64 = mats.iter().flat_map(|m| &m.fits).map(|f| f.time_s).sum();
    let table_time: f64 = mats.iter().map(|m| m.wall_time_s).sum();
    let mut dbs: BTreeMap<&str, usize> = BTreeMap::new();
    for m in mats {
        *dbs.entry(m.database.as_str()).or_default() += 1;
    }
    let rel = |p: &str| {
        let dir = cfg
            .out
            .file_name()
            .map_or(String::new(), |d| d.to_string_lossy().into_owned());
        format!("{dir}/{p}")
    };
    let mut run = format!(
        "{} materials ({}), {} models, {fits} fits. Time in the fits: {} in all, {} per fit \
         on average; per table (resampling the proxy and its {} fits): {} in all.\n\n\
         Files: [losses.csv]({}) (every loss of every model on every material), \
         [params.csv]({}) (the fitted parameters, flat names of the model contract).\n",
        mats.len(),
        dbs.iter()
            .map(|(d, n)| format!("{n} {d}"))
            .collect::<Vec<_>>()
            .join(", "),
        names.len(),
        secs(fit_time),
        secs(fit_time / fits.max(1) as f64),
        names.len(),
        secs(table_time),
        rel("losses.csv"),
        rel("params.csv"),
    );
    run += &format!("\n{}", model_table(&all, &names));
    let ranking = format!(
        "![Materials sorted by the best model's loss, one curve per model]({})\n",
        rel("ranking.png")
    );
    let mut cats: BTreeMap<&str, Vec<&MeasuredMaterial>> = BTreeMap::new();
    for m in mats {
        cats.entry(m.category.as_str()).or_default().push(m);
    }
    let mut by_cat = String::new();
    for (c, ms) in &cats {
        let _ = writeln!(
            by_cat,
            "**{c}** ({} materials)\n\n{}",
            ms.len(),
            model_table(ms, &names)
        );
    }
    vec![
        ("run", run),
        ("ranking", ranking),
        ("categories", by_cat),
        ("thumbnails", thumbs.to_string()),
    ]
}

/// Renders the table and the best fit of `m` under a point light: (table PNG, fit PNG,
/// relative RMS radiance difference).
fn thumbnail(m: &MeasuredMaterial, size: usize) -> Result<(Vec<u8>, Vec<u8>, f64), StudyError> {
    let err = |msg: String| StudyError::Model {
        what: m.name.clone(),
        msg,
    };
    let net = brdfkit_nbrdf::Nbrdf::load(&m.path).map_err(|e| err(e.to_string()))?;
    let table = Arc::new(net.to_table(Dims::MERL).map_err(|e| err(e.to_string()))?.0);
    let b = m.best().ok_or_else(|| err("no fit".into()))?;
    let model = brdfkit_models::from_json(&m.fits[b].params).map_err(|e| err(e.to_string()))?;
    let fitted = Fitted::Shared(model);
    let o = RenderOptions {
        size,
        ..RenderOptions::default()
    };
    let set = render_set(Lighting::Point, &o, Shown::Table(&table), &[&fitted])
        .map_err(|e| err(e.to_string()))?;
    let r = set
        .models
        .into_iter()
        .next()
        .ok_or_else(|| err("no render".into()))?;
    Ok((set.table_png, r.png, r.diff.rel_rms_radiance))
}

/// The thumbnails of the `n` best and `n` worst fitted materials, written below
/// `cfg.out/thumbs`; returns the Markdown table.
fn thumbnails(
    cfg: &MeasuredConfig,
    mats: &[MeasuredMaterial],
    progress: &dyn Observe,
) -> Result<String, StudyError> {
    let r = ranked(mats);
    let n = cfg.thumbnails.min(r.len() / 2);
    let dir = cfg.out.join("thumbs");
    std::fs::create_dir_all(&dir).map_err(|e| StudyError::io(&dir, e))?;
    let rel = cfg
        .out
        .file_name()
        .map_or(String::new(), |d| d.to_string_lossy().into_owned());
    let mut s = String::from(
        "| | material | best model | cbrt loss | measured (proxy table) | best fit | image rel. RMS |\n|---|---|---|---:|---|---|---:|\n",
    );
    let picks = r[..n]
        .iter()
        .map(|m| ("best", m))
        .chain(r[r.len() - n..].iter().map(|m| ("worst", m)));
    for (which, m) in picks {
        progress.observe(&Event::Step(format!("measured: thumbnail of {}", m.name)));
        let (t, f, rms) = thumbnail(m, cfg.thumb_size)?;
        let (tp, fp) = (
            format!("{}-table.png", m.name),
            format!("{}-fit.png", m.name),
        );
        write(&dir.join(&tp), &t)?;
        write(&dir.join(&fp), &f)?;
        let b = &m.fits[m.best().unwrap_or(0)];
        let _ = writeln!(
            s,
            "| {which} | {} ({}, {}) | {} | {} | ![]({rel}/thumbs/{tp}) | ![]({rel}/thumbs/{fp}) | {:.1} % |",
            m.name,
            m.database,
            m.category,
            b.model,
            loss(b.losses[0]),
            rms * 100.0
        );
    }
    Ok(s)
}

/// Reads the run, writes the CSV files, the figure, the thumbnails and the generated
/// sections of the report (`<!-- study:measured-NAME -->` markers; the rest of the
/// document is kept).
pub fn run(
    cfg: &MeasuredConfig,
    progress: &dyn Observe,
) -> Result<Vec<MeasuredMaterial>, StudyError> {
    let cats = read_categories(&cfg.categories)?;
    let mats = read_fits(&cfg.fits, &cats)?;
    if mats.is_empty() {
        return Err(StudyError::Config {
            option: "fits",
            msg: format!("{}: no finished batch table", cfg.fits.display()),
        });
    }
    std::fs::create_dir_all(&cfg.out).map_err(|e| StudyError::io(&cfg.out, e))?;
    write(&cfg.out.join("losses.csv"), losses_csv(&mats).as_bytes())?;
    write(&cfg.out.join("params.csv"), params_csv(&mats)?.as_bytes())?;
    ranking_figure(&cfg.out.join("ranking.png"), &mats)?;
    let thumbs = if cfg.thumbnails > 0 {
        thumbnails(cfg, &mats, progress)?
    } else {
        String::new()
    };
    let mut doc = std::fs::read_to_string(&cfg.report)
        .unwrap_or_else(|_| "# Measured materials: the whole database fitted and ranked\n".into());
    for (name, body) in sections(cfg, &mats, &thumbs) {
        doc = replace_section(&doc, &format!("measured-{name}"), &body);
    }
    write(&cfg.report, doc.as_bytes())?;
    Ok(mats)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(model: &str, cbrt: f64) -> MeasuredFit {
        MeasuredFit {
            model: model.into(),
            losses: [cbrt, 1.0, 1.0, 1.0],
            iterations: 3,
            converged: true,
            time_s: 0.5,
            params: serde_json::json!({"model": "lambert", "params": {"rho_d": 0.5}}),
        }
    }

    fn mat(name: &str, cat: &str, losses: [f64; 2]) -> MeasuredMaterial {
        MeasuredMaterial {
            name: name.into(),
            path: PathBuf::from(name),
            database: "merl".into(),
            category: cat.into(),
            fits: vec![fit("a", losses[0]), fit("b", losses[1])],
            wall_time_s: 1.0,
        }
    }

    #[test]
    fn ranking_wins_and_csv_follow_the_losses() {
        let mats = vec![
            mat("x", "metal", [0.3, 0.2]),
            mat("y", "metal", [0.05, 0.1]),
            mat("z", "fabric", [f64::NAN, 0.4]),
        ];
        assert_eq!(mats[0].best(), Some(1));
        assert_eq!(mats[2].best(), Some(1), "a failed fit never wins");
        let r: Vec<&str> = ranked(&mats).iter().map(|m| m.name.as_str()).collect();
        assert_eq!(r, ["y", "x", "z"]);
        let metals: Vec<&MeasuredMaterial> = mats[..2].iter().collect();
        let t = model_table(&metals, &models(&mats));
        // One win each; the median of a's ratio to the best is (1.5 + 1) / 2.
        assert!(t.contains("| a | 1 | 1.750e-1 | 1.25 |"), "{t}");
        assert!(t.contains("| b | 1 | 1.500e-1 | 1.50 |"), "{t}");
        let csv = losses_csv(&mats);
        assert_eq!(csv.lines().count(), 1 + 6);
        assert!(
            csv.contains("\nz,merl,fabric,a,,1e0,1e0,1e0,3,true,0.5000\n"),
            "{csv}"
        );
        let p = params_csv(&mats[..1]).unwrap();
        assert!(p.contains("x,a,rho_d.r,5e-1\n"), "{p}");
    }

    #[test]
    fn categories_are_read_and_a_missing_proxy_is_an_error() {
        let d = tempfile::tempdir().unwrap();
        let c = d.path().join("c.csv");
        std::fs::write(&c, "name,database,category\n# note\ngold,merl,metal\n").unwrap();
        let cats = read_categories(&c).unwrap();
        assert_eq!(cats["gold"], ("merl".to_string(), "metal".to_string()));
        std::fs::write(&c, "name,database,category\ngold,merl\n").unwrap();
        assert!(read_categories(&c).is_err());
        let fits = d.path().join("fits");
        std::fs::create_dir(&fits).unwrap();
        std::fs::write(
            fits.join("silver.json"),
            serde_json::json!({"format": brdfkit_fit::batch::FORMAT,
                "table": {"name": "silver", "path": "p/silver"}, "fits": []})
            .to_string(),
        )
        .unwrap();
        let e = read_fits(&fits, &cats).unwrap_err();
        assert!(e.to_string().contains("`silver`"), "{e}");
    }
}
