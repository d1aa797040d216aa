//! Importance sampling of directions: cosine-weighted and uniform-sphere warps, and a
//! tabulated BRDF-lobe sampler that works for any isotropic [`SceneMaterial`] (analytic or
//! measured).
//!
//! # The tabulated lobe sampler
//!
//! No BRDF in brdfkit exposes its own sampling routine, and a measured table has none,
//! so the renderer builds one per material (when the `environment` effect asks for
//! it): a piecewise-constant density over directions measured **about the mirror
//! direction** m = (−wo.x, −wo.y, wo.z), in the frame (e1, e2, m) with e2 normal to the
//! plane of incidence. Polar angle θ' from m is split into bins graded geometrically
//! from 10⁻³ rad (sharp specular peaks) to uniform 0.06-rad steps up to π; azimuth φ'
//! into [`LobeSampler::N_PHI`] uniform bins. For K = [`LobeSampler::NODES`] outgoing
//! polar angles θo (bin centres of [0, π/2)) each bin gets the mass
//!
//! M_ij(θo) ≈ Ω_ij · mean over 2×2 sub-points of  f̄(wi, wo) · max(cos θi, 0),
//!
//! f̄ the mean of the three channels and Ω_ij = (cos θ'_i − cos θ'_{i+1}) Δφ the bin's
//! solid angle. Sampling picks a bin from the marginal/conditional CDFs, then a
//! direction uniform in solid angle inside it, so the density is exactly
//! p_tab(wi) = M_ij / (Σ M · Ω_ij). Isotropy makes the table at azimuth 0 valid at
//! every azimuth once the frame follows wo. A defensive fraction ε of cosine-weighted
//! samples (Hesterberg 1995; Veach's thesis §9.2.4) keeps the density positive wherever
//! the integrand can be:
//!
//! p(wi) = (1 − ε) p_tab(wi) + ε cos θi / π,   ε = [`LobeSampler::DEFENSIVE`].
//!
//! The estimate is unbiased for any material (the density is evaluated exactly for MIS);
//! the table only decides how small the variance is. An anisotropic material is
//! sampled as if isotropic (still unbiased, less efficient).

use crate::material::SceneMaterial;
use brdfkit_core::Vec3;
use rayon::prelude::*;
use std::f64::consts::{FRAC_1_PI, FRAC_PI_2, PI};

/// Cosine-weighted direction on the upper hemisphere from two uniforms, by Shirley and
/// Chiu's concentric disk map ("A Low Distortion Map Between Disk and Square", JGT
/// 1997) lifted to the hemisphere (Malley's method). Density cos θ / π.
#[inline]
pub fn sample_cosine(u1: f64, u2: f64) -> Vec3 {
    let a = 2.0 * u1 - 1.0;
    let b = 2.0 * u2 - 1.0;
    let (r, phi) = if a == 0.0 && b == 0.0 {
        (0.0, 0.0)
    } else if a.abs() > b.abs() {
        (a, std::f64::consts::FRAC_PI_4 * (b / a))
    } else {
        (b, FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (a / b))
    };
    let (x, y) = (r * phi.cos(), r * phi.sin());
    // 1 − x² − y² can round to a hair below 0 on the rim.
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    Vec3::new(x, y, z)
}

/// Density of [`sample_cosine`]: cos θ / π above the horizon, 0 below.
#[inline]
pub fn cosine_pdf(w: &Vec3) -> f64 {
    if w.z > 0.0 { w.z * FRAC_1_PI } else { 0.0 }
}

