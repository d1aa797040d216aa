//! The per-θi tables of a written file: the VNDF that parameterises each slice, and the
//! value (`rgb`, `luminance`, `valid`) tables on the warped grid (Dupuy & Jakob 2018,
//! "An Adaptive Parameterization for Efficient Material Acquisition and Rendering",
//! §4–5).
//!
//! - The VNDF of wi is D_wi(m) = D(m) ⟨wi, m⟩₊ / σ(wi) (Heitz 2014, "Understanding the
//!   Masking-Shadowing Function", eq. 38, with G₁ = cos θi / σ). The `vndf` table holds
//!   it as a density over the unit square of (u_θm, u_φm), u_θ = √(2θ/π) and
//!   u_φ = (φm − φi + π)/2π in an isotropic file, (φm + π)/2π (the absolute azimuth)
//!   in an anisotropic one (`measured.cpp`): times the Jacobian |dω/du| = 2π² u_θ sin θm of that map
//!   (the factor `measured.cpp` divides its pdf by). The reader normalises it.
//!   It is mixed with a uniform density ([`UNIFORM_MIX`]).
//! - Sample node s = (x, y)/(n − 1) of the value grid stands for the half vector
//!   u_m = W(s), W the VNDF warp of the slice, and for wo = 2⟨wi, m⟩m − wi: the paper's
//!   measurement positions. W is found here as the inverse of the reader's own
//!   [`Warp2D::invert`] (bisection: its y depends on u_φ alone, its x is monotone in
//!   u_θ at fixed u_φ), so a file read back evaluates to the stored node exactly where
//!   the measurement was taken.
//! - What Mitsuba's `measured` returns from `eval` (the stored value times the Jacobian
//!   below, no further factor) is, by Mitsuba's `BSDF::eval` contract, f · cos θo: the
//!   product its integrators use. The quantity written is therefore f(wi, wo) · cos θo,
//!   which makes Mitsuba render the source (tests/write_mitsuba.rs, the render test).
//! - With the `jacobian` flag Mitsuba returns value · D(m) / (4σ(wi)) (the VNDF's
//!   pdf of wo, D_wi(m) / (4⟨wi, m⟩), since σ = cos θi / G₁); the stored value is
//!   therefore f(wi, wo) · cos θo · 4σ(wi) / D(m), with D and σ the reader's
//!   interpolants of the written `ndf` and `sigma` tables.
//! - `luminance`: Mitsuba samples the value grid by it before the VNDF warp, so its
//!   pdf of wo is lum(s) · p_u(u_m) / (2π² u sin θm · 4⟨wi, m⟩) (`measured.cpp`'s
//!   `pdf`), p_u the VNDF table's density. The table holds the Rec. 709 luminance of
//!   f · cos θo times 4⟨wi, m⟩ · 2π² u sin θm / p_u(u_m), which makes that pdf
//!   proportional to the luminance of f · cos θo: Mitsuba's sample weights are then
//!   nearly constant.
//! - `valid` marks the nodes whose wo lies above the horizon. Below it there is no
//!   measurement, and those nodes store 0: the value of f · cos θo at the horizon (its
//!   limit for any bounded f), so the interpolated f · cos θo falls towards the horizon
//!   instead of rising. Storing anything divided by D there is unsafe: the last column
//!   of the grid (u_θ = 1, θm = 90°, where wo = 2⟨wi, m⟩m − wi is at or below the
//!   horizon for every wi) has D at its floor, ~1e-6 of its maximum, and a stored value
//!   g · 4σ/D of a node there is multiplied back by the reader with the D of the point
//!   evaluated, up to 10³–10⁴ × larger inside the last cell. An earlier version stored
//!   the source at wo lifted to 0.06° above the horizon (f · 1e-3 · 4σ/D, 10² – 5·10⁵
//!   in the file of a Cook-Torrance table); read back, the file gave 70 × the source at
//!   (θi 90°, θo 86°) and up to 300 × it at random pairs above 1° (issue 24,
//!   docs/rgl.md "Near the horizon").

use crate::warp::Warp2D;
use brdfkit_core::{Brdf, Rgb, Vec3};
use std::f64::consts::PI;

use crate::bsdf::{u2phi, u2theta};
use brdfkit_core::direction::spherical;

/// The VNDF table is D_wi mixed with this much of the uniform density over the
/// hemisphere of half vectors (1/2π, D_wi integrating to 1): a departure from the
/// paper, which warps by D_wi alone. A narrow lobe otherwise pulls nearly every value
/// node into the peak and leaves the rest of the hemisphere to a few cells; with equal
/// parts, half the nodes cover the hemisphere evenly. Measured (tests/write.rs figures,
/// 20,000 pairs above 1°, 8 slices, 32²): see docs/rgl.md. The mixture is a density
/// over solid angle like D_wi, so it vanishes at the pole of the u map as D_wi does
/// and Mitsuba's pdf stays bounded (its χ² test).
const UNIFORM_MIX: f64 = 1.0;

/// Bisection steps of the inverse warp (2⁻⁴⁸ ≈ 4e-15 of the unit interval).
const BISECT: usize = 48;

