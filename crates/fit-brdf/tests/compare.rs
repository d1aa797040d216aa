//! `fit-brdf compare A B`: tables, models and NBRDFs against each other, driven as a
//! user would.

#[macro_use]
mod common;

use common::{bin, plastic_and_lambert, red_plastic, stderr, synth_spec, write_file};
use serde_json::Value;
use std::path::Path;

fn compare(a: &Path, b: &Path, extra: &[&str]) -> std::process::Output {
    bin()
        .arg("compare")
        .arg(a)
        .arg(b)
        .args(["--no-renders"])
        .args(extra)
        .output()
        .unwrap()
}

fn json_of(o: &std::process::Output) -> Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn resample(src: &[&str], dims: &str, out: &Path) {
    bin()
        .arg("resample")
        .args(src)
        .args(["--dims", dims, "--quiet", "--out"])
        .arg(out)
        .assert()
        .success();
}

#[test]
fn a_table_against_itself_and_a_model_against_its_score() {
    let d = tempfile::tempdir().unwrap();
    let (t, m) = plastic_and_lambert(d.path());
    let c = json_of(&compare(&t, &t, &["--json"]));
    for loss in ["l2", "cosine", "cbrt", "log"] {
        assert_eq!(c["losses"][loss]["overall"].as_f64(), Some(0.0));
    }
    assert_eq!(c["cells_missing_in_b"], 0);
    assert_eq!(c["largest"][0]["relative"].as_f64(), Some(0.0));
    assert_eq!(c["b_on_grid"], "the same cells");

    // A model B: the losses of `score`, bit for bit (the same cells and function).
    for extra in [
        &[][..],
        &["--weighting", "uniform", "--theta-d-max", "50"][..],
    ] {
        let mut args = vec!["--json"];
        args.extend_from_slice(extra);
        let c = json_of(&compare(&t, &m, &args));
        let s = json_of(
            &bin()
                .arg("score")
                .arg(&t)
                .arg(&m)
                .arg("--json")
                .args(extra)
                .output()
                .unwrap(),
        );
        assert_eq!(c["losses"], s["models"][0]["losses"], "{extra:?}");
        assert_eq!(c["cells_a"], s["models"][0]["losses"]["cells"]);
        // The largest relative differences are sorted and located.
        let top = c["largest"].as_array().unwrap();
        assert_eq!(top.len(), 10);
        for w in top.windows(2) {
            assert!(w[0]["relative"].as_f64() >= w[1]["relative"].as_f64());
        }
        let d0 = &top[0];
        let (a, b) = (d0["a"].as_f64().unwrap(), d0["b"].as_f64().unwrap());
        assert!((d0["relative"].as_f64().unwrap() - (b - a).abs() / a).abs() < 1e-12);
        // θh of cell i is (i/24)² · 90°.
        let i = d0["cell"][0].as_f64().unwrap();
        let th = d0["angles_deg"][0].as_f64().unwrap();
        assert!((th - (i / 24.0).powi(2) * 90.0).abs() < 1e-9, "{d0}");
    }
}

#[test]
fn mismatched_grids_are_refused_unless_resampled() {
    let d = tempfile::tempdir().unwrap();
    let t = synth_spec(d.path(), "plastic", &red_plastic());
    let half = d.path().join("half.binary");
    resample(&["--table", t.to_str().unwrap()], "12,12,24", &half);
    let o = compare(&t, &half, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    common::assert_mentions(
        &e,
        &[
            "plastic.binary",
            "half.binary",
            "24 x 24 x 48",
            "12 x 12 x 24",
            "--resample",
        ],
    );
    // What resampling to the coarser grid lost: > 0, and the nearest lookup loses more
    // than the linear one... at least it differs.
    let lin = json_of(&compare(&t, &half, &["--resample", "linear", "--json"]));
    let near = json_of(&compare(&t, &half, &["--resample", "nearest", "--json"]));
    let l = lin["losses"]["cbrt"]["overall"].as_f64().unwrap();
    let n = near["losses"]["cbrt"]["overall"].as_f64().unwrap();
    assert!(l > 0.0 && n > 0.0 && l != n, "{l} {n}");
    assert!(
        lin["b_on_grid"]
            .as_str()
            .unwrap()
            .contains("resampled from 12 x 12 x 24")
    );
}

#[test]
fn an_nbrdf_against_its_own_table_is_exact() {
    let d = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-measured/merl");
    let nb = root.join("blue-rubber");
    let t = d.path().join("blue.binary");
    resample(&["--nbrdf", nb.to_str().unwrap()], "16,16,32", &t);
    let c = json_of(&compare(&t, &nb, &["--json"]));
    assert_eq!(c["b"]["kind"], "nbrdf");
    assert_eq!(c["losses"]["cbrt"]["overall"].as_f64(), Some(0.0));
    assert_eq!(c["losses"]["l2"]["overall"].as_f64(), Some(0.0));
    // The NBRDF as A, on the table's grid: the same, reversed.
    let c = json_of(&compare(&nb, &t, &["--json"]));
    assert_eq!(c["a"]["kind"], "nbrdf");
    assert_eq!(c["grid"], serde_json::json!([16, 16, 32]));
    assert_eq!(c["losses"]["log"]["overall"].as_f64(), Some(0.0));
}

#[test]
fn renders_and_json_are_written() {
    let d = tempfile::tempdir().unwrap();
    let (t, m) = plastic_and_lambert(d.path());
    let out = d.path().join("cmp");
    let o = fit_brdf_ok!(
        "compare",
        &t,
        &m,
        "--render-size",
        "16",
        "--env-spp",
        "2",
        "--out",
        &out
    );
    let text = String::from_utf8_lossy(&o.stdout);
    common::assert_mentions(&text, &["render (point light)"]);
    for l in ["point", "environment"] {
        for w in ["a", "b", "diff"] {
            let png = std::fs::read(out.join(format!("{l}-{w}.png"))).unwrap();
            assert!(png.starts_with(b"\x89PNG"));
        }
    }
    let c: Value =
        serde_json::from_slice(&std::fs::read(out.join("compare.json")).unwrap()).unwrap();
    assert_eq!(c["renders"].as_array().unwrap().len(), 2);
    assert!(
        c["renders"][0]["models"][0]["diff"]["rel_rms_radiance"]
            .as_f64()
            .unwrap()
            > 0.0
    );
    // An output directory that cannot be created: a runtime failure, exit 1.
    let blocker = write_file(d.path(), "file", "x");
    let o = fit_brdf!(
        "compare",
        &t,
        &m,
        "--no-renders",
        "--out",
        blocker.join("sub")
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
}

#[test]
fn unrecognised_and_incompatible_inputs_exit_2_naming_the_file() {
    let d = tempfile::tempdir().unwrap();
    let t = synth_spec(d.path(), "plastic", &red_plastic());
    let txt = write_file(d.path(), "notes.txt", "hello");
    let aniso = write_file(
        d.path(),
        "aniso.json",
        r#"{"model": "ward", "params": {"rho_d": 0.2, "rho_s": 0.1, "alpha_x": 0.1, "alpha_y": 0.3}}"#,
    );
    let bad = write_file(d.path(), "bad.json", "[1, 2");
    for (a, b, want) in [
        (&t, &txt, "notes.txt"),
        (&t, &d.path().join("nothing-here"), "nothing-here"),
        (&t, &aniso, "aniso.json"),
        (&aniso, &t, "anisotropic"),
        (&t, &bad, "bad.json"),
        (&d.path().join("gone.binary"), &t, "gone.binary"),
    ] {
        let o = compare(a, b, &[]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(want), "{want}: {}", stderr(&o));
    }
}