/// Uniform direction on the unit sphere. Density 1/(4π).
#[inline]
pub fn sample_uniform_sphere(u1: f64, u2: f64) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    // |z| ≤ 1 exactly, but keep the root real under round-off.
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Inverts a normalised CDF (`cdf[0] = 0`, last = 1): the bin i with
/// `cdf[i] ≤ u < cdf[i+1]` (never an empty one), and the position of u inside it,
/// `(u − cdf[i]) / (cdf[i+1] − cdf[i])` ∈ [0, 1), so one uniform number yields both the
/// bin and a uniform offset within it and stratification of u carries through.
#[inline]
pub fn pick(cdf: &[f64], u: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    // partition_point: first index with cdf > u; the bin is one before it.
    let i = cdf
        .partition_point(|&c| c <= u)
        .saturating_sub(1)
        .min(n - 1);
    let width = cdf[i + 1] - cdf[i];
    // width > 0 for any bin u can land in; the clamp keeps round-off inside [0, 1).
    let r = if width > 0.0 {
        ((u - cdf[i]) / width).clamp(0.0, 1.0 - f64::EPSILON)
    } else {
        0.5
    };
    (i, r)
}

/// Builds a normalised CDF from non-negative weights; returns the total.
fn build_cdf(weights: &[f64], cdf: &mut [f64]) -> f64 {
    cdf[0] = 0.0;
    for (i, w) in weights.iter().enumerate() {
        cdf[i + 1] = cdf[i] + w;
    }
    let total = cdf[weights.len()];
    if total > 0.0 {
        for c in cdf.iter_mut() {
            *c /= total;
        }
        // Guard the top against round-off so a u < 1 always finds a bin.
        cdf[weights.len()] = 1.0;
    }
    total
}

/// A sampled direction with its density (solid angle measure).
#[derive(Clone, Copy, Debug)]
pub struct DirSample {
    /// Sampled direction, local frame.
    pub wi: Vec3,
    /// Its density (solid angle measure).
    pub pdf: f64,
}

/// The tabulated BRDF-lobe sampler (see the module documentation).
#[derive(Clone, Debug)]
pub struct LobeSampler {
    theta_edges: Vec<f64>,
    cos_edges: Vec<f64>,
    /// Per node: marginal CDF over θ' bins (nt + 1 entries).
    marginal: Vec<f64>,
    /// Per node and θ' bin: conditional CDF over φ' bins (N_PHI + 1 entries).
    conditional: Vec<f64>,
    /// Per node, θ' bin and φ' bin: the solid-angle density of the tabulated part.
    density: Vec<f64>,
    /// Per node: whether the table has any mass (else cosine sampling only).
    usable: Vec<bool>,
    /// BRDF evaluations spent building the table.
    pub build_evaluations: u64,
}

/// The frame (e1, e2, m) about the mirror direction of `wo`.
#[inline]
fn mirror_frame(wo: &Vec3) -> (Vec3, Vec3, Vec3) {
    let m = Vec3::new(-wo.x, -wo.y, wo.z);
    // Unit vectors: no overflow for hypot to guard against, and sqrt is far cheaper.
    let rho = (wo.x * wo.x + wo.y * wo.y).sqrt();
    let (c, s) = if rho > 0.0 {
        (wo.x / rho, wo.y / rho)
    } else {
        (1.0, 0.0)
    };
    let e2 = Vec3::new(-s, c, 0.0);
    let e1 = e2.cross(&m);
    (e1, e2, m)
}

impl LobeSampler {
    /// Outgoing polar-angle nodes over [0, π/2).
    pub const NODES: usize = 24;
    /// Azimuth bins about the mirror direction.
    pub const N_PHI: usize = 32;
    /// Defensive cosine fraction ε.
    pub const DEFENSIVE: f64 = 0.1;
    /// Sub-points per bin and axis when estimating a bin's mass.
    const SUB: usize = 2;

    /// θ' bin edges: 0, then 10⁻³ · 1.5ᵏ up to 0.1, then uniform steps of about 0.06 to π.
    fn edges() -> Vec<f64> {
        let mut e = vec![0.0];
        let mut x = 1e-3;
        while x < 0.1 {
            e.push(x);
            x *= 1.5;
        }
        let start = *e.last().unwrap();
        let steps = ((PI - start) / 0.06).ceil() as usize;
        for k in 1..=steps {
            e.push(start + (PI - start) * k as f64 / steps as f64);
        }
        e
    }

