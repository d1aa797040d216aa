//! `fit-brdf study` end to end on a tiny configuration: the data-synthetic specs the
//! study needs, shrunk to 16 × 16 × 32 cells, one grid point and the evaluation choices.
//! Checks every output (CSV, JSON, PNG, the report's generated sections), that
//! `--rewrite` reproduces the report from the stored figures, and that bad input is a
//! clear error (exit 2) that leaves no output behind.

#[macro_use]
mod common;

use common::{assert_bad_input, assert_bad_input_writes_nothing, bin, stderr};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The specs the grid (lambert-white) and the choices (gold, copper, silver) read, on a
/// 16 × 16 × 32 grid instead of the MERL one.
fn small_specs(dir: &Path) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-synthetic");
    let out = dir.join("specs");
    std::fs::create_dir_all(&out).unwrap();
    for name in [
        "lambert-white",
        "gold-ggx",
        "copper-beckmann",
        "near-mirror-silver",
    ] {
        let text = std::fs::read_to_string(src.join(format!("{name}.toml"))).unwrap();
        assert!(!text.contains("\ndims"), "{name} sets its own dims");
        // `dims` is a top-level key: it goes before the first table header.
        let at = text.find("\n[").expect("a [material] table");
        let shrunk = format!("{}\ndims = [16, 16, 32]{}", &text[..at], &text[at..]);
        std::fs::write(out.join(format!("{name}.toml")), shrunk).unwrap();
    }
    out
}

fn tiny_args(specs: &Path, out: &Path) -> Vec<String> {
    [
        "study",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
        "--specs",
        specs.to_str().unwrap(),
        "--parts",
        "grid,choices",
        "--materials",
        "lambert-white",
        "--models",
        "lambert,cook-torrance",
        "--solvers",
        "lm",
        "--fractions",
        "0.1,1",
        "--starts",
        "1",
        "--reps",
        "2",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

fn csv_rows(p: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(p).unwrap();
    text.lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// A tiny study set up in `dir`: its arguments (specs written there), its output
/// directory and the index in the arguments of its one material's name, which the
/// error tests replace.
fn tiny_study(dir: &Path) -> (Vec<String>, PathBuf, usize) {
    let specs = small_specs(dir);
    let out = dir.join("avt");
    let args = tiny_args(&specs, &out);
    let m = args.iter().position(|a| a == "lambert-white").unwrap();
    (args, out, m)
}

#[test]
fn tiny_study_writes_every_output_and_rewrites_identically() {
    let dir = tempfile::tempdir().unwrap();
    let (args, out, _) = tiny_study(dir.path());
    let o = bin().args(args).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));

    // The grid: 1 material × 2 models × 1 solver × 2 fractions × 1 start.
    let grid = csv_rows(&out.join("grid.csv"));
    assert_eq!(grid.len(), 1 + 4, "{grid:?}");
    let res: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let rows = res["grid"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    for r in rows {
        assert_eq!(r["material"], "lambert-white");
        assert!(
            r["wall_s"].as_f64().unwrap() > 0.0,
            "a positive wall time: {r}"
        );
        // Both models contain the Lambertian truth: the full-table loss is near 0.
        let loss = r["cbrt"].as_f64().unwrap();
        assert!(loss < 1e-8, "a near-exact fit: {r}");
    }

    // The choices: lookups at random directions, and every Cook-Torrance variant.
    let variants = res["variants"].as_array().unwrap();
    let choices: Vec<&str> = variants
        .iter()
        .map(|v| v["choice"].as_str().unwrap())
        .collect();
    for c in ["fresnel", "beckmann-g1", "smith", "precision"] {
        assert!(choices.contains(&c), "{c} missing from {choices:?}");
    }
    for v in variants.iter().filter(|v| v["choice"] == "precision") {
        let e = v["rel_max"].as_f64().unwrap();
        // float32 evaluation really rounds, and only by float32 round-off.
        assert!(e > 1e-9 && e < 1e-3, "precision error {e}: {v}");
        assert!(v["ns_variant"].as_f64().unwrap() > 0.0);
    }
    assert!(!res["lookups"].as_array().unwrap().is_empty());
    assert!(csv_rows(&out.join("variants.csv")).len() > 4);

    // PNGs that decode to a real picture.
    let mut pngs = 0;
    for e in std::fs::read_dir(&out).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "png") {
            let img = image::open(&p).unwrap();
            assert!(img.width() >= 400 && img.height() >= 300, "{p:?}");
            pngs += 1;
        }
    }
    assert!(pngs >= 3, "the Pareto plots and the choices plot: {pngs}");

    // The report: every generated section present, with this run's numbers.
    let md_path = dir.path().join("avt.md");
    let md = std::fs::read_to_string(&md_path).unwrap();
    for marker in ["<!-- study:run -->", "<!-- study:choices-plot -->"] {
        assert!(md.contains(marker), "{marker} missing");
    }
    assert!(md.contains("lambert-white"));
    assert!(
        md.contains("eval_batch_f32"),
        "the precision row names the path"
    );

    // Hand-written text outside the markers survives; --rewrite measures nothing and
    // regenerates the same report from results.json.
    let edited = format!("{md}\nA reader's note.\n");
    std::fs::write(&md_path, &edited).unwrap();
    fit_brdf_ok!("study", "--quiet", "--rewrite", "--out", &out);
    assert_eq!(std::fs::read_to_string(&md_path).unwrap(), edited);
}

