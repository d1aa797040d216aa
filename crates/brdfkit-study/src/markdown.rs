//! The study's Markdown document (`docs/accuracy-vs-time.md`) and its PNG plots.
//!
//! The report's generated parts sit between `<!-- study:NAME -->` and
//! `<!-- /study:NAME -->`; a re-run replaces only those, so the hand-written reading of
//! the results around them stays. A report that does not exist yet is created from a
//! skeleton.

use crate::files::{write, write_json};
use crate::grid::{CLI_DEFAULT, GridRow, pareto};
use crate::plot::{Axes, Panel, Series, figure};
use crate::{RunInfo, StudyConfig, StudyError, StudyResults};
use brdfkit_core::progress::{Event, Observe};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Replaces the text between the markers of `name`, appending the section when the
/// markers are absent.
pub fn replace_section(doc: &str, name: &str, body: &str) -> String {
    let open = format!("<!-- study:{name} -->");
    let close = format!("<!-- /study:{name} -->");
    let block = format!("{open}\n{}\n{close}", body.trim_end());
    match (doc.find(&open), doc.find(&close)) {
        (Some(a), Some(b)) if b > a => format!("{}{}{}", &doc[..a], block, &doc[b + close.len()..]),
        _ => format!("{}\n{}\n", doc.trim_end(), block),
    }
}

/// Seconds or milliseconds, readable.
pub fn secs(s: f64) -> String {
    if !s.is_finite() {
        "—".into()
    } else if s < 1e-3 {
        format!("{:.1} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.0} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

/// A loss, readable.
pub fn loss(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.3e}")
    } else {
        "failed".into()
    }
}

fn pct(f: f64) -> String {
    let p = f * 100.0;
    if p < 1.0 {
        format!("{p:.1} %")
    } else {
        format!("{p:.0} %")
    }
}

fn conf(r: &GridRow) -> String {
    format!("{} · {} · {}×", r.solver, pct(r.fraction), r.starts)
}

/// The bound under which a fit counts as "as good as the best found": 1 % above the
/// best loss of its material and model, plus 1e-4 absolute (in cube-root units, far
/// below a visible difference; it keeps exact fits at 1e-16 from making every other
/// exact fit "worse").
pub fn good_enough(best: f64) -> f64 {
    best * 1.01 + 1e-4
}

/// Rows grouped by (model, material).
fn by_pair(rows: &[GridRow]) -> BTreeMap<(String, String), Vec<&GridRow>> {
    let mut by: BTreeMap<(String, String), Vec<&GridRow>> = BTreeMap::new();
    for r in rows {
        by.entry((r.model.clone(), r.material.clone()))
            .or_default()
            .push(r);
    }
    by
}

/// The fastest of `rs` whose cbrt loss is at most `bound`.
fn cheapest<'a>(rs: &[&'a GridRow], bound: f64) -> Option<&'a GridRow> {
    rs.iter()
        .filter(|r| r.cbrt <= bound)
        .min_by(|a, b| a.wall_s.total_cmp(&b.wall_s))
        .copied()
}

/// LM on the full table with one start, the grid's plain configuration.
fn plain_lm<'a>(rs: &[&'a GridRow]) -> Option<&'a GridRow> {
    rs.iter()
        .find(|r| r.solver == "lm" && r.fraction == 1.0 && r.starts == 1)
        .copied()
}

/// The Pareto front of `rs` as a table headed by `title`; with a baseline, each row's
/// cbrt loss relative to it too.
fn front_table(out: &mut String, title: &str, rs: &[&GridRow], baseline: Option<f64>) {
    let (head, rule) = match baseline {
        Some(_) => (" vs baseline |", "---:|"),
        None => ("", ""),
    };
    let _ = writeln!(
        out,
        "\n**{title}** ({} fits; Pareto front, fastest first):\n\n\
         | solver · fraction · starts | wall | CPU | cbrt |{head} l2 | cosine | log |\n\
         |---|---:|---:|---:|{rule}---:|---:|---:|",
        rs.len()
    );
    for i in pareto(rs) {
        let r = rs[i];
        let rel = baseline
            .map(|b| format!(" {} |", excess(r.cbrt / b - 1.0)))
            .unwrap_or_default();
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} |{rel} {} | {} | {} |",
            conf(r),
            secs(r.wall_s),
            secs(r.cpu_s),
            loss(r.cbrt),
            loss(r.l2),
            loss(r.cosine),
            loss(r.log)
        );
    }
}

