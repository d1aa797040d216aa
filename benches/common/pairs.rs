//! The direction pairs of the MERL grid (shared by the `models` and `peers` benches).

use brdfkit::core::{HalfDiff, Vec3, from_half_diff};
use std::f64::consts::{FRAC_PI_2, PI};

/// The (wi, wo) pairs of the MERL cells, θh = (i/90)² π/2, θd = j/90 · π/2,
/// φd = k/180 · π, φh = 0, in table order (1 458 000 pairs).
pub fn merl_pairs() -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::with_capacity(90 * 90 * 180);
    for i in 0..90 {
        let th = (i as f64 / 90.0).powi(2) * FRAC_PI_2;
        for j in 0..90 {
            let td = j as f64 / 90.0 * FRAC_PI_2;
            for k in 0..180 {
                let pd = k as f64 / 180.0 * PI;
                v.push(from_half_diff(&HalfDiff::new(th, 0.0, td, pd)));
            }
        }
    }
    v
}
