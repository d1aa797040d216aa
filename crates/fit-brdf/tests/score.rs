//! `fit-brdf score` and `fit-brdf report --given`: given models scored against a table
//! without fitting, on the cells and weights of `fit`, driven as a user would.

#[macro_use]
mod common;

use common::{bin, plastic_and_lambert, red_plastic, stderr, synth_spec, write_file};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn json_of(o: &std::process::Output) -> Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// Fits `model` with `extra` options; returns (PARAMS.json, FIT.json).
fn fit(dir: &Path, table: &Path, model: &str, extra: &[&str], tag: &str) -> (PathBuf, PathBuf) {
    let (p, r) = (
        dir.join(format!("{tag}.json")),
        dir.join(format!("{tag}.fit.json")),
    );
    bin()
        .arg("fit")
        .arg(table)
        .args(["--model", model, "--starts", "2", "--quiet", "--out"])
        .arg(&p)
        .arg("--record")
        .arg(&r)
        .args(extra)
        .assert()
        .success();
    (p, r)
}

fn score(table: &Path, models: &[&Path], extra: &[&str]) -> Value {
    let o = bin()
        .arg("score")
        .arg(table)
        .args(models)
        .args(extra)
        .arg("--json")
        .output()
        .unwrap();
    json_of(&o)
}

/// Every number of two loss reports, equal bit for bit (JSON numbers round-trip f64).
fn assert_same_bits(a: &Value, b: &Value, what: &str) {
    for loss in ["l2", "cosine", "cbrt", "log"] {
        let (x, y) = (&a[loss], &b[loss]);
        let ox = x["overall"].as_f64().unwrap();
        assert_eq!(
            ox.to_bits(),
            y["overall"].as_f64().unwrap().to_bits(),
            "{what} {loss}"
        );
        assert!(ox > 0.0, "{what} {loss}: a loss of 0 proves nothing");
        for c in 0..3 {
            assert_eq!(
                x["channels"][c].as_f64().unwrap().to_bits(),
                y["channels"][c].as_f64().unwrap().to_bits(),
                "{what} {loss} channel {c}"
            );
        }
    }
    assert_eq!(a["cells"], b["cells"], "{what}");
}

#[test]
fn rescored_fits_equal_their_records_to_the_bit() {
    let d = tempfile::tempdir().unwrap();
    let t = synth_spec(d.path(), "plastic", &red_plastic());
    // (model, fit options, the same cell options for score)
    let cases: [(&str, &[&str], &[&str]); 5] = [
        ("lambert", &[], &[]),
        ("ward", &["--loss", "log"], &[]),
        (
            "cook-torrance",
            &[
                "--loss",
                "l2",
                "--weighting",
                "uniform",
                "--theta-d-max",
                "70",
            ],
            &["--weighting", "uniform", "--theta-d-max", "70"],
        ),
        ("plausible-phong", &["--per-channel"], &[]),
        (
            "lafortune",
            &["--per-channel", "--theta-d-max", "60", "--loss", "cosine"],
            &["--theta-d-max", "60"],
        ),
    ];
    for (k, (model, fit_opts, score_opts)) in cases.iter().enumerate() {
        let (p, r) = fit(d.path(), &t, model, fit_opts, &format!("m{k}"));
        let record: Value = serde_json::from_slice(&std::fs::read(&r).unwrap()).unwrap();
        // The parameters file and the record itself both score to the record's losses.
        let s = score(&t, &[&p, &r], score_opts);
        for m in s["models"].as_array().unwrap() {
            assert_same_bits(&m["losses"], &record["losses_full"], model);
        }
        if fit_opts.contains(&"--per-channel") {
            let params: Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
            assert!(params.get("per_channel").is_some());
        }
    }
}

#[test]
fn score_reports_every_loss_and_the_settings() {
    let d = tempfile::tempdir().unwrap();
    let (t, m) = plastic_and_lambert(d.path());
    let all = score(&t, &[&m], &[]);
    let cut = score(
        &t,
        &[&m],
        &["--theta-d-max", "45", "--weighting", "uniform"],
    );
    let (a, c) = (&all["models"][0], &cut["models"][0]);
    assert_eq!(a["weighting"], "solid-angle");
    assert_eq!(c["weighting"], "uniform");
    assert_eq!(c["theta_d_max"].as_f64(), Some(45.0));
    assert_eq!(a["cells_valid"], c["cells_valid"]);
    assert_eq!(a["losses"]["cells"], a["cells_valid"]);
    assert!(c["losses"]["cells"].as_u64() < a["losses"]["cells"].as_u64());
    assert!(a["file"].as_str().unwrap().ends_with("lam.json"));
    // Text: the four losses, overall and per channel.
    let o = fit_brdf!("score", &t, &m);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for loss in ["cbrt", "l2", "cosine", "log"] {
        common::assert_mentions(&text, &[&format!("  {loss} ")]);
    }
    common::assert_mentions(&text, &["lambert (", "solid-angle weights"]);
}