/// Per configuration (solver, fraction, starts): runs, hits of each bound, wall and CPU
/// times, excesses over the baseline.
#[derive(Default)]
struct Tally {
    runs: usize,
    hits: [usize; 2],
    wall: Vec<f64>,
    cpu: Vec<f64>,
    excess: Vec<f64>,
}

impl Tally {
    fn add(&mut self, r: &GridRow, hits: [bool; 2], excess: f64) {
        self.runs += 1;
        for (h, hit) in self.hits.iter_mut().zip(hits) {
            *h += usize::from(hit);
        }
        self.wall.push(r.wall_s);
        self.cpu.push(r.cpu_s);
        self.excess.push(excess);
    }

    /// "k (p %)" of bound `i`.
    fn share(&self, i: usize) -> String {
        format!(
            "{} ({:.0} %)",
            self.hits[i],
            100.0 * self.hits[i] as f64 / self.runs as f64
        )
    }
}

/// The median of `v` (the upper one of an even count, as the synthetic tables always
/// showed), NaN when empty.
fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NAN, f64::max)
}

/// Sort key of a configuration: solver, then fraction and starts in numeric order.
fn tally_key(r: &GridRow) -> (String, String) {
    (
        r.solver.clone(),
        format!("{:08.4}|{:04}", r.fraction, r.starts),
    )
}

/// (fraction, starts) of a [`tally_key`].
fn untally_key(key: &str) -> (String, String) {
    let (f, s) = key.split_once('|').unwrap_or(("", ""));
    (
        pct(f.parse().unwrap_or(f64::NAN)),
        s.trim_start_matches('0').to_string(),
    )
}

/// The per-configuration table: solver, fraction, starts, runs, the `head` columns
/// (`cols` of each tally), then the wall and CPU times.
fn tally_table(
    head: &str,
    tallies: &BTreeMap<(String, String), Tally>,
    cols: &dyn Fn(&Tally) -> Vec<String>,
) -> String {
    let n = head.matches('|').count();
    let mut out = format!(
        "| solver | fraction | starts | runs | {head} median wall | max wall | median CPU |\n\
         |---|---:|---:|---:|{}---:|---:|---:|\n",
        "---:|".repeat(n)
    );
    for ((solver, key), t) in tallies {
        let (f, s) = untally_key(key);
        let _ = writeln!(
            out,
            "| {solver} | {f} | {s} | {} | {} | {} | {} | {} |",
            t.runs,
            cols(t).join(" | "),
            secs(median(&t.wall)),
            secs(max(&t.wall)),
            secs(median(&t.cpu))
        );
    }
    out
}

