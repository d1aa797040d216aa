//! The figures behind the report's charts: θh slices, residual maps and albedo curves,
//! computed over the table's own cells (the cells a fit sees).

use crate::physical::{
    PhysicalReport, PoleChoice, auto_pole, converged_with, model_albedo_converged,
};
use crate::table::{table_albedo, table_brdf};
#[cfg(test)]
use brdfkit_core::GeometryBatch;
use brdfkit_core::direction::spherical;
use brdfkit_core::rusinkiewicz::from_half_diff;
use brdfkit_core::{Model, Rgb};
#[cfg(test)]
use brdfkit_fit::FitData;
use brdfkit_fit::Fitted;
use brdfkit_merl::{Lookup, MerlTable};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The fitted model's value at cell (i, j, k): channel c from the channel-c model,
/// evaluated at the cell's angles (the lower edges of its bin, where the fitter
/// evaluates it too).
pub(crate) fn model_at_cell(
    fitted: &Fitted,
    table: &MerlTable,
    i: usize,
    j: usize,
    k: usize,
) -> Rgb {
    let (wi, wo) = from_half_diff(&table.dims().cell_angles(i, j, k));
    match fitted {
        Fitted::Shared(m) => m.eval(&wi, &wo),
        Fitted::PerChannel(ms) => Rgb([
            ms[0].eval(&wi, &wo)[0],
            ms[1].eval(&wi, &wo)[1],
            ms[2].eval(&wi, &wo)[2],
        ]),
    }
}

/// One θh slice of the table at fixed (θd, φd): the table's cells and each model at
/// them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Slice {
    /// θd of the slice's cells (radians): the lower edge of the bin nearest the
    /// requested angle.
    pub theta_d: f64,
    /// φd of the slice's cells (radians).
    pub phi_d: f64,
    /// θh bin indices i of the valid cells (θh = (i/n)² π/2).
    pub theta_h_index: Vec<usize>,
    /// θh (radians) of those cells.
    pub theta_h: Vec<f64>,
    /// The table's values there.
    pub measured: Vec<Rgb>,
    /// Each model's values there (outer: model, inner: cell).
    pub models: Vec<Vec<Rgb>>,
}

/// The θh slices at the requested θd (radians) and φd (radians), at the nearest cells.
pub(crate) fn slices(
    table: &MerlTable,
    fits: &[&Fitted],
    theta_ds: &[f64],
    phi_d: f64,
) -> Vec<Slice> {
    let d = table.dims();
    let (nh, nd, np) = (d.theta_h(), d.theta_d(), d.phi_d());
    // Nearest bin edge, clamped into the grid (an angle of 90° has no bin of its own).
    let k = ((phi_d / std::f64::consts::PI * np as f64).round() as usize).min(np - 1);
    theta_ds
        .iter()
        .map(|&td| {
            let j = ((td / std::f64::consts::FRAC_PI_2 * nd as f64).round() as usize).min(nd - 1);
            let a = d.cell_angles(0, j, k);
            let mut s = Slice {
                theta_d: a.theta_d,
                phi_d: a.phi_d,
                theta_h_index: Vec::new(),
                theta_h: Vec::new(),
                measured: Vec::new(),
                models: vec![Vec::new(); fits.len()],
            };
            for i in 0..nh {
                if let Some(v) = table.get(i, j, k) {
                    s.theta_h_index.push(i);
                    s.theta_h.push(d.cell_angles(i, j, k).theta_h);
                    s.measured.push(v);
                    for (m, f) in fits.iter().enumerate() {
                        s.models[m].push(model_at_cell(f, table, i, j, k));
                    }
                }
            }
            s
        })
        .collect()
}

