//! The f32 batch evaluation (`eval_flat`, `eval_split`, `eval_stored_flat`: what
//! `fit-brdf eval --bsdf` and `resample --bsdf` run) against the f64 path (`Brdf::eval`,
//! `eval_stored`, the one tests/mitsuba.rs checks against Mitsuba pair by pair) on
//! seeded random pairs and on the edge cases: grazing, θ = 0, φ across the ±π wrap,
//! below the horizon (0). The bound is the against Mitsuba: ≥ 99.9 % within
//! 1e-4 relative + 1e-6 absolute, none off by more than 1 %.

mod common;

use brdfkit_core::{Brdf, Vec3};
use brdfkit_rgl::RglBsdf;
use common::tally::Tally;
use common::{Spec, fields, pairs};

fn file(spec: Spec) -> (tempfile::TempDir, RglBsdf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.bsdf");
    brdfkit_rgl::tensor::write(&fields(spec), &path).unwrap();
    let b = RglBsdf::read(&path).unwrap();
    (dir, b)
}

fn unit(theta_deg: f64, phi: f64) -> [f64; 3] {
    let (t, p) = (theta_deg.to_radians(), phi);
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// Random pairs above 1°, then the edge cases.
fn test_pairs(seed: u64) -> Vec<[f64; 6]> {
    let mut ps = pairs(40_000, 1.0, seed);
    let join = |a: [f64; 3], b: [f64; 3]| [a[0], a[1], a[2], b[0], b[1], b[2]];
    let pole = [0.0, 0.0, 1.0];
    for k in 0..400 {
        let phi = -std::f64::consts::PI + k as f64 * 0.0157;
        // Grazing (89.9° to 89.999°), θ = 0 on either side, φ just either side of ±π.
        ps.push(join(unit(89.9 + 0.00025 * k as f64, phi), unit(45.0, -phi)));
        ps.push(join(unit(30.0, phi), unit(89.99, phi + 1.0)));
        ps.push(join(pole, unit(k as f64 * 0.2, phi)));
        ps.push(join(unit(k as f64 * 0.2, phi), pole));
        let eps = 1e-7 * (k as f64 - 200.0);
        ps.push(join(
            unit(40.0, std::f64::consts::PI + eps),
            unit(60.0, std::f64::consts::PI - eps),
        ));
        ps.push(join(
            unit(70.0, eps),
            unit(20.0, std::f64::consts::PI + eps),
        ));
    }
    ps.push(join(pole, pole));
    ps
}

fn below_horizon() -> Vec<[f64; 6]> {
    let up = [0.3, 0.4, 0.866_025_403_784_438_6];
    let (down, flat) = ([0.3, 0.4, -0.866_025_403_784_438_6], [0.6, 0.8, 0.0]);
    [
        (up, down),
        (down, up),
        (down, down),
        (up, flat),
        (flat, up),
        (flat, flat),
    ]
    .map(|(a, b)| [a[0], a[1], a[2], b[0], b[1], b[2]])
    .to_vec()
}

/// Whether the half vector of `p` lies within 1e-6 rad of φ = ±π (after any fold). An
/// anisotropic file's VNDF and values are looked up at u = (φm + π)/2π: on either side
/// of the seam u is near 0 or near 1, the two edges of the table. Within f32 rounding
/// of π (2.4e-7) the f32 path (and Mitsuba's) and the f64 path may take different
/// sides; the tables of a real file are periodic so the sides agree, the random test
/// tables are not.
fn on_seam(p: &[f64; 6]) -> bool {
    let (mx, my) = (p[0] + p[3], p[1] + p[4]);
    let tiny = |v: f64| v.abs() < 1e-6 * (mx * mx + my * my).sqrt();
    // The folds flip signs only, so the seam is where m lies on the x or y axis.
    tiny(my) || tiny(mx)
}

fn check(spec: Spec) {
    let (_dir, b) = file(spec);
    let ps = test_pairs(spec.seed + 11);
    let flat = ps.concat();
    let mut out = vec![f64::NAN; 3 * ps.len()];
    b.eval_flat(&flat, &mut out);
    let mut t = Tally::default();
    for (p, o) in ps.iter().zip(out.chunks_exact(3)) {
        let want = b.eval(&Vec3::new(p[0], p[1], p[2]), &Vec3::new(p[3], p[4], p[5]));
        for (x, y) in o.iter().zip(want.0) {
            t.add_seam(*x, y, spec.anisotropic && on_seam(p));
        }
    }
    t.check(&format!("RGB {spec:?}"));
    // The stored values (per wavelength, spectral), against `eval_stored`.
    let k = b.stored_len();
    let mut stored = vec![f64::NAN; k * ps.len()];
    b.eval_stored_flat(&flat, &mut stored);
    let (mut t, mut want) = (Tally::default(), vec![0.0; k]);
    for (p, o) in ps.iter().zip(stored.chunks_exact(k)) {
        b.eval_stored(
            &Vec3::new(p[0], p[1], p[2]),
            &Vec3::new(p[3], p[4], p[5]),
            &mut want,
        );
        let seam = spec.anisotropic && on_seam(p);
        o.iter()
            .zip(&want)
            .for_each(|(x, y)| t.add_seam(*x, *y, seam));
    }
    t.check(&format!("stored {spec:?}"));
    // wi and wo apart: the same numbers as `eval_flat`.
    let (wi, wo): (Vec<[f64; 3]>, Vec<[f64; 3]>) = ps
        .iter()
        .map(|p| ([p[0], p[1], p[2]], [p[3], p[4], p[5]]))
        .unzip();
    let mut split = vec![[f64::NAN; 3]; ps.len()];
    b.eval_split(&wi, &wo, &mut split);
    assert_eq!(split.concat(), out);
}

fn spec(anisotropic: bool, spectral: bool, n: u64, m: u64, seed: u64) -> Spec {
    Spec {
        anisotropic,
        spectral,
        n,
        m,
        seed,
    }
}

/// The files whose batch values are checked against the f64 path: (anisotropic,
/// spectral, value grid, VNDF grid), seeded 1, 2, …: isotropic RGB on two grids,
/// anisotropic RGB, isotropic and anisotropic spectral.
const FILES: [(bool, bool, u64, u64); 5] = [
    (false, false, 32, 128),
    (false, false, 64, 32),
    (true, false, 16, 32),
    (false, true, 16, 32),
    (true, true, 16, 16),
];

#[test]
fn rgb_and_spectral_files_agree_with_the_f64_path() {
    for (seed, (aniso, spectral, n, m)) in (1u64..).zip(FILES) {
        check(spec(aniso, spectral, n, m, seed));
    }
}

#[test]
fn below_the_horizon_is_zero_and_odd_lengths_are_whole() {
    let (_dir, b) = file(spec(false, false, 16, 16, 6));
    // 37 pairs: two whole lane blocks and a padded one; the below-horizon ones mixed in.
    let mut ps = pairs(31, 1.0, 7);
    ps.extend(below_horizon());
    ps.rotate_left(13);
    let mut out = vec![f64::NAN; 3 * ps.len()];
    b.eval_flat(&ps.concat(), &mut out);
    for (p, o) in ps.iter().zip(out.chunks_exact(3)) {
        let want = b.eval(&Vec3::new(p[0], p[1], p[2]), &Vec3::new(p[3], p[4], p[5]));
        if p[2] <= 0.0 || p[5] <= 0.0 {
            assert_eq!(o, [0.0; 3], "below the horizon at {p:?}");
        } else {
            for (x, y) in o.iter().zip(want.0) {
                assert!(
                    (x - y).abs() <= 1e-4 * y.abs() + 1e-6,
                    "{x} vs {y} at {p:?}"
                );
                assert!(*x != 0.0);
            }
        }
    }
    let mut none: Vec<f64> = vec![];
    b.eval_flat(&[], &mut none);
}

/// `to_table` (the batch path, what `fit-brdf resample --bsdf` runs) holds in each cell
/// the f64 path's two-order mean, clamped at 0, within the bound.
#[test]
fn to_table_holds_the_f64_two_order_mean() {
    use brdfkit_merl::Dims;
    let (_dir, b) = file(spec(false, false, 32, 64, 8));
    let dims = Dims::new(12, 10, 24).unwrap();
    let (table, stats) = b.to_table(dims).unwrap();
    let mut t = Tally::default();
    let mut present = 0;
    for c in table.present_cells() {
        present += 1;
        let want = b.symmetric(&c.wi, &c.wo).map(|x| x.max(0.0));
        for (x, y) in c.value.0.iter().zip(want.0) {
            t.add(*x, y);
        }
    }
    assert_eq!(
        present + stats.missing,
        dims.theta_h() * dims.theta_d() * dims.phi_d()
    );
    assert!(present > 1000);
    t.check("to_table");
}
