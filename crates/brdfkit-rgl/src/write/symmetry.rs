//! The φi range an anisotropic file needs: the symmetry of its source.
//!
//! Mitsuba 3's `measured` plugin (and brdfkit's reader) derive a fold from the stored
//! range, `reduction` = rint(2π / (φi,last − φi,first)), and mirror every pair (wi, wo)
//! by the signs of wi before the lookup (`measured.cpp`, `mulsign_neg`):
//!
//! - 4: x ↦ −x where wi.x > 0 and y ↦ −y where wi.y > 0, wi into φi ∈ [−π, −π/2]: right
//!   for a source with f(M wi, M wo) = f(wi, wo) under both mirrors M_x: (x, y) ↦ (−x, y)
//!   and M_y: (x, y) ↦ (x, −y) (an anisotropic lobe whose axes are the tangent frame's:
//!   Ward, Ashikhmin-Shirley, Cook-Torrance with αx ≠ αy);
//! - 2: (x, y) ↦ (−x, −y) where wi.y > 0, wi into φi ∈ [−π, 0]: right for a source
//!   invariant under the half turn R = M_x M_y only (e.g. an anisotropic lobe whose axes
//!   are rotated against the frame, as glTF's `KHR_materials_anisotropy` rotation);
//! - 1: no fold, φi over [−π, π]: any source.
//!
//! The writer stores the smallest range the source's symmetry allows. The symmetry is
//! decided by evaluation, not by what the source says of itself (a sum of lobes, a fit,
//! a `.bsdf` file have no typed symmetry): at 512 (`PROBES`) fixed pseudo-random pairs above
//! 2° elevation, f(wi, wo) and f(T wi, T wo) for T = M_x, M_y, R must agree within
//! 1e-9 relative (`REL_TOL`; plus 1e-12 of the largest value probed, `ABS_TOL`). Images differ by
//! floating-point rounding only (≲ 1e-14 relative) when the symmetry holds; a source
//! that breaks it by less than 1e-9 relative at every probe is stored as symmetric, an
//! error far below the format's interpolation (docs/rgl.md, "Anisotropic files").

use super::WriteError;
use brdfkit_core::{Brdf, Rgb, Vec3};
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

/// Probe pairs, their seed and lowest elevation (degrees).
const PROBES: usize = 512;
const SEED: u64 = 0x5eed_f01d;
const MIN_ELEVATION_DEG: f64 = 2.0;

/// Relative tolerance of a symmetric image, and the absolute part (of the largest value
/// probed) for values near 0.
const REL_TOL: f64 = 1e-9;
const ABS_TOL: f64 = 1e-12;

/// The symmetry of a source, as far as the format's fold can use it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Symmetry {
    /// f depends on φo − φi only (`Brdf::is_isotropic`): one φi slice, `phi_i` = \[0\].
    Isotropic,
    /// Invariant under both mirrors M_x and M_y: a quarter of the φi range (4-fold).
    Mirrors,
    /// Invariant under the half turn R only: half the φi range (2-fold).
    HalfTurn,
    /// None of them: the full φi range (no fold).
    None,
}

impl Symmetry {
    /// The reader's `reduction` of a file with this symmetry (isotropic files have none;
    /// Mitsuba folds them as 2).
    pub fn reduction(self) -> i32 {
        match self {
            Symmetry::Isotropic | Symmetry::HalfTurn => 2,
            Symmetry::Mirrors => 4,
            Symmetry::None => 1,
        }
    }

    /// The symmetry and the φi range it lets a file store, in words.
    pub fn describe(self) -> &'static str {
        match self {
            Symmetry::Isotropic => "isotropic: one phi_i slice",
            Symmetry::Mirrors => "mirror-symmetric in x and in y: phi_i over a quarter turn",
            Symmetry::HalfTurn => "symmetric under a half turn only: phi_i over half a turn",
            Symmetry::None => "no mirror or half-turn symmetry: phi_i over the full turn",
        }
    }

    /// The stored φi range [−π, −π + 2π / reduction] (radians) of an anisotropic file.
    pub fn phi_range(self) -> (f64, f64) {
        (-PI, -PI + 2.0 * PI / f64::from(self.reduction()))
    }
}

/// A direction and its images under M_x, M_y and R.
fn images(v: &Vec3) -> [Vec3; 4] {
    [
        *v,
        Vec3::new(-v.x, v.y, v.z),
        Vec3::new(v.x, -v.y, v.z),
        Vec3::new(-v.x, -v.y, v.z),
    ]
}

