//! The study's Markdown document (`docs/accuracy-vs-time.md`) and its PNG plots.
//!
//! The report's generated parts sit between `<!-- study:NAME -->` and
//! `<!-- /study:NAME -->`; a re-run replaces only those, so the hand-written reading of
//! the results around them stays. A report that does not exist yet is created from a
//! skeleton.

use crate::files::{write, write_json};
use crate::grid::{GridRow, pareto};
use crate::plot::{Axes, Panel, Series, figure};
use crate::{RunInfo, StudyConfig, StudyError, StudyResults};
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

fn grid_sections(cfg: &StudyConfig, rows: &[GridRow]) -> (String, String, String) {
    // (material, model) → rows
    let mut by: BTreeMap<(String, String), Vec<&GridRow>> = BTreeMap::new();
    for r in rows {
        by.entry((r.model.clone(), r.material.clone()))
            .or_default()
            .push(r);
    }
    let mut summary = String::from(
        "| model | material | best cbrt loss | found by | cheapest within 1 % (+1e-4) of it | \
         LM, 100 %, 1 start | slowest run |\n|---|---|---:|---|---|---|---:|\n",
    );
    let mut fronts = String::new();
    type Tally = (usize, usize, Vec<f64>, Vec<f64>);
    let mut good_count: BTreeMap<(String, String), Tally> = BTreeMap::new();
    for ((model, material), rs) in &by {
        let best = rs.iter().filter(|r| r.cbrt.is_finite()).min_by(|a, b| {
            a.cbrt
                .total_cmp(&b.cbrt)
                .then(a.wall_s.total_cmp(&b.wall_s))
        });
        let Some(best) = best else { continue };
        let bound = good_enough(best.cbrt);
        let cheapest = rs
            .iter()
            .filter(|r| r.cbrt <= bound)
            .min_by(|a, b| a.wall_s.total_cmp(&b.wall_s))
            .expect("the best is within its own bound");
        let default = rs
            .iter()
            .find(|r| r.solver == "lm" && r.fraction == 1.0 && r.starts == 1);
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
            default
                .map(|d| format!("{}, {}", secs(d.wall_s), loss(d.cbrt)))
                .unwrap_or_else(|| "not in grid".into()),
            secs(slowest)
        );
        let front = pareto(rs);
        let _ = writeln!(
            fronts,
            "\n**{model} on {material}** ({} fits; Pareto front, fastest first):\n\n\
             | solver · fraction · starts | wall | CPU | cbrt | l2 | cosine | log |\n|---|---:|---:|---:|---:|---:|---:|",
            rs.len()
        );
        for &i in &front {
            let r = rs[i];
            let _ = writeln!(
                fronts,
                "| {} | {} | {} | {} | {} | {} | {} |",
                conf(r),
                secs(r.wall_s),
                secs(r.cpu_s),
                loss(r.cbrt),
                loss(r.l2),
                loss(r.cosine),
                loss(r.log)
            );
        }
        for r in rs {
            let e = good_count
                .entry((
                    r.solver.clone(),
                    format!("{:08.4}|{:04}", r.fraction, r.starts),
                ))
                .or_insert((0, 0, Vec::new(), Vec::new()));
            e.1 += 1;
            if r.cbrt <= bound {
                e.0 += 1;
            }
            e.2.push(r.wall_s);
            e.3.push(r.cpu_s);
        }
    }
    let mut solvers = String::from(
        "| solver | fraction | starts | runs | reach the best (within 1 % + 1e-4) | median wall | max wall | median CPU |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for ((solver, key), (good, n, mut t, mut c)) in good_count {
        c.sort_by(|a, b| a.total_cmp(b));
        let (f, s) = key.split_once('|').unwrap_or(("", ""));
        let f: f64 = f.parse().unwrap_or(f64::NAN);
        let s = s.trim_start_matches('0');
        t.sort_by(|a, b| a.total_cmp(b));
        let _ = writeln!(
            solvers,
            "| {solver} | {} | {s} | {n} | {good} ({:.0} %) | {} | {} | {} |",
            pct(f),
            100.0 * good as f64 / n as f64,
            secs(t[t.len() / 2]),
            secs(*t.last().unwrap_or(&f64::NAN)),
            secs(c[c.len() / 2])
        );
    }
    let _ = cfg;
    (summary, solvers, fronts)
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
    let mut s = String::new();
    let when = info.started_unix;
    let _ = writeln!(
        s,
        "Grid `{}`: {} materials ({}), models {}, solvers {}, fractions {}, starts {:?}; \
         Nelder-Mead only up to {}.\n",
        cfg.grid_name,
        cfg.materials.len(),
        cfg.materials.join(", "),
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
        "\n| child process (`fit-brdf …`) | peak RSS | wall | exit |\n|---|---:|---:|---:|\n",
    );
    for m in &sc.memory {
        let _ = writeln!(
            s,
            "| `{}` | {:.0} MB | {} | {} |",
            m.command,
            m.peak_rss_mb,
            secs(m.wall_s),
            m.status
        );
    }
    if sc.memory.is_empty() {
        s.push_str("| (no `fit-brdf` executable given: not measured) | | | |\n");
    }
    s
}

const SKELETON: &str = "# Accuracy vs time\n\n\
Generated by `fit-brdf study --out docs/accuracy-vs-time` (the tables between the `study:` \
markers and the PNGs are rewritten by each run; the text outside them is kept).\n";

fn plots(cfg: &StudyConfig, res: &StudyResults) -> Result<Vec<String>, StudyError> {
    let mut made = Vec::new();
    let solvers: Vec<String> = cfg.solvers.iter().map(|s| s.name().to_string()).collect();
    for mc in &cfg.models {
        let mut panels = Vec::new();
        for mat in &cfg.materials {
            let rs: Vec<&GridRow> = res
                .grid
                .iter()
                .filter(|r| r.model == mc.label && &r.material == mat)
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
                        // Exact fits reach ~1e-17: floor so the log axis stays readable.
                        .map(|r| (r.wall_s, r.cbrt.max(1e-16)))
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
                    .map(|i| (rs[i].wall_s, rs[i].cbrt.max(1e-16)))
                    .collect(),
                line: true,
                tag: false,
                color: 7,
            });
            panels.push(Panel {
                title: mat.clone(),
                series,
            });
        }
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
            &Axes {
                x_label: "wall time of the fit (s)".into(),
                y_label: "cbrt loss, full table".into(),
                log_x: true,
                log_y: true,
            },
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
    progress: &dyn Fn(&str),
) -> Result<(), StudyError> {
    let made = plots(cfg, res)?;
    progress(&format!("plots: {}", made.join(", ")));
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
    doc = replace_section(&doc, "run", &run_section(cfg, info, res));
    if !res.grid.is_empty() {
        let (summary, solvers, fronts) = grid_sections(cfg, &res.grid);
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