fn grid_sections(rows: &[GridRow]) -> (String, String, String) {
    let mut summary = String::from(
        "| model | material | best cbrt loss | found by | cheapest within 1 % (+1e-4) of it | \
         LM, 100 %, 1 start | slowest run |\n|---|---|---:|---|---|---|---:|\n",
    );
    let mut fronts = String::new();
    let mut tallies: BTreeMap<(String, String), Tally> = BTreeMap::new();
    for ((model, material), rs) in &by_pair(rows) {
        let best = rs.iter().filter(|r| r.cbrt.is_finite()).min_by(|a, b| {
            a.cbrt
                .total_cmp(&b.cbrt)
                .then(a.wall_s.total_cmp(&b.wall_s))
        });
        let Some(best) = best else { continue };
        let bound = good_enough(best.cbrt);
        let cheapest = cheapest(rs, bound).expect("the best is within its own bound");
        let slowest = rs.iter().map(|r| r.wall_s).fold(0.0f64, f64::max);
        let _ = writeln!(
            summary,
            "| {model} | {material} | {} | {} ({}) | {} ({}, {}) | {} | {} |",
            loss(best.cbrt),
            conf(best),
            secs(best.wall_s),
            conf(cheapest),
            secs(cheapest.wall_s),
            loss(cheapest.cbrt),
            plain_lm(rs)
                .map(|d| format!("{}, {}", secs(d.wall_s), loss(d.cbrt)))
                .unwrap_or_else(|| "not in grid".into()),
            secs(slowest)
        );
        front_table(&mut fronts, &format!("{model} on {material}"), rs, None);
        for r in rs {
            let hit = r.cbrt <= bound;
            tallies
                .entry(tally_key(r))
                .or_default()
                .add(r, [hit, hit], f64::NAN);
        }
    }
    let solvers = tally_table(
        "reach the best (within 1 % + 1e-4) |",
        &tallies,
        &|t: &Tally| vec![t.share(0)],
    );
    (summary, solvers, fronts)
}

/// A loss relative to its baseline, signed, in percent.
pub fn excess(x: f64) -> String {
    if !x.is_finite() {
        "failed".into()
    } else if x.abs() < 5e-6 {
        "±0.000 %".into()
    } else {
        format!("{:+.3} %", 100.0 * x)
    }
}

/// The bounds of the measured tables: within 0.5 % and within 2 % of the baseline.
pub const MEASURED_BOUNDS: [f64; 2] = [0.005, 0.02];

/// `conf (time, excess)` of a row, or a dash.
fn conf_excess(r: Option<&GridRow>, baseline: f64) -> String {
    r.map(|r| {
        format!(
            "{} ({}, {})",
            conf(r),
            secs(r.wall_s),
            excess(r.cbrt / baseline - 1.0)
        )
    })
    .unwrap_or_else(|| "—".into())
}

/// The measured grid's summary (per model and material), its per-configuration table
/// and its Pareto fronts, every loss relative to the baseline of its material and
/// model ([`crate::grid::baselines`]).
fn measured_sections(res: &StudyResults) -> (String, String, String) {
    let rows = &res.measured_grid;
    let base = crate::grid::baselines(rows, &res.measured_references);
    let mut summary = String::from(
        "| model | material | baseline cbrt loss | best in grid | cheapest within 0.5 % | \
         cheapest within 2 % | fit-brdf default (LM, 8 starts) | LM · 100 % · 1× |\n\
         |---|---|---:|---|---|---|---|---|\n",
    );
    let mut fronts = String::new();
    let mut tallies: BTreeMap<(String, String), Tally> = BTreeMap::new();
    for ((model, material), rs) in &by_pair(rows) {
        let Some(b) = base.get(&(model.clone(), material.clone())) else {
            continue;
        };
        let bound = |x: f64| b.loss * (1.0 + x);
        let best = rs
            .iter()
            .filter(|r| r.cbrt.is_finite())
            .min_by(|x, y| {
                x.cbrt
                    .total_cmp(&y.cbrt)
                    .then(x.wall_s.total_cmp(&y.wall_s))
            })
            .copied();
        let default = rs.iter().find(|r| r.solver == CLI_DEFAULT).copied();
        let _ = writeln!(
            summary,
            "| {model} | {material} | {} ({}) | {} | {} | {} | {} | {} |",
            loss(b.loss),
            b.name(),
            conf_excess(best, b.loss),
            conf_excess(cheapest(rs, bound(MEASURED_BOUNDS[0])), b.loss),
            conf_excess(cheapest(rs, bound(MEASURED_BOUNDS[1])), b.loss),
            default
                .map(|d| format!("{}, {}", secs(d.wall_s), excess(d.cbrt / b.loss - 1.0)))
                .unwrap_or_else(|| "not run".into()),
            plain_lm(rs)
                .map(|d| format!("{}, {}", secs(d.wall_s), excess(d.cbrt / b.loss - 1.0)))
                .unwrap_or_else(|| "not in grid".into()),
        );
        front_table(
            &mut fronts,
            &format!(
                "{model} on {material}, baseline {} ({})",
                loss(b.loss),
                b.name()
            ),
            rs,
            Some(b.loss),
        );
        for r in rs {
            tallies.entry(tally_key(r)).or_default().add(
                r,
                MEASURED_BOUNDS.map(|x| r.cbrt <= bound(x)),
                r.cbrt / b.loss - 1.0,
            );
        }
    }
    let solvers = tally_table(
        "within 0.5 % | within 2 % | median excess | worst excess |",
        &tallies,
        &|t: &Tally| {
            vec![
                t.share(0),
                t.share(1),
                excess(median(&t.excess)),
                excess(max(&t.excess)),
            ]
        },
    );
    (summary, solvers, fronts)
}

