//! The fast batch lookups (`lookup_flat`, `lookup_split`, `lookup_batch`) against the
//! reference mapping: the same cell bit for bit for millions of random pairs, for pairs
//! within an ulp of every bin edge, for wi = wo, h on the normal and grazing pairs; the
//! interpolation over the same stencil to 1e-11.

mod common;

use brdfkit_core::direction::spherical;
use brdfkit_core::{Rgb, Vec3, to_half_diff};
use brdfkit_merl::lookup::PairsError;
use brdfkit_merl::*;
use common::pair_at_coords;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{FRAC_PI_2, PI};

/// A table whose value names its cell, R = i, G = j, B = k (+ 0.5 so no value is 0),
/// with a scattering of missing cells.
fn naming_table(d: Dims) -> MerlTable {
    MerlTable::from_fn(d, |i, j, k| {
        ((i * 7 + j * 3 + k) % 101 != 0)
            .then(|| Rgb::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5))
    })
    .unwrap()
}

fn flat(pairs: &[(Vec3, Vec3)]) -> Vec<f64> {
    pairs
        .iter()
        .flat_map(|(a, b)| [a.x, a.y, a.z, b.x, b.y, b.z])
        .collect()
}

/// The reference value as an output row (NaN for none).
fn row(v: Option<Rgb>) -> [f64; 3] {
    v.map_or([f64::NAN; 3], |v| [v[0], v[1], v[2]])
}

fn same_bits(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|c| a[c].to_bits() == b[c].to_bits() || (a[c].is_nan() && b[c].is_nan()))
}

/// Asserts that the fast nearest lookups of `pairs` equal the reference bit for bit;
/// returns the number of pairs with a value.
fn assert_nearest_exact(t: &MerlTable, pairs: &[(Vec3, Vec3)], what: &str) -> usize {
    let input = flat(pairs);
    let mut out = vec![0.0; 3 * pairs.len()];
    t.nearest_flat(&input, &mut out).unwrap();
    let mut found = 0;
    for (k, (wi, wo)) in pairs.iter().enumerate() {
        let want = row(t.nearest(wi, wo));
        let got = [out[3 * k], out[3 * k + 1], out[3 * k + 2]];
        assert!(
            same_bits(got, want),
            "{what}: pair {k} wi {wi:?} wo {wo:?}: fast {got:?}, reference {want:?} \
             (angles {:?})",
            to_half_diff(wi, wo)
        );
        found += !want[0].is_nan() as usize;
    }
    found
}

/// A unit vector uniform on the upper hemisphere.
fn hemisphere(rng: &mut ChaCha8Rng) -> Vec3 {
    spherical(
        rng.random_range(0.0f64..1.0).acos(),
        rng.random_range(-PI..PI),
    )
}

/// `v` tilted by a small angle `eps` in a random direction.
fn tilt(rng: &mut ChaCha8Rng, v: &Vec3, eps: f64) -> Vec3 {
    let a = Vec3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    );
    let p = (a - v * v.dot(&a)).normalize();
    (v * eps.cos() + p * eps.sin()).normalize()
}

/// A random pair of kind `kind % 4`: uniform on the hemisphere; wo within about `eps`
/// of wi's mirror image (small θh); wo within `eps` of wi (small θd); wo `eps` from
/// grazing. `eps` = 10^u, u uniform in `log_eps`.
fn random_pair(rng: &mut ChaCha8Rng, kind: usize, log_eps: std::ops::Range<f64>) -> (Vec3, Vec3) {
    let wi = hemisphere(rng);
    let eps = 10f64.powf(rng.random_range(log_eps));
    let wo = match kind % 4 {
        0 => hemisphere(rng),
        1 => tilt(rng, &Vec3::new(-wi.x, -wi.y, wi.z), eps),
        2 => tilt(rng, &wi, eps),
        _ => spherical(FRAC_PI_2 - eps, rng.random_range(-PI..PI)),
    };
    (wi, wo)
}

/// 4 million random pairs: uniform on the hemisphere, near the specular direction
/// (small θh), near the retro direction (small θd), near grazing; all cells compared.
#[test]
fn nearest_is_the_reference_cell_for_millions_of_random_pairs() {
    let t = naming_table(Dims::MERL);
    let mut rng = ChaCha8Rng::seed_from_u64(0x6835);
    let mut total_found = 0;
    for batch in 0..8 {
        let pairs: Vec<(Vec3, Vec3)> = (0..500_000)
            .map(|_| random_pair(&mut rng, batch, -12.0..-0.5))
            .collect();
        total_found += assert_nearest_exact(&t, &pairs, &format!("random batch {batch}"));
    }
    assert!(total_found > 3_500_000, "{total_found}");
}

