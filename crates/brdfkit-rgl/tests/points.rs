//! The measured points of a `.bsdf` (brdfkit_rgl::MeasuredPoints): each point's value is
//! the reader's own `eval` at the point's pair, and the weights integrate the cosine
//! over the outgoing hemisphere (∫ cos θo dω_o = π) slice by slice.

mod common;
mod write_support;

use brdfkit_core::Brdf;
use brdfkit_rgl::write::{WriteOptions, write};
use brdfkit_rgl::{MeasuredPoints, RglBsdf};
use brdfkit_rgl::{Tensor, TensorData};
use std::collections::{BTreeMap, BTreeSet};
use std::f32::consts::PI;
use std::f64::consts::{FRAC_PI_2, PI as PI64, TAU};
use std::path::{Path, PathBuf};
use write_support::proxy;

fn felt() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-synthetic/felt-synthetic.bsdf")
}

/// Every point equals `eval` at its pair (to 1e-7 relative: eval recomputes θi and the
/// half vector from the directions, and the warp's inverse is found to 2⁻⁴⁸), and the
/// points are the file's valid bits less the ones skipped or merged: more than 1/`part`
/// of them.
fn points_are_eval(path: &Path, part: usize) -> (RglBsdf, MeasuredPoints) {
    let (bsdf, pts) = MeasuredPoints::read(path).unwrap();
    let (set, _) = bsdf.summary().measured_points.expect("a valid field");
    assert_eq!(pts.valid, set);
    assert_eq!(pts.points.len() + pts.skipped + pts.merged, set);
    assert!(
        pts.points.len() > set / part,
        "{} of {set}",
        pts.points.len()
    );
    let mut worst = 0.0f64;
    for p in &pts.points {
        let e = bsdf.eval(&p.wi, &p.wo);
        for c in 0..3 {
            let d = (e.0[c] - p.rgb[c]).abs() / (1e-12 + e.0[c].abs());
            worst = worst.max(d);
        }
    }
    assert!(
        worst < 1e-7,
        "{}: worst relative difference {worst}",
        path.display()
    );
    (bsdf, pts)
}

/// Σ weight · cos θo over a slice's points is dω_i · π: the weights are the solid
/// angles of the nodes' cells.
fn weights_integrate_the_cosine(pts: &MeasuredPoints) {
    let mut by_slice: BTreeMap<usize, f64> = BTreeMap::new();
    for p in &pts.points {
        *by_slice.entry(p.node[1]).or_insert(0.0) += p.weight * p.wo.z;
        assert!(p.weight > 0.0 && p.weight.is_finite(), "{p:?}");
    }
    assert!(by_slice.len() >= 7, "{} slices", by_slice.len());
    for (k, cos_sum) in &by_slice {
        let ring = ring_of(pts, *k);
        let r = cos_sum / (ring * PI64);
        assert!(
            (r - 1.0).abs() < 0.01,
            "slice {k}: Σ w cos θo / (dω_i π) = {r}"
        );
    }
}

/// dω_i of slice k of the file the points come from.
fn ring_of(pts: &MeasuredPoints, k: usize) -> f64 {
    let bsdf = RglBsdf::read(Path::new(&pts.name)).unwrap();
    let t: Vec<f64> = bsdf.grids().0.iter().map(|&x| f64::from(x)).collect();
    ring(&t, k)
}

/// The vendored synthetic felt (a formula: its `valid` bits and VNDF are patterns, not a
/// measurement, so its weights integrate nothing in particular).
#[test]
fn felt_points_are_the_readers_values() {
    let (_, pts) = points_are_eval(&felt(), 2);
    assert!(
        pts.points
            .iter()
            .all(|p| p.weight > 0.0 && p.weight.is_finite())
    );
}

#[test]
fn written_file_points_are_the_readers_values() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("phenolic_rgb.bsdf");
    write(
        &proxy("specular-red-phenolic"),
        &WriteOptions::default(),
        &path,
    )
    .unwrap();
    let (_, pts) = points_are_eval(&path, 2);
    weights_integrate_the_cosine(&pts);
    let path = dir.path().join("gold_rgb.bsdf");
    write(&proxy("gold-paint"), &WriteOptions::default(), &path).unwrap();
    let (_, pts) = points_are_eval(&path, 2);
    weights_integrate_the_cosine(&pts);
    // A file without `valid` would give every node: the bits here leave out the
    // nodes below the horizon, and the 90° slice is skipped.
    assert!(pts.skipped > 0);
}

