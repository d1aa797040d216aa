//! The environment: a constant radiance or a latitude-longitude image, its radiance
//! lookup, and its importance-sampling distribution.
//!
//! # Lat-long mapping (Mitsuba 3's `envmap` convention, world y up)
//!
//! A world direction d maps to texture coordinates
//!
//! u = atan2(d.x, −d.z) / (2π)  (wrapped into [0, 1)),   v = acos(d.y) / π,
//!
//! texel (⌊u W⌋, ⌊v H⌋), row 0 at the top (v = 0 is straight up, +y). The inverse is
//! d = (sin θ sin φ, cos θ, −sin θ cos φ) with θ = π v, φ = 2π u. Radiance is the
//! texel's value (piecewise constant, no filtering), which is exactly the function the
//! sampling density below is built for.
//!
//! # Sampling
//!
//! A texel is drawn with probability ∝ Y(texel) · sin θ_row (Y the Rec. 709 luminance,
//! θ_row the polar angle of the row's centre) from a marginal CDF over rows and a
//! conditional CDF per row (pbrt-v3 §14.2.4), then (u, v) uniformly inside it. Since
//! dω = 2π² sin θ du dv, the solid-angle density is
//!
//! p(d) = P(texel) · W H / (2π² sin θ(d)).
//!
//! A constant environment is sampled uniformly over the sphere, p = 1/(4π).

use crate::rng::Pcg32;
use crate::sampling::{pick, sample_uniform_sphere};
use brdfkit_core::{Rgb, Vec3};
use std::f64::consts::PI;
use std::path::PathBuf;

/// Rec. 709 / sRGB luminance of linear RGB.
#[inline]
pub fn luminance(c: &Rgb) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// A lat-long radiance image, already scaled, row-major with row 0 at the top.
#[derive(Clone, Debug)]
pub struct LatLong {
    /// The image file.
    pub path: PathBuf,
    /// Texels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Radiance per texel, row-major.
    pub texels: Vec<Rgb>,
}

/// The environment's radiance (W m⁻² sr⁻¹, linear RGB) in every world direction.
#[derive(Clone, Debug)]
pub enum Environment {
    /// The same radiance from every direction.
    Constant(Rgb),
    /// A lat-long image.
    Image(LatLong),
}

/// (u, v) of a unit world direction.
#[inline]
pub fn direction_to_uv(d: &Vec3) -> (f64, f64) {
    let mut u = d.x.atan2(-d.z) * (0.5 / PI);
    u -= u.floor();
    // |d.y| can exceed 1 by an ulp after normalisation.
    let v = d.y.clamp(-1.0, 1.0).acos() / PI;
    (u, v)
}

/// The unit world direction of (u, v).
#[inline]
pub fn uv_to_direction(u: f64, v: f64) -> Vec3 {
    let (st, ct) = (PI * v).sin_cos();
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    Vec3::new(st * sp, ct, -st * cp)
}

/// The row-major index of the texel of a w × h lat-long image that `d` falls in.
#[inline]
fn texel_index(d: &Vec3, w: usize, h: usize) -> usize {
    let (u, v) = direction_to_uv(d);
    // u < 1 and v ≤ 1: the min keeps v = 1 (straight down) in the last row.
    let x = ((u * w as f64) as usize).min(w - 1);
    let y = ((v * h as f64) as usize).min(h - 1);
    y * w + x
}

impl LatLong {
    #[inline]
    fn texel_of(&self, d: &Vec3) -> usize {
        texel_index(d, self.width, self.height)
    }
}

impl Environment {
    /// Radiance arriving from world direction `d` (unit), i.e. seen looking along d.
    #[inline]
    pub fn radiance(&self, d: &Vec3) -> Rgb {
        match self {
            Environment::Constant(c) => *c,
            Environment::Image(img) => img.texels[img.texel_of(d)],
        }
    }
}

/// The sampling distribution of an [`Environment`], built when a render asks for the
/// `environment` effect.
#[derive(Clone, Debug)]
pub enum EnvDistribution {
    /// Uniform over the sphere (constant environment).
    Uniform,
    /// Luminance × sin θ over texels.
    Image {
        /// Texels per row.
        width: usize,
        /// Rows.
        height: usize,
        /// Marginal CDF over rows (height + 1).
        marginal: Vec<f64>,
        /// Conditional CDF per row (height × (width + 1)).
        conditional: Vec<f64>,
        /// P(texel), row-major.
        pmf: Vec<f64>,
    },
    /// An all-black environment: nothing to sample.
    Black,
}

