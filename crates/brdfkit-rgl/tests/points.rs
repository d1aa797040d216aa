//! The measured points of a `.bsdf` (brdfkit_rgl::MeasuredPoints): each point's value is
//! the reader's own `eval` at the point's pair, and the weights integrate the cosine
//! over the outgoing hemisphere (∫ cos θo dω_o = π) slice by slice.

mod common;
mod write_support;

use brdfkit_core::Brdf;
use brdfkit_rgl::write::{WriteOptions, write};
use brdfkit_rgl::{MeasuredPoints, RglBsdf};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use write_support::proxy;

fn felt() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-synthetic/felt-synthetic.bsdf")
}

/// Every point equals `eval` at its pair (to 1e-7 relative: eval recomputes θi and the
/// half vector from the directions, and the warp's inverse is found to 2⁻⁴⁸), and the points are the file's valid bits less the
/// ones on the horizon.
fn points_are_eval(path: &Path) -> (RglBsdf, MeasuredPoints) {
    let (bsdf, pts) = MeasuredPoints::read(path).unwrap();
    let (set, _) = bsdf.summary().measured_points.expect("a valid field");
    assert_eq!(pts.valid, set);
    assert_eq!(pts.points.len() + pts.skipped + pts.merged, set);
    assert!(pts.points.len() > set / 2, "{} of {set}", pts.points.len());
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
        let r = cos_sum / (ring * std::f64::consts::PI);
        assert!(
            (r - 1.0).abs() < 0.01,
            "slice {k}: Σ w cos θo / (dω_i π) = {r}"
        );
    }
}

/// dω_i of slice k: the ring between the midpoints to the neighbouring θi.
fn ring_of(pts: &MeasuredPoints, k: usize) -> f64 {
    let bsdf = RglBsdf::read(Path::new(&pts.name)).unwrap();
    let t: Vec<f64> = bsdf.grids().0.iter().map(|&x| f64::from(x)).collect();
    let a = if k == 0 { 0.0 } else { 0.5 * (t[k - 1] + t[k]) };
    let b = if k + 1 == t.len() {
        std::f64::consts::FRAC_PI_2
    } else {
        0.5 * (t[k] + t[k + 1])
    };
    std::f64::consts::TAU * (a.cos() - b.cos())
}

/// The vendored synthetic felt (a formula: its `valid` bits and VNDF are patterns, not a
/// measurement, so its weights integrate nothing in particular).
#[test]
fn felt_points_are_the_readers_values() {
    let (_, pts) = points_are_eval(&felt());
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
    let (_, pts) = points_are_eval(&path);
    weights_integrate_the_cosine(&pts);
    let path = dir.path().join("gold_rgb.bsdf");
    write(&proxy("gold-paint"), &WriteOptions::default(), &path).unwrap();
    let (_, pts) = points_are_eval(&path);
    weights_integrate_the_cosine(&pts);
    // A file without `valid` would give every node: the bits here leave out the
    // nodes below the horizon, and the 90° slice is skipped.
    assert!(pts.skipped > 0);
}

/// Hand-built files (tests/common, random tables): isotropic RGB and spectral; an
/// anisotropic file (five φi slices over a quarter turn) gives no point yet.
#[test]
fn hand_built_anisotropic_and_spectral_points_are_the_readers_values() {
    let dir = tempfile::tempdir().unwrap();
    for (k, (anisotropic, spectral)) in [(false, false), (false, true), (true, false)]
        .into_iter()
        .enumerate()
    {
        let f = common::fields(common::Spec {
            anisotropic,
            spectral,
            n: 16,
            m: 16,
            seed: 11 + k as u64,
        });
        let path = dir.path().join(format!("hand{k}.bsdf"));
        brdfkit_rgl::tensor::write(&f, &path).unwrap();
        let (bsdf, pts) = MeasuredPoints::read(&path).unwrap();
        if anisotropic {
            assert!(pts.points.is_empty() && pts.skipped == pts.valid && pts.valid > 0);
            continue;
        }
        assert!(!pts.points.is_empty());
        for p in &pts.points {
            let e = bsdf.eval(&p.wi, &p.wo);
            // Relative to the largest channel: these tables are random, so the warp's
            // inverse is steep and a small channel carries the others' round-off.
            let scale = e.0.iter().fold(1e-9f64, |m, v| m.max(v.abs()));
            for c in 0..3 {
                let d = (e.0[c] - p.rgb[c]).abs() / scale;
                assert!(
                    d < 1e-6,
                    "{k}: {:?}: eval {:?}, point {:?}",
                    p.node,
                    e.0,
                    p.rgb
                );
            }
        }
    }
}