/// What the grid was: materials, models, solvers, fractions, starts and caps.
fn grid_description(cfg: &StudyConfig, materials: &[String]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Grid `{}`: {} materials ({}), models {}, solvers {}, fractions {}, starts {:?}; \
         Nelder-Mead only up to {}.\n",
        cfg.grid_name,
        materials.len(),
        materials.join(", "),
        cfg.models
            .iter()
            .map(|m| m.label.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        cfg.solvers
            .iter()
            .map(|s| s.name())
            .collect::<Vec<_>>()
            .join(", "),
        cfg.fractions
            .iter()
            .map(|f| pct(*f))
            .collect::<Vec<_>>()
            .join(", "),
        cfg.starts,
        pct(cfg.nelder_mead_max_fraction)
    );
    let cap = |c: Option<u64>| {
        c.map(|n| n.to_string())
            .unwrap_or_else(|| "solver default".into())
    };
    let _ = writeln!(
        s,
        "Iteration caps per start and stage: {} (lm, gauss-newton, trust-region, lbfgs), {} \
         (nelder-mead); several starts only where {}.\n",
        cap(cfg.max_iters),
        cap(cfg.nelder_mead_max_iters),
        cfg.starts_budget
            .map(|b| format!("starts × fraction ≤ {b} (Nelder-Mead {})", b / 4.0))
            .unwrap_or_else(|| "everywhere".into())
    );
    s
}

/// The measured grid's run: its grid, the baselines, when, the load and the wall time.
fn measured_run_section(res: &StudyResults) -> String {
    let Some(info) = &res.measured_run else {
        return "Not run.".into();
    };
    let cfg = &info.config;
    let mut s = grid_description(cfg, &cfg.measured);
    let [h, d, p] = cfg.measured_dims;
    let base = crate::grid::baselines(&res.measured_grid, &res.measured_references);
    let refs: Vec<String> = base
        .iter()
        .filter(|(_, b)| b.is_reference)
        .map(|((m, mat), _)| format!("{m} on {mat}"))
        .collect();
    let _ = writeln!(
        s,
        "Proxies read from `{}` and resampled in memory onto {h} × {d} × {p} cells; one \
         more fit per material and model with `fit-brdf fit`'s defaults (`{CLI_DEFAULT}`: \
         LM, {} starts ranked on {} cells, the best finished, no grid cap).\n",
        cfg.measured_dir.display(),
        crate::grid::CLI_STARTS,
        brdfkit_fit::config::DEFAULT_EXPLORE_CELLS
    );
    let _ = writeln!(
        s,
        "Baselines: the exhaustive reference fit of `reference-fits.json` for {} ({}); \
         elsewhere the best cbrt loss any configuration of this grid reached for that \
         material and model (`best in grid`).\n",
        if refs.is_empty() {
            "no pair".to_string()
        } else {
            format!(
                "{} pair{}",
                refs.len(),
                if refs.len() == 1 { "" } else { "s" }
            )
        },
        if refs.is_empty() {
            "none applies".to_string()
        } else {
            refs.join(", ")
        }
    );
    let _ = writeln!(
        s,
        "Run started {} UTC on {} rayon threads; load average (1 min) {:.2} at the start, \
         {:.2} at the end. Wall time {} ({} fits, resampling included).",
        utc(info.started_unix),
        info.threads,
        info.load_start.unwrap_or(f64::NAN),
        info.load_end.unwrap_or(f64::NAN),
        info.grid_s.map(secs).unwrap_or_else(|| "—".into()),
        res.measured_grid.len()
    );
    s
}

