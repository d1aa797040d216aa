//! `fit --samples S.csv|S.npy` and `fit X.bsdf` at its measured points, through the
//! binary: exact samples of a model give back its parameters, the record says what the
//! input was, and a bad file is exit 2 naming the file, the row or line and the problem.

mod common;

use brdfkit::core::{Brdf, Model, Vec3};
use common::{assert_alpha_rho_d, assert_bad_input, bin, param, stderr};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const TRUTH: &str = r#"{"model":"cook-torrance","params":{"rho_d":[0.3,0.2,0.1],"rho_s":[0.4,0.5,0.6],"alpha":0.2}}"#;

fn truth() -> Box<dyn Model> {
    brdfkit::models::from_json_str(TRUTH).unwrap()
}

/// `n` pairs on a low-discrepancy sequence (golden-ratio steps), both directions above 5°.
fn pairs(n: usize) -> Vec<(Vec3, Vec3)> {
    let g = [
        0.618_033_988_749_895,
        0.754_877_666_246_693,
        0.569_840_290_998_053,
        0.438_579_073_460_287,
    ];
    let dir = |a: f64, b: f64| {
        let z = 0.0872 + (1.0 - 0.0872) * a;
        let (r, phi) = ((1.0 - z * z).sqrt(), std::f64::consts::TAU * b);
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    (1..=n)
        .map(|k| {
            let u: Vec<f64> = g.iter().map(|x| (k as f64 * x).fract()).collect();
            (dir(u[0], u[1]), dir(u[2], u[3]))
        })
        .collect()
}

/// The model's samples as the documented CSV (with a missing value in row 5).
fn samples_csv(dir: &Path, n: usize) -> PathBuf {
    let m = truth();
    let mut s = String::from("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,r,g,b\n");
    for (k, (wi, wo)) in pairs(n).into_iter().enumerate() {
        let f = m.eval(&wi, &wo).0;
        let g = if k == 5 {
            String::new()
        } else {
            f[1].to_string()
        };
        writeln!(
            s,
            "{},{},{},{},{},{},{},{g},{}",
            wi.x, wi.y, wi.z, wo.x, wo.y, wo.z, f[0], f[2]
        )
        .unwrap();
    }
    let p = dir.join("s.csv");
    std::fs::write(&p, s).unwrap();
    p
}

fn fit_record(args: &[&str], dir: &Path) -> Value {
    let rec = dir.join("r.json");
    let o = bin()
        .args(args)
        .arg("--record")
        .arg(&rec)
        .arg("-q")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_slice(&std::fs::read(rec).unwrap()).unwrap()
}

#[test]
fn fit_samples_csv_recovers_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let csv = samples_csv(dir.path(), 2000);
    let r = fit_record(&["fit", "--samples", csv.to_str().unwrap()], dir.path());
    assert!(
        (param(&r, "alpha", None) - 0.2).abs() < 1e-4,
        "{}",
        r["model"]
    );
    for (c, w) in [0.4, 0.5, 0.6].iter().enumerate() {
        assert!(
            (param(&r, "rho_s", Some(c)) - w).abs() < 1e-4,
            "{}",
            r["model"]
        );
    }
    let i = &r["input"];
    assert_eq!(i["kind"], "samples");
    assert_eq!(
        (i["rows"].as_u64(), i["samples"].as_u64()),
        (Some(2000), Some(1999))
    );
    assert_eq!(
        (i["dropped_missing"].as_u64(), i["weights"].as_str()),
        (Some(1), Some("uniform"))
    );
    assert_eq!(r["cells_full"].as_u64(), Some(1999));
}

#[test]
fn fit_samples_npy_with_weights() {
    let dir = tempfile::tempdir().unwrap();
    let m = truth();
    let mut data = Vec::new();
    for (wi, wo) in pairs(800) {
        let f = m.eval(&wi, &wo).0;
        data.extend([wi.x, wi.y, wi.z, wo.x, wo.y, wo.z, f[0], f[1], f[2], 1e-3]);
    }
    let mut bytes = Vec::new();
    brdfkit::io::samples::write_npy(&mut bytes, &data, 10).unwrap();
    let p = dir.path().join("s.npy");
    std::fs::write(&p, bytes).unwrap();
    let r = fit_record(&["fit", "--samples", p.to_str().unwrap()], dir.path());
    assert_eq!(r["input"]["weights"], "given");
    assert!(
        (param(&r, "alpha", None) - 0.2).abs() < 1e-4,
        "{}",
        r["model"]
    );
}

#[test]
fn bad_samples_files_are_exit_2_naming_file_and_row() {
    let dir = tempfile::tempdir().unwrap();
    let h = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,r,g,b\n";
    let cases: [(&str, String, &[&str]); 4] = [
        (
            "below.csv",
            format!("{h}0,0,1,0,0,1,1,1,1\n0,0,1,0.6,0,-0.8,1,1,1\n"),
            &["below.csv: line 3: wo has z = -0.8", "below the horizon"],
        ),
        (
            "long.csv",
            format!("{h}0,0,1,0,0,2,1,1,1\n"),
            &["long.csv: line 2: wo", "unit vector"],
        ),
        (
            "fields.csv",
            format!("{h}0,0,1,0,0,1,1,1\n"),
            &["fields.csv: line 2: expected 9 fields, found 8"],
        ),
        (
            "empty.csv",
            format!("{h}0,0,1,0,0,1,,,\n"),
            &["empty.csv: no sample to fit (1 rows, 1 with a missing value)"],
        ),
    ];
    for (name, text, needles) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        let o = bin().args(["fit", "--samples"]).arg(&p).output().unwrap();
        assert_bad_input(&o, needles);
    }
    let mut bytes = Vec::new();
    brdfkit::io::samples::write_npy(&mut bytes, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 6).unwrap();
    let p = dir.path().join("six.npy");
    std::fs::write(&p, bytes).unwrap();
    let o = bin().args(["fit", "--samples"]).arg(&p).output().unwrap();
    assert_bad_input(&o, &["six.npy: shape (1, 6), expected (N, 9) or (N, 10)"]);
    let o = bin().args(["fit"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// A `.bsdf` written from the model is fitted at its measured points by default, which
/// gives the model back (to the file's f32 storage and interpolation), and to its MERL
/// resampling with `--bsdf-input table` (a table's cells: no input record). How far
/// each is from the model: docs/rgl.md, "The sample-set fit".
#[test]
fn fit_bsdf_at_its_points_and_as_a_table() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ct_rgb.bsdf");
    brdfkit::rgl::write::write(truth().as_ref(), &Default::default(), &p).unwrap();
    let f = p.to_str().unwrap();
    let r = fit_record(&["fit", f], dir.path());
    assert_eq!(r["input"]["kind"], "bsdf-points");
    assert_eq!(r["input"]["weights"], "given");
    assert_alpha_rho_d(&r, 0.2, [0.3, 0.2, 0.1], 2e-3, "points");
    let r = fit_record(&["fit", f, "--bsdf-input", "table"], dir.path());
    assert!(r.get("input").is_none(), "a table's cells: no input record");
    assert!(r["cells_full"].as_u64().unwrap() > 1_000_000);
}
