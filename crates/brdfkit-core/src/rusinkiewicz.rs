//! Rusinkiewicz half/difference coordinates, as the MERL reference code defines them.
//!
//! For a pair (wi, wo) of unit directions pointing away from the surface:
//!
//! - the half vector h = normalize(wi + wo), θh = acos(h.z), φh = atan2(h.y, h.x);
//! - the difference vector d = rotate(rotate(wi, normal, −φh), binormal, −θh), i.e. wi
//!   expressed in a frame where h is the pole; θd = acos(d.z), φd = atan2(d.y, d.x).
//!
//! (S. Rusinkiewicz, "A New Change of Variables for Efficient BRDF Representation",
//! EGWR 1998; W. Matusik et al., "A Data-Driven Reflectance Model", SIGGRAPH 2003, and
//! the `BRDFRead.cpp` reference reader that ships with the MERL database.)
//!
//! [`to_half_diff`] performs the same floating-point operations in the same order as
//! the reference `std_coords_to_half_diff_coords`, so the table bins computed from its
//! output are bit-identical to the reference lookup.
//!
//! # Where the angles are not defined
//! The conversion is total: every pair of finite vectors gets finite angles.
//! - **θh = 0** (h on the normal): φh is undefined; it is set to 0 (the reference would
//!   give `atan2(±0, ±0)`, which is 0 or ±π depending on the signs of the zeros). Since
//!   d is wi rotated by −φh, φd is then the azimuth of wi.
//! - **wi = wo** (bitwise): θd = 0 and φd is undefined; both are set to exactly 0 and
//!   h = wi. (The reference's φd there is round-off noise: bin 0 or bin nφd−1.) For
//!   nearly equal directions the angles follow the arithmetic; every φd at θd = 0 is the
//!   same physical configuration.
//! - **At or below the horizon** (wi.z ≤ 0 or wo.z ≤ 0): the formulas are pure
//!   geometry and still apply (θh may exceed π/2, θd may too). The conversion does not
//!   refuse such pairs; the consumers do: analytic models return 0, table lookups
//!   return "no sample".
//! - **wi = −wo** (only possible for grazing or below-horizon pairs): h = 0 cannot be
//!   normalised; h is set to the normal.
//! - `acos` arguments are clamped into [−1, 1]: the normalisation can land a ulp beyond
//!   1, where `acos` is NaN.
//!
//! [`from_half_diff`] inverts the conversion: wi = rotate(rotate(d, binormal, θh),
//! normal, φh), wo = 2 (wi·h) h − wi. The round trip is exact to about 1e-15 for
//! generic pairs (the tests demand 1e-12).

use crate::direction::{BINORMAL, NORMAL, Vec3, rotate, spherical};

/// Rusinkiewicz coordinates of a direction pair, in radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfDiff {
    /// Polar angle of the half vector, from the normal.
    pub theta_h: f64,
    /// Azimuth of the half vector.
    pub phi_h: f64,
    /// Polar angle of the difference vector (the angle between wi and h).
    pub theta_d: f64,
    /// Azimuth of the difference vector about h.
    pub phi_d: f64,
}

impl HalfDiff {
    /// Coordinates from the four angles.
    pub fn new(theta_h: f64, phi_h: f64, theta_d: f64, phi_d: f64) -> Self {
        HalfDiff {
            theta_h,
            phi_h,
            theta_d,
            phi_d,
        }
    }
}

/// Converts (wi, wo) to Rusinkiewicz coordinates; see the module doc for the undefined
/// cases and their conventions.
pub fn to_half_diff(wi: &Vec3, wo: &Vec3) -> HalfDiff {
    if wi == wo {
        let (theta_h, phi_h) = crate::direction::to_spherical(wi);
        return HalfDiff::new(theta_h, phi_h, 0.0, 0.0);
    }
    // Same operation order as the reference: sum, norm, divide.
    let mut hx = wi[0] + wo[0];
    let mut hy = wi[1] + wo[1];
    let mut hz = wi[2] + wo[2];
    let norm = (hx * hx + hy * hy + hz * hz).sqrt();
    if norm == 0.0 {
        // wi = −wo: no half vector; the normal is the conventional choice.
        hx = 0.0;
        hy = 0.0;
        hz = 1.0;
    } else {
        hx /= norm;
        hy /= norm;
        hz /= norm;
    }
    let theta_h = hz.clamp(-1.0, 1.0).acos();
    let phi_h = if hx == 0.0 && hy == 0.0 {
        0.0
    } else {
        hy.atan2(hx)
    };
    let temp = rotate(wi, &NORMAL, -phi_h);
    let d = rotate(&temp, &BINORMAL, -theta_h);
    let theta_d = d[2].clamp(-1.0, 1.0).acos();
    let phi_d = if d[0] == 0.0 && d[1] == 0.0 {
        0.0
    } else {
        d[1].atan2(d[0])
    };
    HalfDiff::new(theta_h, phi_h, theta_d, phi_d)
}

