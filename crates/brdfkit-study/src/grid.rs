//! The fit grid: model × solver × sample fraction × starts on every material, with the
//! wall time and every loss on the full table, and the Pareto front of loss against
//! time.

use crate::{StudyConfig, StudyError, SynthMaterial};
use brdfkit_fit::{FitConfig, FitData, Loss, SolverKind, fit};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// One fit of the grid.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct GridRow {
    /// Spec name of the material.
    pub material: String,
    /// Label of the model family.
    pub model: String,
    /// Solver name.
    pub solver: String,
    /// Sample fraction of the valid cells the solver saw (1 = all).
    pub fraction: f64,
    /// Number of starts.
    pub starts: usize,
    /// Cells the solver saw.
    pub cells_fit: usize,
    /// Wall time of the `fit` call (subsampling, warm-up, starts, loss report), s.
    pub wall_s: f64,
    /// CPU time of the call, all threads, s (load-insensitive; ≈ 2 × wall on an idle
    /// 2-core machine when both threads are busy).
    pub cpu_s: f64,
    /// Overall losses on the full table (all valid cells).
    pub cbrt: f64,
    /// The `l2` loss on the full table.
    pub l2: f64,
    /// The `cosine` loss on the full table.
    pub cosine: f64,
    /// The `log` loss on the full table.
    pub log: f64,
    /// Iterations of the kept start.
    pub iterations: u64,
    /// Passes over the fitted cells without / with derivatives, all starts.
    pub cost_evals: u64,
    /// Passes with derivatives, all starts.
    pub jacobian_evals: u64,
    /// Whether the kept start met a convergence test.
    pub converged: bool,
    /// Why the kept start stopped, or the error of a failed fit (losses NaN then).
    pub termination: String,
}

/// The configurations of the grid, in run order: Nelder-Mead only on fractions up to
/// `nelder_mead_max_fraction`.
pub fn configurations(cfg: &StudyConfig) -> Vec<(SolverKind, f64, usize)> {
    let mut v = Vec::new();
    for &s in &cfg.solvers {
        for &f in &cfg.fractions {
            if s == SolverKind::NelderMead && f > cfg.nelder_mead_max_fraction {
                continue;
            }
            for &n in &cfg.starts {
                let budget = cfg.starts_budget.map(|b| {
                    if s == SolverKind::NelderMead {
                        b / 4.0
                    } else {
                        b
                    }
                });
                // A small tolerance: 4 × 10 % is 0.4 in decimal but not in binary.
                if n > 1 && budget.is_some_and(|b| n as f64 * f > b * (1.0 + 1e-9)) {
                    continue;
                }
                v.push((s, f, n));
            }
        }
    }
    v
}

/// Fits one configuration and records it (a failed fit is a row with NaN losses).
pub fn fit_one(
    cfg: &StudyConfig,
    material: &str,
    model_label: &str,
    start: &dyn brdfkit_core::Model,
    data: &FitData,
    (solver, fraction, starts): (SolverKind, f64, usize),
) -> Result<GridRow, StudyError> {
    let what = format!("{material}/{model_label}/{}", solver.name());
    let err = |source| StudyError::Fit {
        what: what.clone(),
        source,
    };
    let mut fc = FitConfig::default()
        .solver(solver)
        .starts(starts)
        .map_err(err)?
        .seed(0);
    if fraction < 1.0 {
        fc = fc.subsample(fraction, 1).map_err(err)?;
    }
    if let Some(t) = cfg.theta_max_deg {
        fc = fc.theta_max_deg(t).map_err(err)?;
    }
    let cap = if solver == SolverKind::NelderMead {
        cfg.nelder_mead_max_iters
    } else {
        cfg.max_iters
    };
    if let Some(n) = cap {
        fc = fc.max_iters(n).map_err(err)?;
    }
    let c0 = crate::cpu_seconds();
    let t = Instant::now();
    let out = fit(start, data, &fc, None);
    let wall_s = t.elapsed().as_secs_f64();
    let cpu_s = crate::cpu_seconds() - c0;
    let mut row = GridRow {
        material: material.into(),
        model: model_label.into(),
        solver: solver.name().into(),
        fraction,
        starts,
        cells_fit: 0,
        wall_s,
        cpu_s,
        cbrt: f64::NAN,
        l2: f64::NAN,
        cosine: f64::NAN,
        log: f64::NAN,
        iterations: 0,
        cost_evals: 0,
        jacobian_evals: 0,
        converged: false,
        termination: String::new(),
    };
    match out {
        Ok(o) => {
            let r = &o.record;
            let l = &r.losses_full;
            row.cells_fit = r.cells_fit;
            row.cbrt = l.get(Loss::Cbrt).overall;
            row.l2 = l.get(Loss::L2).overall;
            row.cosine = l.get(Loss::Cosine).overall;
            row.log = l.get(Loss::Log).overall;
            row.iterations = r.iterations;
            row.cost_evals = r.cost_evals;
            row.jacobian_evals = r.jacobian_evals;
            row.converged = r.converged;
            row.termination = r.termination.clone();
        }
        Err(e) => row.termination = format!("error: {e}"),
    }
    Ok(row)
}