/// Pairs built at every bin edge of each axis (the cells' own angles and the upper
/// edges), their components then moved by −2..=2 ulps: the reference coordinates of
/// these pairs lie within a few ulps of an integer, on both sides.
#[test]
fn nearest_is_the_reference_cell_within_ulps_of_every_bin_edge() {
    let d = Dims::MERL;
    let t = naming_table(d);
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let step = |x: f64, n: i32| {
        let mut x = x;
        for _ in 0..n.abs() {
            x = if n > 0 { x.next_up() } else { x.next_down() };
        }
        x
    };
    let mut pairs = Vec::new();
    let edges = [d.theta_h(), d.theta_d(), d.phi_d()];
    for (axis, &n) in edges.iter().enumerate() {
        for e in 1..n {
            for _ in 0..12 {
                let mut x = [
                    rng.random_range(0.5..d.theta_h() as f64 - 1.0),
                    rng.random_range(0.5..d.theta_d() as f64 - 1.0),
                    rng.random_range(0.5..d.phi_d() as f64 - 1.0),
                ];
                x[axis] = e as f64;
                let Some((wi, wo)) = pair_at_coords(d, x, rng.random_range(-PI..PI)) else {
                    continue;
                };
                for a in -2..=2 {
                    for b in -2..=2 {
                        let mut o = wo;
                        let mut i = wi;
                        o[(axis + 1) % 3] = step(o[(axis + 1) % 3], a);
                        i[axis] = step(i[axis], b);
                        pairs.push((i, o));
                    }
                }
            }
        }
    }
    // The construction does reach the edges: count the pairs whose reference
    // coordinate along the constructed axis lies within 1e-12 of an integer.
    let near = pairs
        .iter()
        .filter(|(wi, wo)| {
            let c = d.coords(&to_half_diff(wi, wo));
            c.iter()
                .any(|x| (x - x.round()).abs() < 1e-12 && x.round() > 0.0)
        })
        .count();
    assert!(
        near > pairs.len() / 2,
        "{near} of {} near an edge",
        pairs.len()
    );
    assert_nearest_exact(&t, &pairs, "bin edges");
}

/// wi = wo (the reference's θd = φd = 0 convention), h on the normal (mirror pairs, the
/// reference's φh = 0 branch), grazing and below-horizon directions, non-finite ones.
#[test]
fn nearest_special_pairs_match_the_reference() {
    let t = naming_table(Dims::MERL);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut pairs = Vec::new();
    for _ in 0..20_000 {
        let w = hemisphere(&mut rng);
        pairs.push((w, w));
        pairs.push((w, Vec3::new(-w.x, -w.y, w.z)));
        let g = spherical(FRAC_PI_2, rng.random_range(-PI..PI));
        pairs.push((w, g));
        pairs.push((g, w));
        let tiny = spherical(FRAC_PI_2 - 1e-300_f64.max(1e-17), rng.random_range(-PI..PI));
        pairs.push((tiny, tiny));
        pairs.push((w, tiny));
        pairs.push((w, Vec3::new(w.x, w.y, -w.z)));
    }
    let n = Vec3::new(0.0, 0.0, 1.0);
    pairs.push((n, n));
    pairs.push((Vec3::new(f64::NAN, 0.0, 1.0), n));
    pairs.push((n, Vec3::new(0.0, f64::INFINITY, 1.0)));
    pairs.push((Vec3::new(1e-300, 0.0, 1.0), Vec3::new(-1e-300, 0.0, 1.0)));
    pairs.push((Vec3::new(0.0, 0.0, 1e-300), n));
    assert_nearest_exact(&t, &pairs, "special pairs");
}

/// The batch forms agree with each other and with `lookup_batch`; other grids (odd
/// dims, 1 bin along an axis) too.
#[test]
fn batch_forms_agree_on_other_grids() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for d in [
        Dims::new(45, 45, 90).unwrap(),
        Dims::new(13, 17, 11).unwrap(),
        Dims::new(1, 1, 1).unwrap(),
        Dims::new(1, 3, 2).unwrap(),
        Dims::new(200, 7, 360).unwrap(),
    ] {
        let t = naming_table(d);
        let pairs: Vec<(Vec3, Vec3)> = (0..50_000)
            .map(|_| (hemisphere(&mut rng), hemisphere(&mut rng)))
            .collect();
        assert_nearest_exact(&t, &pairs, &format!("{d}"));
        let wi: Vec<[f64; 3]> = pairs.iter().map(|p| [p.0.x, p.0.y, p.0.z]).collect();
        let wo: Vec<[f64; 3]> = pairs.iter().map(|p| [p.1.x, p.1.y, p.1.z]).collect();
        let mut split = vec![[0.0; 3]; pairs.len()];
        t.lookup_split(Lookup::Nearest, &wi, &wo, &mut split)
            .unwrap();
        let batch = t.lookup_batch(Lookup::Nearest, &pairs);
        for (k, (wi, wo)) in pairs.iter().enumerate() {
            let want = t.nearest(wi, wo);
            assert_eq!(batch[k], want);
            assert!(same_bits(split[k], row(want)));
        }
        // Interpolated over the same grid.
        assert_interpolated_close(&t, &pairs, &format!("{d}"));
    }
}

