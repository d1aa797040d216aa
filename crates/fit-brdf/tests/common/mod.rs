//! Helpers shared by the CLI test files: the binary, its stderr, and a synthesised
//! table from a spec text.

#![allow(dead_code)] // each test file uses its own subset

use assert_cmd::Command;
use std::path::{Path, PathBuf};

/// The `fit-brdf` binary of this build.
pub fn bin() -> Command {
    Command::cargo_bin("fit-brdf").unwrap()
}

/// A finished command's stderr as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `fit-brdf synth SPEC --out OUT` and asserts it succeeds.
pub fn synth_to(spec: &Path, out: &Path) {
    bin()
        .arg("synth")
        .arg(spec)
        .arg("--out")
        .arg(out)
        .assert()
        .success();
}

/// Writes `spec_text` to `dir/NAME.toml` and synthesises it to `dir/NAME.binary`;
/// returns the table's path.
pub fn synth_spec(dir: &Path, name: &str, spec_text: &str) -> PathBuf {
    let spec = dir.join(format!("{name}.toml"));
    std::fs::write(&spec, spec_text).unwrap();
    let out = dir.join(format!("{name}.binary"));
    synth_to(&spec, &out);
    out
}

/// Runs `fit-brdf synth SPEC --out OUT` and returns its output, whatever its status.
pub fn synth_output(spec: &Path, out: &Path) -> std::process::Output {
    bin()
        .arg("synth")
        .arg(spec)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// The spec of a Cook-Torrance plastic on a small grid (24 × 24 × 48: quick to
/// synthesise and to fit), ρs = 1 and Schlick F0 = 0.04, with `extra` further
/// `[material.params]` lines.
pub fn plastic_spec(name: &str, rho_d: [f64; 3], alpha: f64, extra: &str) -> String {
    format!(
        "name = \"{name}\"\ndims = [24, 24, 48]\n[material]\nmodel = \"cook-torrance\"\n\
         [material.params]\nrho_d = [{}, {}, {}]\nrho_s = 1.0\nalpha = {alpha}\n{extra}\
         fresnel = {{ schlick = {{ f0 = 0.04 }} }}\n",
        rho_d[0], rho_d[1], rho_d[2]
    )
}

/// The red plastic of the report and score tests: GGX, separable Smith.
pub fn red_plastic() -> String {
    plastic_spec(
        "small-plastic",
        [0.45, 0.08, 0.05],
        0.12,
        "distribution = \"ggx\"\nmasking = \"smith-separable\"\n",
    )
}

/// The red plastic's table in `dir` and a Lambertian of about its diffuse colour as
/// `dir/lam.json`: a model that does not fit it exactly (non-zero losses).
pub fn plastic_and_lambert(dir: &Path) -> (PathBuf, PathBuf) {
    let t = synth_spec(dir, "plastic", &red_plastic());
    let m = dir.join("lam.json");
    std::fs::write(
        &m,
        r#"{"model": "lambert", "params": {"rho_d": [0.4, 0.1, 0.05]}}"#,
    )
    .unwrap();
    (t, m)
}
