//! Deterministic, seeded start points spread over the shape parameters.
//!
//! Start 0 is the model as given (its own parameters, normally the family's default
//! start). Starts 1 … n−1 keep every albedo-like parameter at that value and place the
//! free shared (lobe-shape) parameters on a Latin hypercube in the reparameterised
//! coordinate u (see [`crate::reparam`]): the range of each shape parameter is split
//! into n − 1 equal strata and start k takes the centre of stratum π_j(k) of each
//! parameter j, with π_j a permutation drawn from ChaCha8 seeded by the config seed.
//! With one shape parameter (roughness, exponent) this is a regular grid; with several,
//! every stratum of every parameter is still visited once.
//!
//! Ranges in u, about the start value u₀:
//! - log transform (roughness, exponent on (0, ∞)): u₀ ± ln 100, i.e. the start value
//!   ×/÷ 100;
//! - logit transform (a bounded shape parameter): [u₀ − 5, u₀ + 5] clipped to [−7, 7]
//!   (σ(±7) is 0.1 % from either end);
//! - identity (a signed coefficient): u₀ ± max(1, |u₀|).

use crate::reparam::Transform;
use brdfkit_core::{ParamRole, ParamSpec};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Range of u searched for a shape parameter of transform `t` starting at `u0`.
pub fn shape_range(t: &Transform, u0: f64) -> (f64, f64) {
    match t {
        Transform::Log { .. } | Transform::NegLog { .. } => {
            let w = 100f64.ln();
            (u0 - w, u0 + w)
        }
        Transform::Logit { .. } => ((u0 - 5.0).max(-7.0), (u0 + 5.0).min(7.0)),
        Transform::Identity => {
            let w = u0.abs().max(1.0);
            (u0 - w, u0 + w)
        }
    }
}

/// `n` start points (full physical parameter vectors) for the free parameters `free` of
/// a model with `specs` and current parameters `x0`.
pub fn start_points(
    specs: &[ParamSpec],
    x0: &[f64],
    free: &[usize],
    n: usize,
    seed: u64,
) -> Vec<Vec<f64>> {
    let mut out = vec![x0.to_vec()];
    if n <= 1 {
        return out;
    }
    let shape: Vec<usize> = free
        .iter()
        .copied()
        .filter(|&p| specs[p].role == ParamRole::Shared)
        .collect();
    let m = n - 1;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let perms: Vec<Vec<usize>> = shape
        .iter()
        .enumerate()
        .map(|(j, _)| {
            let mut p: Vec<usize> = (0..m).collect();
            // The first shape parameter walks its grid in order (a readable record);
            // the others are shuffled.
            if j > 0 {
                p.shuffle(&mut rng);
            }
            p
        })
        .collect();
    for k in 0..m {
        let mut x = x0.to_vec();
        for (j, &p) in shape.iter().enumerate() {
            let t = Transform::for_domain(&specs[p].domain);
            let (lo, hi) = shape_range(&t, t.inverse(x0[p]));
            let u = lo + (hi - lo) * (perms[j][k] as f64 + 0.5) / m as f64;
            x[p] = crate::reparam::nudge_into(&specs[p].domain, t.forward(u).0);
        }
        out.push(x);
    }
    out
}
