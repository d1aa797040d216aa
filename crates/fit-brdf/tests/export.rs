//! `fit-brdf export`: the Mitsuba 3 export loaded in Mitsuba itself and compared with
//! brdfkit's model; the pbrt-v4 export compared with an independent transcription of
//! pbrt-v4's `ConductorBxDF::f`; unsupported configurations refused with exit 2.
//!
//! The Mitsuba check runs `python/export_check.py` under `$BRDFKIT_PYTHON` or
//! `<workspace>/.venv/bin/python` (the discovery of brdfkit-validate's cross-check).
//! Without Mitsuba that test is ignored, with the reason (probed by build.rs, see
//! build/external_tools.rs); with `CI` set (to anything but "", "0" or "false") a missing
//! Mitsuba fails it.

#[macro_use]
mod common;
#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

use brdfkit::core::{Rgb, Vec3};
use brdfkit::models::cook_torrance::Shape;
use brdfkit_validate::mitsuba::{CrossConfig, Tolerance, cases, compare};
use common::{
    assert_bad_input, bin, gltf_extension_variants, gltf_pbr_ext, lambert_file, names, stderr,
    synth_spec, temp_file, write_file,
};
use serde_json::{Value, json};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Uncaptured output: the harness captures `eprintln!`, not direct writes.
fn say(s: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{s}");
}

const GOLD_ETA: [f64; 3] = [0.143, 0.374, 1.442];
const GOLD_K: [f64; 3] = [3.983, 2.385, 1.603];
const COPPER_ETA: [f64; 3] = [0.200, 0.924, 1.102];
const COPPER_K: [f64; 3] = [3.912, 2.452, 2.142];

fn conductor(eta: [f64; 3], k: [f64; 3]) -> Value {
    json!({"conductor": {"eta": eta, "k": k}})
}

/// Runs `fit-brdf export` on `model`; returns stdout.
/// A small gold conductor table (Cook-Torrance, no diffuse term) in `dir`, with the
/// further `[material.params]` lines `params`.
fn gold_table(dir: &Path, params: &str) -> PathBuf {
    let spec = format!(
        "name = \"gold\"\ndims = [16, 16, 32]\n[material]\nmodel = \"cook-torrance\"\n\
         [material.params]\nrho_d = 0.0\n{params}\
         fresnel = {{ conductor = {{ eta = {GOLD_ETA:?}, k = {GOLD_K:?} }} }}\n"
    );
    synth_spec(dir, "gold", &spec)
}

/// `fit-brdf export MODEL ARGS...`, whatever its status.
fn run_export(model: &Path, args: &[&str]) -> std::process::Output {
    bin().arg("export").arg(model).args(args).output().unwrap()
}

fn export(dir: &Path, model: &Value, args: &[&str]) -> String {
    let p = dir.join("model.json");
    std::fs::write(&p, model.to_string()).unwrap();
    let o = run_export(&p, args);
    assert!(o.status.success(), "{model}: {}", stderr(&o));
    String::from_utf8(o.stdout).unwrap()
}

struct Case {
    name: &'static str,
    model: Value,
    tolerance: Tolerance,
    /// Distribution and α for Mitsuba's D floor (isotropic Beckmann); GGX never reaches
    /// it at these roughnesses.
    microfacet: Option<(brdfkit::core::scattering::Distribution, Shape)>,
}

