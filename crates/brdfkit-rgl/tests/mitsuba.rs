//! brdfkit's `.bsdf` evaluation against Mitsuba 3's `measured` plugin (the reference
//! reader), on hand-built but realistic files: isotropic and anisotropic, RGB
//! (`scalar_rgb`) and spectral (`scalar_spectral`), 32² and 64² value grids, random pairs
//! above 1° elevation. Mitsuba 3.9.1's `eval` at `si.wi = wi`, `wo` returns the stored value
//! (times the Jacobian) as it is: f · cos θo by its `BSDF::eval` contract
//! (`stored_values_are_f_times_cos_theta_o` below); brdfkit's f_r is that over cos θo, so
//! brdfkit · cos θo is compared with Mitsuba. Needs Mitsuba 3 (build/external_tools.rs); with `CI` set a missing Mitsuba fails.

#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

mod common;

use brdfkit_core::{Brdf, Vec3};
use brdfkit_rgl::RglBsdf;
use common::tally::Tally;
use common::{Spec, fields, pairs};
use rand::{Rng, SeedableRng};
use std::path::Path;
use std::process::Command;

fn write_f64(path: &Path, v: &[f64]) {
    let b: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(path, b).unwrap();
}

fn read_f64(path: &Path) -> Vec<f64> {
    std::fs::read(path)
        .unwrap()
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect()
}

/// Mitsuba's `eval` of `file` at `pairs` in `variant` (with `wl`, 4 wavelengths a pair,
/// for a spectral variant), run in `dir`.
fn mitsuba_eval(
    dir: &Path,
    variant: &str,
    file: &Path,
    pairs: &[[f64; 6]],
    wl: &[f64],
) -> Vec<f64> {
    let py = external_tools::require_mitsuba();
    write_f64(&dir.join("pairs.bin"), &pairs.concat());
    write_f64(&dir.join("wl.bin"), wl);
    let status = Command::new(&py)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba_eval.py"))
        .args([
            variant,
            file.to_str().unwrap(),
            "pairs.bin",
            "out.bin",
            "wl.bin",
        ])
        .current_dir(dir)
        .status()
        .unwrap();
    assert!(status.success(), "mitsuba_eval.py failed");
    read_f64(&dir.join("out.bin"))
}

/// Runs Mitsuba on `pairs` of the file of `spec`; returns brdfkit's model, the pairs and
/// Mitsuba's values (and the wavelengths, spectral).
fn run(spec: Spec, count: usize) -> (RglBsdf, Vec<[f64; 6]>, Vec<f64>, Vec<f64>) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("test.bsdf");
    brdfkit_rgl::tensor::write(&fields(spec), &file).unwrap();
    let ps = pairs(count, 1.0, spec.seed + 1);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(spec.seed + 2);
    let wl: Vec<f64> = (0..4 * count)
        .map(|_| rng.random_range(360.0..830.0))
        .collect();
    let variant = if spec.spectral {
        "scalar_spectral"
    } else {
        "scalar_rgb"
    };
    let out = mitsuba_eval(dir.path(), variant, &file, &ps, &wl);
    (RglBsdf::read(&file).unwrap(), ps, out, wl)
}

/// Both paths: the f64 one (`Brdf::eval`) and the f32 batch one (`eval_flat`, what
/// `fit-brdf eval --bsdf` and `resample --bsdf` run).
fn check_rgb(spec: Spec, count: usize) {
    let (bsdf, ps, out, _) = run(spec, count);
    let mut batch = vec![0.0; 3 * ps.len()];
    bsdf.eval_flat(&ps.concat(), &mut batch);
    let (mut t, mut tb) = (Tally::default(), Tally::default());
    for ((p, m), b) in ps
        .iter()
        .zip(out.chunks_exact(3))
        .zip(batch.chunks_exact(3))
    {
        let (wi, wo) = (Vec3::new(p[0], p[1], p[2]), Vec3::new(p[3], p[4], p[5]));
        let ours = bsdf.eval(&wi, &wo);
        for ((o, m), b) in ours.0.iter().zip(m).zip(b) {
            t.add(o * wo.z, *m);
            tb.add(b * wo.z, *m);
        }
    }
    t.check(&format!("{spec:?}"));
    tb.check(&format!("batch {spec:?}"));
}

