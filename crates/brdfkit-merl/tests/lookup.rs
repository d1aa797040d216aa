//! Interpolation: exact on multilinear data, the φd wrap, missing-cell renormalisation;
//! batch lookups equal single ones.

mod common;

use brdfkit_core::direction::spherical;
use brdfkit_core::{HalfDiff, Rgb, Vec3, to_half_diff};
use brdfkit_merl::*;
use common::pair_at_coords;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// A multilinear function of the continuous indices, different per channel, positive.
fn multilinear(x: [f64; 3]) -> Rgb {
    let [u, v, w] = x;
    let f = |a: f64, b: f64, c: f64, d: f64, e: f64| {
        0.3 + a * u + b * v + c * w + d * u * v + e * u * v * w + 1e-4 * v * w + 2e-4 * u * w
    };
    Rgb::new(
        f(0.01, 0.02, 0.003, 1e-4, 1e-6),
        f(0.02, 0.001, 0.01, 2e-4, 3e-6),
        f(0.005, 0.01, 0.002, 5e-5, 2e-6),
    )
}

fn multilinear_table(d: Dims) -> MerlTable {
    MerlTable::from_fn(d, |i, j, k| {
        Some(multilinear([i as f64, j as f64, k as f64]))
    })
    .unwrap()
}

fn close(a: Rgb, b: Rgb, tol: f64) -> bool {
    (0..3).all(|c| (a[c] - b[c]).abs() <= tol * b[c].abs().max(1.0))
}

#[test]
fn interpolation_is_exact_on_multilinear_data() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    for d in [
        Dims::MERL,
        Dims::new(45, 45, 90).unwrap(),
        Dims::new(13, 17, 11).unwrap(),
    ] {
        let t = multilinear_table(d);
        let (nu, nv, nw) = (d.theta_h() as f64, d.theta_d() as f64, d.phi_d() as f64);
        // At coordinates directly.
        for _ in 0..5000 {
            let x = [
                rng.random_range(0.0..nu - 1.0),
                rng.random_range(0.0..nv - 1.0),
                rng.random_range(0.0..nw - 1.0),
            ];
            let got = t.interpolate_coords(x).unwrap();
            assert!(close(got, multilinear(x), 1e-12), "{x:?}: {got:?}");
        }
        // Through directions: the expected value is the function at the coordinates
        // of the pair's actual Rusinkiewicz angles.
        let mut checked = 0;
        while checked < 5000 {
            let x = [
                rng.random_range(0.5..nu - 1.01),
                rng.random_range(0.5..nv - 1.01),
                rng.random_range(0.01..nw - 1.01),
            ];
            let Some((wi, wo)) = pair_at_coords(d, x, rng.random_range(-PI..PI)) else {
                continue;
            };
            let actual = d.coords(&to_half_diff(&wi, &wo));
            assert!((actual[2] - x[2]).abs() < 1e-6, "stayed away from the wrap");
            let got = t.interpolated(&wi, &wo).unwrap();
            assert!(close(got, multilinear(actual), 1e-12), "{x:?}");
            checked += 1;
        }
    }
}

#[test]
fn interpolation_at_nodes_returns_the_cell_and_holds_the_last_node() {
    let d = Dims::new(6, 5, 8).unwrap();
    let t = multilinear_table(d);
    for x in 0..d.cells() {
        let (i, j, k) = d.unflatten(x);
        let got = t
            .interpolate_coords([i as f64, j as f64, k as f64])
            .unwrap();
        assert_eq!(got, t.get_flat(x).unwrap());
    }
    // Past the last θh / θd node (coordinates in [n − 1, n]) the last node is held.
    let a = t.interpolate_coords([5.7, 4.9, 2.0]).unwrap();
    assert_eq!(a, t.get(5, 4, 2).unwrap());
}

