//! Helpers shared by the CLI test files: the binary (and [`fit_brdf!`], one run of it), its stderr, a synthesised table
//! from a spec text, the spec of a small plastic, and hand-built `.npy` files.

#![allow(dead_code, unused_macros)] // each test file uses its own subset

#[path = "../../../brdfkit-io/tests/common/npy_bytes.rs"]
pub mod npy;

use assert_cmd::Command;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// The `fit-brdf` binary of this build.
pub fn bin() -> Command {
    Command::cargo_bin("fit-brdf").unwrap()
}

/// Runs `fit-brdf` with these arguments (each anything [`Command::arg`] takes: `&str`,
/// `&Path`, `PathBuf`, ...) and returns its output, whatever its status. The test files
/// declare `#[macro_use] mod common;`.
macro_rules! fit_brdf {
    ($($arg:expr),+ $(,)?) => {{
        let mut cmd = $crate::common::bin();
        $(cmd.arg($arg);)+
        cmd.output().unwrap()
    }};
}

/// [`fit_brdf!`] for a run that must succeed: asserts its exit status, with its stderr
/// as the failure message, and returns its output.
macro_rules! fit_brdf_ok {
    ($($arg:expr),+ $(,)?) => {{
        let o = fit_brdf!($($arg),+);
        assert!(o.status.success(), "{}", $crate::common::stderr(&o));
        o
    }};
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
    let params = format!(
        "rho_d = {rho_d:?}\nrho_s = 1.0\nalpha = {alpha:?}\n{extra}\
         fresnel = {{ schlick = {{ f0 = 0.04 }} }}"
    );
    spec_text(name, [24, 24, 48], "cook-torrance", &params)
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

/// The text of a synth spec: `name`, grid `dims`, material `model` with the TOML
/// `params` lines.
pub fn spec_text(name: &str, dims: [usize; 3], model: &str, params: &str) -> String {
    format!(
        "name = \"{name}\"\ndims = {dims:?}\n[material]\nmodel = \"{model}\"\n\
         [material.params]\n{params}\n"
    )
}

/// The spec of a small (24 × 24 × 48) plastic named `name`: Cook-Torrance GGX with
/// diffuse `rho_d`, ρs = 1, roughness `alpha` and Schlick f0 = 0.04.
pub fn small_plastic_spec(name: &str, rho_d: [f64; 3], alpha: f64) -> String {
    plastic_spec(name, rho_d, alpha, "distribution = \"ggx\"\n")
}

/// [`assert_bad_input`], and `out` was not written.
pub fn assert_bad_input_writes_nothing(o: &std::process::Output, needles: &[&str], out: &Path) {
    assert_bad_input(o, needles);
    assert!(!out.exists(), "{} written on bad input", out.display());
}

/// Writes `contents` to `dir/name`; returns the path.
pub fn write_file(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, contents).unwrap();
    p
}

/// A fresh temporary directory holding one file, `NAME` with these contents: the
/// start of the tests that feed the CLI one hand-written file. Keep the directory
/// alive as long as the file is used.
pub fn temp_file(name: &str, contents: impl AsRef<[u8]>) -> (tempfile::TempDir, PathBuf) {
    let d = tempfile::tempdir().unwrap();
    let p = write_file(d.path(), name, contents);
    (d, p)
}

