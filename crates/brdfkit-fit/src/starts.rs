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
//! Ranges, about the start value x₀ (see [`shape_range`]):
//! - a half-line (exponent on [0, ∞)), or a bounded domain with x₀ in its lowest tenth
//!   (roughness on [1e-6, 100]): x₀ ×/÷ 100, measured from the lower end, clipped to
//!   90 % of a bounded interval. The logit is logarithmic near its lower end, so the
//!   grid is log-spaced either way;
//! - other bounded domains: u₀ ± 3 in the logit, clipped to [−7, 7];
//! - asinh (a signed coefficient): x₀ ± max(1, |x₀|), mapped to u.

use crate::reparam::Transform;
use brdfkit_core::{ParamRole, ParamSpec};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Range of u searched for a shape parameter of transform `t` (from its domain), starting
/// at `x0`: the start value ×/÷ 100 (measured from the lower end) for a half-line or
/// for a bounded domain whose start sits in the lowest tenth (roughness on [1e-6,
/// 100]: the logit is logarithmic there), clipped to 90 % of a bounded interval;
/// otherwise u₀ ± 3 clipped to [−7, 7] (logit) or x₀ ± max(1, |x₀|) (asinh, a real
/// parameter).
pub fn shape_range(t: &Transform, x0: f64) -> (f64, f64) {
    let u0 = t.inverse(x0);
    match *t {
        Transform::Log { lo } => (
            t.inverse(lo + (x0 - lo) / 100.0),
            t.inverse(lo + (x0 - lo) * 100.0),
        ),
        Transform::NegLog { hi } => (
            t.inverse(hi - (hi - x0) * 100.0),
            t.inverse(hi - (hi - x0) / 100.0),
        ),
        Transform::Logit { lo, hi } if (x0 - lo) < 0.1 * (hi - lo) => {
            // Not below the offset `inverse` moves an end value to (a start on the
            // lower end would otherwise give a zero-width range), and not into the top
            // tenth, where the logit flattens and a start is a poor guess anyway.
            let a = ((x0 - lo) / 100.0).max(crate::reparam::END_OFFSET * (hi - lo));
            let b = ((x0 - lo) * 100.0).min(0.9 * (hi - lo));
            (t.inverse(lo + a), t.inverse(lo + b))
        }
        Transform::Logit { .. } => ((u0 - 3.0).max(-7.0), (u0 + 3.0).min(7.0)),
        Transform::Asinh => {
            let w = x0.abs().max(1.0);
            (t.inverse(x0 - w), t.inverse(x0 + w))
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
    #[allow(clippy::needless_range_loop)] // k indexes the inner permutations, not `perms`
    for k in 0..m {
        let mut x = x0.to_vec();
        for (j, &p) in shape.iter().enumerate() {
            let t = Transform::for_domain(&specs[p].domain);
            let (lo, hi) = shape_range(&t, x0[p]);
            let u = lo + (hi - lo) * (perms[j][k] as f64 + 0.5) / m as f64;
            x[p] = crate::reparam::nudge_into(&specs[p].domain, t.forward(u).0);
        }
        out.push(x);
    }
    out
}
