//! [`FitData`]: the cells a fit sees, precomputed once as a structure of arrays.

use crate::error::FitError;
use brdfkit_core::{GeometryBatch, Model, Rgb};
use brdfkit_merl::{CellBatch, MerlTable};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::FRAC_PI_2;

/// Number of bins along each of √(θh/(π/2)) and θd/(π/2) used to stratify a subsample.
/// The square root follows MERL's θh spacing, so each bin holds a similar cell count.
pub const STRATA: usize = 16;

/// The cells of a fit: per-cell geometry, measured values per channel, the cell's
/// measure of (wi, wo) pairs, and a multiplicity (how many cells of the full set a cell
/// stands for after subsampling; 1 otherwise).
///
/// Cell m has geometry pair m of [`geometry`](Self::geometry), value
/// `values()[c][m]` in channel c (1/sr), measure `measure()[m]` (sr²) and angles
/// `theta_h()[m]`, `theta_d()[m]` (radians).
#[derive(Debug, Clone)]
pub struct FitData {
    geometry: GeometryBatch,
    values: [Vec<f64>; 3],
    measure: Vec<f64>,
    mult: Vec<f64>,
    theta_h: Vec<f64>,
    theta_d: Vec<f64>,
}

impl FitData {
    /// Cells from their parts: geometry, values per channel (finite, ≥ 0) and the
    /// measure of each cell (finite, > 0; pass ones when only uniform weighting will be
    /// used). Angles are recomputed from the geometry: θh = acos(h.z), θd = acos(wi·h).
    pub fn from_parts(
        geometry: GeometryBatch,
        values: [Vec<f64>; 3],
        measure: Vec<f64>,
    ) -> Result<Self, FitError> {
        let n = geometry.len();
        for (c, v) in values.iter().enumerate() {
            if v.len() != n {
                return Err(FitError::Data(format!(
                    "channel {c} has {} values for {n} cells",
                    v.len()
                )));
            }
            if let Some((k, x)) = v
                .iter()
                .enumerate()
                .find(|(_, x)| !(x.is_finite() && **x >= 0.0))
            {
                return Err(FitError::Data(format!(
                    "channel {c} value {x} at cell {k} is not a finite non-negative number"
                )));
            }
        }
        if measure.len() != n {
            return Err(FitError::Data(format!(
                "{} measures for {n} cells",
                measure.len()
            )));
        }
        if let Some((k, x)) = measure
            .iter()
            .enumerate()
            .find(|(_, x)| !(x.is_finite() && **x > 0.0))
        {
            return Err(FitError::Data(format!(
                "measure {x} at cell {k} is not a finite positive number"
            )));
        }
        // acos arguments clamped: normalisation can land a ulp beyond 1.
        let theta_h = geometry
            .h_z
            .par_iter()
            .map(|z| z.clamp(-1.0, 1.0).acos())
            .collect();
        let theta_d = geometry
            .cos_d
            .par_iter()
            .map(|z| z.clamp(-1.0, 1.0).acos())
            .collect();
        Ok(FitData {
            geometry,
            values,
            measure,
            mult: vec![1.0; n],
            theta_h,
            theta_d,
        })
    }

    /// The valid cells of a table batch ([`MerlTable::cell_batch`]).
    pub fn from_cell_batch(b: CellBatch) -> Result<Self, FitError> {
        FitData::from_parts(b.geometry, b.values, b.weights)
    }

    /// The valid cells of a table (only they take part in a fit).
    pub fn from_table(t: &MerlTable) -> Result<Self, FitError> {
        if t.valid_count() == 0 {
            return Err(FitError::NoCells("the table has no valid cell".into()));
        }
        FitData::from_cell_batch(t.cell_batch())
    }

    /// A table's cells with values replaced by a model's at the cells' directions (a
    /// synthetic table for tests and benchmarks). Equivalent to fitting
    /// `MerlTable::from_brdf(model)` but keeps full f64 values.
    pub fn with_model_values(&self, model: &dyn Model) -> FitData {
        let mut out = self.clone();
        let n = self.len();
        let vals: Vec<Rgb> = {
            let mut v = vec![Rgb::ZERO; n];
            v.par_chunks_mut(crate::problem::CHUNK)
                .enumerate()
                .for_each(|(ci, o)| {
                    let s = ci * crate::problem::CHUNK;
                    model.eval_batch(&self.geometry.slice(s..s + o.len()), o);
                });
            v
        };
        for c in 0..3 {
            out.values[c] = vals.iter().map(|v| v[c]).collect();
        }
        out
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.measure.len()
    }

    /// True when there is no cell.
    pub fn is_empty(&self) -> bool {
        self.measure.is_empty()
    }

    /// Per-cell geometry.
    pub fn geometry(&self) -> &GeometryBatch {
        &self.geometry
    }

    /// Measured values, one plane per channel.
    pub fn values(&self) -> &[Vec<f64>; 3] {
        &self.values
    }

    /// Mutable value planes (e.g. to add noise to a synthetic table). Values must stay
    /// finite and non-negative.
    pub fn values_mut(&mut self) -> &mut [Vec<f64>; 3] {
        &mut self.values
    }