/// The symmetry of `source` (module doc); an error if it is not finite at a probe.
pub fn symmetry(source: &dyn Brdf) -> Result<Symmetry, WriteError> {
    if source.is_isotropic() {
        return Ok(Symmetry::Isotropic);
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SEED);
    let zmin = MIN_ELEVATION_DEG.to_radians().sin();
    let mut dir = || {
        let z: f64 = rng.random_range(zmin..1.0);
        let phi = rng.random::<f64>() * 2.0 * PI;
        let r = (1.0 - z * z).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    // Per probe: f at the pair and at its images under M_x, M_y, R.
    let mut values: Vec<[Rgb; 4]> = Vec::with_capacity(PROBES);
    for _ in 0..PROBES {
        let (wi, wo) = (dir(), dir());
        let (ii, oo) = (images(&wi), images(&wo));
        let mut v = [Rgb::ZERO; 4];
        for k in 0..4 {
            v[k] = source.eval(&ii[k], &oo[k]);
            if !v[k].is_finite() {
                return Err(WriteError::NonFinite {
                    wi: ii[k],
                    wo: oo[k],
                });
            }
        }
        values.push(v);
    }
    let peak = values
        .iter()
        .flat_map(|v| v.iter().flat_map(|c| c.0))
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let holds = |k: usize| {
        values.iter().all(|v| {
            (0..3).all(|c| {
                let (a, b) = (v[0].0[c], v[k].0[c]);
                (a - b).abs() <= REL_TOL * a.abs().max(b.abs()) + ABS_TOL * peak
            })
        })
    };
    Ok(if holds(1) && holds(2) {
        Symmetry::Mirrors
    } else if holds(3) {
        Symmetry::HalfTurn
    } else {
        Symmetry::None
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Ward-like lobe exp(−(h_a²/αa² + h_b²/αb²)/h_z²) along axes a, b turned by
    /// `angle` from the frame, plus `skew` × wo.x (which breaks every symmetry).
    struct Lobe {
        angle: f64,
        alpha: (f64, f64),
        skew: f64,
    }

    impl Brdf for Lobe {
        fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
            let h = (wi + wo).normalize();
            let (s, c) = self.angle.sin_cos();
            let (a, b) = (c * h.x + s * h.y, -s * h.x + c * h.y);
            let e = ((a / self.alpha.0).powi(2) + (b / self.alpha.1).powi(2)) / (h.z * h.z);
            Rgb::splat((-e).exp() + 0.1 + self.skew * wo.x)
        }
        fn is_isotropic(&self) -> bool {
            self.alpha.0 == self.alpha.1 && self.skew == 0.0
        }
    }

    fn lobe(angle_deg: f64, alpha: (f64, f64), skew: f64) -> Lobe {
        Lobe {
            angle: angle_deg.to_radians(),
            alpha,
            skew,
        }
    }

    /// Axes along the frame (or turned by a multiple of 90°): both mirrors; turned by
    /// anything else: the half turn only; a skew: nothing; equal α: isotropic, by the
    /// source's word. A tiny skew (1e-6 of the lobe) is seen.
    #[test]
    fn symmetries_are_told_apart() {
        let cases = [
            (lobe(0.0, (0.1, 0.4), 0.0), Symmetry::Mirrors),
            (lobe(90.0, (0.1, 0.4), 0.0), Symmetry::Mirrors),
            (lobe(180.0, (0.1, 0.4), 0.0), Symmetry::Mirrors),
            (lobe(30.0, (0.1, 0.4), 0.0), Symmetry::HalfTurn),
            (lobe(-100.0, (0.3, 0.2), 0.0), Symmetry::HalfTurn),
            (lobe(0.0, (0.1, 0.4), 0.05), Symmetry::None),
            (lobe(0.0, (0.1, 0.4), 1e-6), Symmetry::None),
            (lobe(0.0, (0.2, 0.2), 0.0), Symmetry::Isotropic),
        ];
        for (src, want) in cases {
            let got = symmetry(&src).unwrap();
            assert_eq!(
                got,
                want,
                "angle {}°, α {:?}, skew {}",
                src.angle.to_degrees(),
                src.alpha,
                src.skew
            );
        }
        assert_eq!(Symmetry::Mirrors.phi_range(), (-PI, -PI / 2.0));
        assert_eq!(Symmetry::HalfTurn.phi_range(), (-PI, 0.0));
        assert_eq!(Symmetry::None.phi_range(), (-PI, PI));
    }

    /// A source that is not finite at a probe is an error naming the pair.
    #[test]
    fn a_non_finite_source_is_an_error() {
        let src = lobe(0.0, (0.1, 0.4), f64::NAN);
        assert!(matches!(symmetry(&src), Err(WriteError::NonFinite { .. })));
    }
}