#[test]
fn bad_study_input_is_a_clear_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (tiny, out, m) = tiny_study(dir.path());

    let mut args = tiny.clone();
    args[m] = "no-such-material".into();
    let o = bin().args(&args).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no-such-material.toml"),
        "names the spec: {}",
        stderr(&o)
    );
    assert!(!out.exists(), "no output directory for a failed run");

    for (flag, bad, what) in [
        ("--fractions", "0", "fraction"),
        ("--fractions", "1.5", "fraction"),
        ("--solvers", "newton", "newton"),
        ("--parts", "grid,everything", "everything"),
    ] {
        let mut args = tiny.clone();
        let i = args.iter().position(|a| a == flag).unwrap();
        args[i + 1] = bad.into();
        let o = bin().args(&args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{flag} {bad}: {}", stderr(&o));
        assert!(
            stderr(&o).to_lowercase().contains(what),
            "{flag} {bad}: {}",
            stderr(&o)
        );
        assert!(!out.exists(), "{flag} {bad} left output behind");
    }

    // --rewrite without a previous run names what is missing.
    let o = fit_brdf!("study", "--rewrite", "--out", dir.path().join("never-run"));
    assert_bad_input(&o, &["results.json"]);
}

/// The proxies' folder (issue 30): found from a folder below the checkout (the README's
/// `tour/`), named by `$BRDFKIT_MEASURED_DIR` or `--measured-dir`; a folder that is not
/// there is an error naming both, before any work.
#[test]
fn the_measured_folder_is_found_or_named() {
    let dir = tempfile::tempdir().unwrap();
    let (mut args, out, m) = tiny_study(dir.path());
    args.splice(
        m - 1..=m,
        ["--measured".to_string(), "no-such-proxy".into()],
    );
    let p = args.iter().position(|a| a == "grid,choices").unwrap();
    args[p] = "grid".into();
    let missing = dir.path().join("nowhere");
    let run = |extra: &[&str], env: Option<&Path>| {
        let mut c = bin();
        c.args(&args).args(extra).env_remove("BRDFKIT_MEASURED_DIR");
        if let Some(e) = env {
            c.env("BRDFKIT_MEASURED_DIR", e);
        }
        c.output().unwrap()
    };
    for o in [
        run(&["--measured-dir", missing.to_str().unwrap()], None),
        run(&[], Some(&missing)),
    ] {
        assert_bad_input_writes_nothing(
            &o,
            &["nowhere", "--measured-dir", "BRDFKIT_MEASURED_DIR"],
            &out,
        );
    }
    // From a folder of the checkout without the option: its data-measured/ is found,
    // and the name missing from it is the error.
    let tour = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let o = bin()
        .current_dir(&tour)
        .args(&args)
        .env_remove("BRDFKIT_MEASURED_DIR")
        .output()
        .unwrap();
    assert_bad_input(&o, &["no proxy `no-such-proxy`", "../../../data-measured"]);
}
