//! The sheen lobe of `KHR_materials_sheen` (Khronos, *KHR_materials_sheen*, "Implementation
//! Notes"): the "Charlie" fibre distribution of Estevez & Kulla, "Production Friendly
//! Microfacet Sheen BRDF" (SIGGRAPH 2017 course), its two visibility terms, and the table
//! of its directional albedo E that the albedo scaling of the base needs.
//!
//! With α = sheenRoughness² (the Khronos glTF Sample Viewer's `alphaG`, as in three.js and
//! Filament) and sin²θh = hx² + hy²:
//!
//! ```text
//! D(h)  = (2 + 1/α) · (sin²θh)^(1/(2α)) / (2π)
//! V     = 1 / ((1 + Λ(cos θo) + Λ(cos θi)) · 4 cos θi cos θo)           (charlie)
//! V     = 1 / (4 (cos θi + cos θo − cos θi cos θo))                       (ashikhmin)
//! Λ(μ)  = exp(l(μ))                      for μ < 0.5
//!       = exp(2 l(0.5) − l(1 − μ))       otherwise
//! l(x)  = a / (1 + b x^c) + d x + e,  (a..e) = mix(P0, P1, (1 − α)²)
//! ```
//!
//! Both visibilities are clamped to at most 1, as the reference implementations do (the
//! Khronos glTF Sample Viewer's `V_Sheen` and three.js's `V_Neubelt` saturate them): the
//! formulas diverge at the horizon (Charlie's V reaches ~1e4 at cos θ = 1e-12, where a
//! measured table still has cells), and unclamped the lobe dominates any fit there.
//!
//! with P0 = (21.5473, 3.82987, 0.19823, −1.97760, −4.32054) and P1 = (25.3245, 3.32435,
//! 0.16801, −1.27393, −4.85967) (Estevez & Kulla's fit of the fibre shadowing, as the
//! extension's notes print it). The specification calls the Charlie visibility the
//! reference and names the Ashikhmin-Premože (2007) form as the cheaper alternative; both
//! are the structural choice [`SheenVisibility`].
//!
//! **E**, the directional albedo E(μ) = ∫ D V cos θi dωi of the lobe with sheenColor 1, is
//! what the base is scaled by (`1 − max(sheenColor) · E`). The specification points to a
//! precomputed table (Enterprise PBR §6.2.3 for Charlie, Filament's `cmgen` for
//! Ashikhmin); this module computes its own, per visibility, by quadrature of the very
//! lobe it scales (so the layering's energy balance holds to the table's accuracy):
//! [`E_ROUGHNESS_KNOTS`] knots in sheenRoughness over [`SHEEN_ROUGHNESS_MIN`, 1] and
//! [`E_MU_KNOTS`] in μ = cos θ over [0, 1] (μ = 0 evaluated at 1e-4), each by the graded rule of
//! [`sheen_albedo_quadrature`], interpolated bilinearly in (sheenRoughness, √μ). Its
//! accuracy against the project's adaptive albedo quadrature is a test (within 2e-3 +
//! 0.3 %, the interpolation's error at the narrowest lobe near the horizon).
//!
//! **E exceeds 1** for narrow lobes near the horizon: Estevez & Kulla's fitted Λ is not
//! exact there, and the tabulated Charlie E reaches 1.65 at sheenRoughness 0.07, μ = 1.7e-3 (with V clamped to 1)
//! (E > 1 only for sheenRoughness < 0.3 and μ < 0.06, i.e. θ > 86.5°; test
//! `charlie_albedo_exceeds_one_only_for_narrow_lobes_at_grazing`). [`sheen_albedo`] clamps
//! E to 1, as the reference's lookup texture (an 8-bit image) does, so the albedo scaling
//! of the base stays in [0, 1] and the base is hidden there rather than negative.

use brdfkit_core::quadrature::gauss_legendre;
use brdfkit_core::{Brdf, Rgb, Vec3};
use std::f64::consts::PI;
use std::sync::OnceLock;

/// The sheen visibility term (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SheenVisibility {
    /// Estevez & Kulla's fitted fibre shadowing: the specification's reference.
    Charlie,
    /// Ashikhmin & Premože 2007, 1/(4 (cos θi + cos θo − cos θi cos θo)).
    Ashikhmin,
}