/// Runs the whole grid.
pub fn run_grid(
    cfg: &StudyConfig,
    materials: &[SynthMaterial],
    progress: &dyn Fn(&str),
) -> Result<Vec<GridRow>, StudyError> {
    let confs = configurations(cfg);
    let total = confs.len() * cfg.models.len() * materials.len();
    let partial = cfg.out.join("grid-partial.json");
    let mut rows: Vec<GridRow> = if cfg.resume {
        std::fs::read_to_string(&partial)
            .ok()
            .and_then(|s| serde_json::from_str(&s).ok())
            .unwrap_or_default()
    } else {
        Vec::new()
    };
    let key = |m: &str, l: &str, s: &str, f: f64, n: usize| format!("{m}|{l}|{s}|{f}|{n}");
    let done: std::collections::HashSet<String> = rows
        .iter()
        .map(|r| key(&r.material, &r.model, &r.solver, r.fraction, r.starts))
        .collect();
    let t0 = Instant::now();
    // Model-major: a stopped run has every material of the first models.
    for mc in &cfg.models {
        for m in materials {
            let data = FitData::from_table(&m.table).map_err(|source| StudyError::Fit {
                what: m.spec.name.clone(),
                source,
            })?;
            let start = brdfkit_models::from_json(&mc.start).map_err(|e| StudyError::Model {
                what: mc.label.clone(),
                msg: e.to_string(),
            })?;
            for &c in &confs {
                if done.contains(&key(&m.spec.name, &mc.label, c.0.name(), c.1, c.2)) {
                    continue;
                }
                let row = fit_one(cfg, &m.spec.name, &mc.label, start.as_ref(), &data, c)?;
                rows.push(row);
                let r = rows.last().expect("just pushed");
                progress(&format!(
                    "grid {}/{} ({:.0} s): {} {} {} {:.3} % x{}: {:.3} s (cpu {:.3} s), cbrt {:.4e}",
                    rows.len(),
                    total,
                    t0.elapsed().as_secs_f64(),
                    r.material,
                    r.model,
                    r.solver,
                    r.fraction * 100.0,
                    r.starts,
                    r.wall_s,
                    r.cpu_s,
                    r.cbrt
                ));
            }
            // Saved after every model and material, so a stopped run can resume.
            crate::files::write_json(&partial, &rows)?;
        }
    }
    Ok(rows)
}

/// Indices of the Pareto-optimal rows among `rows` by (wall time, cbrt loss): no other
/// row is at least as fast and strictly better, or faster and at least as good. Rows
/// with a NaN loss are never on the front. Returned in increasing time.
pub fn pareto(rows: &[&GridRow]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].cbrt.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        rows[a]
            .wall_s
            .total_cmp(&rows[b].wall_s)
            .then(rows[a].cbrt.total_cmp(&rows[b].cbrt))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if rows[i].cbrt < best {
            best = rows[i].cbrt;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, l: f64) -> GridRow {
        GridRow {
            material: "m".into(),
            model: "x".into(),
            solver: "lm".into(),
            fraction: 1.0,
            starts: 1,
            cells_fit: 1,
            wall_s: t,
            cpu_s: t,
            cbrt: l,
            l2: l,
            cosine: l,
            log: l,
            iterations: 0,
            cost_evals: 0,
            jacobian_evals: 0,
            converged: true,
            termination: String::new(),
        }
    }

    #[test]
    fn pareto_keeps_only_undominated_points() {
        let rows = [
            row(1.0, 0.5),
            row(2.0, 0.6), // dominated by the first
            row(3.0, 0.1),
            row(0.5, 0.9),
            row(4.0, 0.1),      // as good as a faster one: dominated
            row(0.1, f64::NAN), // failed fit
        ];
        let refs: Vec<&GridRow> = rows.iter().collect();
        assert_eq!(pareto(&refs), vec![3, 0, 2]);
    }

    #[test]
    fn nelder_mead_is_limited_to_small_fractions() {
        let mut c = StudyConfig::quick("x", "y");
        c.solvers = vec![SolverKind::NelderMead, SolverKind::Lm];
        c.fractions = vec![0.005, 0.02, 0.5];
        c.starts = vec![1];
        c.starts_budget = None;
        let confs = configurations(&c);
        assert_eq!(confs.len(), 2 + 3);
        assert!(
            confs
                .iter()
                .all(|(s, f, _)| *s != SolverKind::NelderMead || *f <= 0.02)
        );
    }
}