    /// Each cell's measure of (wi, wo) pairs.
    pub fn measure(&self) -> &[f64] {
        &self.measure
    }

    /// How many cells of the full set each cell stands for (1 unless subsampled).
    pub fn multiplicity(&self) -> &[f64] {
        &self.mult
    }

    /// θh of each cell.
    pub fn theta_h(&self) -> &[f64] {
        &self.theta_h
    }

    /// θd of each cell.
    pub fn theta_d(&self) -> &[f64] {
        &self.theta_d
    }

    /// The cells' weights under a weighting: multiplicity × (measure or 1).
    pub fn weights(&self, w: crate::Weighting) -> Vec<f64> {
        match w {
            crate::Weighting::SolidAngle => self
                .mult
                .iter()
                .zip(&self.measure)
                .map(|(a, b)| a * b)
                .collect(),
            crate::Weighting::Uniform => self.mult.clone(),
        }
    }

    /// The cells with `keep[m]` true.
    pub fn filter(&self, keep: impl Fn(usize) -> bool) -> FitData {
        let idx: Vec<usize> = (0..self.len()).filter(|&m| keep(m)).collect();
        self.select(&idx, None)
    }

    /// The cells `idx`, with multiplicities multiplied by `mult` when given.
    fn select(&self, idx: &[usize], mult: Option<&[f64]>) -> FitData {
        let g = &self.geometry;
        let pick = |v: &Vec<f64>| idx.iter().map(|&m| v[m]).collect::<Vec<f64>>();
        let geometry = GeometryBatch {
            wi_x: pick(&g.wi_x),
            wi_y: pick(&g.wi_y),
            wi_z: pick(&g.wi_z),
            wo_x: pick(&g.wo_x),
            wo_y: pick(&g.wo_y),
            wo_z: pick(&g.wo_z),
            h_x: pick(&g.h_x),
            h_y: pick(&g.h_y),
            h_z: pick(&g.h_z),
            cos_d: pick(&g.cos_d),
        };
        let mut m = pick(&self.mult);
        if let Some(f) = mult {
            for (a, b) in m.iter_mut().zip(f) {
                *a *= b;
            }
        }
        FitData {
            geometry,
            values: [
                pick(&self.values[0]),
                pick(&self.values[1]),
                pick(&self.values[2]),
            ],
            measure: pick(&self.measure),
            mult: m,
            theta_h: pick(&self.theta_h),
            theta_d: pick(&self.theta_d),
        }
    }

    /// The cells with θd ≤ `max_theta_d` (radians): the grazing cells, the least
    /// reliable measurements, are left out.
    pub fn with_theta_d_max(&self, max_theta_d: f64) -> FitData {
        self.filter(|m| self.theta_d[m] <= max_theta_d)
    }

    /// A stratified, seeded subsample of about `fraction` of the cells.
    ///
    /// Cells are binned on a [`STRATA`] × [`STRATA`] grid over (√(θh/(π/2)), θd/(π/2));
    /// from a bin of n cells, max(1, round(fraction · n)) are drawn without replacement
    /// (a ChaCha8 shuffle seeded by `seed` and the bin), and each drawn cell's
    /// multiplicity becomes n / drawn, so the weighted sums of a subsample estimate
    /// those of the full set bin by bin. The same seed gives the same cells.
    pub fn stratified_subsample(&self, fraction: f64, seed: u64) -> FitData {
        if fraction >= 1.0 {
            return self.clone();
        }
        let bin = |m: usize| {
            // θ > π/2 (below-horizon geometry) and round-off clamp into the last bin.
            let a = ((self.theta_h[m].max(0.0) / FRAC_PI_2).sqrt() * STRATA as f64) as usize;
            let b = ((self.theta_d[m].max(0.0) / FRAC_PI_2) * STRATA as f64) as usize;
            a.min(STRATA - 1) * STRATA + b.min(STRATA - 1)
        };
        let mut bins: Vec<Vec<usize>> = vec![Vec::new(); STRATA * STRATA];
        for m in 0..self.len() {
            bins[bin(m)].push(m);
        }
        let mut idx = Vec::new();
        let mut mult = Vec::new();
        for (b, cells) in bins.iter_mut().enumerate() {
            if cells.is_empty() {
                continue;
            }
            let n = cells.len();
            let take = ((fraction * n as f64).round() as usize).clamp(1, n);
            let mut rng =
                ChaCha8Rng::seed_from_u64(seed ^ (b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            cells.shuffle(&mut rng);
            let chosen = &mut cells[..take];
            chosen.sort_unstable();
            let w = n as f64 / take as f64;
            for &m in chosen.iter() {
                idx.push(m);
                mult.push(w);
            }
        }
        // File order keeps the geometry columns' memory access sequential.
        let mut order: Vec<usize> = (0..idx.len()).collect();
        order.sort_unstable_by_key(|&p| idx[p]);
        let idx: Vec<usize> = order.iter().map(|&p| idx[p]).collect();
        let mult: Vec<f64> = order.iter().map(|&p| mult[p]).collect();
        self.select(&idx, Some(&mult))
    }
}
