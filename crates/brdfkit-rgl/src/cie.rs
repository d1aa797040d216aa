//! Spectral values to linear sRGB: the documented conversion of spectral `.bsdf` files.
//!
//! A spectral file stores f_r(λ) at its wavelengths λ_k, and Mitsuba interpolates it
//! linearly in λ (clamped to the end values outside the range). Its colour is taken as
//! that of the reflected light under CIE illuminant D65, normalised so a spectrally flat
//! f_r = 1 gives linear sRGB (1, 1, 1):
//!
//!   XYZ = Σ_λ f(λ) D65(λ) (x̄, ȳ, z̄)(λ) / Σ_λ D65(λ) ȳ(λ),   RGB = M · XYZ,
//!
//! summed at every nanometre from 360 to 830 nm over the CIE 1931 2° matching functions
//! (the table Mitsuba 3 uses, [`crate::cie_table`]), with M Mitsuba's XYZ → linear sRGB
//! matrix (`xyz_to_srgb`, IEC 61966-2-1). Because f is piecewise linear in λ, the sum is
//! a fixed weighted sum of the stored values: [`srgb_weights`] computes those weights
//! once per file, and an evaluation is three dot products.

use crate::cie_table::{CIE_1931_D65, FIRST_NM};

/// Mitsuba 3's XYZ → linear sRGB matrix (`mitsuba/core/spectrum.h`, `xyz_to_srgb`).
pub const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [3.240479, -1.537150, -0.498535],
    [-0.969256, 1.875991, 0.041556],
    [0.055648, -0.204043, 1.057311],
];

/// The weights of the linear interpolant of sorted `wavelengths` at `lambda`: index of
/// the lower node and the weight of the upper (clamped outside the range, as Mitsuba's
/// parameter interpolation).
fn hat(wavelengths: &[f32], lambda: f64) -> (usize, f64) {
    let n = wavelengths.len();
    if n == 1 {
        return (0, 0.0);
    }
    let i = wavelengths[1..n - 1].partition_point(|&v| f64::from(v) < lambda);
    let (a, b) = (f64::from(wavelengths[i]), f64::from(wavelengths[i + 1]));
    (i, ((lambda - a) / (b - a)).clamp(0.0, 1.0))
}

/// Per channel, the weight of each stored wavelength's value in linear sRGB.
pub fn srgb_weights(wavelengths: &[f32]) -> [Vec<f64>; 3] {
    let n = wavelengths.len();
    let mut w = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let norm: f64 = CIE_1931_D65.iter().map(|r| r[1] * r[3]).sum();
    for (k, r) in CIE_1931_D65.iter().enumerate() {
        let lambda = FIRST_NM + k as f64;
        let xyz = [r[0] * r[3] / norm, r[1] * r[3] / norm, r[2] * r[3] / norm];
        let rgb = XYZ_TO_SRGB.map(|m| m[0] * xyz[0] + m[1] * xyz[1] + m[2] * xyz[2]);
        let (i, t) = hat(wavelengths, lambda);
        for (wc, v) in w.iter_mut().zip(rgb) {
            wc[i] += (1.0 - t) * v;
            if t > 0.0 {
                wc[i + 1] += t * v;
            }
        }
    }
    w
}

/// Σ w_k s_k.
pub fn dot(w: &[f64], s: &[f64]) -> f64 {
    w.iter().zip(s).map(|(a, b)| a * b).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_spectrum_is_white() {
        let wl: Vec<f32> = (0..=64).map(|k| 360.0 + 10.0 * k as f32).collect();
        let w = srgb_weights(&wl);
        let s = vec![1.0; wl.len()];
        for wc in &w {
            assert!((dot(wc, &s) - 1.0).abs() < 2e-3, "{}", dot(wc, &s));
        }
    }

    #[test]
    fn weights_sum_like_the_flat_spectrum_whatever_the_grid() {
        // One wavelength: the value is constant over λ, so the weights are the white.
        let w = srgb_weights(&[550.0]);
        let w2 = srgb_weights(&[400.0, 700.0]);
        for (a, b) in w.iter().zip(&w2) {
            assert!((a[0] - (b[0] + b[1])).abs() < 1e-12);
        }
    }
}
