//! `score` and `report` on the inputs of `fit`: scattered samples (`--samples`) and a
//! `.bsdf` at its measured points, through the binary. A score on a tiny samples file
//! equals the losses computed by hand; a report's page has the sections of scattered
//! data and claims no measured sphere for samples; bad files are exit 2 naming the file
//! and the row.

#[macro_use]
mod common;

use common::{assert_bad_input, bin, stderr};
use serde_json::Value;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Three samples (wi, wo, rgb, weight); the second has a missing green value.
const ROWS: [[f64; 10]; 4] = [
    [0.0, 0.0, 1.0, 0.6, 0.0, 0.8, 0.10, 0.20, 0.30, 1.0],
    [0.6, 0.0, 0.8, 0.0, 0.0, 1.0, 0.12, f64::NAN, 0.25, 2.0],
    [0.0, 0.6, 0.8, 0.6, 0.0, 0.8, 0.05, 0.10, 0.15, 0.5],
    [0.0, 0.8, 0.6, 0.0, -0.6, 0.8, 0.08, 0.02, 0.40, 3.0],
];

/// The Lambertian the samples are scored against: f = ρ/π.
const RHO: [f64; 3] = [0.3, 0.5, 0.8];

fn samples_csv(dir: &Path) -> PathBuf {
    let mut s = String::from("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,r,g,b,weight\n");
    for r in ROWS {
        let f: Vec<String> = r
            .iter()
            .map(|v| {
                if v.is_nan() {
                    String::new()
                } else {
                    v.to_string()
                }
            })
            .collect();
        s += &(f.join(",") + "\n");
    }
    let p = dir.join("lab.csv");
    std::fs::write(&p, s).unwrap();
    p
}

fn lambert(dir: &Path) -> PathBuf {
    let p = dir.join("lam.json");
    let v = serde_json::json!({"model": "lambert", "params": {"rho_d": RHO}});
    std::fs::write(&p, v.to_string()).unwrap();
    p
}

/// The losses by their definition (docs/fitting.md): per channel
/// sqrt(Σ w (t(model) − t(measured))² / Σ w), t the loss's transform of f and cos θi,
/// overall the RMS of the channels; the missing sample left out.
fn by_hand(weighting_uniform: bool) -> [(&'static str, f64, [f64; 3]); 4] {
    type Transform = fn(f64, f64) -> f64;
    let t: [(&str, Transform); 4] = [
        ("l2", |f, _| f),
        ("cosine", |f, c| f * c),
        ("cbrt", |f, c| (f * c).cbrt()),
        ("log", |f, c| (f * c).ln_1p()),
    ];
    t.map(|(name, tr)| {
        let (mut s, mut ws) = ([0.0; 3], 0.0);
        for r in ROWS.iter().filter(|r| !r[7].is_nan()) {
            let w = if weighting_uniform { 1.0 } else { r[9] };
            ws += w;
            for c in 0..3 {
                let d = tr(RHO[c] / PI, r[2]) - tr(r[6 + c], r[2]);
                s[c] += w * d * d;
            }
        }
        let ch = s.map(|v| (v / ws).sqrt());
        let overall = ((ch[0] * ch[0] + ch[1] * ch[1] + ch[2] * ch[2]) / 3.0).sqrt();
        (name, overall, ch)
    })
}

fn json_of(o: &std::process::Output) -> Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn score_on_samples_equals_the_losses_computed_by_hand() {
    let d = tempfile::tempdir().unwrap();
    let (s, m) = (samples_csv(d.path()), lambert(d.path()));
    for (uniform, extra) in [(false, &[][..]), (true, &["--weighting", "uniform"][..])] {
        let o = bin()
            .args(["score", "--json", "--samples"])
            .arg(&s)
            .arg(&m)
            .args(extra)
            .output()
            .unwrap();
        let v = json_of(&o);
        let input = &v["input"];
        assert_eq!(input["kind"], "samples", "{v}");
        assert_eq!(input["cells"], 3, "{v}");
        assert_eq!(input["samples"]["rows"], 4, "{v}");
        assert_eq!(input["samples"]["dropped_missing"], 1, "{v}");
        assert_eq!(input["samples"]["weights"], "given", "{v}");
        let losses = &v["models"][0]["losses"];
        assert_eq!(losses["cells"], 3);
        for (name, overall, ch) in by_hand(uniform) {
            let got = losses[name]["overall"].as_f64().unwrap();
            assert!(overall > 1e-3, "{name}: a loss near 0 proves nothing");
            assert!(
                (got - overall).abs() <= 1e-12 * overall,
                "{name}: {got} vs {overall}"
            );
            for c in 0..3 {
                let g = losses[name]["channels"][c].as_f64().unwrap();
                assert!(
                    (g - ch[c]).abs() <= 1e-12 * ch[c].max(1e-300),
                    "{name}[{c}]"
                );
            }
        }
    }
    // The text names the input and its counts.
    let o = fit_brdf_ok!("score", "--samples", &s, &m);
    let text = String::from_utf8_lossy(&o.stdout);
    common::assert_mentions(
        &text,
        &["lab.csv (scattered samples): 3 samples of 4 rows (1 missing"],
    );
}

fn felt() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-synthetic/felt-synthetic.bsdf")
}

