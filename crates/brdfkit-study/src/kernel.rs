//! Cook-Torrance GGX with exact conductor Fresnel and separable Smith masking, written
//! as one branch-free loop over structure-of-arrays geometry, in `f32` and in `f64`
//! (the same code through a macro). The study compares the `f32` kernel against the
//! `f64` model of `brdfkit-models` (error introduced, time saved); the `f64` copy
//! separates what the precision buys from what the loop shape buys. The peer benchmark
//! (`benches/peers.rs`) uses the same kernels against Mitsuba 3's `llvm_ad_rgb`.
//!
//! f_r = ρd/π + ρs · D(h) · F(cos θd) · V(wi, wo), for cos θi > 0 and cos θo > 0, else 0:
//!
//! - GGX (Walter et al. 2007, eq. 33): D = 1/(π α² s²), s = (hx² + hy²)/α² + hz²;
//! - separable Smith with GGX's Λ = (√(1 + q) − 1)/2, q = α² tan²θ (Walter et al. eq. 34;
//!   Heitz 2014 eq. 86): G1 = 1/(1 + Λ) = 2/(1 + √(1 + q)), and multiplying by cos θ,
//!   G1(v)/cos θv = 2/(cos θv + √(cos²θv + α²(1 − cos²θv))); so the whole
//!   G/(4 cos θi cos θo) is V = 1/((zi + √(zi² + α²(1 − zi²)))(zo + √(zo² + α²(1 − zo²))))
//!   — no division by cos², no 0 · ∞ at grazing angles, the same function as the model's
//!   D G F/(4 cos θi cos θo) up to round-off;
//! - conductor Fresnel, unpolarised, η + ik (Möller 1988, as Mitsuba 3's
//!   `fresnel_conductor`; `brdfkit_core::scattering::fresnel::conductor`), at cos θd.

use brdfkit_core::GeomSlice;
use rayon::prelude::*;
use std::f64::consts::FRAC_1_PI;

/// Parameters of the kernel (as the `cook-torrance` model's, isotropic).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GgxConductor {
    pub rho_d: [f64; 3],
    pub rho_s: [f64; 3],
    pub alpha: f64,
    pub eta: [f64; 3],
    pub k: [f64; 3],
}

impl GgxConductor {
    /// The same material as a `cook-torrance` model (GGX, separable Smith, conductor).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({"model": "cook-torrance", "params": {
            "rho_d": self.rho_d, "rho_s": self.rho_s, "alpha": self.alpha,
            "distribution": "ggx", "masking": "smith-separable",
            "fresnel": {"conductor": {"eta": self.eta, "k": self.k}}}})
    }
}

/// The geometry columns the kernel reads, in one precision.
#[derive(Debug, Clone, Default)]
pub struct Geom<T> {
    pub wi_z: Vec<T>,
    pub wo_z: Vec<T>,
    pub h_x: Vec<T>,
    pub h_y: Vec<T>,
    pub h_z: Vec<T>,
    pub cos_d: Vec<T>,
}

/// Output planes (R, G, B) of the kernel.
#[derive(Debug, Clone, Default)]
pub struct Planes<T> {
    pub r: Vec<T>,
    pub g: Vec<T>,
    pub b: Vec<T>,
}

impl<T: Copy + Default> Planes<T> {
    /// Planes of `n` zeros.
    pub fn zeros(n: usize) -> Self {
        Planes {
            r: vec![T::default(); n],
            g: vec![T::default(); n],
            b: vec![T::default(); n],
        }
    }
}

/// Cells per rayon task of the parallel kernels.
pub const CHUNK: usize = 8192;