/// A model's signed log ratio over (θh, θd), averaged over φd and the channels, on
/// blocks of the table's grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResidualMap {
    /// Blocks along θh and θd.
    pub cols: usize,
    /// Blocks along θd.
    pub rows: usize,
    /// θh bins per block and θd bins per block.
    pub block: [usize; 2],
    /// The table's θh and θd bin counts.
    pub bins: [usize; 2],
    /// Row-major (θd row, θh column): the mean of log10(f_model / f_measured) over the
    /// block's cell channels with a positive measurement; `None` where there is none.
    pub values: Vec<Option<f64>>,
    /// Cell channels where the model is exactly 0 and the table is not (their log ratio
    /// is −∞; they enter the mean at [`LOG_RATIO_FLOOR`]).
    pub model_zero: usize,
}

/// Floor of a cell channel's log10 ratio: a model value of exactly 0 against a positive
/// measurement has an infinite log ratio, which would make its block's mean −∞ and hide
/// every other cell in it; −6 (a factor of a million) is far beyond any colour scale.
pub const LOG_RATIO_FLOOR: f64 = -6.0;

/// One (θh, θd) row of the table's cells in a residual map: the sum of the log ratios
/// of its cell channels with a positive measurement, their count, and the model zeros
/// among them, each cell added in φd order ([`add_residual_cell`]).
pub(crate) type RowSums = (f64, usize, usize);

/// Adds one cell to its row's [`RowSums`]: the model's value `model` against the
/// measured `meas`, channel by channel, each channel with a positive measurement
/// entering as log10(f_model / f_measured), floored at [`LOG_RATIO_FLOOR`] (a model 0
/// counted in the zeros and entered at the floor).
#[inline]
pub(crate) fn add_residual_cell(a: &mut RowSums, model: &Rgb, meas: [f64; 3]) {
    for c in 0..3 {
        if meas[c] > 0.0 {
            let r = if model[c] > 0.0 {
                (model[c] / meas[c]).log10().max(LOG_RATIO_FLOOR)
            } else {
                a.2 += 1;
                LOG_RATIO_FLOOR
            };
            a.0 += r;
            a.1 += 1;
        }
    }
}

/// The residual map of a table of `bins` = [θh, θd] bins from its rows' sums (`rows`,
/// row-major: θh slowest, `bins[0] · bins[1]` entries), on blocks of at most
/// `max_bins` × `max_bins`: each block's mean is its rows' sums added θh row by θh row,
/// θd by θd inside each.
pub(crate) fn residual_map_of_rows(
    rows: &[RowSums],
    bins: [usize; 2],
    max_bins: usize,
) -> ResidualMap {
    let [nh, nd] = bins;
    let max_bins = max_bins.max(1);
    let bh = nh.div_ceil(max_bins);
    let bd = nd.div_ceil(max_bins);
    let (cols, rows_out) = (nh.div_ceil(bh), nd.div_ceil(bd));
    let mut values = vec![None; cols * rows_out];
    let mut model_zero = 0;
    for r in 0..rows_out {
        for c in 0..cols {
            let (mut s, mut n) = (0.0, 0usize);
            for i in c * bh..((c + 1) * bh).min(nh) {
                for cell in &rows[i * nd + r * bd..i * nd + ((r + 1) * bd).min(nd)] {
                    s += cell.0;
                    n += cell.1;
                    model_zero += cell.2;
                }
            }
            values[r * cols + c] = (n > 0).then(|| s / n as f64);
        }
    }
    ResidualMap {
        cols,
        rows: rows_out,
        block: [bh, bd],
        bins: [nh, nd],
        values,
        model_zero,
    }
}