fn mitsuba_cases() -> Vec<Case> {
    use brdfkit::core::scattering::Distribution;
    let rel = Tolerance::Relative { rel: 1e-5 };
    vec![
        Case {
            name: "lambert",
            model: json!({"model": "lambert", "params": {"rho_d": [0.2, 0.5, 0.9]}}),
            tolerance: rel,
            microfacet: None,
        },
        Case {
            name: "ggx-gold-rho_s",
            model: json!({"model": "cook-torrance", "params": {"rho_d": 0, "rho_s": [0.9, 0.6, 0.3],
                "alpha": 0.3, "distribution": "ggx", "fresnel": conductor(GOLD_ETA, GOLD_K)}}),
            tolerance: rel,
            microfacet: None,
        },
        Case {
            name: "ggx-copper-anisotropic",
            model: json!({"model": "cook-torrance", "params": {"rho_d": 0, "rho_s": 1,
                "alpha_x": 0.12, "alpha_y": 0.45, "distribution": "ggx",
                "fresnel": conductor(COPPER_ETA, COPPER_K)}}),
            tolerance: rel,
            microfacet: None,
        },
        Case {
            name: "beckmann-rational-gold",
            model: json!({"model": "cook-torrance", "params": {"rho_d": 0, "rho_s": 0.8,
                "alpha": 0.25, "distribution": "beckmann", "beckmann_g1": "rational",
                "fresnel": conductor(GOLD_ETA, GOLD_K)}}),
            tolerance: Tolerance::Beckmann {
                base: 2e-6,
                slope: 1e-6,
                alpha: 0.25,
            },
            microfacet: Some((Distribution::Beckmann, Shape::Isotropic(0.25))),
        },
        Case {
            name: "rough-plastic",
            model: json!({"model": "rough-plastic", "params": {"rho_d": [0.6, 0.3, 0.1],
                "rho_s": 1, "alpha": 0.2, "eta": 1.5}}),
            // The diffuse term's tables: Mitsuba's quadrature against brdfkit's (32² nodes
            // on Heitz 2018's mapping for T, a converged rule for R_int; docs/export.md).
            tolerance: Tolerance::Relative { rel: PLASTIC_REL },
            microfacet: None,
        },
        Case {
            name: "rough-plastic-nonlinear",
            model: json!({"model": "rough-plastic", "params": {"rho_d": [0.9, 0.5, 0.05],
                "rho_s": 0.8, "alpha": 0.05, "eta": 1.7, "nonlinear": true}}),
            tolerance: Tolerance::Relative { rel: PLASTIC_REL },
            microfacet: None,
        },
    ]
}

/// Agreement of `rough-plastic` with Mitsuba's `roughplastic` (measured; docs/export.md).
const PLASTIC_REL: f64 = 2e-3;

fn cross(c: &Case, mitsuba: Value, model: Value) -> CrossConfig {
    CrossConfig {
        name: c.name.into(),
        mitsuba,
        model,
        tolerance: c.tolerance,
        microfacet: c.microfacet,
        reference: None,
    }
}

mitsuba_test! {
    fn mitsuba_export_loads_in_mitsuba_and_matches_the_model() {
        let python = external_tools::require_mitsuba();
        let d = tempfile::tempdir().unwrap();
        // Every 8th case of the cross-check: 700 pairs with grazing, mirror and near-normal
        // configurations, float32-exact so both sides see the same bits.
        let pairs: Vec<(Vec3, Vec3)> = cases(0x4558_504f).into_iter().step_by(8).collect();
        assert!(pairs.len() >= 500);
        let configs = mitsuba_cases();
        let mut exports = Vec::new();
        for c in &configs {
            let xml = export(d.path(), &c.model, &["--to", "mitsuba", "--quiet"]);
            let dict = export(
                d.path(),
                &c.model,
                &["--to", "mitsuba", "--format", "dict", "--quiet"],
            );
            let dict: Value = serde_json::from_str(&dict).expect("--format dict is JSON");
            exports.push(json!({"name": c.name, "xml": xml, "dict": dict}));
        }
        let input = d.path().join("in.json");
        let output = d.path().join("out.json");
        let flat: Vec<[f64; 6]> = pairs
            .iter()
            .map(|(a, b)| [a.x, a.y, a.z, b.x, b.y, b.z])
            .collect();
        std::fs::write(
            &input,
            json!({"variant": "scalar_rgb", "cases": flat, "exports": exports}).to_string(),
        )
        .unwrap();
        let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python/export_check.py");
        let o = std::process::Command::new(&python)
            .arg(&script)
            .arg(&input)
            .arg(&output)
            .output()
            .unwrap_or_else(|e| panic!("cannot run {}: {e}", python.display()));
        assert!(o.status.success(), "export_check.py failed: {}", stderr(&o));
        let out: Value = serde_json::from_slice(&std::fs::read(&output).unwrap()).unwrap();
        let values = |v: &Value| -> Vec<Rgb> {
            v.as_array()
                .unwrap()
                .iter()
                .map(|x| {
                    Rgb::new(
                        x[0].as_f64().unwrap(),
                        x[1].as_f64().unwrap(),
                        x[2].as_f64().unwrap(),
                    )
                })
                .collect()
        };
        for (c, r) in configs.iter().zip(out["exports"].as_array().unwrap()) {
            assert_eq!(r["name"], c.name);
            let (xml, dict) = (values(&r["xml"]), values(&r["dict"]));
            assert_eq!(xml.len(), pairs.len());
            assert_eq!(
                xml, dict,
                "{}: the XML and the dict are the same BSDF",
                c.name
            );
            let plugin = if c.name == "lambert" {
                "SmoothDiffuse"
            } else if c.name.starts_with("rough-plastic") {
                "RoughPlastic"
            } else {
                "RoughConductor"
            };
            assert_eq!(
                (r["xml_type"].as_str(), r["dict_type"].as_str()),
                (Some(plugin), Some(plugin))
            );
            let cfg = cross(c, Value::Null, c.model.clone());
            let cmp = compare(&cfg, &pairs, &xml).unwrap();
            say(&format!(
                "export {} (Mitsuba {}, {plugin}): {}",
                c.name,
                out["mitsuba"].as_str().unwrap_or("?"),
                cmp.to_text()
            ));
            assert!(cmp.passed, "{cmp}");
            assert!(cmp.max_rel_diff > 0.0, "{}: float32 leaves a trace", c.name);
        }
        // The comparison can fail: the anisotropic export against the model with its axes
        // swapped, and the scaled gold against the model without ρs.
        let swapped = {
            let mut m = configs[2].model.clone();
            m["params"]["alpha_x"] = json!(0.45);
            m["params"]["alpha_y"] = json!(0.12);
            m
        };
        let unscaled = {
            let mut m = configs[1].model.clone();
            m["params"]["rho_s"] = json!(1.0);
            m
        };
        for (k, wrong) in [(2usize, swapped), (1, unscaled)] {
            let r = &out["exports"][k];
            let cmp = compare(
                &cross(&configs[k], Value::Null, wrong),
                &pairs,
                &values(&r["xml"]),
            )
            .unwrap();
            assert!(!cmp.passed, "a wrong model must not match: {cmp}");
        }
    }
}

