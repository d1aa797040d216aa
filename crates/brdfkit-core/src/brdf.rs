//! The [`Brdf`] trait: anything that returns f_r for a pair of directions.

use crate::{Rgb, Vec3};

/// A bidirectional reflectance distribution function.
///
/// Directions are unit vectors in the local frame (z = normal), **both pointing away
/// from the surface**. [`eval`](Brdf::eval) returns f_r(wi, wo) in 1/sr **without the
/// cosine factor**: the reflected radiance from light arriving along `wi` is
/// `eval(wi, wo) · L_i · cos θi · dω_i`. (Mitsuba 3's `eval` includes the cosine;
/// pbrt-v4's `f()` does not, like this one.)
///
/// A direction at or below the horizon (z ≤ 0) gives exactly zero for analytic models.
pub trait Brdf: Send + Sync {
    /// f_r(wi, wo) in 1/sr, without the cosine factor.
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb;

    /// True when f_r depends on the azimuths of wi and wo only through their
    /// difference (no preferred tangent direction).
    fn is_isotropic(&self) -> bool {
        true
    }
}

impl<T: Brdf + ?Sized> Brdf for &T {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        (**self).eval(wi, wo)
    }
    fn is_isotropic(&self) -> bool {
        (**self).is_isotropic()
    }
}

impl<T: Brdf + ?Sized> Brdf for Box<T> {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        (**self).eval(wi, wo)
    }
    fn is_isotropic(&self) -> bool {
        (**self).is_isotropic()
    }
}
