//! Drives the `fit-brdf` binary as a user would: every subcommand and its failure modes.

#[macro_use]
mod common;

use common::{
    assert_bad_input, bin, lambert_file, names, small_plastic_spec, spec_text, stderr,
    synth_output, synth_spec, temp_file, write_file,
};
use std::path::{Path, PathBuf};

/// A small grey-ish Lambertian (16 × 16 × 32).
fn small_lambert() -> String {
    spec_text(
        "small",
        [16, 16, 32],
        "lambert",
        "rho_d = [0.5, 0.25, 0.125]",
    )
}

/// Writes a spec and synthesises its table in `dir`; returns the table path.
fn small_table(dir: &Path) -> PathBuf {
    synth_spec(dir, "small", &small_lambert())
}

#[test]
fn synth_then_info_text_and_json() {
    let d = tempfile::tempdir().unwrap();
    let t = small_table(d.path());
    assert_eq!(
        std::fs::metadata(&t).unwrap().len(),
        12 + 3 * 8 * 16 * 16 * 32
    );
    let o = fit_brdf!("info", &t);
    assert!(o.status.success());
    let s = String::from_utf8(o.stdout).unwrap();
    common::assert_mentions(&s, &["16 x 16 x 32"]);
    let o = fit_brdf!("info", &t, "--json");
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["dims"], serde_json::json!([16, 16, 32]));
    let med = v["channels"]["r"]["median"].as_f64().unwrap();
    assert!((med - 0.5 / std::f64::consts::PI).abs() < 1e-12);
    let a0 = v["albedo"][0]["albedo"][0].as_f64().unwrap();
    assert!((a0 - 0.5).abs() < 5e-3, "albedo at normal incidence {a0}");
}

#[test]
fn info_rejects_bad_tables_with_exit_2_and_the_file_name() {
    let d = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("empty.binary", vec![]),
        ("short.binary", vec![0u8; 11]),
        (
            "negdims.binary",
            [
                (-1i32).to_le_bytes(),
                1i32.to_le_bytes(),
                1i32.to_le_bytes(),
            ]
            .concat(),
        ),
        ("truncated.binary", {
            let mut v = [1i32.to_le_bytes(), 1i32.to_le_bytes(), 2i32.to_le_bytes()].concat();
            v.extend_from_slice(&[0u8; 8 * 5]);
            v
        }),
    ];
    for (name, bytes) in cases {
        let p = d.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let o = fit_brdf!("info", &p);
        assert_eq!(o.status.code(), Some(2), "{name}");
        let e = stderr(&o);
        assert!(e.starts_with("error: ") && e.contains(name), "{name}: {e}");
    }
    let o = fit_brdf!("info", d.path());
    assert_eq!(o.status.code(), Some(2), "a directory is bad input");
    let o = fit_brdf!("info", d.path().join("nope.binary"));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nope.binary"));
}

#[test]
fn eval_table_and_model_write_one_row_per_pair() {
    let d = tempfile::tempdir().unwrap();
    let t = small_table(d.path());
    let dirs = d.path().join("dirs.csv");
    // Normal incidence, a generic pair, and a below-horizon pair (no sample).
    std::fs::write(
        &dirs,
        "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n0.6,0,0.8,0,0.6,0.8\n1,0,0,0,0,1\n",
    )
    .unwrap();
    for interp in ["nearest", "linear"] {
        let out = d.path().join(format!("{interp}.csv"));
        bin()
            .args(["eval", "--table"])
            .arg(&t)
            .arg("--dirs")
            .arg(&dirs)
            .args(["--interp", interp, "--out"])
            .arg(&out)
            .assert()
            .success();
        let s = std::fs::read_to_string(&out).unwrap();
        let lines: Vec<&str> = s.lines().collect();
        assert_eq!(lines.len(), 4, "{s}");
        assert_eq!(lines[0], "r,g,b");
        let r: f64 = lines[1].split(',').next().unwrap().parse().unwrap();
        assert!((r - 0.5 / std::f64::consts::PI).abs() < 1e-12);
        assert_eq!(lines[3], ",,", "below the horizon there is no sample");
    }
    let model = lambert_file(d.path(), "m.json", "0.3");
    let o = fit_brdf_ok!("eval", "--model", &model, "--dirs", &dirs);
    let s = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<&str> = s.lines().collect();
    assert_eq!(lines.len(), 4);
    assert_eq!(lines[3], "0,0,0", "a model is exactly 0 below the horizon");
}