/// A sampled environment direction.
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    /// World direction towards the environment.
    pub dir: Vec3,
    /// Radiance arriving from it.
    pub radiance: Rgb,
    /// Density of the direction (solid angle measure).
    pub pdf: f64,
}

impl EnvDistribution {
    /// Builds the distribution of `env`.
    pub fn build(env: &Environment) -> Self {
        match env {
            Environment::Constant(c) => {
                if c.max_channel() > 0.0 {
                    EnvDistribution::Uniform
                } else {
                    EnvDistribution::Black
                }
            }
            Environment::Image(img) => {
                let (w, h) = (img.width, img.height);
                let mut weights = vec![0.0; w * h];
                for y in 0..h {
                    let s = ((y as f64 + 0.5) / h as f64 * PI).sin();
                    for x in 0..w {
                        weights[y * w + x] = luminance(&img.texels[y * w + x]) * s;
                    }
                }
                let total: f64 = weights.iter().sum();
                if total <= 0.0 {
                    return EnvDistribution::Black;
                }
                let mut conditional = vec![0.0; h * (w + 1)];
                let mut row_sums = vec![0.0; h];
                for y in 0..h {
                    let row = &weights[y * w..(y + 1) * w];
                    let cdf = &mut conditional[y * (w + 1)..(y + 1) * (w + 1)];
                    cdf[0] = 0.0;
                    for x in 0..w {
                        cdf[x + 1] = cdf[x] + row[x];
                    }
                    row_sums[y] = cdf[w];
                    if cdf[w] > 0.0 {
                        let t = cdf[w];
                        cdf.iter_mut().for_each(|c| *c /= t);
                        cdf[w] = 1.0;
                    }
                }
                let mut marginal = vec![0.0; h + 1];
                for y in 0..h {
                    marginal[y + 1] = marginal[y] + row_sums[y];
                }
                let t = marginal[h];
                marginal.iter_mut().for_each(|c| *c /= t);
                marginal[h] = 1.0;
                let pmf = weights.iter().map(|w| w / total).collect();
                EnvDistribution::Image {
                    width: w,
                    height: h,
                    marginal,
                    conditional,
                    pmf,
                }
            }
        }
    }

    /// False for an all-black environment.
    pub fn can_sample(&self) -> bool {
        !matches!(self, EnvDistribution::Black)
    }

    /// Draws a direction from the environment with two uniforms (rows then columns
    /// of the CDF, each uniform reused for the offset inside its bin).
    #[inline]
    pub fn sample(&self, env: &Environment, u: [f64; 2]) -> Option<EnvSample> {
        match self {
            EnvDistribution::Black => None,
            EnvDistribution::Uniform => {
                let dir = sample_uniform_sphere(u[0], u[1]);
                Some(EnvSample {
                    dir,
                    radiance: env.radiance(&dir),
                    pdf: 0.25 / PI,
                })
            }
            EnvDistribution::Image {
                width,
                height,
                marginal,
                conditional,
                ..
            } => {
                let (w, h) = (*width, *height);
                let (y, ry) = pick(marginal, u[0]);
                let (x, rx) = pick(&conditional[y * (w + 1)..(y + 1) * (w + 1)], u[1]);
                let uu = (x as f64 + rx) / w as f64;
                let vv = (y as f64 + ry) / h as f64;
                let dir = uv_to_direction(uu, vv);
                // The direction's texel is the drawn one away from the texel's borders:
                // no `atan2` and `acos` to find it again.
                let texel = drawn_texel(x, y, w, [rx, ry]);
                let (radiance, pdf) = self.radiance_and_pdf_in(env, &dir, texel);
                if pdf <= 0.0 {
                    // Only at the exact poles (sin θ = 0), a set of measure zero.
                    return None;
                }
                Some(EnvSample { dir, radiance, pdf })
            }
        }
    }

    /// Density (solid angle) of drawing world direction `d`.
    #[inline]
    pub fn pdf(&self, d: &Vec3) -> f64 {
        match self {
            EnvDistribution::Black => 0.0,
            EnvDistribution::Uniform => 0.25 / PI,
            EnvDistribution::Image {
                width, height, pmf, ..
            } => image_pdf(pmf, *width, *height, d, || texel_index(d, *width, *height)),
        }
    }

