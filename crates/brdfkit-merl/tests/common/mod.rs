//! Helpers shared by the lookup test files.

#![allow(dead_code)] // each test file uses its own subset

use brdfkit_core::{HalfDiff, Vec3, from_half_diff};
use brdfkit_merl::{Dims, phi_d_angle, theta_d_angle, theta_h_angle};

/// The pair at continuous grid coordinates `x` (θh, θd, φd) of `d`, with half-vector
/// azimuth `phi_h`; `None` when a direction falls at or below the horizon.
pub fn pair_at_coords(d: Dims, x: [f64; 3], phi_h: f64) -> Option<(Vec3, Vec3)> {
    let c = HalfDiff::new(
        theta_h_angle(x[0], d.theta_h()),
        phi_h,
        theta_d_angle(x[1], d.theta_d()),
        phi_d_angle(x[2], d.phi_d()),
    );
    let (wi, wo) = from_half_diff(&c);
    (wi.z > 0.0 && wo.z > 0.0).then_some((wi, wo))
}