#[test]
fn cli_output_is_the_library_mapping() {
    use brdfkit_export::{self as lib, ExportForm, Renderer, renderer_material};
    let d = tempfile::tempdir().unwrap();
    let text = |v: &Value, form| lib::export(v, form, "model.json").unwrap().text;
    for c in mitsuba_cases() {
        let dict: Value = serde_json::from_str(&export(
            d.path(),
            &c.model,
            &["--to", "mitsuba", "--format", "dict", "--quiet"],
        ))
        .unwrap();
        // The dictionary brdfkit-validate's cross-check evaluates.
        let m = renderer_material(&c.model, Renderer::Mitsuba).unwrap();
        assert_eq!(dict, m.mitsuba_dict(), "{}", c.name);
        let xml = export(d.path(), &c.model, &["--to", "mitsuba", "--quiet"]);
        assert_eq!(xml, text(&c.model, ExportForm::MitsubaXml), "{}", c.name);
    }
    let pbrt = json!({"model": "cook-torrance", "params": {"rho_d": 0, "rho_s": 1, "alpha": 0.2,
        "masking": "smith-correlated", "fresnel": conductor(GOLD_ETA, GOLD_K)}});
    assert_eq!(
        export(d.path(), &pbrt, &["--to", "pbrt", "--quiet"]),
        text(&pbrt, ExportForm::Pbrt)
    );
}