/// The residual map of `fitted` against `table`, on blocks of at most `max_bins` ×
/// `max_bins`, by its own evaluation of the model: the reference of the report's maps,
/// which the quality pass computes from the values it evaluates anyway
/// ([`crate::quality`]'s `fit_quality_and_maps`). `data` holds the table's cells
/// ([`FitData::from_table`]), evaluated a θh slab at a time.
#[cfg(test)]
pub(crate) fn residual_map(
    table: &MerlTable,
    data: &FitData,
    fitted: &Fitted,
    max_bins: usize,
) -> ResidualMap {
    let d = table.dims();
    let (nh, nd, np) = (d.theta_h(), d.theta_d(), d.phi_d());
    let slab = nd * np;
    let mask = table.valid_mask();
    // The cells are the valid ones in file order (θh slowest): slab i's are a run.
    let mut start = 0;
    let runs: Vec<(usize, usize)> = mask
        .chunks(slab)
        .map(|s| {
            let n = s.iter().filter(|v| **v).count();
            start += n;
            (start - n, n)
        })
        .collect();
    debug_assert_eq!(start, data.len());
    let models = [0, 1, 2].map(|c| fitted.channel_model(c));
    let same = matches!(fitted, Fitted::Shared(_));
    let vals = data.values();
    let mut rows: Vec<RowSums> = Vec::with_capacity(nh * nd);
    for (i, (s, n)) in runs.into_iter().enumerate() {
        // The model at the slab's cells: channel c from the channel-c model.
        let mut f = vec![Rgb::ZERO; n];
        let mut tmp = if same { Vec::new() } else { vec![Rgb::ZERO; n] };
        let mut scratch = GeometryBatch::default();
        let gs = data.geometry_of(s..s + n, &mut scratch);
        models[0].eval_batch(&gs, &mut f);
        if !same {
            for c in 1..3 {
                models[c].eval_batch(&gs, &mut tmp);
                for (a, b) in f.iter_mut().zip(&tmp) {
                    a[c] = b[c];
                }
            }
        }
        let mut acc = vec![(0.0, 0, 0); nd];
        let cells = mask[i * slab..(i + 1) * slab]
            .iter()
            .enumerate()
            .filter(|(_, v)| **v);
        for (q, (x, _)) in cells.enumerate() {
            let meas = [0, 1, 2].map(|c| vals[c][s + q]);
            add_residual_cell(&mut acc[x / np], &f[q], meas);
        }
        rows.extend(acc);
    }
    residual_map_of_rows(&rows, [nh, nd], max_bins)
}

/// The directional albedo a(θo) = ∫ f(wi, wo) cos θi dωi (φo = 0) of the table and
/// the models, by the quadratures of the physical and table checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlbedoCurves {
    /// θo (radians).
    pub theta_o: Vec<f64>,
    /// The table's albedo (interpolated lookups, missing ones filled with the mean);
    /// `None` where no lookup found a sample.
    pub table: Vec<Option<Rgb>>,
    /// Fraction of the cosine-weighted hemisphere whose table lookups were missing.
    pub table_missing_weight: Vec<f64>,
    /// Each model's albedo (outer: model).
    pub models: Vec<Vec<Rgb>>,
}

/// The report's tolerance of a model's albedo
/// ([`crate::physical::albedo_converged`]'s `good_enough`).
const MODEL_ALBEDO_GOOD_ENOUGH: f64 = 1e-6;

fn model_albedo(m: &dyn Model, theta_o: f64) -> Rgb {
    model_albedo_converged(
        m,
        &spherical(theta_o, 0.0),
        PoleChoice::Auto,
        MODEL_ALBEDO_GOOD_ENOUGH,
        false,
    )
    .0
}

/// The albedo at `theta_o` (φ = 0) that a physical check's energy curve already holds,
/// when it is what [`model_albedo`] would compute to the bit: the same direction, the
/// automatic pole, and a kept pole converged to [`MODEL_ALBEDO_GOOD_ENOUGH`]. The check
/// stops its pole search at its own tolerance (1e-2 × the convergence threshold,
/// 1.0000000000000002e-6 by default); with the kept estimate at or below 1e-6 the
/// search here would stop at the same pole (every pole tried before it was above the
/// check's tolerance, hence above 1e-6) and keep the same best one.
fn checked_albedo(check: &PhysicalReport, auto_pole: bool, theta_o: f64) -> Option<Rgb> {
    if !auto_pole {
        return None;
    }
    check
        .energy
        .curve
        .iter()
        .find(|p| p.theta.to_bits() == theta_o.to_bits() && p.phi.to_bits() == 0)
        .filter(|p| p.convergence <= MODEL_ALBEDO_GOOD_ENOUGH)
        .map(|p| p.a_wo)
}

