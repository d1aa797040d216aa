//! The index mapping against hand-computed cells and a literal transcription of the
//! reference `BRDFRead.cpp` bin functions.

use brdfkit_core::direction::spherical;
use brdfkit_core::{HalfDiff, Rgb, Vec3, from_half_diff, to_half_diff};
use brdfkit_merl::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{FRAC_PI_2, PI};

/// The reference bin functions, transcribed line by line (C casts are `as i32`; the
/// resolutions are parameters instead of `#define`s; `res_phi_d` is the reference's
/// 360, twice the number of stored φd bins).
mod reference {
    const M_PI: f64 = std::f64::consts::PI;

    pub fn theta_half_index(theta_half: f64, res_theta_h: i32) -> i32 {
        if theta_half <= 0.0 {
            return 0;
        }
        let theta_half_deg = (theta_half / (M_PI / 2.0)) * res_theta_h as f64;
        let mut temp = theta_half_deg * res_theta_h as f64;
        temp = temp.sqrt();
        let mut ret_val = temp as i32;
        if ret_val < 0 {
            ret_val = 0;
        }
        if ret_val >= res_theta_h {
            ret_val = res_theta_h - 1;
        }
        ret_val
    }

    pub fn theta_diff_index(theta_diff: f64, res_theta_d: i32) -> i32 {
        let tmp = (theta_diff / (M_PI * 0.5) * res_theta_d as f64) as i32;
        if tmp < 0 {
            0
        } else if tmp < res_theta_d - 1 {
            tmp
        } else {
            res_theta_d - 1
        }
    }

    pub fn phi_diff_index(mut phi_diff: f64, res_phi_d: i32) -> i32 {
        if phi_diff < 0.0 {
            phi_diff += M_PI;
        }
        let tmp = (phi_diff / M_PI * res_phi_d as f64 / 2.0) as i32;
        if tmp < 0 {
            0
        } else if tmp < res_phi_d / 2 - 1 {
            tmp
        } else {
            res_phi_d / 2 - 1
        }
    }

    /// The flat index of `lookup_brdf_val`.
    pub fn index(c: &brdfkit_core::HalfDiff, th: i32, td: i32, pd2: i32) -> usize {
        (phi_diff_index(c.phi_d, pd2)
            + theta_diff_index(c.theta_d, td) * pd2 / 2
            + theta_half_index(c.theta_h, th) * pd2 / 2 * td) as usize
    }
}

const N: usize = 90;

#[test]
fn theta_h_hand_computed() {
    assert_eq!(theta_h_bin(0.0, N), 0);
    assert_eq!(theta_h_bin(-0.3, N), 0);
    assert_eq!(theta_h_coord(-0.3, N), 0.0);
    assert_eq!(theta_h_bin(1e-10, N), 0); // sqrt(1e-10 / (π/2) · 8100) = 7.2e-4
    // sqrt(0.1 / (π/2) · 8100) = sqrt(515.66) = 22.708
    assert_eq!(theta_h_bin(0.1, N), 22);
    // sqrt(1.0 / (π/2) · 8100) = sqrt(5156.62) = 71.8096
    assert_eq!(theta_h_bin(1.0, N), 71);
    assert!((theta_h_coord(1.0, N) - 71.809_610).abs() < 1e-6);
    // θh = π/2: coordinate exactly 90, clamped to the last bin; beyond too.
    assert_eq!(theta_h_coord(FRAC_PI_2, N), 90.0);
    assert_eq!(theta_h_bin(FRAC_PI_2, N), 89);
    assert_eq!(theta_h_bin(2.5, N), 89);
    // Probes at bin centres: coordinate i + 0.5 -> θh = ((i + 0.5)/90)² π/2.
    assert_bin_centres(theta_h_bin, theta_h_angle, N);
    // The NaN case: the reference's cast is undefined; here bin 0.
    assert_eq!(theta_h_bin(f64::NAN, N), 0);
}

/// The angle at the centre of each of the `n` bins of an axis (coordinate i + 0.5)
/// falls in bin i.
fn assert_bin_centres(bin: fn(f64, usize) -> usize, angle: fn(f64, usize) -> f64, n: usize) {
    for i in 0..n {
        assert_eq!(bin(angle(i as f64 + 0.5, n), n), i, "bin {i}");
    }
}

