//! `fit-brdf report`: the files, their content, and the failure modes, driven as a user
//! would.

#[macro_use]
mod common;

use assert_cmd::Command;
use common::{
    assert_bad_input, assert_bad_input_writes_nothing, bin, names, stderr, synth_spec, write_file,
};
use serde_json::Value;
use std::path::{Path, PathBuf};

const FIVE: &str = "lambert,plausible-phong,ward,lafortune,cook-torrance";

/// A small red plastic (the demo's material on a 24 × 24 × 48 grid): cook-torrance
/// fits it exactly, the other families cannot.
fn small_table(dir: &Path) -> PathBuf {
    synth_spec(dir, "small", &common::red_plastic())
}

/// The quick settings of these tests: the five families, one start, small renders.
fn report(table: &Path, out: &Path) -> Command {
    report_of(table, out, FIVE)
}

fn report_of(table: &Path, out: &Path, models: &str) -> Command {
    let mut c = bin();
    c.arg("report")
        .arg(table)
        .args(["--models", models, "--starts", "1", "--render-size", "32"])
        .args(["--env-spp", "4", "--quiet", "--out"])
        .arg(out);
    c
}

#[test]
fn report_writes_the_page_and_the_json_of_every_model_and_loss() {
    let d = tempfile::tempdir().unwrap();
    let t = small_table(d.path());
    let out = d.path().join("rep");
    let o = report(&t, &out).arg("--json").output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // Exactly the two files: no temporary file left behind.
    assert_eq!(names(&out), ["index.html", "report.json"]);

    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    // --json prints report.json's summary.
    let printed: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(printed, json["summary"]);

    let s = &json["summary"];
    assert_eq!(s["table"]["dims"], serde_json::json!([24, 24, 48]));
    let models = s["models"].as_array().unwrap();
    let labels: Vec<&str> = models
        .iter()
        .map(|m| m["label"].as_str().unwrap())
        .collect();
    assert_eq!(labels, FIVE.split(',').collect::<Vec<_>>());
    let loss = |m: &Value, l: &str| m["losses"][l]["overall"].as_f64().unwrap();
    for m in models {
        for l in ["l2", "cosine", "cbrt", "log"] {
            assert!(loss(m, l).is_finite() && loss(m, l) >= 0.0, "{m}");
            assert_eq!(m["losses"][l]["channels"].as_array().unwrap().len(), 3);
        }
        assert!(m["fit_time_s"].as_f64().unwrap() > 0.0);
        assert!(m["params"]["model"].is_string());
        assert!(m["physical_passed"].is_boolean(), "{m}");
    }
    // The truth: cook-torrance is the material's own family, Lambert cannot make a
    // highlight.
    let (lam, ct) = (&models[0], &models[4]);
    assert!(loss(ct, "cbrt") < 1e-6, "{ct}");
    assert!(loss(lam, "cbrt") > 1e3 * loss(ct, "cbrt"));
    assert_eq!(ct["physical_passed"], true);

    // Details: quality, residual map, physical checks, slices, albedo, renders.
    for m in json["models"].as_array().unwrap() {
        assert_eq!(m["physical"].as_array().unwrap().len(), 1);
        let map = &m["residual_map"];
        assert_eq!(
            map["values"].as_array().unwrap().len(),
            (map["cols"].as_u64().unwrap() * map["rows"].as_u64().unwrap()) as usize
        );
        assert_eq!(m["quality"]["theta_h_bands"].as_array().unwrap().len(), 8);
    }
    assert_eq!(json["slices"].as_array().unwrap().len(), 4);
    assert_eq!(json["albedo"]["models"].as_array().unwrap().len(), 5);
    let renders = json["renders"].as_array().unwrap();
    assert_eq!(renders.len(), 2);
    for r in renders {
        let ms = r["models"].as_array().unwrap();
        assert_eq!(ms.len(), 5);
        // The exact family renders like the table (interpolated lookups differ from
        // the model only between cells); Lambert does not.
        let rel = |k: usize| ms[k]["diff"]["rel_rms_radiance"].as_f64().unwrap();
        assert!(rel(4) < rel(0), "{r}");
    }

    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    common::assert_mentions(
        &html,
        &[
            "id=\"summary\"",
            "id=\"summary-table\"",
            "id=\"slices\"",
            "id=\"residuals\"",
            "id=\"renders\"",
            "id=\"albedo\"",
            "id=\"checks\"",
            "id=\"details\"",
            "id=\"page-check\"",
        ],
    );
    // Self-contained: charts inline, images embedded, nothing fetched.
    assert!(html.matches("<svg").count() >= 4 * 3 + 5 + 1 + 3);
    // 2 lightings × (table + 5 × (fit, difference)).
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 22);
    assert!(!html.contains("src=\"http") && !html.contains("href=\"http"));
    for label in FIVE.split(',') {
        assert!(html.contains(label));
    }
}