/// The table's albedo at `thetas` (radians): each value (`None` where no lookup found a
/// sample) and the fraction of the hemisphere whose lookups were missing.
pub(crate) fn table_albedo_curve(table: &MerlTable, thetas: &[f64]) -> Vec<(Option<Rgb>, f64)> {
    thetas
        .par_iter()
        .map(|&t| {
            let wo = spherical(t, 0.0);
            let guess = auto_pole(&table_brdf(table, Lookup::Interpolated), &wo);
            let (_, _, _, res) = converged_with(&wo, PoleChoice::Auto, 1e-4, guess, |q| {
                let (a, m) = table_albedo(table, Lookup::Interpolated, &wo, q);
                (a.unwrap_or(Rgb::splat(f64::NAN)), (a, m))
            });
            res
        })
        .collect()
}

/// Each model's albedo at `thetas` (outer: model). `checks[m]` holds model m's physical
/// checks (one per channel model; empty when not run) and `auto_pole` whether they
/// chose their poles automatically: a value a check's energy curve already holds is
/// taken from it ([`checked_albedo`]: the same bits), the others are integrated.
pub(crate) fn model_albedo_curves(
    fits: &[&Fitted],
    thetas: &[f64],
    checks: &[Vec<PhysicalReport>],
    auto_pole: bool,
) -> Vec<Vec<Rgb>> {
    let known = |m: usize, k: usize, t: f64| {
        checks
            .get(m)
            .and_then(|r| r.get(k))
            .and_then(|r| checked_albedo(r, auto_pole, t))
    };
    fits.iter()
        .enumerate()
        .map(|(m, f)| {
            thetas
                .par_iter()
                .map(|&t| match f {
                    Fitted::Shared(s) => {
                        known(m, 0, t).unwrap_or_else(|| model_albedo(s.as_ref(), t))
                    }
                    Fitted::PerChannel(ms) => Rgb(std::array::from_fn(|c| {
                        known(m, c, t).unwrap_or_else(|| model_albedo(ms[c].as_ref(), t))[c]
                    })),
                })
                .collect()
        })
        .collect()
}

