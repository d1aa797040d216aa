//! Direction vectors in the local shading frame (z = normal).

/// A 3-vector in the local frame: z is the surface normal, x the tangent.
pub type Vec3 = nalgebra::Vector3<f64>;

/// The surface normal of the local frame.
pub const NORMAL: Vec3 = Vec3::new(0.0, 0.0, 1.0);
/// The binormal (y axis), the axis of the θh rotation in Rusinkiewicz coordinates.
pub const BINORMAL: Vec3 = Vec3::new(0.0, 1.0, 0.0);

/// Unit vector of polar angle `theta` (from the normal) and azimuth `phi` (from x).
pub fn spherical(theta: f64, phi: f64) -> Vec3 {
    let s = theta.sin();
    Vec3::new(s * phi.cos(), s * phi.sin(), theta.cos())
}

/// Polar angle and azimuth of a unit vector. The polar angle is computed with `atan2`
/// of (|xy|, z), which keeps full precision near the pole where `acos(z)` loses half
/// of the digits. The azimuth of a vector on the pole is 0.
pub fn to_spherical(w: &Vec3) -> (f64, f64) {
    let rho = w.x.hypot(w.y);
    let phi = if w.x == 0.0 && w.y == 0.0 {
        0.0
    } else {
        w.y.atan2(w.x)
    };
    (rho.atan2(w.z), phi)
}

/// Mirror reflection of `w` about the normal: (−x, −y, z).
pub fn reflect(w: &Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// Strictly above the horizon: z > 0. Analytic models return zero otherwise.
pub fn above_horizon(w: &Vec3) -> bool {
    w.z > 0.0
}

/// Rotates `v` by `angle` about the unit `axis` (Rodrigues' formula), with the same
/// sequence of floating-point operations as `rotate_vector` of the MERL reference code,
/// so the Rusinkiewicz angles (and hence the table bins) are bit-identical to it.
pub fn rotate(v: &Vec3, axis: &Vec3, angle: f64) -> Vec3 {
    let cos_ang = angle.cos();
    let sin_ang = angle.sin();
    let mut out = Vec3::new(v[0] * cos_ang, v[1] * cos_ang, v[2] * cos_ang);
    let mut temp = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
    temp *= 1.0 - cos_ang;
    out[0] += axis[0] * temp;
    out[1] += axis[1] * temp;
    out[2] += axis[2] * temp;
    let cross = Vec3::new(
        axis[1] * v[2] - axis[2] * v[1],
        axis[2] * v[0] - axis[0] * v[2],
        axis[0] * v[1] - axis[1] * v[0],
    );
    out[0] += cross[0] * sin_ang;
    out[1] += cross[1] * sin_ang;
    out[2] += cross[2] * sin_ang;
    out
}

/// How far from 1 the length of a given direction may be: directions are taken as they
/// are, never renormalised behind the caller's back (a direction twice too long would
/// otherwise give a silently wrong value), and the float64 rounding of a unit vector
/// is ~1e-16, of a float32 one ~1e-7.
pub const UNIT_TOLERANCE: f64 = 1e-6;

/// True when `w` is finite and of unit length within [`UNIT_TOLERANCE`] (written as the
/// "good" test so that NaN is not unit).
#[inline]
pub fn is_unit(w: [f64; 3]) -> bool {
    ((w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt() - 1.0).abs() <= UNIT_TOLERANCE
}

/// A pair of directions that are not both unit vectors ([`check_unit_pairs`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "row {row}: |wi| = {wi_len}, |wo| = {wo_len}: directions must be unit vectors (within {})",
    UNIT_TOLERANCE
)]
pub struct NotUnit {
    /// The first offending row (0-based).
    pub row: usize,
    /// |wi| of that row (NaN for a non-finite direction).
    pub wi_len: f64,
    /// |wo| of that row.
    pub wo_len: f64,
}

