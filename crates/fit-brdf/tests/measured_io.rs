//! Neural BRDFs as a source (`--nbrdf`) and the `.npy` contract of `eval`, through the
//! binary: the same values whatever the format, typed errors with exit 2 for bad files.

#[macro_use]
mod common;

use common::npy::npy_bytes;
use common::{assert_bad_input, assert_bad_input_writes_nothing, bin, write_file};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fabric() -> PathBuf {
    repo().join("data-measured/merl/pink-fabric")
}

/// A few direction pairs: normal, oblique, grazing-ish, retro, and one below the horizon.
const PAIRS: [[f64; 6]; 5] = [
    [0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
    [0.6, 0.0, 0.8, -0.6, 0.0, 0.8],
    [0.8, 0.0, 0.6, 0.0, 0.8, 0.6],
    [0.0, 0.9998, 0.02, 0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0, 0.0, 0.0, 1.0],
];

fn write_csv(dir: &Path) -> PathBuf {
    let mut s = String::from("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n");
    for r in PAIRS {
        let f: Vec<String> = r.iter().map(|x| x.to_string()).collect();
        s += &(f.join(",") + "\n");
    }
    let p = dir.join("pairs.csv");
    std::fs::write(&p, s).unwrap();
    p
}

fn write_npy(dir: &Path) -> PathBuf {
    let body: Vec<u8> = PAIRS
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let p = dir.join("pairs.npy");
    std::fs::write(&p, npy_bytes("<f8", "(5, 6)", &body)).unwrap();
    p
}

/// The N×3 values of an output `.npy` (header skipped by its length field).
fn read_values(p: &Path) -> Vec<f64> {
    let b = std::fs::read(p).unwrap();
    assert_eq!(&b[..6], b"\x93NUMPY");
    let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
    let header = String::from_utf8_lossy(&b[10..10 + hl]).into_owned();
    common::assert_mentions(&header, &["'<f8'", "'shape': (5, 3"]);
    b[10 + hl..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The values of an output CSV, NaN for empty fields.
fn read_csv(text: &str) -> Vec<f64> {
    text.lines()
        .skip(1)
        .flat_map(|l| {
            l.split(',')
                .map(|f| f.parse().unwrap_or(f64::NAN))
                .collect::<Vec<_>>()
        })
        .collect()
}

fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}

/// Runs `eval` with CSV and with `.npy` for one source; both must give the same bits.
fn csv_and_npy_agree(dir: &Path, source: &[&str]) -> Vec<f64> {
    let csv = write_csv(dir);
    let npy = write_npy(dir);
    let o = bin()
        .arg("eval")
        .args(source)
        .arg("--dirs")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let from_csv = read_csv(&String::from_utf8(o.stdout).unwrap());
    let out = dir.join("v.npy");
    bin()
        .arg("eval")
        .args(source)
        .arg("--dirs")
        .arg(&npy)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let from_npy = read_values(&out);
    assert!(same(&from_csv, &from_npy), "{from_csv:?} vs {from_npy:?}");
    from_npy
}

#[test]
fn nbrdf_resample_writes_a_merl_table_and_reports_clamping() {
    let d = tempfile::tempdir().unwrap();
    let t = d.path().join("fabric.binary");
    let o = fit_brdf!(
        "resample",
        "--nbrdf",
        fabric(),
        "--dims",
        "18,18,36",
        "--out",
        &t
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    common::assert_mentions(&err, &["were negative and are stored as 0"]);
    common::assert_mentions(&err, &["below the horizon are missing"]);
    // 12 + 3 channels × 18·18·36 f64.
    assert_eq!(
        std::fs::metadata(&t).unwrap().len(),
        12 + 3 * 8 * 18 * 18 * 36
    );
    // The table then works as any table does.
    csv_and_npy_agree(d.path(), &["--table", t.to_str().unwrap()]);
}

#[test]
fn eval_gives_the_same_bits_from_csv_and_npy_for_every_source() {
    let d = tempfile::tempdir().unwrap();
    let nb = csv_and_npy_agree(d.path(), &["--nbrdf", fabric().to_str().unwrap()]);
    // Above the horizon a fabric reflects something; below it f_r is 0 (the Brdf contract).
    assert!(nb[..12].iter().all(|v| *v > 0.0), "{nb:?}");
    assert_eq!(&nb[12..], &[0.0, 0.0, 0.0]);
    let model = write_file(
        d.path(),
        "m.json",
        r#"{"model": "cook-torrance", "params": {"rho_d": [0.3, 0.2, 0.1], "alpha": 0.2}}"#,
    );
    csv_and_npy_agree(d.path(), &["--model", model.to_str().unwrap()]);
}

#[test]
fn bad_npy_and_nbrdf_inputs_exit_2_naming_the_file() {
    let d = tempfile::tempdir().unwrap();
    let f32 = write_file(d.path(), "f32.npy", npy_bytes("<f4", "(1, 6)", &[0u8; 24]));
    let shape = write_file(
        d.path(),
        "shape.npy",
        npy_bytes("<f8", "(1, 3)", &[0u8; 24]),
    );
    let cases = [
        (f32.clone(), "dtype '<f4'"),
        (shape.clone(), "expected (N, 6)"),
    ];
    for (p, want) in cases {
        let o = fit_brdf!("eval", "--nbrdf", fabric(), "--dirs", &p);
        assert_bad_input(&o, &[p.to_str().unwrap(), want]);
    }
    let missing = d.path().join("no-such-material");
    let o = fit_brdf!(
        "resample",
        "--nbrdf",
        &missing,
        "--dims",
        "9,9,18",
        "--out",
        d.path().join("t.binary")
    );
    assert_bad_input_writes_nothing(
        &o,
        &["no-such-material_fc1.npy", "missing"],
        &d.path().join("t.binary"),
    );
}