/// The φi grids of the hand-built files: isotropic (one value), a quarter turn in
/// five slices (4-fold reduction) and a half turn in nine (2-fold).
fn phi_grids() -> [(&'static str, Vec<f32>); 3] {
    let turn = |span: f32, n: usize| -> Vec<f32> {
        (0..n)
            .map(|k| -PI + k as f32 * span / (n - 1) as f32)
            .collect()
    };
    [
        ("isotropic", vec![0.0]),
        ("4-fold", turn(PI / 2.0, 5)),
        ("2-fold", turn(PI, 9)),
    ]
}

/// A hand-built file (tests/common: random tables, random `valid` bits).
fn hand_built(phi: &[f32], spectral: bool, n: u64, seed: u64) -> Vec<Tensor> {
    let spec = common::Spec {
        anisotropic: phi.len() > 2,
        spectral,
        n,
        m: 16,
        seed,
    };
    common::fields_with_phi(spec, phi.to_vec())
}

fn write_fields(f: &[Tensor], path: &Path) {
    brdfkit_rgl::tensor::write(f, path).unwrap();
}

/// Hand-built files with random tables, isotropic and anisotropic (both reductions),
/// RGB and spectral: every point equals the reader's `eval` at its pair to 1e-7
/// relative, and every valid node is a point, skipped or merged.
#[test]
fn hand_built_anisotropic_and_spectral_points_are_the_readers_values() {
    let dir = tempfile::tempdir().unwrap();
    let mut seed = 11;
    for (name, phi) in phi_grids() {
        for spectral in [false, true] {
            seed += 1;
            let path = dir.path().join(format!("{name}-{spectral}.bsdf"));
            write_fields(&hand_built(&phi, spectral, 16, seed), &path);
            let (bsdf, pts) = points_are_eval(&path, 3);
            assert_eq!(bsdf.is_anisotropic(), phi.len() > 2);
            let slices: BTreeSet<usize> = pts.points.iter().map(|p| p.node[0]).collect();
            assert_eq!(
                slices.len(),
                phi.len(),
                "{name}: every φi slice gives points"
            );
        }
    }
}

/// Anisotropic files (both reductions) with every node valid and a smooth VNDF that
/// depends on φi: Σ weight · cos θo over each (φi, θi) slice's points is dω_i · π within
/// 1 %, dω_i the ring of the θi slice times the φi slice's share of the stored range
/// (the whole ring at θi = 0, where one slice stands for the pole).
#[test]
fn anisotropic_weights_integrate_the_cosine() {
    let dir = tempfile::tempdir().unwrap();
    for (name, phi) in phi_grids().into_iter().skip(1) {
        let (n, m) = (32u64, 16usize);
        let mut f = hand_built(&phi, false, n, 5);
        let nt = 8;
        for t in &mut f {
            match t.name.as_str() {
                "valid" => t.data = TensorData::U8(vec![0xff; t.shape[0] as usize]),
                "vndf" => t.data = TensorData::F32(smooth_vndf(&phi, nt, m)),
                _ => {}
            }
        }
        let path = dir.path().join(format!("{name}-smooth.bsdf"));
        write_fields(&f, &path);
        let (bsdf, pts) = MeasuredPoints::read(&path).unwrap();
        let theta: Vec<f64> = bsdf.grids().0.iter().map(|&x| f64::from(x)).collect();
        let mut by_slice: BTreeMap<[usize; 2], f64> = BTreeMap::new();
        for p in &pts.points {
            *by_slice.entry([p.node[0], p.node[1]]).or_insert(0.0) += p.weight * p.wo.z;
            assert!(p.weight > 0.0 && p.weight.is_finite(), "{p:?}");
        }
        // One pole slice and every φi slice of the other seven θi.
        assert_eq!(by_slice.len(), 1 + 7 * phi.len(), "{name}");
        let mut worst = 0.0f64;
        for ([a, b], cos_sum) in &by_slice {
            let share = if *b == 0 { 1.0 } else { phi_share(&phi, *a) };
            let r = cos_sum / (ring(&theta, *b) * share * PI64);
            assert!(
                (r - 1.0).abs() < 0.01,
                "{name}: slice ({a}, {b}): Σ w cos θo / (dω_i π) = {r}"
            );
            worst = worst.max((r - 1.0).abs());
        }
        println!("{name}: worst |Σ w cos θo / (dω_i π) − 1| = {worst:.5}");
    }
}

/// A smooth positive VNDF over (φi, θi, u_φ, u_θ) that turns with φi.
fn smooth_vndf(phi: &[f32], nt: usize, m: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity(phi.len() * nt * m * m);
    for &p in phi {
        for b in 0..nt {
            for y in 0..m {
                for x in 0..m {
                    let (ut, up) = (x as f64 / (m - 1) as f64, y as f64 / (m - 1) as f64);
                    let az = TAU * up - PI64 - f64::from(p);
                    let v = (0.3 + ut) * (1.0 + 0.5 * az.cos()) * (1.0 + 0.05 * b as f64);
                    out.push(v as f32);
                }
            }
        }
    }
    out
}

/// The share of the stored φi range that slice `a` stands for: the interval between
/// the midpoints to its neighbours.
fn phi_share(phi: &[f32], a: usize) -> f64 {
    let g = |k: usize| f64::from(phi[k]);
    let last = phi.len() - 1;
    let lo = if a == 0 {
        g(0)
    } else {
        0.5 * (g(a - 1) + g(a))
    };
    let hi = if a == last {
        g(last)
    } else {
        0.5 * (g(a) + g(a + 1))
    };
    (hi - lo) / (g(last) - g(0))
}

/// The ring of θi slice k: between the midpoints to the neighbouring θi.
fn ring(t: &[f64], k: usize) -> f64 {
    let a = if k == 0 { 0.0 } else { 0.5 * (t[k - 1] + t[k]) };
    let b = if k + 1 == t.len() {
        FRAC_PI_2
    } else {
        0.5 * (t[k] + t[k + 1])
    };
    TAU * (a.cos() - b.cos())
}