brdfkit_core::named_choice!(SheenVisibility, "sheen visibility", {
    Charlie => "charlie",
    Ashikhmin => "ashikhmin",
});

/// The smallest sheenRoughness: three.js clamps to it, and below it the lobe is a
/// grazing spike narrower than the E table can resolve.
pub const SHEEN_ROUGHNESS_MIN: f64 = 0.07;
/// Knots of the E table in sheenRoughness.
pub const E_ROUGHNESS_KNOTS: usize = 32;
/// Knots of the E table in √μ (μ = cos θ): dense near the horizon, where E of a narrow
/// lobe varies fastest.
pub const E_MU_KNOTS: usize = 49;

const P0: [f64; 5] = [21.5473, 3.82987, 0.19823, -1.97760, -4.32054];
const P1: [f64; 5] = [25.3245, 3.32435, 0.16801, -1.27393, -4.85967];

/// l(x) and ∂l/∂α (module doc).
fn l_and_da(x: f64, alpha: f64) -> (f64, f64) {
    let t = (1.0 - alpha) * (1.0 - alpha);
    let dt_da = -2.0 * (1.0 - alpha);
    let p: [f64; 5] = std::array::from_fn(|k| P0[k] + (P1[k] - P0[k]) * t);
    let dp: [f64; 5] = std::array::from_fn(|k| P1[k] - P0[k]);
    let [a, b, c, d, _] = p;
    let xc = x.powf(c);
    let den = 1.0 + b * xc;
    let l = a / den + d * x + p[4];
    // ∂(x^c)/∂c = x^c ln x, which tends to 0 at x = 0.
    let xc_ln = if x > 0.0 { xc * x.ln() } else { 0.0 };
    let dl_dt =
        dp[0] / den - a * (dp[1] * xc + b * xc_ln * dp[2]) / (den * den) + dp[3] * x + dp[4];
    (l, dl_dt * dt_da)
}

/// Λ(μ) and ∂Λ/∂α (module doc).
fn lambda_and_da(mu: f64, alpha: f64) -> (f64, f64) {
    if mu < 0.5 {
        let (l, dl) = l_and_da(mu, alpha);
        let v = l.exp();
        (v, v * dl)
    } else {
        let (lh, dlh) = l_and_da(0.5, alpha);
        // A unit vector's z can round to just above 1 (1 + 4e-16 from a MERL cell).
        let (l1, dl1) = l_and_da((1.0 - mu).max(0.0), alpha);
        let v = (2.0 * lh - l1).exp();
        (v, v * (2.0 * dlh - dl1))
    }
}

/// D·V of the sheen lobe at one pair (cosines zi, zo > 0, sin²θh = `sin2h`) and
/// ∂(D·V)/∂sheenRoughness.
pub(crate) fn sheen_dv(
    vis: SheenVisibility,
    sheen_roughness: f64,
    zi: f64,
    zo: f64,
    sin2h: f64,
) -> (f64, f64) {
    let alpha = sheen_roughness * sheen_roughness;
    let inv = 1.0 / alpha;
    if sin2h <= 0.0 {
        return (0.0, 0.0);
    }
    let d = (2.0 + inv) * sin2h.powf(0.5 * inv) / (2.0 * PI);
    // ∂ln D/∂α = −(1/α²)/(2 + 1/α) − ln(sin²θh)/(2α²).
    let mut dln_da = -(inv * inv) / (2.0 + inv) - sin2h.ln() * 0.5 * inv * inv;
    let v = match vis {
        SheenVisibility::Charlie => {
            let (li, dli) = lambda_and_da(zi, alpha);
            let (lo, dlo) = lambda_and_da(zo, alpha);
            let s = 1.0 + li + lo;
            let v = 1.0 / (s * 4.0 * zi * zo);
            if v < 1.0 {
                dln_da -= (dli + dlo) / s;
            }
            v.min(1.0)
        }
        SheenVisibility::Ashikhmin => (1.0 / (4.0 * (zi + zo - zi * zo))).min(1.0),
    };
    let dv = d * v;
    (dv, dv * dln_da * 2.0 * sheen_roughness)
}