#[test]
fn theta_d_hand_computed() {
    assert_eq!(theta_d_bin(0.0, N), 0);
    // 1.0 / (π/2) · 90 = 57.296
    assert_eq!(theta_d_bin(1.0, N), 57);
    assert_eq!(theta_d_bin(FRAC_PI_2, N), 89);
    assert_eq!(theta_d_coord(FRAC_PI_2, N), 90.0);
    assert_eq!(theta_d_bin(3.0, N), 89);
    assert_bin_centres(theta_d_bin, theta_d_angle, N);
}

#[test]
fn phi_d_hand_computed() {
    let n = 180;
    assert_eq!(phi_d_bin(0.0, n), 0);
    // 1.0 / π · 180 = 57.296
    assert_eq!(phi_d_bin(1.0, n), 57);
    // −1 + π = 2.14159; / π · 180 = 122.70: negative φd folds by reciprocity.
    assert_eq!(phi_d_bin(-1.0, n), 122);
    assert_eq!(phi_d_bin(-FRAC_PI_2, n), 90);
    // φd = π: coordinate 180, clamped to the last bin (not wrapped to 0).
    assert_eq!(phi_d_coord(PI, n), 180.0);
    assert_eq!(phi_d_bin(PI, n), 179);
    // φd = −π folds to exactly 0.
    assert_eq!(phi_d_bin(-PI, n), 0);
    // A tiny negative φd folds to π (−1e-300 + π rounds to π): the last bin.
    assert_eq!(phi_d_bin(-1e-300, n), 179);
    for k in 0..n {
        let centre = phi_d_angle(k as f64 + 0.5, n);
        assert_eq!(phi_d_bin(centre, n), k, "bin {k}");
        assert_eq!(phi_d_bin(centre - PI, n), k, "folded bin {k}");
    }
}

#[test]
fn flat_index_of_hand_computed_angles() {
    let d = Dims::MERL;
    let c = HalfDiff::new(1.0, 0.7, 1.0, -1.0);
    assert_eq!(d.bins(&c), (71, 57, 122));
    assert_eq!(d.bin_index(&c), 122 + 180 * (57 + 90 * 71));
    // Other dims: the same mappings scaled (45 x 45 x 90 halves each coordinate).
    let h = Dims::new(45, 45, 90).unwrap();
    assert_eq!(h.bins(&c), (35, 28, 61));
}

fn random_pair(rng: &mut ChaCha8Rng) -> (Vec3, Vec3) {
    // z uniform in (0, 1]: uniform over the hemisphere, strictly above the horizon.
    let dir = |rng: &mut ChaCha8Rng| {
        let z: f64 = 1.0 - rng.random::<f64>();
        spherical(z.acos(), rng.random_range(-PI..PI))
    };
    (dir(rng), dir(rng))
}

/// A table whose value encodes the cell index, so a lookup tells which cell it read.
fn index_table(d: Dims) -> MerlTable {
    MerlTable::from_fn(d, |i, j, k| Some(Rgb::splat(d.index(i, j, k) as f64))).unwrap()
}

#[test]
fn bins_equal_the_reference_transcription_on_random_pairs() {
    let mut rng = ChaCha8Rng::seed_from_u64(2003);
    for d in [
        Dims::MERL,
        Dims::new(45, 45, 90).unwrap(),
        Dims::new(180, 90, 360).unwrap(),
    ] {
        let table = index_table(d);
        let (th, td, pd2) = (d.theta_h() as i32, d.theta_d() as i32, 2 * d.phi_d() as i32);
        let n_pairs = if d == Dims::MERL { 100_000 } else { 20_000 };
        for _ in 0..n_pairs {
            let (wi, wo) = random_pair(&mut rng);
            let c = to_half_diff(&wi, &wo);
            let oracle = reference::index(&c, th, td, pd2);
            assert_eq!(d.bin_index(&c), oracle, "{c:?} in {d}");
            // nearest() reads exactly that cell.
            let got = table.nearest(&wi, &wo).unwrap();
            let want = table.get_flat(oracle).unwrap();
            assert_eq!(got[0].to_bits(), want[0].to_bits());
        }
    }
}

