//! Checks every model's tests share (and `brdfkit-validate` reuses): agreement of the
//! four evaluation paths, gradients against central finite differences, reciprocity,
//! non-negativity, zero below the horizon, and finiteness over the hard-case grid.
//!
//! The `assert_*` functions panic with a message naming the model, the pair and the
//! parameter; they are meant for tests.

use crate::shape::Shape;
use brdfkit_core::direction::spherical;
use brdfkit_core::quadrature::{AlbedoQuadrature, directional_albedo};
use brdfkit_core::{Brdf, GeometryBatch, Model, Rgb, Vec3};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// The relative error of a float32 f_r `got` (widened) against the float64 `want` of the
/// same pair, the measure every float32 path is held to: a float64 zero must be exactly
/// 0 in float32 (asserted, `at` naming the model and pair), and a value below float32's
/// normal range (1e-30; it rounds to 0 or a subnormal) has no relative error (0).
pub fn f32_relative_error(got: f64, want: f64, at: impl FnOnce() -> String) -> f64 {
    if want == 0.0 {
        assert_eq!(got, 0.0, "{}: zero in f64, {got} in f32", at());
        0.0
    } else if want < 1e-30 {
        0.0
    } else {
        (got - want).abs() / want
    }
}

/// A small deterministic generator (SplitMix64, Steele et al. 2014), so the checks need
/// no RNG dependency and give the same pairs on every machine.
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// A direction uniform over the solid angle of the upper hemisphere (z > 0).
    pub fn hemisphere(&mut self) -> Vec3 {
        loop {
            let z = self.next_f64();
            if z > 0.0 {
                let phi = self.uniform(-PI, PI);
                let s = (1.0 - z * z).sqrt();
                return Vec3::new(s * phi.cos(), s * phi.sin(), z);
            }
        }
    }
}

/// `n` seeded pairs, both directions uniform over the upper hemisphere.
pub fn random_pairs(seed: u64, n: usize) -> Vec<(Vec3, Vec3)> {
    let mut r = SplitMix64(seed);
    (0..n).map(|_| (r.hemisphere(), r.hemisphere())).collect()
}

/// Polar angles of the hard-case grid: normal, near-normal, 45°, near-grazing,
/// grazing, and just below the horizon.
pub const HARD_THETAS: [f64; 8] = [
    0.0,
    1e-8,
    1e-4,
    FRAC_PI_4,
    89.9 * PI / 180.0,
    89.999 * PI / 180.0,
    FRAC_PI_2,
    FRAC_PI_2 + 1e-6,
];

/// The hard-case grid of direction pairs: every pair of [`HARD_THETAS`] at azimuths
/// {0, π/2, π, 2} for wo (wi at azimuth 0), plus wi = wo and wi the mirror of wo at
/// every angle.
pub fn hard_case_pairs() -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::new();
    for &ti in &HARD_THETAS {
        for &to in &HARD_THETAS {
            for &po in &[0.0, FRAC_PI_2, PI, 2.0] {
                v.push((spherical(ti, 0.0), spherical(to, po)));
            }
        }
        let w = spherical(ti, 0.7);
        v.push((w, w));
        v.push((Vec3::new(-w.x, -w.y, w.z), w));
    }
    v
}

/// A dense grid of pairs over both hemispheres (θ in `n_theta` steps up to 90°,
/// φo in `n_phi` steps, φi = 0), including grazing directions.
pub fn dense_grid_pairs(n_theta: usize, n_phi: usize) -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::with_capacity(n_theta * n_theta * n_phi);
    for a in 0..n_theta {
        let ti = FRAC_PI_2 * a as f64 / (n_theta - 1) as f64;
        for b in 0..n_theta {
            let to = FRAC_PI_2 * b as f64 / (n_theta - 1) as f64;
            for c in 0..n_phi {
                let po = 2.0 * PI * c as f64 / n_phi as f64;
                v.push((spherical(ti, 0.0), spherical(to, po)));
            }
        }
    }
    v
}