/// pbrt-v4's `ConductorBxDF::f` (src/pbrt/bxdfs.h) with `TrowbridgeReitzDistribution`
/// and `FrConductor` (src/pbrt/util/scattering.h), transcribed in f64 from the formulas:
/// f = D(h) G(wo, wi) F(|wi·h|) / (4 cos θi cos θo), G = 1/(1 + Λ(wo) + Λ(wi)),
/// D = 1/(π αx αy cos⁴θ (1 + tan²θ (cos²φ/αx² + sin²φ/αy²))²),
/// Λ = (√(1 + α(φ)² tan²θ) − 1)/2 with α(φ)² = (cos φ αx)² + (sin φ αy)².
fn pbrt_conductor(wi: Vec3, wo: Vec3, ax: f64, ay: f64, eta: [f64; 3], k: [f64; 3]) -> [f64; 3] {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return [0.0; 3];
    }
    let trig = |w: Vec3| {
        let l = (w.x * w.x + w.y * w.y + w.z * w.z).sqrt();
        let (x, y, z) = (w.x / l, w.y / l, w.z / l);
        let sin = (x * x + y * y).sqrt();
        let (cphi, sphi) = if sin == 0.0 {
            (1.0, 0.0)
        } else {
            (x / sin, y / sin)
        };
        (z, sin * sin / (z * z), cphi, sphi)
    };
    let lambda = |w: Vec3| {
        let (_, tan2, c, s) = trig(w);
        let a2 = (c * ax).powi(2) + (s * ay).powi(2);
        ((1.0 + a2 * tan2).sqrt() - 1.0) / 2.0
    };
    let h = {
        let s = Vec3::new(wi.x + wo.x, wi.y + wo.y, wi.z + wo.z);
        let l = (s.x * s.x + s.y * s.y + s.z * s.z).sqrt();
        Vec3::new(s.x / l, s.y / l, s.z / l)
    };
    let (cos_h, tan2, c, s) = trig(h);
    let e = tan2 * (c * c / (ax * ax) + s * s / (ay * ay));
    let d = 1.0 / (std::f64::consts::PI * ax * ay * cos_h.powi(4) * (1.0 + e).powi(2));
    let g = 1.0 / (1.0 + lambda(wo) + lambda(wi));
    let cos_i = (wi.x * h.x + wi.y * h.y + wi.z * h.z).abs().min(1.0);
    let mut f = [0.0; 3];
    for ch in 0..3 {
        // FrConductor (Lagarde's memo, as pbrt-v4).
        let (c2, s2) = (cos_i * cos_i, 1.0 - cos_i * cos_i);
        let (e2, k2) = (eta[ch] * eta[ch], k[ch] * k[ch]);
        let t0 = e2 - k2 - s2;
        let a2b2 = (t0 * t0 + 4.0 * e2 * k2).sqrt();
        let t1 = a2b2 + c2;
        let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
        let t2 = 2.0 * cos_i * a;
        let rs = (t1 - t2) / (t1 + t2);
        let t3 = c2 * a2b2 + s2 * s2;
        let t4 = t2 * s2;
        let rp = rs * (t3 - t4) / (t3 + t4);
        f[ch] = d * g * 0.5 * (rp + rs) / (4.0 * wi.z * wo.z);
    }
    f
}

/// The numbers after `"<kind> <name>" [` in a pbrt directive.
fn pbrt_param(text: &str, decl: &str) -> Option<Vec<f64>> {
    let at = text.find(&format!("\"{decl}\""))?;
    let rest = &text[at..];
    let open = rest.find('[')?;
    let close = rest.find(']')?;
    Some(
        rest[open + 1..close]
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect(),
    )
}

#[test]
fn pbrt_export_matches_pbrts_conductor_formula() {
    let d = tempfile::tempdir().unwrap();
    let pairs: Vec<(Vec3, Vec3)> = cases(7).into_iter().step_by(4).collect();
    for (alpha, model_alpha) in [
        ((0.2, 0.2), json!({"alpha": 0.2})),
        ((0.08, 0.5), json!({"alpha_x": 0.08, "alpha_y": 0.5})),
    ] {
        let mut params = json!({"rho_d": 0, "rho_s": 1, "distribution": "ggx",
            "masking": "smith-correlated", "fresnel": conductor(COPPER_ETA, COPPER_K)});
        for (k, v) in model_alpha.as_object().unwrap() {
            params[k] = v.clone();
        }
        let model = json!({"model": "cook-torrance", "params": params});
        let text = export(d.path(), &model, &["--to", "pbrt", "--quiet"]);
        common::assert_mentions(&text, &["Material \"conductor\""]);
        common::assert_mentions(&text, &["\"bool remaproughness\" false"]);
        let (ax, ay) = match pbrt_param(&text, "float roughness") {
            Some(r) => (r[0], r[0]),
            None => (
                pbrt_param(&text, "float uroughness").unwrap()[0],
                pbrt_param(&text, "float vroughness").unwrap()[0],
            ),
        };
        assert_eq!((ax, ay), alpha, "{text}");
        let eta: [f64; 3] = pbrt_param(&text, "rgb eta").unwrap().try_into().unwrap();
        let k: [f64; 3] = pbrt_param(&text, "rgb k").unwrap().try_into().unwrap();
        assert_eq!((eta, k), (COPPER_ETA, COPPER_K));
        let m = brdfkit::models::from_json(&model).unwrap();
        let mut worst = 0.0f64;
        for (wi, wo) in &pairs {
            let a = m.eval(wi, wo);
            let b = pbrt_conductor(*wi, *wo, ax, ay, eta, k);
            for ch in 0..3 {
                let scale = a[ch].abs().max(b[ch].abs());
                if scale > 0.0 {
                    worst = worst.max((a[ch] - b[ch]).abs() / scale);
                }
            }
        }
        assert!(
            worst < 1e-9,
            "alpha {alpha:?}: worst relative difference {worst}"
        );
        // The transcription can tell: the separable masking differs at grazing pairs.
        let mut sep = model.clone();
        sep["params"]["masking"] = json!("smith-separable");
        let ms = brdfkit::models::from_json(&sep).unwrap();
        let off = pairs.iter().any(|(wi, wo)| {
            let (a, b) = (ms.eval(wi, wo), pbrt_conductor(*wi, *wo, ax, ay, eta, k));
            (a[0] - b[0]).abs() > 1e-3 * b[0].abs()
        });
        assert!(off, "separable masking must differ from pbrt's");
    }
    // Lambert: the diffuse material with its reflectance.
    let text = export(
        d.path(),
        &json!({"model": "lambert", "params": {"rho_d": [0.25, 0.5, 0.75]}}),
        &["--to", "pbrt", "--quiet"],
    );
    common::assert_mentions(&text, &["Material \"diffuse\""]);
    assert_eq!(
        pbrt_param(&text, "rgb reflectance").unwrap(),
        vec![0.25, 0.5, 0.75]
    );
}