/// The VNDF density of the slice of incident direction `wi` on a `res` × `res` grid
/// (rows u_φ, columns u_θ; u_φ relative to wi's azimuth in an isotropic file, where wi
/// is at φ = 0, absolute in an anisotropic one), with `d` the NDF at (u_θ, u_φ), mixed
/// with the uniform density ([`UNIFORM_MIX`]), in f32, floored at `floor` × its maximum
/// so every row can be inverted.
pub(crate) fn vndf_slice(
    d: &dyn Fn([f64; 2]) -> f64,
    sigma: f64,
    wi: Vec3,
    res: usize,
    floor: f64,
) -> Vec<f32> {
    let step = 1.0 / (res - 1) as f64;
    let mut out: Vec<f64> = Vec::with_capacity(res * res);
    for y in 0..res {
        let uy = y as f64 * step;
        let phi = u2phi(uy);
        for x in 0..res {
            let u = x as f64 * step;
            let th = u2theta(u);
            let m = spherical(th, phi);
            let jac = 2.0 * PI * PI * u * th.sin();
            let d_wi = d([u, uy]) * wi.dot(&m).max(0.0) / sigma;
            out.push((d_wi + UNIFORM_MIX / (2.0 * PI)) * jac);
        }
    }
    let max = out.iter().copied().fold(0.0, f64::max);
    let lo = if max > 0.0 { floor * max } else { 1.0 };
    out.iter().map(|&v| v.max(lo) as f32).collect()
}

/// The half-vector coordinates u_m = W(s) of sample position `s` under the slice's
/// parameters `p`: the inverse of [`Warp2D::invert`] by bisection.
pub(crate) fn forward(vndf: &Warp2D, s: [f64; 2], p: &[f64]) -> [f64; 2] {
    let solve = |target: f64, f: &dyn Fn(f64) -> f64| {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..BISECT {
            let mid = 0.5 * (lo + hi);
            if f(mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    let uy = solve(s[1], &|u| vndf.invert([0.5, u], p).0[1]);
    let ux = solve(s[0], &|u| vndf.invert([u, uy], p).0[0]);
    [ux, uy]
}

/// Rec. 709 luminance of linear RGB.
#[inline]
pub(crate) fn luminance(c: &Rgb) -> f64 {
    0.2126 * c.0[0] + 0.7152 * c.0[1] + 0.0722 * c.0[2]
}

/// One slice's values: `rgb` (3 × n × n, channel-major), `luminance` (n × n), the
/// `valid` flags (n × n) and the number of negative source values stored as 0.
pub(crate) struct SliceValues {
    pub rgb: Vec<f32>,
    pub luminance: Vec<f32>,
    pub valid: Vec<bool>,
    pub clamped: usize,
    /// A non-finite source value, if any: (wi, wo).
    pub non_finite: Option<(Vec3, Vec3)>,
}

/// What a slice's value tables need.
pub(crate) struct SliceSpec<'a> {
    pub source: &'a dyn Brdf,
    /// The slice's VNDF warp and its parameters (φi, θi) as the reader passes them.
    pub vndf: &'a Warp2D,
    pub params: [f64; 2],
    /// The incident direction the source is evaluated at (the slice's, or just above
    /// the horizon for a θi = 90° slice): at φ = 0 in an isotropic file (u_φ relative),
    /// at the slice's φi in an anisotropic one (u_φ absolute).
    pub wi: Vec3,
    /// D(u_m) / (4σ(wi)) of the reader, from u_m.
    pub jacobian: &'a dyn Fn([f64; 2]) -> f64,
    /// The value grid, n × n.
    pub n: usize,
}

/// The value tables of one slice (see the module's notes).
pub(crate) fn values_slice(spec: &SliceSpec) -> SliceValues {
    let n = spec.n;
    let wi = spec.wi;
    let step = 1.0 / (n - 1) as f64;
    let mut out = SliceValues {
        rgb: vec![0.0; 3 * n * n],
        luminance: vec![0.0; n * n],
        valid: vec![false; n * n],
        clamped: 0,
        non_finite: None,
    };
    let mut lum = vec![0.0f64; n * n];
    for y in 0..n {
        for x in 0..n {
            let k = y * n + x;
            let um = forward(spec.vndf, [x as f64 * step, y as f64 * step], &spec.params);
            let (_, pdf_u) = spec.vndf.invert(um, &spec.params);
            let th_m = u2theta(um[0]);
            let m = spherical(th_m, u2phi(um[1]));
            let wo = m * (2.0 * wi.dot(&m)) - wi;
            out.valid[k] = wo.z > 0.0;
            if !out.valid[k] {
                // f · cos θo at the horizon (module notes); the luminance floor below
                // keeps the node reachable by Mitsuba's sampling.
                continue;
            }
            let f = spec.source.eval(&wi, &wo);
            if !f.is_finite() && out.non_finite.is_none() {
                out.non_finite = Some((wi, wo));
            }
            out.clamped += f.0.iter().filter(|&&c| c < 0.0).count();
            let scale = wo.z / (spec.jacobian)(um);
            let stored = f.map(|c| c.max(0.0) * scale);
            for c in 0..3 {
                out.rgb[c * n * n + k] = stored.0[c] as f32;
            }
            // The luminance pdf that makes Mitsuba's total pdf ∝ Y(f · cos θo): its pdf
            // is lum(s) · p_u(u_m) / (J(u_m) · 4⟨wi, m⟩), J = 2π² u sin θm (≥ 1e-6).
            let jac_u = (2.0 * PI * PI * um[0] * th_m.sin()).max(1e-6);
            let fcos = f.map(|c| c.max(0.0) * wo.z);
            lum[k] = luminance(&fcos) * 4.0 * wi.dot(&m).max(0.0) * jac_u / pdf_u.max(1e-30);
        }
    }
    // Mitsuba normalises the luminance per slice; a floor keeps every cell reachable
    // (and a black slice uniform) so its warp stays invertible.
    let max = lum.iter().copied().fold(0.0, f64::max);
    let lo = if max > 0.0 { 1e-3 * max } else { 1.0 };
    out.luminance = lum.iter().map(|&v| v.max(lo) as f32).collect();
    out
}