/// `YYYY-MM-DD HH:MM` of a Unix time (civil-from-days, H. Hinnant's algorithm).
pub fn utc(t: u64) -> String {
    let days = (t / 86_400) as i64;
    let (h, m) = ((t % 86_400) / 3600, (t % 3600) / 60);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let mo = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(mo <= 2);
    format!("{y:04}-{mo:02}-{d:02} {h:02}:{m:02}")
}

fn run_section(cfg: &StudyConfig, info: &RunInfo, res: &StudyResults) -> String {
    let mut s = grid_description(cfg, &cfg.materials);
    let when = info.started_unix;
    let _ = writeln!(
        s,
        "Run started {} UTC on {} rayon threads; load average (1 min) {:.2} at the \
         start, {:.2} at the end. Wall time: grid {}, evaluation choices {}, scaling {} \
         ({} fits in the grid).",
        utc(when),
        info.threads,
        info.load_start.unwrap_or(f64::NAN),
        info.load_end.unwrap_or(f64::NAN),
        info.grid_s.map(secs).unwrap_or_else(|| "not run".into()),
        info.choices_s.map(secs).unwrap_or_else(|| "not run".into()),
        info.scale_s.map(secs).unwrap_or_else(|| "not run".into()),
        res.grid.len()
    );
    s
}

fn lookup_section(res: &StudyResults) -> String {
    let mut s = String::from(
        "| material | lookup | found | median rel. error | 90 % | 99 % | cbrt error | ns/lookup (1 thread) | ns/lookup (all threads) |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in &res.lookups {
        let _ = writeln!(
            s,
            "| {} | {} | {:.4} % | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.0} | {:.0} |",
            r.material,
            r.mode,
            r.found * 100.0,
            r.err.rel_median,
            r.err.rel_p90,
            r.err.rel_p99,
            r.err.cbrt_rms,
            r.ns_1_thread,
            r.ns_all_threads
        );
    }
    s
}

fn variant_section(res: &StudyResults) -> String {
    let mut s = String::from(
        "| choice | material | reference | variant | median rel. error | 99 % | max | cbrt error | ns/cell reference | ns/cell variant | time saved |\n\
         |---|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in &res.variants {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.1} | {:.1} | {:.0} % |",
            r.choice,
            r.material,
            r.reference,
            r.variant,
            r.err.rel_median,
            r.err.rel_p99,
            r.err.rel_max,
            r.err.cbrt_rms,
            r.ns_reference,
            r.ns_variant,
            100.0 * (1.0 - r.ns_variant / r.ns_reference)
        );
    }
    s
}

fn scale_section(res: &StudyResults) -> String {
    let Some(sc) = &res.scale else {
        return "Not run.".into();
    };
    let mut s = String::from(
        "| varies | cells | free params | threads | starts | wall (median) | cbrt loss |\n|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for p in &sc.points {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            p.axis,
            p.cells,
            p.params,
            p.threads,
            p.starts,
            secs(p.wall_s),
            loss(p.cbrt)
        );
    }
    s.push_str("\n| batch | tables | wall | tables/s | note |\n|---|---:|---:|---:|---|\n");
    for b in &sc.batch {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} | {} |",
            b.how,
            b.tables,
            secs(b.wall_s),
            b.tables_per_s,
            b.note
        );
    }
    s.push_str(
        "\nWhole-process figures (wall time and peak RSS of `fit-brdf batch`, `info` and \
         `fit` on these tables) are benchmarks: docs/performance.md, \"Whole-process time \
         and peak memory\" (`benches/peers/process_memory.py`).\n",
    );
    s
}