    /// Tabulates `material` (in parallel over the θo nodes).
    pub fn build(material: &SceneMaterial) -> Self {
        let theta_edges = Self::edges();
        let cos_edges: Vec<f64> = theta_edges.iter().map(|t| t.cos()).collect();
        let nt = theta_edges.len() - 1;
        let np = Self::N_PHI;
        let dphi = 2.0 * PI / np as f64;
        // Per node: (marginal CDF, conditional CDFs, densities, usable, evaluations).
        type NodeTable = (Vec<f64>, Vec<f64>, Vec<f64>, bool, u64);
        let per_node: Vec<NodeTable> = (0..Self::NODES)
            .into_par_iter()
            .map(|k| {
                let theta_o = (k as f64 + 0.5) / Self::NODES as f64 * FRAC_PI_2;
                let wo = Vec3::new(theta_o.sin(), 0.0, theta_o.cos());
                let (e1, e2, m) = mirror_frame(&wo);
                let mut mass = vec![0.0; nt * np];
                let mut evals = 0u64;
                for i in 0..nt {
                    let (ca, cb) = (cos_edges[i], cos_edges[i + 1]);
                    let omega = (ca - cb) * dphi;
                    for j in 0..np {
                        let mut sum = 0.0;
                        for a in 0..Self::SUB {
                            let ct = ca + (a as f64 + 0.5) / Self::SUB as f64 * (cb - ca);
                            // |ct| ≤ 1; the max only guards the root against round-off.
                            let st = (1.0 - ct * ct).max(0.0).sqrt();
                            for b in 0..Self::SUB {
                                let phi = (j as f64 + (b as f64 + 0.5) / Self::SUB as f64) * dphi;
                                let wi = st * phi.cos() * e1 + st * phi.sin() * e2 + ct * m;
                                if wi.z <= 0.0 {
                                    continue;
                                }
                                evals += 1;
                                let (f, _) = material.eval(&wi, &wo);
                                let v = f.mean() * wi.z;
                                // A material may return NaN/negative garbage; such a
                                // bin simply gets no tabulated mass (the render checks
                                // finiteness of the result itself).
                                if v.is_finite() && v > 0.0 {
                                    sum += v;
                                }
                            }
                        }
                        mass[i * np + j] = sum / (Self::SUB * Self::SUB) as f64 * omega;
                    }
                }
                let mut row_mass = vec![0.0; nt];
                let mut cond = vec![0.0; nt * (np + 1)];
                for i in 0..nt {
                    row_mass[i] = build_cdf(
                        &mass[i * np..(i + 1) * np],
                        &mut cond[i * (np + 1)..(i + 1) * (np + 1)],
                    );
                }
                let mut marg = vec![0.0; nt + 1];
                let total = build_cdf(&row_mass, &mut marg);
                let mut dens = vec![0.0; nt * np];
                if total > 0.0 {
                    for i in 0..nt {
                        let omega = (cos_edges[i] - cos_edges[i + 1]) * dphi;
                        for j in 0..np {
                            dens[i * np + j] = mass[i * np + j] / total / omega;
                        }
                    }
                }
                (marg, cond, dens, total > 0.0, evals)
            })
            .collect();
        let mut s = LobeSampler {
            theta_edges,
            cos_edges,
            marginal: Vec::new(),
            conditional: Vec::new(),
            density: Vec::new(),
            usable: Vec::new(),
            build_evaluations: 0,
        };
        for (marg, cond, dens, usable, evals) in per_node {
            s.marginal.extend(marg);
            s.conditional.extend(cond);
            s.density.extend(dens);
            s.usable.push(usable);
            s.build_evaluations += evals;
        }
        s
    }

    fn nt(&self) -> usize {
        self.theta_edges.len() - 1
    }