#[test]
fn phi_d_wraps_by_reciprocity() {
    let d = Dims::new(10, 10, 20).unwrap();
    // Values strongly different at k = 19 and k = 0, so a wrong neighbour shows.
    let t = MerlTable::from_fn(d, |i, j, k| {
        Some(Rgb::new(
            1.0 + k as f64,
            2.0 + k as f64 + i as f64,
            3.0 + j as f64,
        ))
    })
    .unwrap();
    let f19 = t.get(4, 6, 19).unwrap();
    let f0 = t.get(4, 6, 0).unwrap();
    for frac in [0.0, 0.25, 0.5, 0.9] {
        let got = t.interpolate_coords([4.0, 6.0, 19.0 + frac]).unwrap();
        let want = f19 * (1.0 - frac) + f0 * frac;
        assert!(close(got, want, 1e-12), "{frac}: {got:?} vs {want:?}");
    }
    // Coordinate nφd (φd = π) is node 0.
    assert_eq!(
        t.interpolate_coords([4.0, 6.0, 20.0]),
        t.interpolate_coords([4.0, 6.0, 0.0])
    );
    // Through angles: φd just below π, and just below 0 (folded to just below π).
    let th = theta_h_angle(4.0, 10);
    let td = theta_d_angle(6.0, 10);
    let w = 19.5;
    for phi_d in [phi_d_angle(w, 20), phi_d_angle(w, 20) - PI] {
        let got = t
            .interpolated_half_diff(&HalfDiff::new(th, 0.0, td, phi_d))
            .unwrap();
        let want = (f19 + f0) * 0.5;
        assert!(close(got, want, 1e-9), "{phi_d}: {got:?} vs {want:?}");
    }
}

#[test]
fn missing_corners_are_renormalised_out() {
    let d = Dims::new(20, 25, 40).unwrap();
    let mut t = multilinear_table(d);
    let x = [10.25, 20.5, 30.75];
    let corners = [(10, 20, 30), (11, 21, 31), (10, 21, 30)];
    for &(i, j, k) in &corners {
        t.set(i, j, k, None).unwrap();
    }
    // By hand: weights of the 8 corners, the missing ones dropped.
    let (mut acc, mut ws) = (Rgb::ZERO, 0.0);
    for (i, wu) in [(10, 0.75), (11, 0.25)] {
        for (j, wv) in [(20, 0.5), (21, 0.5)] {
            for (k, ww) in [(30, 0.25), (31, 0.75)] {
                if corners.contains(&(i, j, k)) {
                    continue;
                }
                let w = wu * wv * ww;
                acc += multilinear([i as f64, j as f64, k as f64]) * w;
                ws += w;
            }
        }
    }
    let got = t.interpolate_coords(x).unwrap();
    assert!(close(got, acc / ws, 1e-12), "{got:?} vs {:?}", acc / ws);
    // A missing cell is never read as zero: the result stays within the valid values.
    assert!(got.min_channel() > 0.3);

    // None valid: all 8 corners missing.
    for i in 10..=11 {
        for j in 20..=21 {
            for k in 30..=31 {
                t.set(i, j, k, None).unwrap();
            }
        }
    }
    assert_eq!(t.interpolate_coords(x), None);
    // Only zero-weight corners valid: None too (at a missing node exactly).
    let mut t2 = multilinear_table(d);
    t2.set(3, 4, 5, None).unwrap();
    assert_eq!(t2.interpolate_coords([3.0, 4.0, 5.0]), None);
    assert!(t2.interpolate_coords([3.0, 4.0, 5.1]).is_some());
}

#[test]
fn batch_lookups_equal_single_lookups() {
    let t = multilinear_table(Dims::MERL);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let pairs: Vec<(Vec3, Vec3)> = (0..20_000)
        .map(|_| {
            // Some below the horizon on purpose.
            let wi = spherical(rng.random_range(0.0..1.8), rng.random_range(-PI..PI));
            let wo = spherical(rng.random_range(0.0..1.65), rng.random_range(-PI..PI));
            (wi, wo)
        })
        .collect();
    for mode in [Lookup::Nearest, Lookup::Interpolated] {
        let batch = t.lookup_batch(mode, &pairs);
        assert_eq!(batch.len(), pairs.len());
        let mut nones = 0;
        for ((wi, wo), b) in pairs.iter().zip(&batch) {
            assert_eq!(*b, t.lookup(mode, wi, wo));
            assert_eq!(b.is_none(), wi.z <= 0.0 || wo.z <= 0.0);
            nones += b.is_none() as usize;
        }
        assert!(nones > 1000, "the sample includes below-horizon pairs");
    }
    assert_eq!(
        t.nearest_batch(&pairs[..10]),
        t.lookup_batch(Lookup::Nearest, &pairs[..10])
    );
    assert_eq!(
        t.interpolated_batch(&pairs[..10]),
        t.sample_pairs(Lookup::Interpolated, &pairs[..10])
    );
}