#[test]
fn eval_rejects_bad_input_with_exit_2() {
    let d = tempfile::tempdir().unwrap();
    let t = small_table(d.path());
    let dirs = write_file(
        d.path(),
        "bad.csv",
        "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,2,0,0,1\n",
    );
    let o = fit_brdf!("eval", "--table", &t, "--dirs", &dirs);
    assert_bad_input(&o, &["bad.csv: line 2"]);
    let model = d.path().join("m.json");
    for (text, what) in [
        (r#"{"model": "lambert", "params": {"rho_d": 1.5}}"#, "rho_d"),
        (r#"{"model": "lambrt"}"#, "unknown model"),
        ("{not json", "not valid JSON"),
    ] {
        std::fs::write(&model, text).unwrap();
        let good = write_file(
            d.path(),
            "good.csv",
            "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n",
        );
        let o = fit_brdf!("eval", "--model", &model, "--dirs", &good);
        assert_eq!(o.status.code(), Some(2), "{text}");
        let e = stderr(&o);
        common::assert_mentions(&e, &["m.json", what]);
    }
    // Both sources, or none: usage errors.
    let o = fit_brdf!("eval", "--dirs", "x.csv");
    assert_eq!(o.status.code(), Some(2));
    let o = fit_brdf!("eval", "--table", "a", "--model", "b", "--dirs", "x.csv");
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn resample_table_and_model() {
    let d = tempfile::tempdir().unwrap();
    let t = small_table(d.path());
    let out = d.path().join("big.binary");
    bin()
        .args(["resample", "--table"])
        .arg(&t)
        .args(["--dims", "32,16,64", "--interp", "nearest", "--out"])
        .arg(&out)
        .assert()
        .success();
    assert_eq!(
        std::fs::metadata(&out).unwrap().len(),
        12 + 24 * 32 * 16 * 64
    );
    let model = lambert_file(d.path(), "m.json", "[0.1, 0.2, 0.3]");
    let mt = d.path().join("model.binary");
    bin()
        .args(["resample", "--model"])
        .arg(&model)
        .args(["--dims", "8,8,16", "--out"])
        .arg(&mt)
        .assert()
        .success();
    let o = fit_brdf!("info", &mt, "--json");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let g = v["channels"]["g"]["max"].as_f64().unwrap();
    assert!((g - 0.2 / std::f64::consts::PI).abs() < 1e-12);
    for bad in ["1,2", "0,1,1", "a,b,c", "-1,2,3"] {
        let o = fit_brdf!(
            "resample",
            "--table",
            &t,
            "--dims",
            bad,
            "--out",
            d.path().join("x.binary")
        );
        assert_bad_input(&o, &["--dims"]);
    }
}

#[test]
fn write_failure_is_exit_1_and_leaves_nothing_behind() {
    let d = tempfile::tempdir().unwrap();
    let spec = write_file(d.path(), "small.toml", small_lambert());
    let o = synth_output(&spec, &d.path().join("no-such-dir").join("t.binary"));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("t.binary"));
    let names = names(d.path());
    assert_eq!(names.len(), 1, "only the spec: {names:?}");
}

#[test]
fn synth_rejects_a_bad_spec_with_exit_2() {
    let (d, spec) = temp_file(
        "bad.toml",
        "name = \"x\"\ncolour = 1\n[material]\nmodel = \"lambert\"\n",
    );
    let o = synth_output(&spec, &d.path().join("t.binary"));
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    common::assert_mentions(&e, &["bad.toml", "colour"]);
    assert!(!d.path().join("t.binary").exists());
}

#[test]
fn unknown_subcommand_is_a_usage_error() {
    let o = fit_brdf!("frobnicate");
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn check_passes_lambert_fails_phong_and_checks_tables() {
    let d = tempfile::tempdir().unwrap();
    let lambert = lambert_file(d.path(), "lambert.json", "0.7");
    fit_brdf_ok!("check", &lambert);
    let o = fit_brdf!("check", &lambert, "--json");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["passed"], true);
    let phong = write_file(
        d.path(),
        "phong.json",
        r#"{"model": "phong", "params": {"k_d": 0.1, "k_s": 0.5, "n": 10}}"#,
    );
    let o = fit_brdf!("check", &phong);
    assert_eq!(
        o.status.code(),
        Some(1),
        "the original Phong fails its physical checks"
    );
    let s = String::from_utf8_lossy(&o.stdout);
    common::assert_mentions(&s, &["reciprocity", "FAIL"]);
    let t = small_table(d.path());
    let o = fit_brdf_ok!("check", &t, "--json");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["passed"], true);
    let o = fit_brdf!("check", d.path());
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn render_writes_png_and_exr_and_rejects_bad_scenes() {
    let d = tempfile::tempdir().unwrap();
    let scene =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes/sphere-point.toml");
    let png = d.path().join("s.png");
    let exr = d.path().join("s.exr");
    let o = fit_brdf_ok!(
        "render", &scene, "--out", &png, "--exr", &exr, "--size", "32x24"
    );
    let s = stderr(&o);
    assert!(
        s.contains("direct") && s.contains("environment"),
        "per-effect cost: {s}"
    );
    let png_bytes = std::fs::read(&png).unwrap();
    assert_eq!(&png_bytes[..8], b"\x89PNG\r\n\x1a\n");
    let exr_bytes = std::fs::read(&exr).unwrap();
    assert_eq!(&exr_bytes[..4], &[0x76, 0x2f, 0x31, 0x01], "EXR magic");
    let o = fit_brdf!("render", &scene, "--out", d.path().join("s.jpg"));
    assert_eq!(o.status.code(), Some(2));
    let bad = write_file(d.path(), "bad.toml", "effects = [\"direct\"]\nwibble = 1\n");
    let o = fit_brdf!("render", &bad, "--out", &png);
    assert_bad_input(&o, &["bad.toml"]);
}

fn small_plastic(dir: &Path) -> PathBuf {
    let spec = small_plastic_spec("small-plastic", [0.4, 0.2, 0.1], 0.15);
    synth_spec(dir, "plastic", &spec)
}

#[test]
fn fit_recovers_a_synthetic_plastic_and_writes_params_and_record() {
    let d = tempfile::tempdir().unwrap();
    let t = small_plastic(d.path());
    let params = d.path().join("params.json");
    let record = d.path().join("fit.json");
    fit_brdf_ok!(
        "fit",
        &t,
        "--model",
        "cook-torrance",
        "--distribution",
        "ggx",
        "--fresnel",
        "schlick",
        "--starts",
        "2",
        "--out",
        &params,
        "--record",
        &record
    );
    let p: serde_json::Value = serde_json::from_slice(&std::fs::read(&params).unwrap()).unwrap();
    let alpha = p["params"]["alpha"].as_f64().unwrap();
    assert!((alpha - 0.15).abs() < 1e-6, "alpha {alpha}");
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&record).unwrap()).unwrap();
    assert!(r["losses_full"]["cbrt"]["overall"].as_f64().unwrap() < 1e-10);
    assert!(r["starts"].as_array().unwrap().len() >= 2);
    // The fitted parameters are a model the other commands read.
    let dirs = write_file(
        d.path(),
        "dirs.csv",
        "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n",
    );
    bin()
        .args(["eval", "--model"])
        .arg(&params)
        .arg("--dirs")
        .arg(&dirs)
        .assert()
        .success();
}