    /// Draws wi for the outgoing direction `wo` (local frame, wo.z > 0): `choice`
    /// picks the defensive cosine part or the table, `u` places the direction (its
    /// stratification carries through both warps). The density is that of
    /// [`pdf`](Self::pdf); wi may lie below the horizon (the integrand is zero there).
    #[inline]
    pub fn sample(&self, wo: &Vec3, choice: f64, u: [f64; 2]) -> DirSample {
        self.sample_in(&LobeFrame::of(wo), choice, u)
    }

    /// [`sample`](Self::sample) for the outgoing direction of `f`.
    #[inline]
    pub fn sample_in(&self, f: &LobeFrame, choice: f64, u: [f64; 2]) -> DirSample {
        let k = f.node;
        let wi = if choice < Self::DEFENSIVE || !self.usable[k] {
            sample_cosine(u[0], u[1])
        } else {
            let nt = self.nt();
            let np = Self::N_PHI;
            let (i, r1) = pick(&self.marginal[k * (nt + 1)..(k + 1) * (nt + 1)], u[0]);
            let base = (k * nt + i) * (np + 1);
            let (j, r2) = pick(&self.conditional[base..base + np + 1], u[1]);
            let (ca, cb) = (self.cos_edges[i], self.cos_edges[i + 1]);
            let ct = ca + r1 * (cb - ca);
            // |ct| ≤ 1; the max only guards the root against round-off.
            let st = (1.0 - ct * ct).max(0.0).sqrt();
            let phi = (j as f64 + r2) * (2.0 * PI / np as f64);
            st * phi.cos() * f.e1 + st * phi.sin() * f.e2 + ct * f.m
        };
        DirSample {
            wi,
            pdf: self.pdf_in(&wi, f),
        }
    }

    /// The density (per unit solid angle) with which [`sample`](Self::sample) draws
    /// `wi` for `wo`.
    #[inline]
    pub fn pdf(&self, wi: &Vec3, wo: &Vec3) -> f64 {
        self.pdf_in(wi, &LobeFrame::of(wo))
    }

    /// [`pdf`](Self::pdf) for the outgoing direction of `f`.
    #[inline]
    pub fn pdf_in(&self, wi: &Vec3, f: &LobeFrame) -> f64 {
        let k = f.node;
        if !self.usable[k] {
            return cosine_pdf(wi);
        }
        let (x1, x2, x3) = (wi.dot(&f.e1), wi.dot(&f.e2), wi.dot(&f.m));
        let mut phi = x2.atan2(x1);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let nt = self.nt();
        let np = Self::N_PHI;
        // θ' bin i has cos θ'_i ≥ cos θ' > cos θ'_{i+1}: compare cosines (descending),
        // no inverse trigonometry. cos(10⁻³) = 1 − 5·10⁻⁷ is well resolved in f64.
        // cos θ' = −1 exactly (wi opposite m) would count past the last edge; φ' = 2π
        // (atan2 of −0) would index one bin past the end: both belong to the last bin.
        let i = self.cos_edges[1..]
            .partition_point(|&c| c >= x3)
            .min(nt - 1);
        let j = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
        let tab = self.density[(k * nt + i) * np + j];
        (1.0 - Self::DEFENSIVE) * tab + Self::DEFENSIVE * cosine_pdf(wi)
    }
}

/// What [`LobeSampler`]'s draws and densities need of an outgoing direction wo: its θo
/// node and the frame about its mirror direction. Every sample of a shading point shares
/// one wo, so a renderer computes this once per point rather than an `acos` and a
/// frame per draw and per density (the same bits either way).
#[derive(Clone, Copy, Debug)]
pub struct LobeFrame {
    node: usize,
    e1: Vec3,
    e2: Vec3,
    m: Vec3,
}