#[test]
fn bad_input_exits_2_naming_the_file() {
    let d = tempfile::tempdir().unwrap();
    let t = synth_spec(d.path(), "plastic", &red_plastic());
    let write = |name: &str, text: &str| {
        let p = d.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let aniso = write(
        "aniso.json",
        r#"{"model": "ward", "params": {"rho_d": 0.2, "rho_s": 0.1, "alpha_x": 0.1, "alpha_y": 0.3}}"#,
    );
    let cases = [
        (write("broken.json", "{\"model\": "), "broken.json"),
        (
            write("unknown.json", r#"{"model": "no-such"}"#),
            "unknown.json",
        ),
        (
            write("two.json", r#"{"per_channel": [{"model": "lambert"}]}"#),
            "two.json",
        ),
        (aniso, "anisotropic"),
        (d.path().join("missing.json"), "missing.json"),
    ];
    for (p, want) in &cases {
        let o = fit_brdf!("score", &t, p);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(want), "{want}: {}", stderr(&o));
    }
    let ok = write("ok.json", r#"{"model": "lambert"}"#);
    // A missing table, an out-of-range cutoff.
    let o = fit_brdf!("score", d.path().join("none.binary"), &ok);
    assert_eq!(o.status.code(), Some(2));
    common::assert_mentions(&stderr(&o), &["none.binary"]);
    let o = fit_brdf!("score", &t, &ok, "--theta-d-max", "0");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    common::assert_mentions(&stderr(&o), &["theta-d-max"]);
}

#[test]
fn report_given_models_beside_fitted_ones() {
    let d = tempfile::tempdir().unwrap();
    let t = synth_spec(d.path(), "plastic", &red_plastic());
    let (p, _) = fit(d.path(), &t, "ward", &[], "ward");
    let given = write_file(
        d.path(),
        "given.json",
        r#"{"model": "cook-torrance", "params": {"rho_d": [0.4, 0.1, 0.05], "rho_s": 1.0, "alpha": 0.15}}"#,
    );
    let run = |out: &Path, extra: &[&str]| {
        let o = bin()
            .arg("report")
            .arg(&t)
            .args([
                "--render-size",
                "16",
                "--env-spp",
                "1",
                "--no-checks",
                "--quiet",
            ])
            .arg("--out")
            .arg(out)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let r: Value =
            serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
        (r, String::from_utf8_lossy(&o.stdout).into_owned())
    };
    // Given alone: nothing is fitted (the fit-only `--fix` of every parameter is no
    // longer needed).
    let arg = format!("{},{}", given.display(), p.display());
    let (r, text) = run(&d.path().join("given"), &["--given", &arg]);
    let models = r["summary"]["models"].as_array().unwrap();
    assert_eq!(models.len(), 2);
    for m in models {
        assert_eq!(m["origin"], "given");
        assert!(m["label"].as_str().unwrap().contains("given"), "{m}");
        assert!(m["fit_time_s"].is_null());
    }
    assert!(r["fit_config"].is_null());
    common::assert_mentions(&text, &["(given: "]);
    // The report's losses of a given model are its score.
    let s = score(&t, &[&given], &[]);
    assert_eq!(models[0]["losses"], s["models"][0]["losses"]);
    let html = std::fs::read_to_string(d.path().join("given/index.html")).unwrap();
    assert!(html.contains("given: "), "the page labels given models");
    // Beside a fit of the same family.
    let (r, _) = run(
        &d.path().join("both"),
        &[
            "--given",
            &given.display().to_string(),
            "--models",
            "cook-torrance",
            "--starts",
            "1",
        ],
    );
    let origins: Vec<&str> = r["summary"]["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["origin"].as_str().unwrap())
        .collect();
    assert_eq!(origins, ["fitted", "given"]);
    assert!(r["fit_config"].is_object());
    // A bad given file: exit 2, named.
    let o = fit_brdf!(
        "report",
        &t,
        "--given",
        "nope.json",
        "--quiet",
        "--out",
        d.path().join("bad")
    );
    assert_eq!(o.status.code(), Some(2));
    common::assert_mentions(&stderr(&o), &["nope.json"]);
}