/// The sheen lobe alone with sheenColor 1, for the E table and its tests.
#[derive(Debug, Clone, Copy)]
pub struct SheenLobe {
    /// The visibility term.
    pub vis: SheenVisibility,
    /// sheenRoughness.
    pub roughness: f64,
}

impl Brdf for SheenLobe {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let h = brdfkit_core::geometry::half_vector(wi, wo);
        Rgb::splat(sheen_dv(self.vis, self.roughness, wi.z, wo.z, h.x * h.x + h.y * h.y).0)
    }
}

/// The E table of one visibility (module doc): `e[i * E_MU_KNOTS + j]` at roughness
/// knot i and μ knot j.
struct AlbedoTable {
    e: Vec<f64>,
}

fn roughness_knot(i: usize) -> f64 {
    SHEEN_ROUGHNESS_MIN + (1.0 - SHEEN_ROUGHNESS_MIN) * i as f64 / (E_ROUGHNESS_KNOTS - 1) as f64
}

/// E(μ) of `lobe`: μi = cos θi over graded segments (edges 0, 1e-6, 1e-5, …, 0.3, 0.6, 1;
/// Gauss-Legendre of order 12 in each), φi by 64-point Gauss-Legendre over [0, π] (the
/// lobe is symmetric about the plane of wo). The grading is needed because the Charlie
/// visibility's Λ(μ) = exp(a/(1 + b μ^c) + …) with c ≈ 0.2 varies over decades of μ
/// near the horizon.
pub fn sheen_albedo_quadrature(lobe: &SheenLobe, mu: f64) -> f64 {
    const EDGES: [f64; 11] = [0.0, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3, 0.6, 1.0];
    let (x, w) = gauss_legendre(12);
    let (xp, wp) = gauss_legendre(64);
    let mu = mu.max(1e-4);
    let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
    let mut sum = 0.0;
    for seg in EDGES.windows(2) {
        let (a, b) = (seg[0], seg[1]);
        for (xt, wt) in x.iter().zip(&w) {
            let zi = a + 0.5 * (b - a) * (xt + 1.0);
            let st = (1.0 - zi * zi).sqrt();
            let mut ring = 0.0;
            for (xf, wf) in xp.iter().zip(&wp) {
                let p = 0.5 * PI * (xf + 1.0);
                let wi = Vec3::new(st * p.cos(), st * p.sin(), zi);
                ring += wf * lobe.eval(&wi, &wo)[0];
            }
            // dμ = (b − a)/2 dx, dφ = π/2 dx, both halves of the φ circle.
            sum += wt * 0.5 * (b - a) * zi * ring * 0.5 * PI * 2.0;
        }
    }
    sum
}

fn table(vis: SheenVisibility) -> &'static AlbedoTable {
    static CHARLIE: OnceLock<AlbedoTable> = OnceLock::new();
    static ASHIKHMIN: OnceLock<AlbedoTable> = OnceLock::new();
    let cell = match vis {
        SheenVisibility::Charlie => &CHARLIE,
        SheenVisibility::Ashikhmin => &ASHIKHMIN,
    };
    cell.get_or_init(|| {
        let mut e = Vec::with_capacity(E_ROUGHNESS_KNOTS * E_MU_KNOTS);
        for i in 0..E_ROUGHNESS_KNOTS {
            let lobe = SheenLobe {
                vis,
                roughness: roughness_knot(i),
            };
            for j in 0..E_MU_KNOTS {
                let t = j as f64 / (E_MU_KNOTS - 1) as f64;
                e.push(sheen_albedo_quadrature(&lobe, t * t));
            }
        }
        AlbedoTable { e }
    })
}

/// E(μ, sheenRoughness) from the table, bilinear in (sheenRoughness, √μ) and clamped to
/// at most 1 (module doc), and its derivative in sheenRoughness.
pub fn sheen_albedo(vis: SheenVisibility, sheen_roughness: f64, mu: f64) -> (f64, f64) {
    let (e, de) = sheen_albedo_unclamped(vis, sheen_roughness, mu);
    if e > 1.0 { (1.0, 0.0) } else { (e, de) }
}

