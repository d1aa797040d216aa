//! Resampling (analytic → table → other dims → back), the valid-cell view, solid-angle
//! weights and table statistics.

use brdfkit_core::direction::spherical;
use brdfkit_core::{Brdf, Rgb, Vec3, from_half_diff, to_half_diff};
use brdfkit_merl::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// f = ρ/π.
struct Lambert(Rgb);

impl Brdf for Lambert {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.0 / PI
    }
}

/// A diffuse term plus a Blinn–Phong-like lobe: smooth, strongly varying in θh.
struct Glossy;

impl Brdf for Glossy {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let h = (wi + wo).normalize();
        Rgb::new(0.1, 0.2, 0.3) / PI + Rgb::new(2.0, 1.5, 1.0) * h.z.powi(40)
    }
}

/// f = c cos θi cos θo: a(θo) = c cos θo · 2π/3 in closed form.
struct CosCos(f64);

impl Brdf for CosCos {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        Rgb::splat(self.0 * wi.z.max(0.0) * wo.z.max(0.0))
    }
}

/// A model that returns a bad value somewhere.
struct Bad(f64);

impl Brdf for Bad {
    fn eval(&self, wi: &Vec3, _wo: &Vec3) -> Rgb {
        if wi.z < 0.5 {
            Rgb::new(0.1, self.0, 0.1)
        } else {
            Rgb::splat(0.1)
        }
    }
}

#[test]
fn analytic_to_table_holds_the_model_at_cell_angles_and_masks_the_horizon() {
    let d = Dims::MERL;
    let t = MerlTable::from_brdf(&Glossy, d).unwrap();
    let mut missing = 0;
    for x in 0..d.cells() {
        let (i, j, k) = d.unflatten(x);
        let c = d.cell_angles(i, j, k);
        assert_eq!(c.phi_h, 0.0);
        let (wi, wo) = from_half_diff(&c);
        if wi.z <= 0.0 || wo.z <= 0.0 {
            assert_eq!(t.get_flat(x), None, "cell {i} {j} {k} is below the horizon");
            assert_eq!(t.raw_at(x), [MISSING_RAW; 3]);
            missing += 1;
            continue;
        }
        let want = Glossy.eval(&wi, &wo);
        let got = t.get_flat(x).unwrap();
        for ch in 0..3 {
            // Stored as raw = value / scale, read as raw × scale: one ulp at most.
            assert!(
                (got[ch] - want[ch]).abs() <= 2.0 * f64::EPSILON * want[ch],
                "{i} {j} {k}: {got:?} vs {want:?}"
            );
        }
    }
    assert_eq!(t.valid_count(), d.cells() - missing);
    eprintln!(
        "valid fraction of an analytic MERL-grid table: {:.4}",
        t.valid_fraction()
    );
    assert!(t.valid_fraction() > 0.5 && t.valid_fraction() < 0.8);
}