/// Both paths: the f64 one (`eval_spectral`) and the f32 batch one
/// (`eval_stored_flat`'s values at the file's wavelengths, interpolated linearly in λ
/// with the clamped weight of the format, as `Warp2D` interpolates its last parameter).
fn check_spectral(spec: Spec, count: usize) {
    let (bsdf, ps, out, wl) = run(spec, count);
    let nodes: Vec<f64> = bsdf
        .wavelengths()
        .unwrap()
        .iter()
        .map(|&x| f64::from(x))
        .collect();
    let n = nodes.len();
    let mut stored = vec![0.0; n * ps.len()];
    bsdf.eval_stored_flat(&ps.concat(), &mut stored);
    let at = |v: &[f64], lambda: f64| {
        let i = nodes[1..n - 1].partition_point(|&x| x < lambda);
        let t = ((lambda - nodes[i]) / (nodes[i + 1] - nodes[i])).clamp(0.0, 1.0);
        v[i] * (1.0 - t) + v[i + 1] * t
    };
    let (mut t, mut tb) = (Tally::default(), Tally::default());
    for (k, p) in ps.iter().enumerate() {
        let (wi, wo) = (Vec3::new(p[0], p[1], p[2]), Vec3::new(p[3], p[4], p[5]));
        for c in 0..4 {
            let ours = bsdf.eval_spectral(&wi, &wo, wl[4 * k + c]).unwrap();
            t.add(ours * wo.z, out[4 * k + c]);
            let b = at(&stored[n * k..n * (k + 1)], wl[4 * k + c]);
            tb.add(b * wo.z, out[4 * k + c]);
        }
    }
    t.check(&format!("{spec:?}"));
    tb.check(&format!("batch {spec:?}"));
}

const fn spec(anisotropic: bool, spectral: bool, n: u64, m: u64, seed: u64) -> Spec {
    Spec {
        anisotropic,
        spectral,
        n,
        m,
        seed,
    }
}

/// The files of the comparisons, (anisotropic, value grid, VNDF grid), for RGB and
/// for spectral: isotropic and anisotropic, each at 32² and 64².
const FILES: [(bool, u64, u64); 4] = [
    (false, 32, 32),
    (false, 64, 48),
    (true, 32, 32),
    (true, 64, 48),
];

/// The specs of [`FILES`], `spectral` or not, seeded from `seed` by tens.
fn files(spectral: bool, seed: u64) -> impl Iterator<Item = Spec> {
    (0u64..)
        .zip(FILES)
        .map(move |(k, (aniso, n, m))| spec(aniso, spectral, n, m, seed + 10 * k))
}

mitsuba_test! {
    /// 4 RGB files × 25,000 pairs = 100,000 pairs in `scalar_rgb`.
    fn rgb_files_match_mitsuba() {
        files(false, 10).for_each(|s| check_rgb(s, 25_000));
    }
}

mitsuba_test! {
    /// 4 spectral files × 25,000 pairs (4 wavelengths each) in `scalar_spectral`.
    fn spectral_files_match_mitsuba() {
        files(true, 50).for_each(|s| check_spectral(s, 25_000));
    }
}