/// `score X.bsdf` takes the file's measured points by default (the cells of `fit`: a
/// fit re-scored gives its record's losses), and its resampling with `--bsdf-input
/// table`.
#[test]
fn score_on_a_bsdf_takes_the_points_of_fit() {
    let d = tempfile::tempdir().unwrap();
    let (p, r) = (d.path().join("p.json"), d.path().join("r.json"));
    fit_brdf_ok!(
        "fit",
        felt(),
        "--model",
        "lambert",
        "--starts",
        "1",
        "-q",
        "--out",
        &p,
        "--record",
        &r
    );
    let rec: Value = serde_json::from_slice(&std::fs::read(&r).unwrap()).unwrap();
    let score = |extra: &[&str]| {
        let o = bin()
            .arg("score")
            .arg(felt())
            .arg(&p)
            .args(extra)
            .arg("--json")
            .output()
            .unwrap();
        json_of(&o)
    };
    let v = score(&[]);
    assert_eq!(v["input"]["kind"], "bsdf-points", "{v}");
    let points = rec["input"]["samples"].as_u64().unwrap();
    assert_eq!(v["input"]["cells"].as_u64().unwrap(), points);
    for loss in ["l2", "cosine", "cbrt", "log"] {
        assert_eq!(
            v["models"][0]["losses"][loss]["overall"], rec["losses_full"][loss]["overall"],
            "{loss}"
        );
    }
    let t = score(&["--bsdf-input", "table"]);
    assert_eq!(t["input"]["kind"], "bsdf-table", "{t}");
    assert!(t["input"]["cells"].as_u64().unwrap() > 10 * points, "{t}");
}

fn report(args: &[&str], input: &[&std::ffi::OsStr], out: &Path) -> (Value, String) {
    let o = bin()
        .arg("report")
        .args(input)
        .args([
            "--models",
            "lambert,cook-torrance",
            "--starts",
            "1",
            "--quiet",
            "--json",
        ])
        .args(["--render-size", "16", "--env-spp", "1", "--out"])
        .arg(out)
        .args(args)
        .output()
        .unwrap();
    let v = json_of(&o);
    (v, std::fs::read_to_string(out.join("index.html")).unwrap())
}

#[test]
fn report_on_samples_plots_them_and_claims_no_measured_sphere() {
    let d = tempfile::tempdir().unwrap();
    let s = samples_csv(d.path());
    let out = d.path().join("r");
    let (v, html) = report(&[], &["--samples".as_ref(), s.as_os_str()], &out);
    assert_eq!(v["input"]["kind"], "samples", "{v}");
    assert_eq!(v["resampled"], false);
    assert!(v["measured_sphere"].is_null(), "{v}");
    assert_eq!(v["models"].as_array().unwrap().len(), 2);
    for id in [
        "not-resampled",
        "summary-table",
        "scatter",
        "profiles",
        "no-measured-sphere",
    ] {
        assert!(html.contains(&format!("id=\"{id}\"")), "no #{id}");
    }
    assert!(!html.contains("id=\"measured-sphere\""));
    // No sphere at all: nothing measured to render, and no image claims to be it.
    assert!(!html.contains("<img"), "an image in a samples report");
    assert!(html.contains("No measured sphere: the data are 3 scattered samples"));
    let full: Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let bands = full["models"][0]["by_theta_d"].as_array().unwrap();
    let counted: u64 = bands.iter().map(|b| b["samples"].as_u64().unwrap()).sum();
    assert_eq!(counted, 3, "every kept sample in exactly one θd band");
    assert!(full["renders"].as_array().unwrap().is_empty());
}