/// `fit-brdf export MODEL --to TO` exits 2 with `needle` in its stderr.
fn refused(model: &Path, to: &str, needle: &str) {
    let o = run_export(model, &["--to", to]);
    assert_bad_input(&o, &[needle]);
}

#[test]
fn unsupported_exports_are_refused_with_exit_2_and_a_reason() {
    let d = tempfile::tempdir().unwrap();
    let gold = conductor(GOLD_ETA, GOLD_K);
    let cases: Vec<(Value, &str, &str)> = vec![
        (
            json!({"model": "ward", "params": {}}),
            "mitsuba",
            "model `ward`",
        ),
        (
            json!({"model": "cook-torrance", "params": {"rho_d": 0.2, "fresnel": gold}}),
            "mitsuba",
            "rho_d",
        ),
        (
            json!({"model": "cook-torrance", "params": {"rho_d": 0}}),
            "mitsuba",
            "Schlick",
        ),
        (
            json!({"model": "cook-torrance", "params": {"rho_d": 0, "masking": "v-cavity", "fresnel": gold}}),
            "mitsuba",
            "v-cavity",
        ),
        (
            json!({"model": "cook-torrance", "params": {"rho_d": 0, "distribution": "beckmann", "fresnel": gold}}),
            "mitsuba",
            "rational",
        ),
        (
            json!({"model": "cook-torrance", "params": {"rho_d": 0, "rho_s": 0.5,
                "masking": "smith-correlated", "fresnel": gold}}),
            "pbrt",
            "rho_s",
        ),
        (
            json!({"model": "cook-torrance", "params": {"rho_d": 0, "rho_s": 1, "fresnel": gold}}),
            "pbrt",
            "height-correlated",
        ),
    ];
    let p = d.path().join("m.json");
    for (model, to, what) in cases {
        std::fs::write(&p, model.to_string()).unwrap();
        let out = d.path().join("never.xml");
        let o = fit_brdf!("export", &p, "--to", to, "--out", &out);
        assert_eq!(o.status.code(), Some(2), "{model}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("m.json") && e.contains(what), "{model}: {e}");
        assert!(!out.exists(), "nothing written on refusal");
    }
    // A per-channel fit: three models, no single material.
    std::fs::write(
        &p,
        json!({"per_channel": [{"model": "lambert"}, {"model": "lambert"}, {"model": "lambert"}]})
            .to_string(),
    )
    .unwrap();
    refused(&p, "mitsuba", "per-channel fit");
    // Not JSON.
    std::fs::write(&p, "{\"model\": ").unwrap();
    refused(&p, "pbrt", "m.json: not valid JSON");
    // A model that is not valid at all, a missing file, and usage errors.
    std::fs::write(&p, r#"{"model": "lambert", "params": {"rho_d": 2}}"#).unwrap();
    refused(&p, "mitsuba", "rho_d");
    refused(&d.path().join("nope.json"), "mitsuba", "");
    std::fs::write(&p, r#"{"model": "lambert"}"#).unwrap();
    for args in [
        vec!["--to", "blender"],
        vec!["--to", "pbrt", "--format", "dict"],
        vec![],
    ] {
        let o = bin().arg("export").arg(&p).args(&args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn export_writes_the_file_atomically_and_notes_on_stderr() {
    let d = tempfile::tempdir().unwrap();
    let p = lambert_file(d.path(), "m.json", "0.4");
    let out = d.path().join("bsdf.xml");
    let o = fit_brdf_ok!("export", &p, "--to", "mitsuba", "--out", &out);
    assert!(o.stdout.is_empty());
    common::assert_mentions(&stderr(&o), &["note:"]);
    let x = std::fs::read_to_string(&out).unwrap();
    #[cfg(unix)]
    {
        // Readable like a plainly created file (not tempfile's owner-only 0o600).
        use std::os::unix::fs::PermissionsExt;
        let plain = write_file(d.path(), "plain", "x");
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o444;
        assert_eq!(mode(&out), mode(&plain));
        std::fs::remove_file(&plain).unwrap();
    }
    common::assert_mentions(&x, &["<bsdf type=\"diffuse\" version=\"3.0.0\">"]);
    common::assert_mentions(&x, &["value=\"0.4, 0.4, 0.4\""]);
    let o = fit_brdf!("export", &p, "--to", "mitsuba", "--quiet", "--out", &out);
    assert!(o.status.success() && o.stderr.is_empty(), "{}", stderr(&o));
    let names = names(d.path());
    assert_eq!(names.len(), 2, "{names:?}");
}

#[test]
fn a_conductor_fitted_with_rho_d_fixed_at_0_exports() {
    let d = tempfile::tempdir().unwrap();
    let table = gold_table(d.path(), "rho_s = 0.7\nalpha = 0.15\n");
    let start = write_file(d.path(), "start.json", json!({"model": "cook-torrance", "params": {"rho_d": 0, "fresnel": conductor(GOLD_ETA, GOLD_K)}})
            .to_string());
    let params = d.path().join("params.json");
    fit_brdf_ok!(
        "fit", &table, "--model", &start, "--fix", "rho_d", "--starts", "1", "--quiet", "--out",
        &params
    );
    let p: Value = serde_json::from_slice(&std::fs::read(&params).unwrap()).unwrap();
    assert_eq!(p["params"]["rho_d"], json!([0.0, 0.0, 0.0]), "{p}");
    assert!(
        (p["params"]["alpha"].as_f64().unwrap() - 0.15).abs() < 1e-6,
        "{p}"
    );
    let xml = run_export(&params, &["--to", "mitsuba", "--quiet"]);
    assert!(xml.status.success(), "{}", stderr(&xml));
    assert!(String::from_utf8_lossy(&xml.stdout).contains("roughconductor"));
    // Unknown names, an empty list, or nothing left free: bad input.
    for (args, code) in [
        (vec!["--fix", "nope"], 2),
        (vec!["--fix", ""], 2),
        (vec!["--fix", "rho_d,rho_s,alpha"], 2),
    ] {
        let o = bin()
            .arg("fit")
            .arg(&table)
            .arg("--model")
            .arg(&start)
            .args(&args)
            .args(["--starts", "1", "--quiet"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(code), "{args:?}: {}", stderr(&o));
    }
}

/// Runs the validator on `file`; returns its report (issues).
fn validate_gltf(dir: &Path, file: &Path) -> Value {
    let script = "const v = require('gltf-validator'); const fs = require('fs');\
        v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[1])))\
        .then(r => { console.log(JSON.stringify(r.issues)); })\
        .catch(e => { console.error(String(e)); process.exit(2); });";
    let o = std::process::Command::new("node")
        .current_dir(dir)
        .args(["-e", script])
        .arg(file)
        .output()
        .unwrap();
    assert!(o.status.success(), "gltf-validator: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// The glTF export of a metal `gltf-pbr`: the file's text and its JSON.
fn gltf_export(dir: &Path) -> (String, Value) {
    let model = json!({"model": "gltf-pbr", "params": {"base_color": [0.8, 0.5, 0.2],
        "metallic": 0.9, "roughness": 0.35}});
    let text = export(dir, &model, &["--to", "gltf", "--quiet"]);
    let g = serde_json::from_str(&text).unwrap();
    (text, g)
}

#[test]
fn gltf_export_is_a_gltf_material() {
    let d = tempfile::tempdir().unwrap();
    let (_, g) = gltf_export(d.path());
    assert_eq!(g["asset"]["version"], "2.0");
    let pbr = &g["materials"][0]["pbrMetallicRoughness"];
    assert_eq!(pbr["baseColorFactor"], json!([0.8, 0.5, 0.2, 1.0]));
    assert_eq!(pbr["metallicFactor"], json!(0.9));
    assert_eq!(pbr["roughnessFactor"], json!(0.35));
    let notes = &g["materials"][0]["extras"]["brdfkit"]["notes"];
    assert!(
        notes[0].as_str().unwrap().contains("smith-correlated"),
        "{g}"
    );
    // Other models are refused, pointing at --approximate and fit --for.
    let p = write_file(d.path(), "ct.json", json!({"model": "lambert"}).to_string());
    refused(&p, "gltf", "--approximate");
    let o = run_export(&p, &["--to", "gltf", "--format", "xml"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

gltf_validator_test! {
    fn gltf_export_passes_the_khronos_validator() {
        let dir = external_tools::require_gltf_validator();
        let d = tempfile::tempdir().unwrap();
        let (text, g) = gltf_export(d.path());
        let file = write_file(d.path(), "material.gltf", &text);
        let r = validate_gltf(&dir, &file);
        say(&format!("gltf-validator: {r}"));
        assert_eq!(r["numErrors"], 0, "{r}");
        assert_eq!(r["numWarnings"], 0, "{r}");
        // The validator can fail: a factor outside [0, 1] is an error.
        let mut bad = g.clone();
        bad["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] = json!(1.5);
        std::fs::write(&file, bad.to_string()).unwrap();
        assert!(validate_gltf(&dir, &file)["numErrors"].as_u64().unwrap() > 0);
    }
}

/// One `gltf-pbr-ext` per glTF variant `fit --for gltf` chooses between, and all at once,
/// after the core alone as a `gltf-pbr-ext` with no extension.
fn gltf_ext_variants() -> Vec<(&'static str, Value)> {
    let core = json!({"base_color": [0.6, 0.2, 0.1], "metallic": 0.0, "roughness": 0.7});
    let mut v = vec![("core", gltf_pbr_ext(&core, json!({})))];
    v.extend(gltf_extension_variants(&core));
    v
}

#[test]
fn gltf_export_writes_each_extension() {
    let d = tempfile::tempdir().unwrap();
    for (name, model) in gltf_ext_variants() {
        let g: Value =
            serde_json::from_str(&export(d.path(), &model, &["--to", "gltf", "--quiet"])).unwrap();
        let m = &g["materials"][0];
        assert_eq!(
            m["pbrMetallicRoughness"]["roughnessFactor"],
            json!(0.7),
            "{name}"
        );
        let used: Vec<&str> = g["extensionsUsed"]
            .as_array()
            .map(|a| a.iter().map(|v| v.as_str().unwrap()).collect())
            .unwrap_or_default();
        let want: Vec<&str> = match name {
            "core" => vec![],
            "sheen" => vec!["KHR_materials_sheen"],
            "clearcoat" => vec!["KHR_materials_clearcoat"],
            "specular" => vec!["KHR_materials_specular", "KHR_materials_ior"],
            _ => vec![
                "KHR_materials_sheen",
                "KHR_materials_clearcoat",
                "KHR_materials_specular",
                "KHR_materials_ior",
            ],
        };
        assert_eq!(used, want, "{name}: {g}");
        for e in &want {
            assert!(m["extensions"][e].is_object(), "{name}: {e} missing in {g}");
        }
        let p = &model["params"];
        if name == "sheen" {
            let s = &m["extensions"]["KHR_materials_sheen"];
            assert_eq!(s["sheenColorFactor"], p["sheen_color"]);
            assert_eq!(s["sheenRoughnessFactor"], p["sheen_roughness"]);
        }
        if name == "clearcoat" {
            let c = &m["extensions"]["KHR_materials_clearcoat"];
            assert_eq!(c["clearcoatFactor"], p["clearcoat"]);
            assert_eq!(c["clearcoatRoughnessFactor"], p["clearcoat_roughness"]);
        }
        if name == "specular" {
            let s = &m["extensions"]["KHR_materials_specular"];
            assert_eq!(s["specularFactor"], p["specular"]);
            assert_eq!(s["specularColorFactor"], p["specular_color"]);
            assert_eq!(m["extensions"]["KHR_materials_ior"]["ior"], p["ior"]);
        }
        let notes = m["extras"]["brdfkit"]["notes"].to_string();
        assert_eq!(
            notes.contains("sheen fitted with the charlie"),
            want.contains(&"KHR_materials_sheen"),
            "{notes}"
        );
    }
}

gltf_validator_test! {
    fn gltf_extensions_pass_the_khronos_validator() {
        let dir = external_tools::require_gltf_validator();
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join("material.gltf");
        for (name, model) in gltf_ext_variants() {
            let text = export(d.path(), &model, &["--to", "gltf", "--quiet"]);
            std::fs::write(&file, &text).unwrap();
            let r = validate_gltf(&dir, &file);
            say(&format!("gltf-validator, {name}: {r}"));
            assert_eq!(r["numErrors"], 0, "{name}: {r}");
            assert_eq!(r["numWarnings"], 0, "{name}: {r}");
            if name == "all" {
                // The validator checks the extensions: an extension not in
                // extensionsUsed is an error, and an out-of-range factor too.
                let mut bad: Value = serde_json::from_str(&text).unwrap();
                bad["extensionsUsed"] = json!(["KHR_materials_sheen"]);
                std::fs::write(&file, bad.to_string()).unwrap();
                assert!(validate_gltf(&dir, &file)["numErrors"].as_u64().unwrap() > 0);
                let mut bad: Value = serde_json::from_str(&text).unwrap();
                bad["materials"][0]["extensions"]["KHR_materials_clearcoat"]["clearcoatFactor"] = json!(1.5);
                std::fs::write(&file, bad.to_string()).unwrap();
                assert!(validate_gltf(&dir, &file)["numErrors"].as_u64().unwrap() > 0);
            }
        }
    }
}

#[test]
fn approximate_fits_the_nearest_material_and_states_the_error() {
    let (d, p) = temp_file(
        "ward.json",
        json!({"model": "ward", "params": {"rho_d": [0.3, 0.2, 0.1], "rho_s": 0.1, "alpha": 0.15}})
            .to_string(),
    );
    refused(&p, "mitsuba", "--approximate");
    let out = d.path().join("ward.xml");
    let o = fit_brdf_ok!(
        "export",
        &p,
        "--to",
        "mitsuba",
        "--approximate",
        "--out",
        &out
    );
    let e = stderr(&o);
    say(&e);
    common::assert_mentions(
        &e,
        &["note: approximation: `ward` is not exactly a mitsuba material"],
    );
    let x = std::fs::read_to_string(&out).unwrap();
    common::assert_mentions(&x, &["<!-- note: approximation:"]);
    // A diffuse base with a glossy lobe: the plastic is the nearest Mitsuba material.
    common::assert_mentions(&x, &["roughplastic"]);
    let rel: f64 = e
        .split("relative RMS error ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{e}"));
    // Relative to f = 0: below 100 % means the fit explains part of the model (measured
    // 39.9 %: the l2 error is dominated by the lobe's peak).
    assert!(rel > 0.0 && rel < 100.0, "{rel} %");
    // An exact model is written exactly, without fitting.
    let l = write_file(
        d.path(),
        "l.json",
        json!({"model": "lambert", "params": {"rho_d": 0.4}}).to_string(),
    );
    let o = run_export(&l, &["--to", "pbrt", "--approximate"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("approximation:"), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("Material \"diffuse\""));
    // Invalid input stays an error.
    std::fs::write(
        &l,
        json!({"model": "lambert", "params": {"rho_d": 2}}).to_string(),
    )
    .unwrap();
    let o = run_export(&l, &["--to", "gltf", "--approximate"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn fit_for_a_renderer_writes_a_model_export_takes() {
    let d = tempfile::tempdir().unwrap();
    let table = gold_table(
        d.path(),
        "rho_s = 1.0\nalpha = 0.2\nmasking = \"smith-correlated\"\n",
    );
    for (to, best, form) in [
        ("pbrt", "conductor", "Material \"conductor\""),
        // The core or an extension (on this conductor the clear coat's second lobe lowers
        // the loss by a few percent): each is a glTF material.
        ("gltf", "gltf-", "pbrMetallicRoughness"),
    ] {
        let params = d.path().join(format!("{to}.json"));
        let o = fit_brdf_ok!(
            "fit", &table, "--for", to, "--starts", "2", "--quiet", "--out", &params
        );
        let text = String::from_utf8_lossy(&o.stdout);
        common::assert_mentions(&text, &[&format!("best for {to}: {best}")]);
        let p: Value = serde_json::from_slice(&std::fs::read(&params).unwrap()).unwrap();
        if to == "pbrt" {
            // η and k were fitted, not kept at the start's 0.2 and 3.
            let eta = &p["params"]["fresnel"]["conductor"]["eta"];
            assert!((eta[2].as_f64().unwrap() - 0.2).abs() > 0.1, "{p}");
        }
        let o = run_export(&params, &["--to", to, "--quiet"]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(String::from_utf8_lossy(&o.stdout).contains(form));
    }
    // --for fixes the families: --model with it is a usage error.
    let o = fit_brdf!("fit", &table, "--for", "mitsuba", "--model", "lambert");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