mitsuba_test! {
    /// A file whose RGB values are all 0.25 with the Jacobian flag off: Mitsuba's `eval`
    /// returns 0.25 at every pair above the horizon (it applies no cosine of its own: the
    /// stored value is f · cos θo), and brdfkit's f_r is 0.25 / cos θo.
    fn stored_values_are_f_times_cos_theta_o() {
        let mut f = fields(spec(false, false, 32, 32, 90));
        for t in &mut f {
            match t.name.as_str() {
                "rgb" => t.data = brdfkit_rgl::TensorData::F32(vec![0.25; t.data.len()]),
                "jacobian" => t.data = brdfkit_rgl::TensorData::U8(vec![0]),
                _ => {}
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("flat.bsdf");
        brdfkit_rgl::tensor::write(&f, &file).unwrap();
        let ps = pairs(200, 1.0, 91);
        let out = mitsuba_eval(dir.path(), "scalar_rgb", &file, &ps, &[]);
        let bsdf = RglBsdf::read(&file).unwrap();
        for (p, m) in ps.iter().zip(out.chunks_exact(3)) {
            let ours = bsdf.eval(&Vec3::new(p[0], p[1], p[2]), &Vec3::new(p[3], p[4], p[5]));
            for (o, m) in ours.0.iter().zip(m) {
                assert!((m - 0.25).abs() < 1e-6, "Mitsuba {m}");
                assert!((o * p[5] - 0.25).abs() < 1e-12, "brdfkit {o} at cos θo {}", p[5]);
            }
        }
    }
}

mitsuba_test! {
    /// brdfkit's writer against Mitsuba's own tensor reader (`mitsuba.tensor_io.read`),
    /// every dtype; and Mitsuba's writer (`tensor_io.write`) against brdfkit's reader.
    fn tensor_files_cross_read_with_mitsubas_tensor_io() {
        use brdfkit_rgl::{Tensor, TensorData, TensorFile};
        let py = external_tools::require_mitsuba();
        let dir = tempfile::tempdir().unwrap();
        let fields = vec![
            Tensor::new("u8", &[2], TensorData::U8(vec![0, 255])),
            Tensor::new("i8", &[2], TensorData::I8(vec![-128, 127])),
            Tensor::new("u16", &[2], TensorData::U16(vec![1, 65535])),
            Tensor::new("i16", &[2], TensorData::I16(vec![-32768, 5])),
            Tensor::new("u32", &[2], TensorData::U32(vec![7, u32::MAX])),
            Tensor::new("i32", &[2], TensorData::I32(vec![-7, i32::MIN])),
            Tensor::new("u64", &[2], TensorData::U64(vec![1 << 40, 3])),
            Tensor::new("i64", &[2], TensorData::I64(vec![-(1 << 40), 3])),
            Tensor::new("f16", &[2], TensorData::F16(vec![half::f16::from_f32(1.5), half::f16::from_f32(-0.25)])),
            Tensor::new("f32", &[1, 2], TensorData::F32(vec![1.25, -3.5])),
            Tensor::new("f64", &[2, 1], TensorData::F64(vec![1e300, -2.5])),
        ];
        let ours = dir.path().join("ours.tensor");
        brdfkit_rgl::tensor::write(&fields, &ours).unwrap();
        let script = r#"
import sys, numpy as np
from mitsuba.python import tensor_io
d = tensor_io.read(sys.argv[1])
want = {'u8': [0, 255], 'i8': [-128, 127], 'u16': [1, 65535], 'i16': [-32768, 5],
        'u32': [7, 2**32 - 1], 'i32': [-7, -2**31], 'u64': [2**40, 3], 'i64': [-2**40, 3],
        'f16': [1.5, -0.25], 'f32': [1.25, -3.5], 'f64': [1e300, -2.5]}
for k, v in want.items():
    name = {'f': 'float', 'u': 'uint', 'i': 'int'}[k[0]] + k[1:]
    assert d[k].dtype.name == name, (k, d[k].dtype)
    assert d[k].ravel().tolist() == v, (k, d[k])
assert d['f32'].shape == (1, 2) and d['f64'].shape == (2, 1)
tensor_io.write(sys.argv[2], a=np.arange(6, dtype=np.int16).reshape(2, 3), b=np.array([0.5, -1.0], dtype=np.float64), c='text')
"#;
        let theirs = dir.path().join("theirs.tensor");
        let status = Command::new(&py).args(["-c", script]).arg(&ours).arg(&theirs).status().unwrap();
        assert!(status.success(), "Mitsuba's tensor_io disagrees with brdfkit's writer");
        let tf = TensorFile::read(&theirs).unwrap();
        assert_eq!(tf.to_f64("a").unwrap(), [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(tf.get("a").unwrap().shape, [2, 3]);
        assert_eq!(tf.to_f64("b").unwrap(), [0.5, -1.0]);
        assert_eq!(tf.u8s("c").unwrap(), b"text");
    }
}

mitsuba_test! {
    /// The measured points of an isotropic file and of anisotropic files (both
    /// reductions: a quarter turn of φi in five slices, a half turn in nine) against
    /// Mitsuba's `eval` at the points' own pairs: value · cos θo as Mitsuba returns it.
    /// None may be off by more than 1 %; at least 99 % within 1e-4 (+1e-6), below the
    /// issue's 99.9 % for random pairs: 99.76 % (isotropic), 99.65 % (4-fold) and
    /// 99.48 % (2-fold) here, worst 0.05 %, 0.04 % and 0.44 % (docs/rgl.md, "The
    /// sample-set fit"). The misses are near the half vector's pole: of the anisotropic
    /// files' 437, 299 at column 1 (θm = 1.6e-3 rad), 26 at column 2, 18 at column 3,
    /// fewer further out, where Mitsuba's f32 φm = atan2(m.y, m.x) of components
    /// ~sin θm is off by ~1e-7/θm rad; random pairs almost never come that close to the
    /// pole, and the warped grid puts a column of nodes there.
    fn measured_points_match_mitsuba() {
        use std::f32::consts::PI;
        let turn = |span: f32, n: usize| -> Vec<f32> {
            (0..n).map(|k| -PI + k as f32 * span / (n - 1) as f32).collect()
        };
        for (seed, phi) in [(90, vec![0.0]), (100, turn(PI / 2.0, 5)), (110, turn(PI, 9))] {
            let dir = tempfile::tempdir().unwrap();
            let file = dir.path().join("aniso.bsdf");
            let f = common::fields_with_phi(spec(phi.len() > 2, false, 32, 32, seed), phi);
            brdfkit_rgl::tensor::write(&f, &file).unwrap();
            let (_, pts) = brdfkit_rgl::MeasuredPoints::read(&file).unwrap();
            assert!(pts.points.len() > 2_000, "{} points", pts.points.len());
            let ps: Vec<[f64; 6]> = pts
                .points
                .iter()
                .map(|p| [p.wi.x, p.wi.y, p.wi.z, p.wo.x, p.wo.y, p.wo.z])
                .collect();
            let out = mitsuba_eval(dir.path(), "scalar_rgb", &file, &ps, &[]);
            let mut t = Tally::default();
            let mut left_out = 0;
            for (p, m) in pts.points.iter().zip(out.chunks_exact(3)) {
                // Row n − 1 (u_φ = 1) is the half vector at φm = π, row 0's direction:
                // Mitsuba's f32 atan2 gives π_f32 there, so u_φ = 1 wraps to row 0,
                // while brdfkit's f64 u_φ stays below 1 and reads row n − 1. Column 0
                // is the half vector at the pole, whose φm is the atan2 of round-off in
                // either. A measured file holds one direction's value in those rows;
                // these random tables differ. Left out, and counted.
                if p.node[2] == 31 || p.node[3] == 0 {
                    left_out += 1;
                    continue;
                }
                for (v, m) in p.rgb.iter().zip(m) {
                    t.add(v * p.wo.z, *m);
                }
            }
            let frac = t.fraction_within();
            eprintln!(
                "points, seed {seed}: {t:?} ({:.4} % within 1e-4; {left_out} left out)",
                100.0 * frac
            );
            assert!(left_out * 15 < pts.points.len(), "{left_out} left out");
            assert!(t.beyond_1pct == 0 && t.worst <= 0.01, "{t:?}");
            assert!(frac >= 0.99, "{t:?}");
        }
    }
}