    /// [`Environment::radiance`] and [`pdf`](Self::pdf) of `d` together: for an image
    /// and its own distribution the texel of `d` is found once (one `atan2` and one
    /// `acos` rather than two of each), with the same bits as the two calls.
    #[inline]
    pub fn radiance_and_pdf(&self, env: &Environment, d: &Vec3) -> (Rgb, f64) {
        self.radiance_and_pdf_in(env, d, None)
    }

    /// [`radiance_and_pdf`](Self::radiance_and_pdf), `texel` being the texel of `d`
    /// when known (the same one `texel_of` would find), else looked up.
    #[inline]
    fn radiance_and_pdf_in(&self, env: &Environment, d: &Vec3, texel: Option<usize>) -> (Rgb, f64) {
        match (self, env) {
            (
                EnvDistribution::Image {
                    width, height, pmf, ..
                },
                Environment::Image(img),
            ) if img.width == *width && img.height == *height => {
                let texel = texel.unwrap_or_else(|| img.texel_of(d));
                let pdf = image_pdf(pmf, *width, *height, d, || texel);
                (img.texels[texel], pdf)
            }
            _ => (env.radiance(d), self.pdf(d)),
        }
    }
}

/// How far (in texels) a drawn (u, v) must lie from its texel's borders for the round
/// trip (u, v) → direction → (u, v) to land in the same texel ([`drawn_texel`]).
///
/// The trip's error: `sin_cos` and the products are within an ulp or two, `atan2` is
/// well conditioned in its ratio (|Δu| ≲ 10⁻¹⁵), and `acos` near the poles turns an ulp
/// of cos θ (1.1·10⁻¹⁶) into at most √(2 · 1.1·10⁻¹⁶) ≈ 1.5·10⁻⁸ rad, 4.7·10⁻⁹ of v:
/// 3·10⁻⁷ of a texel for an image 64 rows high, 10⁻⁵ for one of 2,000 rows. The
/// margin is 10⁻⁴ texel; `drawn_texels_are_the_round_trips` holds it on every texel.
const TRIP_MARGIN: f64 = 1e-4;

/// The texel (x, y) of a draw at offsets (rx, ry) inside it, when the round trip
/// through its direction cannot leave it ([`TRIP_MARGIN`]); `None` near a border.
#[inline]
fn drawn_texel(x: usize, y: usize, w: usize, [rx, ry]: [f64; 2]) -> Option<usize> {
    let inside = |r: f64| (TRIP_MARGIN..=1.0 - TRIP_MARGIN).contains(&r);
    (inside(rx) && inside(ry)).then_some(y * w + x)
}

/// The density (solid angle) of a w × h image distribution at `d`, whose texel `texel`
/// gives (asked only off the poles): pmf · w h / (2π² sin θ), the (u, v) density's
/// Jacobian to solid angle.
#[inline]
fn image_pdf(pmf: &[f64], w: usize, h: usize, d: &Vec3, texel: impl FnOnce() -> usize) -> f64 {
    // |d.y| can exceed 1 by an ulp after normalisation.
    let sin_theta = (1.0 - d.y * d.y).max(0.0).sqrt();
    if sin_theta < 1e-12 {
        // At the poles the density in (u, v) maps to an infinite solid-angle
        // density; such directions have measure zero, report none.
        return 0.0;
    }
    pmf[texel()] * (w * h) as f64 / (2.0 * PI * PI * sin_theta)
}