#[test]
fn doubling_then_halving_with_nearest_recovers_the_table_exactly() {
    let t1 = MerlTable::from_brdf(&Glossy, Dims::MERL).unwrap();
    let fine = Dims::new(180, 90, 360).unwrap();
    let t2 = t1.resample(fine, Lookup::Nearest);
    assert_eq!(t2.dims(), fine);
    // Each fine cell copies the coarse cell (i/2, j, k/2) bit for bit.
    for x in (0..fine.cells()).step_by(7) {
        let (i, j, k) = fine.unflatten(x);
        let src = Dims::MERL.index(i / 2, j, k / 2);
        assert_eq!(
            t2.raw_at(x).map(f64::to_bits),
            t1.raw_at(src).map(f64::to_bits)
        );
    }
    let t3 = t2.resample(Dims::MERL, Lookup::Nearest);
    assert_eq!(t3.dims(), Dims::MERL);
    assert!(
        t3.raw()
            .iter()
            .zip(t1.raw())
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    assert_eq!(t3.valid_mask(), t1.valid_mask());
    assert_eq!(t3, t1);
    // Halving takes every other cell.
    let half = Dims::new(45, 45, 90).unwrap();
    let th = t1.resample(half, Lookup::Nearest);
    for x in 0..half.cells() {
        let (i, j, k) = half.unflatten(x);
        assert_eq!(
            th.raw_at(x),
            t1.raw_at(Dims::MERL.index(2 * i, 2 * j, 2 * k))
        );
    }
    // Same dims: identity.
    assert_eq!(t1.resample(Dims::MERL, Lookup::Interpolated), t1);
}

#[test]
fn interpolated_resampling_of_multilinear_data_is_exact() {
    // Every axis maps target index to source coordinate linearly (i · nS / nT, also
    // for the square-root-spaced θh), so a multilinear source gives the same function
    // on the target grid, except past the last source node (held) and across the wrap.
    let src = Dims::new(20, 16, 24).unwrap();
    let f = |u: f64, v: f64, w: f64| 1.0 + 0.1 * u + 0.2 * v + 0.05 * w + 0.01 * u * v * w;
    let t = MerlTable::from_fn(src, |i, j, k| {
        Some(Rgb::splat(f(i as f64, j as f64, k as f64)))
    })
    .unwrap();
    let dst = Dims::new(30, 40, 36).unwrap();
    let r = t.resample(dst, Lookup::Interpolated);
    let mut checked = 0;
    for x in 0..dst.cells() {
        let (i, j, k) = dst.unflatten(x);
        let (u, v, w) = (
            i as f64 * 20.0 / 30.0,
            j as f64 * 16.0 / 40.0,
            k as f64 * 24.0 / 36.0,
        );
        if u > 19.0 || v > 15.0 || w > 23.0 {
            continue;
        }
        let got = r.get_flat(x).unwrap()[0];
        assert!((got - f(u, v, w)).abs() < 1e-12 * f(u, v, w), "{i} {j} {k}");
        checked += 1;
    }
    assert!(checked > dst.cells() / 2);
}

#[test]
fn interpolated_resampling_propagates_missing_cells() {
    let src = Dims::new(4, 4, 4).unwrap();
    let t = MerlTable::from_fn(src, |i, _, _| (i < 2).then_some(Rgb::splat(1.0))).unwrap();
    let r = t.resample(Dims::new(8, 4, 4).unwrap(), Lookup::Interpolated);
    // Target θh coordinate i/2: cells 0..=2 reach valid sources only, 3 (coordinate
    // 1.5) renormalises onto source 1, 4 and above see only missing sources.
    for i in 0..8 {
        let v = r.get(i, 1, 1);
        if i <= 3 {
            assert_eq!(v, Some(Rgb::splat(1.0)), "{i}");
        } else {
            assert_eq!(v, None, "{i}");
        }
    }
}

#[test]
fn model_errors_name_the_cell() {
    let e = MerlTable::from_brdf(&Bad(f64::NAN), Dims::new(9, 9, 18).unwrap()).unwrap_err();
    assert!(
        matches!(
            e,
            TableError::NonFinite(BadValue {
                channel: Channel::Green,
                ..
            })
        ),
        "{e}"
    );
    let e = MerlTable::from_brdf(&Bad(-1.0), Dims::new(9, 9, 18).unwrap()).unwrap_err();
    assert!(matches!(e, TableError::Negative(_)), "{e}");
    assert!(e.to_string().contains("missing"), "{e}");
}

#[test]
fn cell_weights_sum_to_eight_pi_squared() {
    for d in [
        Dims::MERL,
        Dims::new(45, 45, 90).unwrap(),
        Dims::new(180, 90, 360).unwrap(),
        Dims::new(1, 1, 1).unwrap(),
        Dims::new(7, 3, 5).unwrap(),
    ] {
        let mut s = 0.0;
        for i in 0..d.theta_h() {
            for j in 0..d.theta_d() {
                s += cell_weight(d, i, j) * d.phi_d() as f64;
                assert!(cell_weight(d, i, j) > 0.0);
            }
        }
        let want = 8.0 * PI * PI;
        assert!((s - want).abs() < 1e-12 * want, "{d}: {s} vs {want}");
    }
}

#[test]
fn cell_weights_match_a_monte_carlo_measure_of_pair_space() {
    // Pairs uniform over hemisphere × hemisphere (measure (2π)²). Blocks of bins whose
    // pairs all lie above the horizon (θh + θd < π/2) have measure Σ weights; the
    // fraction of samples landing in them estimates that measure independently of the
    // Jacobian used by the weights.
    let d = Dims::MERL;
    let n: usize = 1_000_000;
    let hist: Vec<u64> = (0..n as u64)
        .into_par_iter()
        .fold(
            || vec![0u64; 90 * 90],
            |mut h, s| {
                let mut rng = ChaCha8Rng::seed_from_u64(s);
                let mut dir = || {
                    let z: f64 = 1.0 - rng.random::<f64>();
                    spherical(z.acos(), rng.random_range(-PI..PI))
                };
                let (wi, wo) = (dir(), dir());
                let (i, j, _) = d.bins(&to_half_diff(&wi, &wo));
                h[i * 90 + j] += 1;
                h
            },
        )
        .reduce(
            || vec![0u64; 90 * 90],
            |mut a, b| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                a
            },
        );
    for (imax, jmax) in [(45, 45), (30, 60), (80, 10), (89, 1)] {
        let top_h = theta_h_angle(imax as f64, 90);
        let top_d = theta_d_angle(jmax as f64, 90);
        assert!(
            top_h + top_d <= FRAC_PI_2 + 1e-12,
            "block entirely above the horizon"
        );
        let mut w = 0.0;
        let mut count = 0u64;
        for i in 0..imax {
            for j in 0..jmax {
                w += cell_weight(d, i, j) * 180.0;
                count += hist[i * 90 + j];
            }
        }
        let p = count as f64 / n as f64;
        let est = 4.0 * PI * PI * p;
        let sigma = 4.0 * PI * PI * (p * (1.0 - p) / n as f64).sqrt();
        eprintln!("block ({imax}, {jmax}): weights {w:.5}, Monte Carlo {est:.5} ± {sigma:.5}");
        assert!(
            (est - w).abs() < 4.5 * sigma,
            "block ({imax}, {jmax}): {w} vs {est} ± {sigma}"
        );
    }
}