impl LobeFrame {
    /// The node and frame of `wo` (local frame).
    #[inline]
    pub fn of(wo: &Vec3) -> Self {
        // acos is coarse near the pole, but a node spans 3.75°; the clamp keeps a unit
        // vector's z that rounds past 1 out of NaN, the min puts θo = π/2 (or a direction
        // below the horizon, never asked for) in the last node.
        let theta_o = wo.z.clamp(-1.0, 1.0).acos();
        let n = LobeSampler::NODES;
        let node = ((theta_o / FRAC_PI_2 * n as f64) as usize).min(n - 1);
        let (e1, e2, m) = mirror_frame(wo);
        LobeFrame { node, e1, e2, m }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::MaterialSource;
    use crate::rng::{Pcg32, sample_mean};
    use brdfkit_core::direction::spherical;
    use std::sync::Arc;

    fn model(json: &str) -> SceneMaterial {
        SceneMaterial::Model {
            model: Arc::from(brdfkit_models::from_json_str(json).unwrap()),
            source: MaterialSource::Inline,
        }
    }

    /// ∫ p dω over the sphere by a fine midpoint rule in (cos θ, φ) must be 1.
    fn integral_of_pdf(s: &LobeSampler, wo: &Vec3) -> f64 {
        let (nz, nphi) = (2000, 2000);
        let mut sum = 0.0;
        for a in 0..nz {
            let z = -1.0 + (a as f64 + 0.5) * 2.0 / nz as f64;
            let r = (1.0 - z * z).sqrt();
            for b in 0..nphi {
                let phi = (b as f64 + 0.5) * 2.0 * PI / nphi as f64;
                sum += s.pdf(&Vec3::new(r * phi.cos(), r * phi.sin(), z), wo);
            }
        }
        sum * (2.0 / nz as f64) * (2.0 * PI / nphi as f64)
    }

    #[test]
    fn tabulated_density_integrates_to_one() {
        let m =
            model(r#"{"model":"cook-torrance","params":{"rho_d":0.2,"rho_s":0.8,"alpha":0.3}}"#);
        let s = LobeSampler::build(&m);
        for (t, p) in [(0.1, 0.0), (0.7, 1.3), (1.3, -2.0)] {
            let wo = spherical(t, p);
            let i = integral_of_pdf(&s, &wo);
            // Midpoint rule over a piecewise-constant density: error from the cells
            // cut by bin edges, well under 1 %.
            assert!((i - 1.0).abs() < 5e-3, "θo={t}: ∫p = {i}");
        }
    }

    #[test]
    fn sampled_directions_follow_the_density() {
        // Mean of g(wi)/p(wi) over samples estimates ∫ g dω; with g = cos θi above the
        // horizon the exact value is π (a consistency check of sample() against pdf()).
        let m =
            model(r#"{"model":"cook-torrance","params":{"rho_d":0.1,"rho_s":0.9,"alpha":0.2}}"#);
        let s = LobeSampler::build(&m);
        let wo = spherical(0.6, 0.4);
        let mut rng = Pcg32::new(3, 1);
        let (mean, se) = sample_mean(400_000, || {
            let d = s.sample(&wo, rng.uniform(), [rng.uniform(), rng.uniform()]);
            assert!(d.pdf > 0.0, "a sampled direction has zero density");
            assert!((d.wi.norm() - 1.0).abs() < 1e-12);
            if d.wi.z > 0.0 { d.wi.z / d.pdf } else { 0.0 }
        });
        assert!(
            (mean - PI).abs() < 5.0 * se,
            "∫cos = {mean} ± {se}, expected π"
        );
    }

    #[test]
    fn cosine_warp_has_its_density() {
        let mut rng = Pcg32::new(9, 2);
        let (mean, _) = sample_mean(200_000, || {
            let w = sample_cosine(rng.uniform(), rng.uniform());
            assert!((w.norm() - 1.0).abs() < 1e-12 && w.z >= 0.0);
            w.z
        });
        // E[cos θ] under cos θ/π is 2/3.
        assert!((mean - 2.0 / 3.0).abs() < 3e-3);
    }
}