macro_rules! kernel {
    ($t:ty, $from:ident, $eval:ident, $eval_par:ident, $body:ident, $avx2:ident, $avx512:ident) => {
        /// Copies (and rounds, for `f32`) the columns the kernel reads.
        pub fn $from(g: &GeomSlice<'_>) -> Geom<$t> {
            let c = |v: &[f64]| v.iter().map(|&x| x as $t).collect::<Vec<$t>>();
            Geom {
                wi_z: c(g.wi_z),
                wo_z: c(g.wo_z),
                h_x: c(g.h_x),
                h_y: c(g.h_y),
                h_z: c(g.h_z),
                cos_d: c(g.cos_d),
            }
        }

        /// Evaluates the kernel over the cells `start..start + out[0].len()` of `g`, into
        /// `out` (one slice per channel), with the widest vector instructions the
        /// processor has: the crate is compiled for baseline x86-64 (SSE2: 2 f64 or 4 f32
        /// lanes), so copies of the loop compiled for AVX2 + FMA and for AVX-512 are
        /// chosen at run time (`is_x86_feature_detected!`).
        pub fn $eval(p: &GgxConductor, g: &Geom<$t>, start: usize, out: [&mut [$t]; 3]) {
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                {
                    // SAFETY: the features the copy was compiled for are present.
                    return unsafe { $avx512(p, g, start, out) };
                }
                if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                {
                    // SAFETY: as above.
                    return unsafe { $avx2(p, g, start, out) };
                }
            }
            $body(p, g, start, out)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        fn $avx2(p: &GgxConductor, g: &Geom<$t>, start: usize, out: [&mut [$t]; 3]) {
            $body(p, g, start, out)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
        fn $avx512(p: &GgxConductor, g: &Geom<$t>, start: usize, out: [&mut [$t]; 3]) {
            $body(p, g, start, out)
        }

        #[inline(always)]
        fn $body(p: &GgxConductor, g: &Geom<$t>, start: usize, out: [&mut [$t]; 3]) {
            let n = out[0].len();
            let a2 = (p.alpha * p.alpha) as $t;
            let inv_a2 = 1.0 / a2;
            // D's constant and the horizon-free factor; the Lambertian term per channel.
            let d_norm = (FRAC_1_PI / (p.alpha * p.alpha)) as $t;
            let diff: [$t; 3] = std::array::from_fn(|c| (p.rho_d[c] * FRAC_1_PI) as $t);
            let spec: [$t; 3] = std::array::from_fn(|c| p.rho_s[c] as $t);
            // Conductor constants: η² − k² and 4η²k².
            let e2k2: [$t; 3] =
                std::array::from_fn(|c| (p.eta[c] * p.eta[c] - p.k[c] * p.k[c]) as $t);
            let four_e2k2: [$t; 3] =
                std::array::from_fn(|c| (4.0 * p.eta[c] * p.eta[c] * p.k[c] * p.k[c]) as $t);
            let (wi_z, wo_z) = (&g.wi_z[start..start + n], &g.wo_z[start..start + n]);
            let (hx, hy, hz) = (
                &g.h_x[start..start + n],
                &g.h_y[start..start + n],
                &g.h_z[start..start + n],
            );
            let cd = &g.cos_d[start..start + n];
            let [or, og, ob] = out;
            for i in 0..n {
                let (zi, zo) = (wi_z[i], wo_z[i]);
                let s = (hx[i] * hx[i] + hy[i] * hy[i]) * inv_a2 + hz[i] * hz[i];
                let d = d_norm / (s * s);
                let vi = zi + (zi * zi + a2 * (1.0 - zi * zi)).sqrt();
                let vo = zo + (zo * zo + a2 * (1.0 - zo * zo)).sqrt();
                let dv = d / (vi * vo);
                let c = cd[i];
                let c2 = c * c;
                let s2 = 1.0 - c2;
                let s4 = s2 * s2;
                let mut f = [0.0 as $t; 3];
                for ch in 0..3 {
                    let t = e2k2[ch] - s2;
                    let ab2 = (t * t + four_e2k2[ch]).sqrt();
                    // (ab2 + t)/2 ≥ 0 in exact arithmetic; round-off can make it −0-ish.
                    let a = ((ab2 + t) * 0.5).max(0.0).sqrt();
                    let t1 = ab2 + c2;
                    let t2 = 2.0 * a * c;
                    let rs = (t1 - t2) / (t1 + t2);
                    let t3 = ab2 * c2 + s4;
                    let t4 = t2 * s2;
                    let rp = rs * (t3 - t4) / (t3 + t4);
                    f[ch] = diff[ch] + spec[ch] * dv * 0.5 * (rs + rp);
                }
                // Below the horizon the BRDF is exactly 0 (a select, so the loop has no
                // branch and vectorises).
                let up = zi > 0.0 && zo > 0.0;
                or[i] = if up { f[0] } else { 0.0 };
                og[i] = if up { f[1] } else { 0.0 };
                ob[i] = if up { f[2] } else { 0.0 };
            }
        }

        /// The kernel over all cells, split into chunks of [`CHUNK`] that rayon spreads
        /// over the current pool.
        pub fn $eval_par(p: &GgxConductor, g: &Geom<$t>, out: &mut Planes<$t>) {
            out.r
                .par_chunks_mut(CHUNK)
                .zip(out.g.par_chunks_mut(CHUNK))
                .zip(out.b.par_chunks_mut(CHUNK))
                .enumerate()
                .for_each(|(c, ((r, gg), b))| $eval(p, g, c * CHUNK, [r, gg, b]));
        }
    };
}

kernel!(
    f32,
    geom_f32,
    eval_f32,
    eval_par_f32,
    body_f32,
    avx2_f32,
    avx512_f32
);
kernel!(
    f64,
    geom_f64,
    eval_f64,
    eval_par_f64,
    body_f64,
    avx2_f64,
    avx512_f64
);

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_core::{GeometryBatch, HalfDiff, Rgb, from_half_diff};

    fn batch() -> GeometryBatch {
        let mut pairs = Vec::new();
        for i in 0..30 {
            let th = (i as f64 / 30.0).powi(2) * std::f64::consts::FRAC_PI_2;
            for j in 0..30 {
                let td = j as f64 / 30.0 * std::f64::consts::FRAC_PI_2;
                for k in 0..20 {
                    let pd = k as f64 / 20.0 * std::f64::consts::PI;
                    pairs.push(from_half_diff(&HalfDiff::new(th, 0.3, td, pd)));
                }
            }
        }
        GeometryBatch::from_pairs(&pairs)
    }

    fn gold(alpha: f64) -> GgxConductor {
        GgxConductor {
            rho_d: [0.05, 0.1, 0.0],
            rho_s: [1.0, 0.9, 0.8],
            alpha,
            eta: [0.143, 0.374, 1.442],
            k: [3.983, 2.385, 1.603],
        }
    }

    /// The vector copies chosen at run time compute the same numbers as the baseline
    /// loop (Rust does not contract a·b + c into an FMA, so they are bit-identical).
    #[test]
    fn dispatched_copies_equal_the_baseline_loop() {
        let b = batch();
        let s = b.as_slice();
        let p = gold(0.1);
        let g = geom_f32(&s);
        let n = b.len() - 7; // not a multiple of any vector width
        let (mut x, mut y) = (Planes::<f32>::zeros(n), Planes::<f32>::zeros(n));
        eval_f32(&p, &g, 7, [&mut x.r, &mut x.g, &mut x.b]);
        body_f32(&p, &g, 7, [&mut y.r, &mut y.g, &mut y.b]);
        assert_eq!(x.r, y.r);
        assert_eq!(x.b, y.b);
        let g = geom_f64(&s);
        let (mut x, mut y) = (Planes::<f64>::zeros(n), Planes::<f64>::zeros(n));
        eval_f64(&p, &g, 7, [&mut x.r, &mut x.g, &mut x.b]);
        body_f64(&p, &g, 7, [&mut y.r, &mut y.g, &mut y.b]);
        assert_eq!(x.g, y.g);
        assert!(x.g.iter().any(|v| *v > 0.0));
    }

    /// The f64 kernel is the model (independent code path: the model forms G1 and
    /// divides by 4 cos θi cos θo), and the f32 kernel is within float32 round-off of it.
    #[test]
    fn kernels_match_the_model() {
        let b = batch();
        let s = b.as_slice();
        for alpha in [0.002, 0.05, 0.2, 0.8] {
            let p = gold(alpha);
            let m = brdfkit_models::from_json(&p.to_json()).unwrap();
            let mut want = vec![Rgb::ZERO; b.len()];
            m.eval_batch(&s, &mut want);
            let g64 = geom_f64(&s);
            let mut o64 = Planes::zeros(b.len());
            eval_par_f64(&p, &g64, &mut o64);
            let g32 = geom_f32(&s);
            let mut o32 = Planes::<f32>::zeros(b.len());
            eval_par_f32(&p, &g32, &mut o32);
            let (mut e64, mut e32) = (0.0f64, 0.0f64);
            let mut lit = 0;
            for (i, w) in want.iter().enumerate() {
                let got64 = [o64.r[i], o64.g[i], o64.b[i]];
                let got32 = [o32.r[i], o32.g[i], o32.b[i]];
                for c in 0..3 {
                    let w = w[c];
                    if w == 0.0 {
                        assert_eq!(got64[c], 0.0, "alpha {alpha} cell {i}");
                        continue;
                    }
                    lit += 1;
                    e64 = e64.max((got64[c] - w).abs() / w);
                    e32 = e32.max((got32[c] as f64 - w).abs() / w);
                }
            }
            assert!(lit > 10_000);
            assert!(e64 < 1e-12, "alpha {alpha}: f64 kernel off by {e64:e}");
            // float32: a few ulp (6e-8) per operation, amplified where D is steep.
            assert!(e32 < 1e-3, "alpha {alpha}: f32 kernel off by {e32:e}");
            assert!(e32 > 1e-9, "the f32 kernel must really round");
        }
    }
}