#[test]
fn fit_compares_several_models() {
    let d = tempfile::tempdir().unwrap();
    let t = small_plastic(d.path());
    let out = d.path().join("fits");
    let o = fit_brdf_ok!(
        "fit",
        &t,
        "--model",
        "lambert,plausible-phong,cook-torrance",
        "--starts",
        "2",
        "--json",
        "--quiet",
        "--out",
        &out
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let losses: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| {
            x["record"]["losses_full"]["cbrt"]["overall"]
                .as_f64()
                .unwrap()
        })
        .collect();
    assert_eq!(losses.len(), 3);
    assert!(
        losses[2] < losses[1] && losses[1] < losses[0],
        "microfacet < phong < lambert: {losses:?}"
    );
    for m in ["lambert", "plausible-phong", "cook-torrance"] {
        assert!(
            out.join(format!("{m}.json")).exists() && out.join(format!("{m}.fit.json")).exists()
        );
    }
}

#[test]
fn fit_rejects_bad_options_with_exit_2() {
    let d = tempfile::tempdir().unwrap();
    let t = small_table(d.path());
    for args in [
        vec!["--model", "nope"],
        vec!["--model", "lambert", "--loss", "l3"],
        vec!["--model", "lambert", "--solver", "magic"],
        vec!["--model", "lambert", "--starts", "0"],
        vec!["--model", "lambert", "--sample-fraction", "0"],
        vec!["--model", "lambert", "--distribution", "ggx"],
        vec!["--model", "cook-torrance", "--fresnel", "gold"],
        vec!["--model", "lambert,ward", "--record", "x.json"],
    ] {
        let o = bin().arg("fit").arg(&t).args(&args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn quiet_and_json_options_where_results_are_printed() {
    let d = tempfile::tempdir().unwrap();
    let spec = write_file(d.path(), "small.toml", small_lambert());
    let t = d.path().join("t.binary");
    let o = fit_brdf!("synth", &spec, "--out", &t, "--quiet");
    assert!(o.status.success() && o.stdout.is_empty() && o.stderr.is_empty());
    let r = d.path().join("r.binary");
    let o = fit_brdf!(
        "resample", "--table", &t, "--dims", "8,8,16", "-q", "--out", &r
    );
    assert!(o.status.success() && o.stderr.is_empty());
    let phong = write_file(
        d.path(),
        "phong.json",
        r#"{"model": "phong", "params": {"k_d": 0.1, "k_s": 0.5, "n": 10}}"#,
    );
    let o = fit_brdf!("check", &phong, "--quiet");
    assert_eq!(o.status.code(), Some(1));
    assert!(o.stdout.is_empty());
    let scene =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes/sphere-point.toml");
    let o = fit_brdf!(
        "render",
        &scene,
        "--out",
        d.path().join("s.png"),
        "--size",
        "16x16",
        "--json",
        "--quiet"
    );
    assert!(o.status.success() && o.stderr.is_empty(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["effects"]["direct"]["requested"], true);
    assert_eq!(v["effects"]["environment"]["requested"], false);
    assert_eq!(v["effects"]["environment"]["brdf_evals"], 0);
}