#[test]
fn text_output_names_the_files_and_options_of_fit_apply() {
    let d = tempfile::tempdir().unwrap();
    let t = small_table(d.path());
    let out = d.path().join("rep");
    let o = fit_brdf_ok!(
        "report",
        &t,
        "--models",
        "lambert,cook-torrance",
        "--loss",
        "log",
        "--starts",
        "1",
        "--sample-fraction",
        "0.5",
        "--distribution",
        "ggx",
        "--no-renders",
        "--no-checks",
        "--out",
        &out
    );
    let s = String::from_utf8(o.stdout.clone()).unwrap();
    common::assert_mentions(&s, &["index.html", "optimised: log"]);
    // Progress on stderr without --quiet.
    common::assert_mentions(&stderr(&o), &["[2/2] fitting cook-torrance"]);
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["summary"]["loss_optimised"], "log");
    assert_eq!(json["fit_config"]["subsample"], 0.5);
    assert!(json["renders"].as_array().unwrap().is_empty());
    assert!(json["summary"]["models"][0]["physical_passed"].is_null());
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("Not rendered") && html.contains("Not run."));
}

#[test]
fn bad_input_exits_2_naming_the_file() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("rep");
    let missing = d.path().join("nope.binary");
    let o = report(&missing, &out).output().unwrap();
    assert_bad_input(&o, &["nope.binary"]);

    let garbage = write_file(d.path(), "garbage.binary", b"not a table at all");
    let o = report(&garbage, &out).output().unwrap();
    assert_bad_input_writes_nothing(&o, &["garbage.binary"], &out);

    let t = small_table(d.path());
    for args in [
        &["--models", "no-such-model"][..],
        &["--render-size", "4"],
        &["--env-spp", "0"],
        &["--loss", "l7"],
        &["--sample-fraction", "0"],
    ] {
        let o = bin()
            .arg("report")
            .arg(&t)
            .args(args)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).starts_with("error:"), "{args:?}: {}", stderr(&o));
    }
    assert!(!out.exists());
}

#[test]
fn write_failures_exit_1_and_leave_no_partial_report() {
    let d = tempfile::tempdir().unwrap();
    let t = small_table(d.path());
    let quick = |c: &mut Command| {
        c.args(["--no-renders", "--no-checks"]);
    };

    // The output "directory" is a file: it stays as it was.
    let file = write_file(d.path(), "a-file", "keep me");
    let mut c = report_of(&t, &file, "lambert");
    quick(&mut c);
    let o = c.output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    common::assert_mentions(&stderr(&o), &["a-file"]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");

    // index.html cannot be replaced (a directory is in the way): report.json, renamed
    // first, is taken back, and no temporary file remains.
    let out = d.path().join("rep");
    std::fs::create_dir_all(out.join("index.html").join("sub")).unwrap();
    let mut c = report_of(&t, &out, "lambert");
    quick(&mut c);
    let o = c.output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    common::assert_mentions(&stderr(&o), &["index.html"]);
    assert_eq!(names(&out), ["index.html"]);

    // The directory may exist: a second run replaces both files.
    std::fs::remove_dir_all(out.join("index.html")).unwrap();
    let mut c = report_of(&t, &out, "lambert");
    quick(&mut c);
    c.assert().success();
    let mut c = report_of(&t, &out, "lambert");
    quick(&mut c);
    c.assert().success();
    assert_eq!(names(&out), ["index.html", "report.json"]);
}