const SKELETON: &str = "# Accuracy vs time\n\n\
Generated by `fit-brdf study --out docs/accuracy-vs-time` (the tables between the `study:` \
markers and the PNGs are rewritten by each run; the text outside them is kept).\n";

/// One panel per material of a model's rows: every configuration's `y` against its
/// wall time, one colour per solver, the Pareto front as a black line, and `extra`
/// horizontal lines (label, y) across the panel.
fn pareto_panels(
    rows: &[GridRow],
    model: &str,
    materials: &[String],
    solvers: &[String],
    y: &dyn Fn(&GridRow) -> f64,
    extra: &[(&str, f64)],
) -> Vec<Panel> {
    let mut panels = Vec::new();
    for mat in materials {
        let rs: Vec<&GridRow> = rows
            .iter()
            .filter(|r| r.model == model && &r.material == mat)
            .collect();
        if rs.is_empty() {
            continue;
        }
        let mut series: Vec<Series> = solvers
            .iter()
            .enumerate()
            .map(|(i, s)| Series {
                name: s.clone(),
                points: rs
                    .iter()
                    .filter(|r| &r.solver == s)
                    .map(|r| (r.wall_s, y(r)))
                    .collect(),
                line: false,
                tag: false,
                color: i,
            })
            .filter(|s| !s.points.is_empty())
            .collect();
        series.push(Series {
            name: "Pareto front".into(),
            points: pareto(&rs)
                .into_iter()
                .map(|i| (rs[i].wall_s, y(rs[i])))
                .collect(),
            line: true,
            tag: false,
            color: 7,
        });
        let (t0, t1) = rs
            .iter()
            .map(|r| r.wall_s)
            .fold((f64::INFINITY, 0.0f64), |(a, b), t| (a.min(t), b.max(t)));
        for (k, (name, v)) in extra.iter().enumerate() {
            series.push(Series {
                name: name.to_string(),
                points: vec![(t0, *v), (t1, *v)],
                line: true,
                tag: false,
                color: 5 + k,
            });
        }
        panels.push(Panel {
            title: mat.clone(),
            series,
        });
    }
    panels
}

/// The log-log axes of the Pareto plots.
fn pareto_axes(y_label: &str) -> Axes {
    Axes {
        x_label: "wall time of the fit (s)".into(),
        y_label: y_label.into(),
        log_x: true,
        log_y: true,
    }
}

/// The measured grid's plots, one per model: each fit's excess over its baseline
/// against its wall time.
fn measured_plots(out: &std::path::Path, res: &StudyResults) -> Result<Vec<String>, StudyError> {
    let rows = &res.measured_grid;
    let base = crate::grid::baselines(rows, &res.measured_references);
    let mut models: Vec<String> = Vec::new();
    let mut materials: Vec<String> = Vec::new();
    let mut solvers: Vec<String> = Vec::new();
    for r in rows {
        for (v, x) in [
            (&mut models, &r.model),
            (&mut materials, &r.material),
            (&mut solvers, &r.solver),
        ] {
            if !v.contains(x) {
                v.push(x.clone());
            }
        }
    }
    // Fits at or below the baseline sit on the floor of the log axis.
    let y = |r: &GridRow| {
        base.get(&(r.model.clone(), r.material.clone()))
            .map_or(f64::NAN, |b| (r.cbrt / b.loss - 1.0).max(1e-5))
    };
    let mut made = Vec::new();
    for model in &models {
        let panels = pareto_panels(
            rows,
            model,
            &materials,
            &solvers,
            &y,
            &[("0.5 %", MEASURED_BOUNDS[0]), ("2 %", MEASURED_BOUNDS[1])],
        );
        let name = format!("pareto-measured-{model}.png");
        figure(
            &out.join(&name),
            &format!(
                "{model} on measured proxies: cbrt loss / baseline - 1 vs wall time (floor 1e-5)"
            ),
            &panels,
            &pareto_axes("excess over the baseline"),
            3,
            (460, 360),
        )?;
        made.push(name);
    }
    Ok(made)
}