/// The albedo curves at `thetas` (radians) from the table's ([`table_albedo_curve`],
/// computed once for all models) and the models' ([`model_albedo_curves`]).
pub(crate) fn albedo_curves(
    thetas: &[f64],
    tab: Vec<(Option<Rgb>, f64)>,
    models: Vec<Vec<Rgb>>,
) -> AlbedoCurves {
    AlbedoCurves {
        theta_o: thetas.to_vec(),
        table: tab.iter().map(|x| x.0).collect(),
        table_missing_weight: tab.iter().map(|x| x.1).collect(),
        models,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_merl::Dims;

    fn lambert(rho: f64) -> Fitted {
        Fitted::Shared(
            brdfkit_models::from_json_str(&format!(
                r#"{{"model": "lambert", "params": {{"rho_d": {rho}}}}}"#
            ))
            .unwrap(),
        )
    }

    fn lambert_table(rho: f64) -> MerlTable {
        let dims = Dims::new(8, 8, 16).unwrap();
        // Cells whose directions are below the horizon are missing, as in MERL files.
        MerlTable::from_fn(dims, |i, j, k| {
            let (wi, wo) = from_half_diff(&dims.cell_angles(i, j, k));
            (wi.z > 0.0 && wo.z > 0.0).then(|| Rgb::splat(rho / std::f64::consts::PI))
        })
        .unwrap()
    }

    #[test]
    fn residual_map_is_the_log_ratio_of_a_known_scale() {
        let t = lambert_table(0.5);
        // A model twice as bright everywhere: log10(2) in every block.
        let cells = FitData::from_table(&t).unwrap();
        let m = residual_map(&t, &cells, &lambert(1.0), 4);
        assert_eq!((m.cols, m.rows, m.block), (4, 4, [2, 2]));
        for v in &m.values {
            assert!((v.unwrap() - 2f64.log10()).abs() < 1e-12, "{v:?}");
        }
        assert_eq!(m.model_zero, 0);
        // The exact model: 0 everywhere.
        let m = residual_map(&t, &cells, &lambert(0.5), 100);
        assert_eq!((m.cols, m.rows), (8, 8));
        assert!(m.values.iter().all(|v| v.unwrap().abs() < 1e-12));
    }

    #[test]
    fn slices_pick_the_nearest_cells_and_the_model_values() {
        let t = lambert_table(0.5);
        let s = slices(&t, &[&lambert(0.25)], &[0.7], std::f64::consts::FRAC_PI_2);
        assert_eq!(s.len(), 1);
        // 0.7 rad = 40.1° → bin 3.57 → edge 4 of 8: 45°.
        assert!((s[0].theta_d - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert!((s[0].phi_d - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(!s[0].measured.is_empty());
        for (m, f) in s[0].measured.iter().zip(&s[0].models[0]) {
            assert!((m[0] / f[0] - 2.0).abs() < 1e-12);
        }
    }

    #[test]
    fn albedo_of_a_lambertian_table_and_model_is_rho() {
        let t = lambert_table(0.5);
        let thetas = [0.0, 1.0];
        let c = albedo_curves(
            &thetas,
            table_albedo_curve(&t, &thetas),
            model_albedo_curves(&[&lambert(0.3)], &thetas, &[], true),
        );
        for k in 0..2 {
            assert!(
                (c.table[k].unwrap()[1] - 0.5).abs() < 1e-3,
                "{:?}",
                c.table[k]
            );
            assert!((c.models[0][k][1] - 0.3).abs() < 1e-6);
        }
    }

    /// The model curves that take values from the physical checks' energy curves are
    /// the integrated ones to the bit, for a shared and a per-channel model, and the
    /// checks do supply some of them (θo = 0, 30, 60, 85° are on both grids).
    #[test]
    fn albedo_taken_from_the_checks_is_the_integrated_one() {
        let m = |j: &str| brdfkit_models::from_json_str(j).unwrap();
        let ct = r#"{"model": "cook-torrance", "params": {"rho_d": [0.2, 0.25, 0.3], "rho_s": 0.5, "alpha": 0.2}}"#;
        let lam = |r: f64| format!(r#"{{"model": "lambert", "params": {{"rho_d": {r}}}}}"#);
        let fits = [
            Fitted::Shared(m(ct)),
            Fitted::PerChannel([m(&lam(0.2)), m(ct), m(&lam(0.5))]),
        ];
        let fitted: Vec<&Fitted> = fits.iter().collect();
        let co = crate::html::bounded_checks();
        let checks: Vec<Vec<PhysicalReport>> = fitted
            .iter()
            .map(|f| crate::html::physical(f, &co))
            .collect();
        let thetas = crate::html::ReportOptions::default().albedo_theta_o;
        let taken = thetas
            .iter()
            .filter(|t| checked_albedo(&checks[0][0], true, **t).is_some())
            .count();
        assert_eq!(taken, 4, "0, 30, 60 and 85° come from the checks");
        let with = model_albedo_curves(&fitted, &thetas, &checks, true);
        let without = model_albedo_curves(&fitted, &thetas, &[], true);
        assert_eq!(with, without);
        assert!(checked_albedo(&checks[0][0], false, 0.0).is_none());
    }
}