#[test]
fn bins_equal_the_reference_on_random_and_edge_angles() {
    // Angles straight into the bin functions, including values outside the table's
    // range, exact edges and the fold, for the three axes separately.
    let mut rng = ChaCha8Rng::seed_from_u64(1998);
    let edges = [
        0.0, -0.0, 1e-300, -1e-300, FRAC_PI_2, PI, -PI, 1.0, -1.0, 3.5, -3.5,
    ];
    let mut angles: Vec<f64> = edges.to_vec();
    for _ in 0..100_000 {
        angles.push(rng.random_range(-3.3..3.3));
    }
    // Every cell's own angles, where round-off decides.
    for x in 0..=180 {
        angles.push(theta_h_angle(x as f64, 90));
        angles.push(theta_d_angle(x as f64, 90));
        angles.push(phi_d_angle(x as f64, 180));
        angles.push(phi_d_angle(x as f64, 180) - PI);
    }
    // (axis, our bin and its count, the reference's index and its resolution; the
    // reference's φd resolution spans 2π, ours π).
    type Bin = fn(f64, usize) -> usize;
    type Index = fn(f64, i32) -> i32;
    let axes: [(&str, Bin, usize, Index, i32); 5] = [
        ("θh", theta_h_bin, 90, reference::theta_half_index, 90),
        ("θd", theta_d_bin, 90, reference::theta_diff_index, 90),
        ("φd", phi_d_bin, 180, reference::phi_diff_index, 360),
        ("θh", theta_h_bin, 45, reference::theta_half_index, 45),
        ("φd", phi_d_bin, 90, reference::phi_diff_index, 180),
    ];
    for &a in &angles {
        for (axis, bin, n, index, res) in axes {
            assert_eq!(bin(a, n) as i32, index(a, res), "{axis} {a}");
        }
        // bin = clamp(trunc(coordinate)), bit for bit.
        let u = theta_h_coord(a, 90);
        assert_eq!(theta_h_bin(a, 90), (u as usize).min(89));
    }
}

#[test]
fn nearest_is_none_at_or_below_the_horizon_and_for_missing_cells() {
    let t = index_table(Dims::MERL);
    let up = spherical(0.3, 0.2);
    let grazing = spherical(FRAC_PI_2, 1.0); // z = 6e-17 > 0 by round-off
    let flat = Vec3::new(1.0, 0.0, 0.0); // z = 0 exactly
    let below = spherical(1.7, 0.0);
    assert!(t.nearest(&up, &spherical(0.5, 2.0)).is_some());
    assert!(grazing.z > 0.0 && t.nearest(&up, &grazing).is_some());
    for w in [flat, below, -up, Vec3::new(f64::NAN, 0.0, 0.5)] {
        assert_eq!(t.nearest(&up, &w), None);
        assert_eq!(t.nearest(&w, &up), None);
        assert_eq!(t.interpolated(&up, &w), None);
        assert_eq!(t.interpolated(&w, &up), None);
    }
    // A missing cell gives None, not zero.
    let (wi, wo) = (spherical(0.3, 0.2), spherical(0.5, 2.0));
    let idx = Dims::MERL.bin_index(&to_half_diff(&wi, &wo));
    let mut t2 = t.clone();
    let (i, j, k) = Dims::MERL.unflatten(idx);
    t2.set(i, j, k, None).unwrap();
    assert_eq!(t2.nearest(&wi, &wo), None);
    assert!(!t2.is_valid(idx));
}

#[test]
fn lookup_at_a_cells_own_angles_often_lands_a_bin_lower() {
    // The trap documented in docs/merl-format.md: cell angles are lower bin edges, and
    // the round trip through directions drifts below them for most cells.
    let d = Dims::MERL;
    let (mut total, mut lower) = (0usize, 0usize);
    for i in (1..90).step_by(4) {
        for j in (1..90).step_by(4) {
            for k in (1..180).step_by(4) {
                let c = d.cell_angles(i, j, k);
                let (wi, wo) = from_half_diff(&HalfDiff { phi_h: 0.3, ..c });
                if wi.z <= 0.0 || wo.z <= 0.0 {
                    continue;
                }
                total += 1;
                if d.bin_index(&to_half_diff(&wi, &wo)) != d.index(i, j, k) {
                    lower += 1;
                }
            }
        }
    }
    let frac = lower as f64 / total as f64;
    eprintln!("cells whose own angles look up another cell: {lower} of {total} ({frac:.3})");
    assert!(frac > 0.3, "{frac}");
    // While the bin centre always finds the cell.
    for (i, j, k) in [(5, 7, 9), (60, 20, 100), (89, 1, 179)] {
        let c = HalfDiff::new(
            theta_h_angle(i as f64 + 0.5, 90),
            0.0,
            theta_d_angle(j as f64 + 0.5, 90),
            phi_d_angle(k as f64 + 0.5, 180),
        );
        assert_eq!(d.bins(&c), (i, j, k));
    }
}