/// The table's bilinear interpolation before the clamp of [`sheen_albedo`].
pub fn sheen_albedo_unclamped(vis: SheenVisibility, sheen_roughness: f64, mu: f64) -> (f64, f64) {
    let t = table(vis);
    let span = (1.0 - SHEEN_ROUGHNESS_MIN) / (E_ROUGHNESS_KNOTS - 1) as f64;
    let u =
        ((sheen_roughness - SHEEN_ROUGHNESS_MIN) / span).clamp(0.0, (E_ROUGHNESS_KNOTS - 1) as f64);
    let v = mu.clamp(0.0, 1.0).sqrt() * (E_MU_KNOTS - 1) as f64;
    let i = (u.floor() as usize).min(E_ROUGHNESS_KNOTS - 2);
    let j = (v.floor() as usize).min(E_MU_KNOTS - 2);
    let (fu, fv) = (u - i as f64, v - j as f64);
    let at = |a: usize, b: usize| t.e[a * E_MU_KNOTS + b];
    let e0 = at(i, j) + (at(i, j + 1) - at(i, j)) * fv;
    let e1 = at(i + 1, j) + (at(i + 1, j + 1) - at(i + 1, j)) * fv;
    (e0 + (e1 - e0) * fu, (e1 - e0) / span)
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_core::direction::spherical;
    use brdfkit_core::quadrature::{AlbedoQuadrature, Pole, directional_albedo};

    #[test]
    fn the_table_matches_the_adaptive_albedo_quadrature() {
        let q = AlbedoQuadrature::default().with_pole(Pole::Normal);
        let mut worst: f64 = 0.0;
        for vis in SheenVisibility::ALL {
            for r in [0.07, 0.2, 0.45, 0.8, 1.0] {
                for t in [0.0, 0.5, 1.0, 1.3, 1.5] {
                    let lobe = SheenLobe { vis, roughness: r };
                    let want = directional_albedo(&lobe, &spherical(t, 0.0), &q)[0];
                    let got = sheen_albedo_unclamped(vis, r, t.cos()).0;
                    worst = worst.max((want - got).abs());
                    assert!(
                        (want - got).abs() < 2e-3 + 3e-3 * want,
                        "{vis:?} r {r} θ {t}: {want} vs {got}"
                    );
                }
            }
        }
        eprintln!("largest |E table − adaptive quadrature| = {worst:.2e}");
    }

    #[test]
    fn charlie_albedo_exceeds_one_only_for_narrow_lobes_at_grazing() {
        let t = table(SheenVisibility::Charlie);
        let mut worst = (0.0, 0.0, 0.0);
        for i in 0..E_ROUGHNESS_KNOTS {
            for j in 0..E_MU_KNOTS {
                let e = t.e[i * E_MU_KNOTS + j];
                let mu = (j as f64 / (E_MU_KNOTS - 1) as f64).powi(2);
                assert!(e >= 0.0);
                if e > 1.0 {
                    assert!(
                        roughness_knot(i) < 0.3 && mu < 0.06,
                        "E {e} at r {} μ {mu}",
                        roughness_knot(i)
                    );
                    if e > worst.0 {
                        worst = (e, roughness_knot(i), mu);
                    }
                }
                assert!(sheen_albedo(SheenVisibility::Charlie, roughness_knot(i), mu).0 <= 1.0);
            }
        }
        eprintln!(
            "largest tabulated E = {:.3} at sheenRoughness {} μ {:.1e}",
            worst.0, worst.1, worst.2
        );
    }

    #[test]
    fn lambda_gradient_matches_finite_differences() {
        for mu in [0.05, 0.3, 0.5, 0.7, 0.99] {
            for a in [0.01, 0.3, 0.9] {
                let h = 1e-6;
                let fd = (lambda_and_da(mu, a + h).0 - lambda_and_da(mu, a - h).0) / (2.0 * h);
                let an = lambda_and_da(mu, a).1;
                assert!(
                    (fd - an).abs() <= 1e-6 * an.abs().max(1e-9),
                    "{mu} {a}: {fd} {an}"
                );
            }
        }
    }
}