fn plots(cfg: &StudyConfig, res: &StudyResults) -> Result<Vec<String>, StudyError> {
    let mut made = Vec::new();
    let solvers: Vec<String> = cfg.solvers.iter().map(|s| s.name().to_string()).collect();
    for mc in &cfg.models {
        // Exact fits reach ~1e-17: floor so the log axis stays readable.
        let panels = pareto_panels(
            &res.grid,
            &mc.label,
            &cfg.materials,
            &solvers,
            &|r: &GridRow| r.cbrt.max(1e-16),
            &[],
        );
        if panels.is_empty() {
            continue;
        }
        let name = format!("pareto-{}.png", mc.label);
        figure(
            &cfg.out.join(&name),
            &format!(
                "{}: full-table cbrt loss vs wall time (every solver x fraction x starts)",
                mc.label
            ),
            &panels,
            &pareto_axes("cbrt loss, full table"),
            3,
            (460, 360),
        )?;
        made.push(name);
    }
    if !res.lookups.is_empty() || !res.variants.is_empty() {
        let mut lk: Vec<Series> = Vec::new();
        for (i, mode) in ["nearest", "interpolated"].iter().enumerate() {
            lk.push(Series {
                name: mode.to_string(),
                points: res
                    .lookups
                    .iter()
                    .filter(|r| &r.mode == mode)
                    .map(|r| (r.ns_1_thread, r.err.cbrt_rms.max(1e-16)))
                    .collect(),
                line: false,
                tag: false,
                color: i,
            });
        }
        let mut vs: Vec<Series> = Vec::new();
        for (i, r) in res.variants.iter().enumerate() {
            vs.push(Series {
                name: format!("{} ({})", r.variant, r.material),
                points: vec![(r.ns_variant / r.ns_reference, r.err.cbrt_rms.max(1e-16))],
                line: false,
                tag: true,
                color: i,
            });
        }
        let name = "choices.png".to_string();
        figure(
            &cfg.out.join(&name),
            "Evaluation choices: error introduced vs time",
            &[
                Panel {
                    title: "table lookup (x: ns per lookup, 1 thread)".into(),
                    series: lk,
                },
                Panel {
                    title: "model variants (x: time / reference time)".into(),
                    series: vs,
                },
            ],
            &Axes {
                x_label: "time".into(),
                y_label: "cbrt error vs truth / reference".into(),
                log_x: false,
                log_y: true,
            },
            2,
            (620, 460),
        )?;
        made.push(name);
    }
    if let Some(sc) = &res.scale {
        let pts = |axis: &str| -> Vec<(f64, f64)> {
            sc.points
                .iter()
                .filter(|p| p.axis == axis)
                .map(|p| (if axis == "cells" { p.cells as f64 } else { p.x }, p.wall_s))
                .collect()
        };
        let threads = |starts: usize| -> Vec<(f64, f64)> {
            sc.points
                .iter()
                .filter(|p| p.axis == "threads" && p.starts == starts)
                .map(|p| (p.x, p.wall_s))
                .collect()
        };
        let name = "scale.png".to_string();
        let line = |n: &str, p: Vec<(f64, f64)>, c: usize| Series {
            name: n.into(),
            points: p,
            line: true,
            tag: false,
            color: c,
        };
        figure(
            &cfg.out.join(&name),
            "Fit time (Cook-Torrance, LM, 1 start unless said) against cells, parameters, threads",
            &[
                Panel {
                    title: "x: valid cells fitted".into(),
                    series: vec![line("wall time (s)", pts("cells"), 0)],
                },
                Panel {
                    title: "x: free parameters (Lambert + 1..3 lobes)".into(),
                    series: vec![line("wall time (s)", pts("params"), 1)],
                },
                Panel {
                    title: "x: threads".into(),
                    series: vec![
                        line("1 start", threads(1), 2),
                        line("4 starts", threads(4), 3),
                    ],
                },
            ],
            &Axes {
                x_label: "".into(),
                y_label: "wall time (s)".into(),
                log_x: false,
                log_y: false,
            },
            3,
            (460, 360),
        )?;
        made.push(name);
    }
    Ok(made)
}