/// Writes a Lambert model description `{"model": "lambert", "params": {"rho_d": RHO}}`
/// to `dir/NAME` (`rho_d` as JSON text: a number, an RGB array or a bad value) and
/// returns its path: the model file most CLI tests start from.
pub fn lambert_file(dir: &Path, name: &str, rho_d: &str) -> PathBuf {
    let text = format!(r#"{{"model": "lambert", "params": {{"rho_d": {rho_d}}}}}"#);
    write_file(dir, name, text)
}

/// The names of the entries of `dir`, sorted.
pub fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Asserts that a command was refused as bad input: exit code 2, a stderr that names
/// every one of `needles`, and no panic.
pub fn assert_bad_input(o: &std::process::Output, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_mentions(&err, needles);
}

/// Asserts that `text` (a command's output, a page) holds every one of `needles`,
/// failing with the first one missing and the text (its first 4 kB: a page is large).
pub fn assert_mentions(text: &str, needles: &[&str]) {
    for n in needles {
        if !text.contains(n) {
            let end = (0..=text.len().min(4096))
                .rev()
                .find(|&i| text.is_char_boundary(i))
                .unwrap_or(0);
            panic!("`{n}` not in {} ({} bytes)", &text[..end], text.len());
        }
    }
}

/// `fit-brdf export --to gltf` of the model description `model`, written to
/// `dir/<name>.json`, into `dir/<name>.gltf`; asserts it succeeds.
pub fn export_gltf(dir: &Path, name: &str, model: &Value) -> PathBuf {
    let params = dir.join(format!("{name}.json"));
    std::fs::write(&params, model.to_string()).unwrap();
    let out = dir.join(format!("{name}.gltf"));
    let o = fit_brdf!("export", &params, "--to", "gltf", "--quiet", "--out", &out);
    assert!(o.status.success(), "export {name}: {}", stderr(&o));
    out
}

/// The `gltf-pbr-ext` description of the glTF core parameters `core` with `extra`
/// parameters (the extensions' list and factors) added.
pub fn gltf_pbr_ext(core: &Value, extra: Value) -> Value {
    let mut p = core.clone();
    for (k, v) in extra.as_object().unwrap() {
        p[k] = v.clone();
    }
    json!({"model": "gltf-pbr-ext", "params": p})
}

/// One `gltf-pbr-ext` over `core` per extension `fit --for gltf` chooses between
/// ("sheen", "clearcoat", "specular", each with colours of unequal channels), then
/// "all" three at once with grey colours given as one number.
pub fn gltf_extension_variants(core: &Value) -> Vec<(&'static str, Value)> {
    let ext = |extra| gltf_pbr_ext(core, extra);
    vec![
        (
            "sheen",
            ext(
                json!({"extensions": ["sheen"], "sheen_color": [0.7, 0.5, 0.4], "sheen_roughness": 0.4}),
            ),
        ),
        (
            "clearcoat",
            ext(
                json!({"extensions": ["clearcoat"], "clearcoat": 0.8, "clearcoat_roughness": 0.15}),
            ),
        ),
        (
            "specular",
            ext(
                json!({"extensions": ["specular"], "specular": 0.6, "specular_color": [1.4, 1.0, 0.8], "ior": 1.6}),
            ),
        ),
        (
            "all",
            ext(
                json!({"extensions": ["sheen", "clearcoat", "specular"], "sheen_color": 0.5,
                "sheen_roughness": 0.5, "clearcoat": 0.3, "clearcoat_roughness": 0.1,
                "specular": 0.9, "specular_color": 1.2, "ior": 1.45}),
            ),
        ),
    ]
}

/// Parameter `k` of a fit record's model (channel `c` of a per-channel one).
pub fn param(r: &Value, k: &str, c: Option<usize>) -> f64 {
    let v = &r["model"]["params"][k];
    c.map_or(v, |c| &v[c]).as_f64().unwrap()
}

/// A fit record's model has roughness `alpha` and diffuse albedo `rho_d` within `tol`
/// (`what` names the fit in the message).
pub fn assert_alpha_rho_d(r: &Value, alpha: f64, rho_d: [f64; 3], tol: f64, what: &str) {
    let a = param(r, "alpha", None);
    assert!((a - alpha).abs() < tol, "{what}: alpha {a}");
    for (c, w) in rho_d.iter().enumerate() {
        let v = param(r, "rho_d", Some(c));
        assert!((v - w).abs() < tol, "{what}: rho_d[{c}] {v}");
    }
}