#[test]
fn valid_cells_of_a_lambert_table_integrate_its_reflectance() {
    // Σ f cos θi cos θo w over valid cells ≈ ∫∫ (ρ/π) cos θi cos θo dωi dωo = π ρ, and
    // Σ w over valid cells ≈ (2π)² (the pairs above the horizon). Cells are valued at
    // their lower bin edges and bins crossing the horizon count whole when their
    // corner is above it, so both sums are first-order approximations: the error must
    // roughly halve when the grid is refined by two.
    let rho = Rgb::new(0.2, 0.5, 0.8);
    let errors = |d: Dims| {
        let t = MerlTable::from_brdf(&Lambert(rho), d).unwrap();
        let (s, w) = t
            .par_valid_cells()
            .map(|c| (c.value * (c.wi.z * c.wo.z * c.weight), c.weight))
            .reduce(|| (Rgb::ZERO, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
        let e_w = (w / (4.0 * PI * PI) - 1.0).abs();
        let e_s = (0..3)
            .map(|c| (s[c] / PI / rho[c] - 1.0).abs())
            .fold(0.0, f64::max);
        eprintln!("{d}: Σ w / 4π² − 1 = {e_w:.4}; Σ f cos cos w / (πρ) − 1 = {e_s:.4}");
        (e_w, e_s)
    };
    let (w45, s45) = errors(Dims::new(45, 45, 90).unwrap());
    let (w90, s90) = errors(Dims::MERL);
    assert!(w90 < 0.05 && s90 < 0.06, "{w90} {s90}");
    assert!(
        w90 < 0.6 * w45 && s90 < 0.6 * s45,
        "first-order convergence"
    );
}

#[test]
fn valid_cell_view_and_batch_agree_with_the_table() {
    let d = Dims::new(12, 10, 16).unwrap();
    let t = MerlTable::from_brdf(&Glossy, d).unwrap();
    let cells: Vec<Cell> = t.valid_cells().collect();
    assert_eq!(cells.len(), t.valid_count());
    let mut par: Vec<Cell> = t.par_valid_cells().collect();
    par.sort_by_key(|c| c.index);
    assert_eq!(par, cells);
    for c in &cells {
        assert_eq!(d.unflatten(c.index), (c.i, c.j, c.k));
        assert_eq!(c.angles, d.cell_angles(c.i, c.j, c.k));
        assert_eq!((c.wi, c.wo), from_half_diff(&c.angles));
        assert!(c.wi.z > 0.0 && c.wo.z > 0.0);
        assert_eq!(Some(c.value), t.get_flat(c.index));
        assert_eq!(c.weight, cell_weight(d, c.i, c.j));
    }
    let b = t.cell_batch();
    assert_eq!(b.len(), cells.len());
    assert_eq!(b.geometry.len(), cells.len());
    let g = b.geometry.as_slice();
    for (m, c) in cells.iter().enumerate() {
        assert_eq!(b.indices[m], c.index);
        assert_eq!(g.pair(m), (c.wi, c.wo));
        assert!((g.cos_d[m] - c.angles.theta_d.cos()).abs() < 1e-12);
        for ch in 0..3 {
            assert_eq!(b.values[ch][m], c.value[ch]);
        }
        assert_eq!(b.weights[m], c.weight);
    }
}

#[test]
fn cell_batch_of_a_larger_table_keeps_file_order_across_runs() {
    let d = Dims::new(45, 45, 90).unwrap();
    let t = MerlTable::from_brdf(&Glossy, d).unwrap();
    let b = t.cell_batch();
    let want: Vec<usize> = (0..d.cells()).filter(|&x| t.is_valid(x)).collect();
    assert!(want.len() > 3 * 8192, "several parallel runs");
    assert_eq!(b.indices, want);
    assert_eq!(b.geometry.len(), want.len());
    assert_eq!(b.weights.len(), want.len());
    let g = b.geometry.as_slice();
    for m in (0..want.len()).step_by(997).chain([want.len() - 1]) {
        let c = t.cell(want[m]).unwrap();
        assert_eq!(g.pair(m), (c.wi, c.wo));
        assert_eq!(b.values[2][m], c.value[2]);
        assert_eq!(b.weights[m], c.weight);
    }
}

#[test]
fn albedo_of_a_lambert_table_is_its_reflectance() {
    let rho = Rgb::new(0.2, 0.5, 0.8);
    let t = MerlTable::from_brdf(&Lambert(rho), Dims::MERL).unwrap();
    for lookup in [Lookup::Nearest, Lookup::Interpolated] {
        let q = Quadrature {
            lookup,
            ..Quadrature::default()
        };
        for deg in [0.0f64, 20.0, 45.0, 70.0, 85.0, 89.0] {
            let a = t.albedo(deg.to_radians(), &q);
            let got = a.albedo.unwrap();
            for c in 0..3 {
                assert!((got[c] - rho[c]).abs() < 1e-12, "{lookup:?} {deg}: {got:?}");
            }
            assert!(a.missing_weight < 0.01, "{}", a.missing_weight);
        }
    }
}

#[test]
fn albedo_quadrature_accuracy_on_a_smooth_table() {
    // f = c cos θi cos θo: a(θo) = c cos θo 2π/3. The table error (cell-corner
    // samples) dominates the quadrature's.
    let c = 0.3;
    let t = MerlTable::from_brdf(&CosCos(c), Dims::MERL).unwrap();
    let q = Quadrature::default();
    for deg in [0.0f64, 30.0, 60.0, 80.0] {
        let th = deg.to_radians();
        let want = c * th.cos() * 2.0 * PI / 3.0;
        let got = t.albedo(th, &q).albedo.unwrap()[0];
        eprintln!(
            "θo {deg}: albedo {got:.6}, closed form {want:.6}, rel {:.2e}",
            (got - want).abs() / want
        );
        assert!((got - want).abs() < 0.02 * want);
    }
}

#[test]
fn stats_report_coverage_ranges_and_albedo() {
    let d = Dims::new(3, 2, 2).unwrap();
    // Values 1..=12 by index; two cells missing.
    let t = MerlTable::from_fn(d, |i, j, k| {
        let x = d.index(i, j, k);
        (x != 4 && x != 7).then(|| Rgb::new(x as f64 + 1.0, 2.0 * (x as f64 + 1.0), 0.5))
    })
    .unwrap();
    let s = t.stats();
    assert_eq!(s.dims, d);
    assert_eq!((s.cells, s.valid), (12, 10));
    assert!((s.valid_fraction - 10.0 / 12.0).abs() < 1e-15);
    let ch = s.channels.unwrap();
    // Valid values 1, 2, 3, 4, 6, 7, 9, 10, 11, 12: median (6 + 7) / 2.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    assert!(close(ch[0].min, 1.0) && close(ch[0].max, 12.0) && close(ch[0].median, 6.5));
    assert!(close(ch[1].median, 13.0));
    assert!(close(ch[2].min, 0.5) && close(ch[2].median, 0.5) && close(ch[2].max, 0.5));
    assert_eq!(s.albedo.len(), stats::ALBEDO_ANGLES_DEG.len());
    // Odd count.
    let mut t2 = t.clone();
    t2.set(0, 0, 0, None).unwrap();
    assert!(close(t2.channel_stats().unwrap()[0].median, 7.0));
    // Nothing valid.
    let empty = MerlTable::all_missing(d);
    assert_eq!(empty.channel_stats(), None);
    assert!(
        empty
            .stats()
            .albedo
            .iter()
            .all(|a| a.albedo.is_none() && a.missing_weight == 1.0)
    );
}