/// Checks that every `wi[k]` and `wo[k]` is a unit vector (the rule of every entry point
/// that takes directions: the command line's pair files and the Python bindings);
/// the error names the first row that is not. Below-horizon directions (z ≤ 0) are
/// valid here: each caller states what it returns for them.
///
/// Blocks of pairs are tested without an early exit, a loop that vectorises (an
/// early-exit `position` over 1.46 M pairs cost a third of a nearest lookup's time);
/// the first bad row is searched for only in the first failing block. Callers that
/// split the pairs over threads add their block's offset to [`NotUnit::row`].
pub fn check_unit_pairs(wi: &[[f64; 3]], wo: &[[f64; 3]]) -> Result<(), NotUnit> {
    const BLOCK: usize = 256;
    let norm = |w: [f64; 3]| (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    let good = |(&a, &b): (&[f64; 3], &[f64; 3])| is_unit(a) & is_unit(b);
    for (k, (bi, bo)) in wi.chunks(BLOCK).zip(wo.chunks(BLOCK)).enumerate() {
        if bi.iter().zip(bo).fold(true, |ok, p| ok & good(p)) {
            continue;
        }
        let row = k * BLOCK + bi.iter().zip(bo).position(|p| !good(p)).unwrap_or(0);
        return Err(NotUnit {
            row,
            wi_len: norm(wi[row]),
            wo_len: norm(wo[row]),
        });
    }
    Ok(())
}

/// The largest z in [−1, 1] at which `holds(z)` is true, for a `holds` true at −1,
/// false at 1 and monotone between (true, then false, along the f64 order): the exact
/// cut of a formula of a cosine (such as acos z ≥ θ), found by bisection over the f64
/// values themselves, so comparing z with the cut gives the formula's answer without
/// computing it (no acos a cell in the fitter's strata and the report's bands).
pub fn last_cosine_where(holds: impl Fn(f64) -> bool) -> f64 {
    // f64 → i64 keeping the order (`f64::total_cmp`'s key; its own inverse).
    let key = |x: f64| {
        let b = x.to_bits() as i64;
        b ^ ((((b >> 63) as u64) >> 1) as i64)
    };
    let val = |k: i64| f64::from_bits((k ^ ((((k >> 63) as u64) >> 1) as i64)) as u64);
    let (mut lo, mut hi) = (key(-1.0), key(1.0));
    debug_assert!(holds(val(lo)) && !holds(val(hi)));
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if holds(val(mid)) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    val(lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn spherical_round_trip() {
        for &(t, p) in &[(0.3, 1.2), (1.5, -2.0), (1e-9, 0.7), (0.0, 0.0)] {
            let w = spherical(t, p);
            let (t2, p2) = to_spherical(&w);
            assert_relative_eq!(t, t2, epsilon = 1e-15);
            if t > 0.0 {
                assert_relative_eq!(p, p2, epsilon = 1e-12);
            } else {
                assert_eq!(p2, 0.0);
            }
        }
    }

    #[test]
    fn rotation_matches_the_right_hand_rule() {
        let x = Vec3::new(1.0, 0.0, 0.0);
        let r = rotate(&x, &NORMAL, std::f64::consts::FRAC_PI_2);
        assert_relative_eq!(r, Vec3::new(0.0, 1.0, 0.0), epsilon = 1e-15);
        let z = rotate(&NORMAL, &BINORMAL, std::f64::consts::FRAC_PI_2);
        assert_relative_eq!(z, Vec3::new(1.0, 0.0, 0.0), epsilon = 1e-15);
    }

    #[test]
    fn reflect_keeps_the_normal_component() {
        let w = spherical(0.4, 0.9);
        let r = reflect(&w);
        assert_eq!(r.z, w.z);
        assert_relative_eq!(r.x, -w.x);
        assert_relative_eq!(r.y, -w.y);
    }

    #[test]
    fn unit_pairs_name_the_first_bad_row() {
        let up = [0.0, 0.0, 1.0];
        let tilted = [0.6, 0.0, 0.8];
        assert!(check_unit_pairs(&[up, tilted], &[tilted, up]).is_ok());
        assert!(is_unit([0.0, 0.0, 1.0 + 0.9e-6]) && !is_unit([0.0, 0.0, 1.0 + 1.1e-6]));
        let e =
            check_unit_pairs(&[up, up, [0.0, 0.0, 0.5]], &[up, [0.0, 0.0, 2.0], up]).unwrap_err();
        assert_eq!((e.row, e.wi_len, e.wo_len), (1, 1.0, 2.0));
        assert_eq!(
            e.to_string(),
            "row 1: |wi| = 1, |wo| = 2: directions must be unit vectors (within 0.000001)"
        );
        let e = check_unit_pairs(&[[f64::NAN, 0.0, 1.0]], &[up]).unwrap_err();
        assert!(e.wi_len.is_nan() && e.row == 0);
        assert!(!is_unit([0.0; 3]) && !is_unit([f64::INFINITY, 0.0, 0.0]));
    }
}