fn rel_diff(a: f64, b: f64) -> f64 {
    let s = a.abs().max(b.abs());
    if s == 0.0 { 0.0 } else { (a - b).abs() / s }
}

/// The four evaluation paths (`eval`, `eval_grad`, `eval_batch`, `eval_grad_batch`) give
/// the same values (relative `tol`), and the two gradient paths the same gradients.
pub fn assert_paths_agree(m: &dyn Model, pairs: &[(Vec3, Vec3)], tol: f64) {
    let np = m.num_params();
    let batch = GeometryBatch::from_pairs(pairs);
    let g = batch.as_slice();
    let mut out = vec![Rgb::ZERO; pairs.len()];
    m.eval_batch(&g, &mut out);
    let mut out2 = vec![Rgb::ZERO; pairs.len()];
    let mut grad = vec![Rgb::ZERO; np * pairs.len()];
    m.eval_grad_batch(&g, &mut out2, &mut grad);
    let mut gk = vec![Rgb::ZERO; np];
    for (k, (wi, wo)) in pairs.iter().enumerate() {
        let f = m.eval(wi, wo);
        let fg = m.eval_grad(wi, wo, &mut gk);
        for c in 0..3 {
            for (what, v) in [
                ("eval_grad", fg[c]),
                ("eval_batch", out[k][c]),
                ("eval_grad_batch", out2[k][c]),
            ] {
                assert!(
                    rel_diff(f[c], v) <= tol,
                    "{}: eval {} vs {what} {} at pair {k} ({wi:?}, {wo:?}) channel {c}",
                    m.name(),
                    f[c],
                    v
                );
            }
            for p in 0..np {
                let a = gk[p][c];
                let b = grad[p * pairs.len() + k][c];
                assert!(
                    rel_diff(a, b) <= tol,
                    "{}: gradient of param {p} eval_grad {a} vs eval_grad_batch {b} at pair {k} channel {c}",
                    m.name()
                );
            }
        }
    }
}

/// Central finite differences of f with respect to every parameter.
///
/// The step is `rel_step · max(|x|, 1e-3)`, shrunk to half the distance to a domain
/// end so both probes stay inside the domain.
pub fn fd_gradient(m: &dyn Model, wi: &Vec3, wo: &Vec3, rel_step: f64) -> Vec<Rgb> {
    let p0 = m.params();
    let specs = m.param_specs();
    let mut out = vec![Rgb::ZERO; p0.len()];
    let mut probe = m.clone_box();
    for p in 0..p0.len() {
        let x = p0[p];
        let d = specs[p].domain;
        let mut h = rel_step * x.abs().max(1e-3);
        if d.lo.is_finite() {
            h = h.min(0.5 * (x - d.lo));
        }
        if d.hi.is_finite() {
            h = h.min(0.5 * (d.hi - x));
        }
        assert!(
            h > 0.0,
            "{}: parameter {} at its domain end {x}",
            m.name(),
            specs[p].name
        );
        let mut q = p0.clone();
        q[p] = x + h;
        probe.set_params(&q).expect("probe inside the domain");
        let fp = probe.eval(wi, wo);
        q[p] = x - h;
        probe.set_params(&q).expect("probe inside the domain");
        let fm = probe.eval(wi, wo);
        out[p] = (fp - fm) / (2.0 * h);
    }
    out
}

/// Analytic gradients agree with central finite differences: for every parameter and
/// channel, |analytic − fd| ≤ rel_tol · max(|analytic|, |fd|) + 1e-8 · |f| / max(|x|, 1e-3),
/// the second term being about 100x the round-off of the difference quotient.
pub fn assert_gradient_matches_fd(
    m: &dyn Model,
    pairs: &[(Vec3, Vec3)],
    rel_step: f64,
    rel_tol: f64,
) {
    let np = m.num_params();
    let p0 = m.params();
    let names: Vec<String> = m.param_specs().into_iter().map(|s| s.name).collect();
    let mut g = vec![Rgb::ZERO; np];
    for (wi, wo) in pairs {
        let f = m.eval_grad(wi, wo, &mut g);
        let fd = fd_gradient(m, wi, wo, rel_step);
        for p in 0..np {
            for c in 0..3 {
                let (a, b) = (g[p][c], fd[p][c]);
                let tol =
                    rel_tol * a.abs().max(b.abs()) + 1e-8 * f[c].abs() / p0[p].abs().max(1e-3);
                assert!(
                    (a - b).abs() <= tol,
                    "{}: ∂f/∂{} channel {c}: analytic {a} vs finite difference {b} at ({wi:?}, {wo:?}) params {p0:?}",
                    m.name(),
                    names[p]
                );
            }
        }
    }
}