/// For tests: a random direction estimate of ∫ L dω over the sphere through this
/// distribution (should equal the exact integral).
#[doc(hidden)]
pub fn estimate_total_power(env: &Environment, dist: &EnvDistribution, n: usize, seed: u64) -> Rgb {
    let mut rng = Pcg32::new(seed, 0);
    let mut sum = Rgb::ZERO;
    for _ in 0..n {
        if let Some(s) = dist.sample(env, [rng.uniform(), rng.uniform()]) {
            sum += s.radiance / s.pdf;
        }
    }
    sum / n as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shortcut of [`drawn_texel`] is the round trip's texel: at the margin's four
    /// corners of every texel of a 128 × 64 and a 2048 × 1024 image (rows near the
    /// poles included), and at random offsets.
    #[test]
    fn drawn_texels_are_the_round_trips() {
        let mut rng = crate::rng::Pcg32::new(5, 3);
        for (w, h) in [(128usize, 64usize), (2048, 1024)] {
            let (m, n) = (TRIP_MARGIN, 1.0 - TRIP_MARGIN);
            for y in 0..h {
                for x in (0..w).step_by(if w > 128 { 7 } else { 1 }) {
                    let offsets = [
                        [m, m],
                        [m, n],
                        [n, m],
                        [n, n],
                        [rng.uniform(), rng.uniform()],
                    ];
                    for r in offsets {
                        let Some(t) = drawn_texel(x, y, w, r) else {
                            continue;
                        };
                        let (u, v) = ((x as f64 + r[0]) / w as f64, (y as f64 + r[1]) / h as f64);
                        assert_eq!(
                            texel_index(&uv_to_direction(u, v), w, h),
                            t,
                            "{x} {y} {r:?}"
                        );
                    }
                }
            }
        }
        assert_eq!(drawn_texel(3, 2, 10, [0.5 * TRIP_MARGIN, 0.5]), None);
        assert_eq!(drawn_texel(3, 2, 10, [0.5, 1.0 - 0.5 * TRIP_MARGIN]), None);
    }

    fn image(w: usize, h: usize, f: impl Fn(usize, usize) -> Rgb) -> Environment {
        let mut texels = Vec::new();
        for y in 0..h {
            for x in 0..w {
                texels.push(f(x, y));
            }
        }
        Environment::Image(LatLong {
            path: PathBuf::from("test.exr"),
            width: w,
            height: h,
            texels,
        })
    }

    #[test]
    fn uv_round_trip_and_axes() {
        for &(u, v) in &[(0.1, 0.2), (0.6, 0.9), (0.99, 0.5), (0.25, 0.5)] {
            let d = uv_to_direction(u, v);
            let (u2, v2) = direction_to_uv(&d);
            assert!((u - u2).abs() < 1e-12 && (v - v2).abs() < 1e-12);
        }
        // v = 0 is +y; u = 0 at the equator is −z; u = 1/4 is +x.
        assert!((uv_to_direction(0.0, 0.0) - Vec3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
        assert!((uv_to_direction(0.0, 0.5) - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        assert!((uv_to_direction(0.25, 0.5) - Vec3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn image_pdf_integrates_to_one_and_sampling_recovers_power() {
        // Texel (x, y) radiance 1 + x + 2y; exact ∫ L dω = Σ L_texel Ω_texel with
        // Ω = (2π/W)(cos θ_y − cos θ_{y+1}).
        let (w, h) = (8, 6);
        let env = image(w, h, |x, y| {
            Rgb::new(1.0 + x as f64, 1.0 + 2.0 * y as f64, 0.5)
        });
        let dist = EnvDistribution::build(&env);
        let mut exact = Rgb::ZERO;
        let Environment::Image(img) = &env else {
            unreachable!()
        };
        for y in 0..h {
            let om = 2.0 * PI / w as f64
                * ((y as f64 / h as f64 * PI).cos() - ((y + 1) as f64 / h as f64 * PI).cos());
            for x in 0..w {
                exact += img.texels[y * w + x] * om;
            }
        }
        // ∫ p dω = ∫∫ p sin θ dθ dφ by a fine midpoint rule in (θ, φ) (p sin θ is
        // bounded; p itself has a 1/sin θ factor at the poles).
        let n = 1200;
        let mut ip = 0.0;
        for a in 0..n {
            let th = (a as f64 + 0.5) * PI / n as f64;
            let (st, ct) = th.sin_cos();
            for b in 0..n {
                let p = (b as f64 + 0.5) * 2.0 * PI / n as f64;
                ip += dist.pdf(&Vec3::new(st * p.cos(), ct, st * p.sin())) * st;
            }
        }
        ip *= (PI / n as f64) * (2.0 * PI / n as f64);
        assert!((ip - 1.0).abs() < 1e-3, "∫p = {ip}");
        let est = estimate_total_power(&env, &dist, 400_000, 5);
        for c in 0..3 {
            assert!(
                ((est[c] - exact[c]) / exact[c]).abs() < 1e-2,
                "{est:?} vs {exact:?}"
            );
        }
    }

    #[test]
    fn black_environment_has_no_distribution() {
        assert!(!EnvDistribution::build(&Environment::Constant(Rgb::ZERO)).can_sample());
        let env = image(4, 2, |_, _| Rgb::ZERO);
        assert!(!EnvDistribution::build(&env).can_sample());
    }
}