/// Converts Rusinkiewicz coordinates back to (wi, wo). Total: any angles give unit
/// vectors (possibly below the horizon, as for the grazing cells of a table).
pub fn from_half_diff(c: &HalfDiff) -> (Vec3, Vec3) {
    let d = spherical(c.theta_d, c.phi_d);
    let t = rotate(&d, &BINORMAL, c.theta_h);
    let wi = rotate(&t, &NORMAL, c.phi_h);
    let h = spherical(c.theta_h, c.phi_h);
    let wo = 2.0 * wi.dot(&h) * h - wi;
    (wi, wo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::direction::spherical;
    use approx::assert_relative_eq;
    use proptest::prelude::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn assert_pair_eq(a: (Vec3, Vec3), b: (Vec3, Vec3), tol: f64) {
        for k in 0..3 {
            assert!((a.0[k] - b.0[k]).abs() <= tol, "wi {:?} vs {:?}", a.0, b.0);
            assert!((a.1[k] - b.1[k]).abs() <= tol, "wo {:?} vs {:?}", a.1, b.1);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn round_trip_generic_pairs(
            ti in 0.01f64..1.56, pi_ in -PI..PI, to in 0.01f64..1.56, po in -PI..PI,
        ) {
            let wi = spherical(ti, pi_);
            let wo = spherical(to, po);
            prop_assume!((wi - wo).norm() > 1e-6);
            let c = to_half_diff(&wi, &wo);
            let back = from_half_diff(&c);
            assert_pair_eq(back, (wi, wo), 1e-12);
        }

        #[test]
        fn half_diff_round_trip(th in 0.001f64..1.5, ph in -3.1f64..3.1, td in 0.001f64..1.5,
                                pd in -3.1f64..3.1) {
            let c = HalfDiff::new(th, ph, td, pd);
            let (wi, wo) = from_half_diff(&c);
            let c2 = to_half_diff(&wi, &wo);
            prop_assert!((c.theta_h - c2.theta_h).abs() < 1e-9);
            prop_assert!((c.theta_d - c2.theta_d).abs() < 1e-9);
            prop_assert!((c.phi_h - c2.phi_h).abs() < 1e-9);
            prop_assert!((c.phi_d - c2.phi_d).abs() < 1e-9);
        }
    }

    #[test]
    fn theta_d_is_the_angle_between_wi_and_h() {
        let wi = spherical(0.7, 0.3);
        let wo = spherical(0.2, 2.5);
        let c = to_half_diff(&wi, &wo);
        let h = (wi + wo).normalize();
        assert_relative_eq!(c.theta_d, wi.dot(&h).acos(), epsilon = 1e-12);
        assert_relative_eq!(c.theta_h, h.z.acos(), epsilon = 1e-12);
    }

    #[test]
    fn specular_pair_has_zero_theta_h() {
        // wo the mirror of wi: h is the normal, φh is 0 by convention, φd = φi.
        let wi = spherical(0.6, 1.1);
        let wo = Vec3::new(-wi.x, -wi.y, wi.z);
        let c = to_half_diff(&wi, &wo);
        assert_eq!(c.theta_h, 0.0);
        assert_eq!(c.phi_h, 0.0);
        assert_relative_eq!(c.theta_d, 0.6, epsilon = 1e-12);
        assert_relative_eq!(c.phi_d, 1.1, epsilon = 1e-12);
        let back = from_half_diff(&c);
        assert_pair_eq(back, (wi, wo), 1e-12);
    }

    #[test]
    fn equal_directions_give_zero_difference_angles() {
        let w = spherical(0.9, -0.4);
        let c = to_half_diff(&w, &w);
        assert_eq!(c.theta_d, 0.0);
        assert_eq!(c.phi_d, 0.0);
        assert_relative_eq!(c.theta_h, 0.9, epsilon = 1e-15);
        assert_relative_eq!(c.phi_h, -0.4, epsilon = 1e-15);
        let (wi, wo) = from_half_diff(&c);
        assert_pair_eq((wi, wo), (w, w), 1e-15);
    }

    #[test]
    fn normal_pair_is_all_zero() {
        let n = Vec3::new(0.0, 0.0, 1.0);
        assert_eq!(to_half_diff(&n, &n), HalfDiff::new(0.0, 0.0, 0.0, 0.0));
    }

    #[test]
    fn opposite_directions_are_finite() {
        let wi = Vec3::new(1.0, 0.0, 0.0);
        let wo = Vec3::new(-1.0, 0.0, 0.0);
        let c = to_half_diff(&wi, &wo);
        assert_eq!(c.theta_h, 0.0);
        assert_relative_eq!(c.theta_d, FRAC_PI_2, epsilon = 1e-15);
        assert!(c.phi_d.is_finite());
    }

    #[test]
    fn below_horizon_pairs_are_converted_geometrically() {
        let wi = spherical(1.8, 0.2); // below the horizon
        let wo = spherical(0.5, 2.0);
        let c = to_half_diff(&wi, &wo);
        assert!(c.theta_h.is_finite() && c.theta_d.is_finite());
        let back = from_half_diff(&c);
        assert_pair_eq(back, (wi, wo), 1e-12);
    }

    #[test]
    fn grazing_pairs_stay_finite() {
        for &t in &[FRAC_PI_2, FRAC_PI_2 - 1e-12, 1e-12, 0.0] {
            for &p in &[0.0, 1.0, PI, -PI] {
                let wi = spherical(t, p);
                let wo = spherical(FRAC_PI_2, 0.3);
                let c = to_half_diff(&wi, &wo);
                assert!(
                    c.theta_h.is_finite()
                        && c.phi_h.is_finite()
                        && c.theta_d.is_finite()
                        && c.phi_d.is_finite()
                );
            }
        }
    }
}
