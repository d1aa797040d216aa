//! Synthetic cell sets from a model: the ground truth of the recovery tests and the
//! benchmark.

use crate::data::FitData;
use crate::error::FitError;
use brdfkit_core::Model;
use brdfkit_merl::{Dims, MerlTable, cell_directions, cell_weight};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Which cells of the grid a synthetic table keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coverage {
    /// Every cell of the grid, including those whose directions are below the horizon
    /// (where every model is 0): "all cells valid".
    All,
    /// The MERL pattern: cells whose directions (at the cell's angles) are below the
    /// horizon are missing ([`MerlTable::from_brdf`]).
    AboveHorizon,
}

/// The cells of a `dims` grid with the model's values (full f64, no table round-off),
/// solid-angle measures and the chosen coverage.
pub fn synth_data(model: &dyn Model, dims: Dims, coverage: Coverage) -> Result<FitData, FitError> {
    let data = match coverage {
        Coverage::AboveHorizon => {
            let t = MerlTable::from_brdf(model, dims)
                .map_err(|e| FitError::Data(format!("synthetic table: {e}")))?;
            FitData::from_table(&t)?
        }
        Coverage::All => {
            let n = dims.cells();
            let mut g = brdfkit_core::GeometryBatch::with_capacity(n);
            let mut w = Vec::with_capacity(n);
            for x in 0..n {
                let (i, j, k) = dims.unflatten(x);
                let (_, wi, wo, _) = cell_directions(dims, i, j, k);
                g.push(&wi, &wo);
                w.push(cell_weight(dims, i, j));
            }
            let z = vec![0.0; n];
            FitData::from_parts(g, [z.clone(), z.clone(), z], w)?
        }
    };
    Ok(data.with_model_values(model))
}

/// Multiplies every value by exp(σ · N(0, 1)) (log-normal noise of relative size σ),
/// seeded: N(0, 1) by the Box-Muller transform from ChaCha8 uniforms.
pub fn add_lognormal_noise(data: &mut FitData, sigma: f64, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for plane in data.values_mut().iter_mut() {
        for v in plane.iter_mut() {
            // u1 in (0, 1]: ln(u1) finite.
            let u1: f64 = 1.0 - rng.random::<f64>();
            let u2: f64 = rng.random::<f64>();
            let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            *v *= (sigma * z).exp();
        }
    }
}

/// Marks a seeded random `fraction` of the cells missing (drops them).
pub fn drop_cells(data: &FitData, fraction: f64, seed: u64) -> FitData {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let keep: Vec<bool> = (0..data.len())
        .map(|_| rng.random::<f64>() >= fraction)
        .collect();
    data.filter(|m| keep[m])
}