#[test]
fn report_on_a_bsdf_renders_the_file_itself_at_its_points() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("r");
    let f = felt();
    let (v, html) = report(&[], &[f.as_os_str()], &out);
    assert_eq!(v["input"]["kind"], "bsdf-points", "{v}");
    assert_eq!(v["resampled"], false);
    assert!(
        v["measured_sphere"]
            .as_str()
            .unwrap()
            .contains("the file's own evaluation"),
        "{v}"
    );
    for id in ["not-resampled", "scatter", "profiles", "measured-sphere"] {
        assert!(html.contains(&format!("id=\"{id}\"")), "no #{id}");
    }
    assert!(!html.contains("no-measured-sphere"));
    let full: Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    // Two lightings, the file and both models.
    let renders = full["renders"].as_array().unwrap();
    assert_eq!(renders.len(), 2);
    assert!(
        renders
            .iter()
            .all(|r| r["models"].as_array().unwrap().len() == 2)
    );
    // --bsdf-input table: the table report, the resampling named on the page.
    let out_t = d.path().join("t");
    let (v, html) = report(&["--bsdf-input", "table"], &[f.as_os_str()], &out_t);
    assert_eq!(v["table"]["dims"], serde_json::json!([90, 90, 180]), "{v}");
    assert!(html.contains("resampled to a 90 × 90 × 180 MERL table"));
}

#[test]
fn bad_sample_files_are_exit_2_naming_file_and_row_in_score_and_report() {
    let d = tempfile::tempdir().unwrap();
    let m = lambert(d.path());
    let p = d.path().join("bad.csv");
    let h = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,r,g,b\n";
    std::fs::write(
        &p,
        format!("{h}0,0,1,0,0,1,1,1,1\n0,0,1,0.6,0,-0.8,1,1,1\n"),
    )
    .unwrap();
    let needles = ["bad.csv: line 3: wo has z = -0.8", "below the horizon"];
    let o = fit_brdf!("score", "--samples", &p, &m);
    assert_bad_input(&o, &needles);
    let out = d.path().join("r");
    let o = fit_brdf!("report", "--samples", &p, "--out", &out);
    assert_bad_input(&o, &needles);
    assert!(!out.exists(), "a report written on bad input");
    // score with --samples needs a model; without, a table and a model.
    let o = fit_brdf!("score", "--samples", &p);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = fit_brdf!("score", &m);
    assert_bad_input(&o, &["give a table (or --samples) and at least one model"]);
}

/// A fit whose answer reflects more light than it receives is said to be so: the
/// Cook-Torrance fit of the felt's measured points runs along a nearly flat lobe (α ≈ 10,
/// ρs in the tens of thousands) to a directional albedo of about 5.6; the
/// energy-conserving fit of the same points keeps it under 1 and has no such note.
#[test]
fn a_fit_that_is_not_energy_conserving_says_so() {
    let note = "not energy-conserving: its directional albedo reaches";
    let fit = |extra: &[&str]| {
        let o = bin()
            .arg("fit")
            .arg(felt())
            .args(["--model", "cook-torrance", "--quiet"])
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let free = fit(&[]);
    let line = free
        .lines()
        .find(|l| l.contains(note))
        .unwrap_or_else(|| panic!("{free}"));
    let reached: f64 = line
        .split(note)
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(reached > 2.0, "{line}");
    let held = fit(&["--energy-conserving"]);
    assert!(!held.contains(note), "{held}");
}