/// Largest relative asymmetry |f(wi,wo) − f(wo,wi)| / max(|f|) over the pairs.
pub fn max_reciprocity_error(m: &dyn Model, pairs: &[(Vec3, Vec3)]) -> f64 {
    pairs
        .iter()
        .map(|(wi, wo)| {
            let a = m.eval(wi, wo);
            let b = m.eval(wo, wi);
            (0..3).map(|c| rel_diff(a[c], b[c])).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

/// f(wi, wo) = f(wo, wi) to relative `tol` on every pair.
pub fn assert_reciprocal(m: &dyn Model, pairs: &[(Vec3, Vec3)], tol: f64) {
    let e = max_reciprocity_error(m, pairs);
    assert!(e <= tol, "{}: reciprocity error {e} > {tol}", m.name());
}

/// f ≥ 0 (and finite) on every pair.
pub fn assert_nonnegative(m: &dyn Model, pairs: &[(Vec3, Vec3)]) {
    for (wi, wo) in pairs {
        let f = m.eval(wi, wo);
        assert!(
            f.is_finite() && f.min_channel() >= 0.0,
            "{}: f = {f:?} at ({wi:?}, {wo:?})",
            m.name()
        );
    }
}

/// No NaN or infinity in any value or gradient, on any path, over the pairs.
pub fn assert_finite_everywhere(m: &dyn Model, pairs: &[(Vec3, Vec3)]) {
    let np = m.num_params();
    let mut g = vec![Rgb::ZERO; np];
    for (wi, wo) in pairs {
        let f = m.eval_grad(wi, wo, &mut g);
        assert!(
            f.is_finite(),
            "{}: f = {f:?} at ({wi:?}, {wo:?}) params {:?}",
            m.name(),
            m.params()
        );
        for (p, gp) in g.iter().enumerate() {
            assert!(
                gp.is_finite(),
                "{}: gradient {p} = {gp:?} at ({wi:?}, {wo:?}) params {:?}",
                m.name(),
                m.params()
            );
        }
    }
    let batch = GeometryBatch::from_pairs(pairs);
    let mut out = vec![Rgb::ZERO; pairs.len()];
    let mut grad = vec![Rgb::ZERO; np * pairs.len()];
    m.eval_grad_batch(&batch.as_slice(), &mut out, &mut grad);
    assert!(
        out.iter().all(Rgb::is_finite),
        "{}: non-finite batch value",
        m.name()
    );
    assert!(
        grad.iter().all(Rgb::is_finite),
        "{}: non-finite batch gradient",
        m.name()
    );
}

/// Value and gradient are exactly zero when either direction is at or below the
/// horizon (z ≤ 0).
pub fn assert_zero_below_horizon(m: &dyn Model) {
    let np = m.num_params();
    let mut g = vec![Rgb::ZERO; np];
    let up = spherical(0.3, 0.2);
    // `spherical(π/2, φ)` has z = 6e-17 > 0: build the horizon directions exactly.
    let at = |z: f64| {
        let s = (1.0 - z * z).sqrt();
        Vec3::new(s * 0.6, s * 0.8, z)
    };
    for z in [0.0, -0.0, -1e-9, -0.5, -1.0] {
        let down = at(z);
        for (wi, wo) in [(down, up), (up, down), (down, down)] {
            let f = m.eval_grad(&wi, &wo, &mut g);
            assert_eq!(f, Rgb::ZERO, "{}: f at ({wi:?}, {wo:?})", m.name());
            assert!(
                g.iter().all(|x| *x == Rgb::ZERO),
                "{}: gradient below the horizon",
                m.name()
            );
            assert_eq!(m.eval(&wi, &wo), Rgb::ZERO);
            let b = GeometryBatch::from_pairs(&[(wi, wo)]);
            let mut out = [Rgb::splat(1.0)];
            m.eval_batch(&b.as_slice(), &mut out);
            assert_eq!(out[0], Rgb::ZERO, "{}: batch below the horizon", m.name());
        }
    }
}

/// The JSON contract's round trip: `m.to_json()` read back is the same model (its name,
/// its parameters bit for bit, and the same JSON again).
pub fn assert_json_round_trip(m: &dyn Model) {
    let back = crate::from_json(&m.to_json()).unwrap();
    assert_eq!(back.name(), m.name());
    assert_eq!(back.params(), m.params(), "{}", m.name());
    assert_eq!(back.to_json(), m.to_json());
}

/// The property checks on given pair sets: the four paths agree exactly on `pairs` and
/// `hard`; f is reciprocal to 1e-12 on `pairs` and `dense`, nonnegative on `dense`,
/// finite on `hard` and zero below the horizon.
pub fn assert_properties_on(
    m: &dyn Model,
    pairs: &[(Vec3, Vec3)],
    hard: &[(Vec3, Vec3)],
    dense: &[(Vec3, Vec3)],
) {
    assert_paths_agree(m, pairs, 0.0);
    assert_paths_agree(m, hard, 0.0);
    assert_reciprocal(m, pairs, 1e-12);
    assert_reciprocal(m, dense, 1e-12);
    assert_nonnegative(m, dense);
    assert_finite_everywhere(m, hard);
    assert_zero_below_horizon(m);
}

/// The checks most models' unit tests run on one parameter set: the four paths agree
/// exactly on `seed`'s 300 random pairs, the hard cases and a dense grid; f is
/// reciprocal to 1e-12 on all three when the model says it is
/// ([`Model::is_reciprocal`]); f ≥ 0 on a finer dense grid; zero below the horizon;
/// analytic gradients match finite differences on the random pairs.
pub fn assert_shared_checks(m: &dyn Model, seed: u64) {
    let pairs = random_pairs(seed, 300);
    assert_paths_agree(m, &pairs, 0.0);
    assert_paths_agree(m, &hard_case_pairs(), 0.0);
    assert_paths_agree(m, &dense_grid_pairs(12, 6), 0.0);
    if m.is_reciprocal() {
        assert_reciprocal(m, &pairs, 1e-12);
        assert_reciprocal(m, &hard_case_pairs(), 1e-12);
        assert_reciprocal(m, &dense_grid_pairs(20, 8), 1e-12);
    }
    assert_nonnegative(m, &dense_grid_pairs(40, 16));
    assert_zero_below_horizon(m);
    assert_gradient_matches_fd(m, &pairs, 1e-6, 1e-6);
}

/// The body of the models' gradient property tests, on `seed`'s 12 random pairs:
/// analytic gradients match finite differences, the paths agree exactly, and f is
/// reciprocal to 1e-12 when the model says it is.
pub fn assert_gradient_paths_reciprocity(m: &dyn Model, seed: u64) {
    let pairs = random_pairs(seed, 12);
    assert_gradient_matches_fd(m, &pairs, 1e-6, 1e-6);
    assert_paths_agree(m, &pairs, 0.0);
    if m.is_reciprocal() {
        assert_reciprocal(m, &pairs, 1e-12);
    }
}

/// The Phong lobe max(cos θr, 0)ⁿ about the mirror direction, from the spherical angles
/// alone (an independent truth for the Phong models' tests): cos θr = cos θi cos θo −
/// sin θi sin θo cos(φi − φo).
pub fn mirror_lobe_from_angles(ti: f64, pi: f64, to: f64, po: f64, n: f64) -> f64 {
    let cr = ti.cos() * to.cos() - ti.sin() * to.sin() * (pi - po).cos();
    if cr > 0.0 { cr.powf(n) } else { 0.0 }
}

/// `eval` agrees with an independent closed form `want(θi, φi, θo, φo)` to relative
/// `tol` per channel, on `count` angle quadruples drawn from `seed` (θ uniform in
/// [0, `theta_max`), φ in [−3, 3)).
pub fn assert_matches_angle_formula(
    m: &dyn Model,
    seed: u64,
    count: usize,
    theta_max: f64,
    tol: f64,
    want: impl Fn(f64, f64, f64, f64) -> Rgb,
) {
    let mut r = SplitMix64(seed);
    for _ in 0..count {
        let (ti, pi, to, po) = (
            r.uniform(0.0, theta_max),
            r.uniform(-3.0, 3.0),
            r.uniform(0.0, theta_max),
            r.uniform(-3.0, 3.0),
        );
        let f = m.eval(&spherical(ti, pi), &spherical(to, po));
        let w = want(ti, pi, to, po);
        for c in 0..3 {
            assert!(
                (f[c] - w[c]).abs() <= tol * w[c],
                "{}: {} vs {} at θi {ti}, φi {pi}, θo {to}, φo {po}, channel {c}",
                m.name(),
                f[c],
                w[c]
            );
        }
    }
}

/// The roughness shapes the hard-case tests sweep: for each α in {1e-6, 1e-4, 1e-2,
/// 0.5, 1, 2, 100}, isotropic α, (α, 0.3) and (1e-6, α), in that order.
pub fn hard_shapes() -> Vec<Shape> {
    [1e-6, 1e-4, 1e-2, 0.5, 1.0, 2.0, 100.0]
        .into_iter()
        .flat_map(|a| {
            [
                Shape::Isotropic(a),
                Shape::Anisotropic(a, 0.3),
                Shape::Anisotropic(1e-6, a),
            ]
        })
        .collect()
}

/// A shape from decimal logarithms (property tests draw exponents or roughnesses over
/// decades): (10^la, 10^lb) when `aniso`, else isotropic 10^la.
pub fn shape_from_log10(aniso: bool, la: f64, lb: f64) -> Shape {
    if aniso {
        Shape::Anisotropic(10f64.powf(la), 10f64.powf(lb))
    } else {
        Shape::Isotropic(10f64.powf(la))
    }
}

/// The albedo rule of the energy checks of narrow lobes: the default segments with 1024
/// azimuths. The default 128 are not enough for a lobe of width 0.01 cut by the horizon
/// (Cook-Torrance, α = 0.01, θo = 89°: 0.8964 instead of 0.9394); 1024 agree with 4096
/// azimuths at order 32 to 1e-8 (`albedo_quadrature_converged` in
/// tests/cook_torrance.rs).
pub fn azimuth_converged_rule() -> AlbedoQuadrature {
    AlbedoQuadrature {
        n_phi: 1024,
        ..AlbedoQuadrature::default()
    }
}

/// The red channel's directional albedo of `make(a)` at θo = t degrees (azimuth `phi`)
/// under [`azimuth_converged_rule`], for every (a, t) of `params` × `thetas_deg`, in
/// parallel: (albedo, a, t) triples in that order.
pub fn albedo_grid<M: Brdf>(
    params: &[f64],
    thetas_deg: &[f64],
    phi: f64,
    make: impl Fn(f64) -> M + Sync,
) -> Vec<(f64, f64, f64)> {
    let q = azimuth_converged_rule();
    let cases: Vec<(f64, f64)> = params
        .iter()
        .flat_map(|&a| thetas_deg.iter().map(move |&t| (a, t)))
        .collect();
    cases
        .par_iter()
        .map(|&(a, t)| {
            let wo = spherical(t.to_radians(), phi);
            (directional_albedo(&make(a), &wo, &q).r(), a, t)
        })
        .collect()
}