/// Asserts that the fast interpolation equals the reference's to 1e-11 relative, plus,
/// with `slope` (a bound on the table's change per unit of index coordinate), what the
/// reference's own round-off in θd and φd can move it by: its rotated vector d carries
/// up to about 1e-14 of round-off (measured: 2.4e-15), so θd is off by up to
/// 1e-14 / sin θd (at most 3e-8, the step of acos below 1) and φd by 1e-14 / sin θd
/// (the azimuth of a short vector).
fn assert_interpolated_close(t: &MerlTable, pairs: &[(Vec3, Vec3)], what: &str) {
    assert_interpolated_within(t, pairs, what, 0.0)
}

fn assert_interpolated_within(t: &MerlTable, pairs: &[(Vec3, Vec3)], what: &str, slope: f64) {
    let input = flat(pairs);
    let mut out = vec![0.0; 3 * pairs.len()];
    t.interpolated_flat(&input, &mut out).unwrap();
    let wi: Vec<[f64; 3]> = pairs.iter().map(|p| [p.0.x, p.0.y, p.0.z]).collect();
    let wo: Vec<[f64; 3]> = pairs.iter().map(|p| [p.1.x, p.1.y, p.1.z]).collect();
    let mut split = vec![[0.0; 3]; pairs.len()];
    t.lookup_split(Lookup::Interpolated, &wi, &wo, &mut split)
        .unwrap();
    let d = t.dims();
    for (k, (wi, wo)) in pairs.iter().enumerate() {
        let want = row(t.interpolated(wi, wo));
        let got = [out[3 * k], out[3 * k + 1], out[3 * k + 2]];
        assert!(same_bits(got, split[k]), "{what}: flat and split differ");
        // sin θd from the chord (|wi − wo| = 2 sin θd), not from the reference's θd,
        // which is the quantity in doubt.
        let sin_d = (wi - wo).norm() / 2.0;
        let dv = (1e-14 / sin_d).min(3e-8) * d.theta_d() as f64 / FRAC_PI_2;
        let dw = 1e-14 / sin_d * d.phi_d() as f64 / PI;
        let allow = slope * (dv + dw);
        for c in 0..3 {
            assert!(
                (want[c].is_nan() && got[c].is_nan())
                    || (got[c] - want[c]).abs() <= 1e-11 * want[c].abs().max(1.0) + allow,
                "{what}: pair {k} wi {wi:?} wo {wo:?}: fast {got:?}, reference {want:?}"
            );
        }
    }
}

/// Interpolation: the reference's value to 1e-11 (plus the reference's own round-off
/// near θd = 0) over a million pairs of every kind on a smooth table; to 1e-11 on the
/// cell-naming table with missing cells (whose jumps show a wrong stencil).
#[test]
fn interpolated_matches_the_reference_over_the_same_stencil() {
    // Changes by at most 0.04 per unit of index coordinate.
    let smooth = MerlTable::from_fn(Dims::MERL, |i, j, k| {
        let (u, v, w) = (i as f64, j as f64, k as f64);
        Some(Rgb::new(
            1.0 + 0.01 * u + 0.003 * v * w / 180.0,
            2.0 + (w / 30.0).sin(),
            0.5 + u * v * 1e-4,
        ))
    })
    .unwrap();
    let naming = naming_table(Dims::MERL);
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    for batch in 0..4 {
        let pairs: Vec<(Vec3, Vec3)> = (0..250_000)
            .map(|_| random_pair(&mut rng, batch, -10.0..-0.5))
            .collect();
        assert_interpolated_within(&smooth, &pairs, "smooth", 0.04);
        if batch == 0 {
            assert_interpolated_close(&naming, &pairs[..100_000], "naming");
        }
    }
}

#[test]
fn shape_errors_are_typed() {
    let t = naming_table(Dims::new(4, 4, 8).unwrap());
    let mut out = vec![0.0; 3];
    assert_eq!(
        t.nearest_flat(&[0.0; 7], &mut out),
        Err(PairsError::NotRows { len: 7 })
    );
    assert_eq!(
        t.nearest_flat(&[0.0; 12], &mut out),
        Err(PairsError::Output {
            pairs: 2,
            expected: 6,
            actual: 3
        })
    );
    let mut o = vec![[0.0; 3]; 2];
    assert!(matches!(
        t.lookup_split(Lookup::Nearest, &[[0.0; 3]], &[[0.0; 3]], &mut o),
        Err(PairsError::Lengths {
            wi: 1,
            wo: 1,
            out: 2
        })
    ));
    // Empty input is fine.
    t.nearest_flat(&[], &mut []).unwrap();
}