/// Writes the plots and updates the report.
pub fn write_all(
    cfg: &StudyConfig,
    info: &RunInfo,
    res: &StudyResults,
    progress: &dyn Observe,
) -> Result<(), StudyError> {
    let mut made = plots(cfg, res)?;
    made.extend(measured_plots(&cfg.out, res)?);
    progress.observe(&Event::Step(format!("plots: {}", made.join(", "))));
    if let Some(sc) = &res.scale {
        write_json(&cfg.out.join("scale.json"), sc)?;
    }
    let path = cfg.report_path();
    let mut doc = match std::fs::read_to_string(&path) {
        Ok(s) => s,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => SKELETON.to_string(),
        Err(e) => return Err(StudyError::io(&path, e)),
    };
    let dir = cfg
        .out
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    if !cfg.materials.is_empty() {
        doc = replace_section(&doc, "run", &run_section(cfg, info, res));
    }
    if !res.grid.is_empty() {
        let (summary, solvers, fronts) = grid_sections(&res.grid);
        let imgs: String = cfg
            .models
            .iter()
            .filter(|m| made.contains(&format!("pareto-{}.png", m.label)))
            .map(|m| format!("![{0}](./{dir}/pareto-{0}.png)\n", m.label))
            .collect();
        doc = replace_section(&doc, "grid-summary", &summary);
        doc = replace_section(&doc, "grid-solvers", &solvers);
        doc = replace_section(&doc, "grid-plots", &imgs);
        doc = replace_section(&doc, "grid-fronts", &fronts);
    }
    if !res.measured_grid.is_empty() {
        let (summary, solvers, fronts) = measured_sections(res);
        let imgs: String = made
            .iter()
            .filter(|n| n.starts_with("pareto-measured-"))
            .map(|n| {
                let model = n
                    .trim_start_matches("pareto-measured-")
                    .trim_end_matches(".png");
                format!("![{model} on measured proxies](./{dir}/{n})\n")
            })
            .collect();
        doc = replace_section(&doc, "measured-run", &measured_run_section(res));
        doc = replace_section(&doc, "measured-summary", &summary);
        doc = replace_section(&doc, "measured-solvers", &solvers);
        doc = replace_section(&doc, "measured-plots", &imgs);
        doc = replace_section(&doc, "measured-fronts", &fronts);
    }
    if !res.lookups.is_empty() || !res.variants.is_empty() {
        doc = replace_section(&doc, "lookups", &lookup_section(res));
        doc = replace_section(&doc, "variants", &variant_section(res));
        doc = replace_section(
            &doc,
            "choices-plot",
            &format!("![choices](./{dir}/choices.png)"),
        );
    }
    if res.scale.is_some() {
        doc = replace_section(&doc, "scale", &scale_section(res));
        doc = replace_section(&doc, "scale-plot", &format!("![scale](./{dir}/scale.png)"));
    }
    write(&path, doc.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_are_replaced_in_place_and_appended_when_absent() {
        let doc = "# T\n\nintro\n<!-- study:a -->\nold\n<!-- /study:a -->\n\nreading\n";
        let d = replace_section(doc, "a", "new");
        assert_eq!(
            d,
            "# T\n\nintro\n<!-- study:a -->\nnew\n<!-- /study:a -->\n\nreading\n"
        );
        let d = replace_section(&d, "b", "bb");
        assert!(d.ends_with("reading\n<!-- study:b -->\nbb\n<!-- /study:b -->\n"));
        // Idempotent.
        assert_eq!(replace_section(&d, "b", "bb"), d);
    }

    #[test]
    fn utc_dates() {
        assert_eq!(utc(0), "1970-01-01 00:00");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00");
        assert_eq!(utc(1_795_298_974), "2026-11-21 22:09");
    }
}
