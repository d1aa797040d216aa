//! `fit-brdf demo`, the README's main job: on the embedded measured material by default
//! (no model fits it exactly, and the report says so), on the synthetic plastic with
//! known parameters under `--synthetic` (its own family fits it to round-off).

mod common;

use common::{bin, names, stderr};
use serde_json::Value;
use std::path::Path;

/// Runs the demo into a fresh directory; returns its stdout and report.json.
fn demo(dir: &Path, extra: &[&str]) -> (String, Value) {
    let out = dir.join("demo");
    let o = bin()
        .arg("demo")
        .arg("--out")
        .arg(&out)
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let s = String::from_utf8(o.stdout).unwrap();
    // The steps, in order: the round trip, the fits, the report and where it is.
    let at = |needle: &str| {
        s.find(needle)
            .unwrap_or_else(|| panic!("no `{needle}` in\n{s}"))
    };
    assert!(at("identical to what was written") < at("fitting 5 model families"));
    assert!(at("optimised: cbrt") < at("report written"));
    let page = out.join("report").join("index.html");
    common::assert_mentions(&s, &[&page.display().to_string()]);
    let names = names(&out.join("report"));
    assert_eq!(names, ["index.html", "report.json"]);
    let html = std::fs::read_to_string(&page).unwrap();
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 22);
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report/report.json")).unwrap())
            .unwrap();
    assert_eq!(json["summary"]["models"].as_array().unwrap().len(), 5);
    // The interactive panels, with the table and the five models embedded, well under
    // the 15 MB a five-model report may take.
    common::assert_mentions(
        &html,
        &[
            "panel-incidence",
            "panel-slice",
            "panel-sphere",
            "panel-albedo",
        ],
    );
    assert_eq!(json["view_precision"].as_array().unwrap().len(), 6);
    assert!(html.len() < 15_000_000, "{} bytes", html.len());
    assert_eq!(
        json["summary"]["table"]["dims"],
        serde_json::json!([90, 90, 180])
    );
    (s, json)
}

fn cbrt(json: &Value, k: usize) -> f64 {
    json["summary"]["models"][k]["losses"]["cbrt"]["overall"]
        .as_f64()
        .unwrap()
}

#[test]
fn the_default_demo_fits_a_measured_material_that_no_model_fits_exactly() {
    let d = tempfile::tempdir().unwrap();
    let (s, json) = demo(d.path(), &[]);
    common::assert_mentions(&s, &["specular-red-phenolic", "MERL"]);
    // Measured reflectance: every family leaves a visible residual (the synthetic
    // material's own family reaches 1e-6 and below, see the other test).
    for k in 0..5 {
        assert!(cbrt(&json, k) > 1e-3, "model {k}: {}", cbrt(&json, k));
    }
}

#[test]
fn the_synthetic_demo_is_fitted_exactly_by_its_own_family() {
    let d = tempfile::tempdir().unwrap();
    let (s, json) = demo(d.path(), &["--synthetic"]);
    assert!(s.contains("demo-plastic") || s.contains("red"), "{s}");
    assert_eq!(json["summary"]["models"][4]["label"], "cook-torrance");
    assert!(cbrt(&json, 4) < 1e-6);
}
