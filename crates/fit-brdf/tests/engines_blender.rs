//! The exported glTF material in Blender: Debian's Blender 3.4.1 (bundled glTF importer
//! io_scene_gltf2 3.4.50) imports each `export --to gltf` variant headless
//! (tests/engines/blender_readback.py) and the node tree it builds must be what the
//! importer's mapping promises, value for value (float32). docs/export.md has the
//! mapping as a table; in short, 3.4.50's importer
//!
//! - core: Principled `Base Color` = baseColorFactor, `Metallic`, `Roughness`;
//! - `KHR_materials_ior`: `IOR` = ior (1.5 without the extension);
//! - `KHR_materials_clearcoat`: `Clearcoat` = clearcoatFactor, `Clearcoat Roughness` =
//!   clearcoatRoughnessFactor (defaults 0 and 0.03 without it);
//! - `KHR_materials_specular`: `Specular` = lum(specularColorFactor) / 0.08 · f0(ior),
//!   lum(c) = 0.3 r + 0.6 g + 0.1 b, f0(ior) = ((ior − 1)/(ior + 1))²; `Specular Tint` =
//!   lum((ĉ_spec − 1) / (ĉ_base − 1)) clamped to [0, 1] with ĉ = c / lum(c) (1 for a
//!   grey base). **specularFactor is not used** by the Principled BSDF: it is kept, with
//!   specularColorFactor, on the "glTF Material Output" group node only (defaults 0.5
//!   and 0 without the extension);
//! - `KHR_materials_sheen`: **not** mapped onto the Principled `Sheen`/`Sheen Tint` (they
//!   stay at 0 and 0.5; 3.4's Principled has no sheen roughness): a Velvet BSDF with
//!   `Color` = sheenColorFactor and `Sigma` = sheenRoughnessFactor is added to the
//!   Principled BSDF by an Add Shader. Velvet is not the Charlie sheen and the addition
//!   does not scale the base by 1 − max(sheenColor)·E: a Blender render of a sheen
//!   material is brighter than the specification's.
//!
//! The test fails when any value differs, and proves it can: a deliberately altered file
//! is imported too and must fail the check against the unaltered file's mapping.
//!
//! Needs `blender` (`apt-get install --no-install-recommends blender python3-numpy`;
//! `.ci/run` does it); ignored with the reason otherwise, failing under CI.

#[macro_use]
mod common;
#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

use common::{export_gltf, gltf_extension_variants, stderr, write_file};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// The variants `fit --for gltf` chooses between, and all extensions at once.
fn variants() -> Vec<(&'static str, Value)> {
    let core = json!({"base_color": [0.6, 0.2, 0.1], "metallic": 0.3, "roughness": 0.55});
    let mut v = vec![("core", json!({"model": "gltf-pbr", "params": core}))];
    v.extend(gltf_extension_variants(&core));
    v
}

fn rgb(v: &Value) -> [f64; 3] {
    [0, 1, 2].map(|i| v[i].as_f64().unwrap())
}

/// Blender's luminance weights in the 3.4 importer (`KHR_materials_specular`).
fn lum(c: [f64; 3]) -> f64 {
    0.3 * c[0] + 0.6 * c[1] + 0.1 * c[2]
}

/// c / lum(c) (c itself for black).
fn chroma(c: [f64; 3]) -> [f64; 3] {
    let l = lum(c);
    if l == 0.0 { c } else { c.map(|x| x / l) }
}

/// The importer's Specular and Specular Tint for a specular extension (module doc).
fn specular_inputs(base: [f64; 3], spec_color: [f64; 3], ior: f64) -> (f64, f64) {
    let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
    let specular = lum(spec_color) / 0.08 * f0;
    let (cs, cb) = (chroma(spec_color), chroma(base));
    let tint = if cb.iter().all(|&x| x == 1.0) {
        1.0
    } else {
        lum([0, 1, 2].map(|i| (cs[i] - 1.0) / (cb[i] - 1.0))).clamp(0.0, 1.0)
    };
    (specular, tint)
}

/// What Blender 3.4.1's importer promises for the exported document (module doc), in
/// the shape blender_readback.py writes.
fn mapping(gltf: &Value) -> Value {
    let m = &gltf["materials"][0];
    let pbr = &m["pbrMetallicRoughness"];
    let ext = &m["extensions"];
    let base = rgb(&pbr["baseColorFactor"]);
    let ior = ext["KHR_materials_ior"]
        .get("ior")
        .cloned()
        .unwrap_or(json!(1.5));
    let cc = &ext["KHR_materials_clearcoat"];
    let mut principled = json!({
        "Base Color": pbr["baseColorFactor"], "Metallic": pbr["metallicFactor"],
        "Roughness": pbr["roughnessFactor"], "IOR": ior,
        "Clearcoat": cc.get("clearcoatFactor").cloned().unwrap_or(json!(0.0)),
        "Clearcoat Roughness": cc.get("clearcoatRoughnessFactor").cloned().unwrap_or(json!(0.03)),
        "Specular": 0.5, "Specular Tint": 0.0, "Sheen": 0.0, "Sheen Tint": 0.5,
    });
    let mut gltf_output = Value::Null;
    if let Some(s) = ext.get("KHR_materials_specular") {
        let c = s.get("specularColorFactor").map_or([1.0; 3], rgb);
        let (spec, tint) = specular_inputs(base, c, ior.as_f64().unwrap());
        principled["Specular"] = json!(spec);
        principled["Specular Tint"] = json!(tint);
        gltf_output = json!({"Specular": s.get("specularFactor").cloned().unwrap_or(json!(1.0)),
            "Specular Color": [c[0], c[1], c[2], 1.0]});
    }
    let velvet: Vec<Value> = ext
        .get("KHR_materials_sheen")
        .map(|s| {
            let c = rgb(&s["sheenColorFactor"]);
            json!({"Color": [c[0], c[1], c[2], 1.0], "Sigma": s["sheenRoughnessFactor"], "reaches_output": true})
        })
        .into_iter()
        .collect();
    json!({"principled": principled, "principled_linked": [], "principled_reaches_output": true,
        "velvet": velvet, "gltf_output": gltf_output})
}

/// Every difference between `want` and `got` under `path` (numbers to float32
/// precision; keys of `got` that `want` does not name are not compared).
fn differences(path: &str, want: &Value, got: &Value, out: &mut Vec<String>) {
    match (want, got) {
        (Value::Number(a), Value::Number(b)) => {
            let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
            if (a - b).abs() > 1e-6 * a.abs().max(1.0) {
                out.push(format!("{path}: Blender has {b}, the mapping promises {a}"));
            }
        }
        (Value::Object(w), Value::Object(g)) => {
            for (k, v) in w {
                differences(
                    &format!("{path}.{k}"),
                    v,
                    g.get(k).unwrap_or(&Value::Null),
                    out,
                );
            }
        }
        (Value::Array(w), Value::Array(g)) if w.len() == g.len() => {
            for (i, (a, b)) in w.iter().zip(g).enumerate() {
                differences(&format!("{path}[{i}]"), a, b, out);
            }
        }
        (Value::Object(w), _) if w.is_empty() => {}
        _ if want == got => {}
        _ => out.push(format!(
            "{path}: Blender has {got}, the mapping promises {want}"
        )),
    }
}

/// Whether Blender's import of a file (one entry of blender_readback.py's output)
/// is `want`; the differences otherwise.
fn check(want: &Value, imported: &Value) -> Result<(), Vec<String>> {
    let mats = imported["materials"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    if mats.len() != 1 {
        return Err(vec![format!(
            "{} materials named brdfkit imported, want 1",
            mats.len()
        )]);
    }
    let mut out = Vec::new();
    differences("", want, &mats[0], &mut out);
    if out.is_empty() { Ok(()) } else { Err(out) }
}

/// Runs tests/engines/blender_readback.py on `files`.
fn blender_import(dir: &Path, files: &[PathBuf]) -> Vec<Value> {
    let exe = external_tools::require_blender();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/engines/blender_readback.py");
    let out = dir.join("blender.json");
    let o = std::process::Command::new(exe)
        .args([
            "-b",
            "--factory-startup",
            "--python-exit-code",
            "3",
            "--python",
        ])
        .arg(&script)
        .arg("--")
        .arg(&out)
        .args(files)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&o.stdout).to_string() + &stderr(&o);
    assert!(
        o.status.success() && out.is_file(),
        "blender: {}\n{log}",
        o.status
    );
    serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap()
}

blender_test! {
    fn blender_imports_the_exported_extensions_as_its_mapping_promises() {
        let d = tempfile::tempdir().unwrap();
        let mut files = Vec::new();
        let mut wants = Vec::new();
        for (name, model) in variants() {
            let f = export_gltf(d.path(), name, &model);
            let gltf: Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
            wants.push((name, mapping(&gltf)));
            files.push(f);
        }
        // The altered file: "all" with another clear coat and sheen roughness.
        let mut bad: Value = serde_json::from_str(&std::fs::read_to_string(&files[4]).unwrap()).unwrap();
        let e = &mut bad["materials"][0]["extensions"];
        e["KHR_materials_clearcoat"]["clearcoatFactor"] = json!(0.5);
        e["KHR_materials_sheen"]["sheenRoughnessFactor"] = json!(0.6);
        let bad_file = write_file(d.path(), "altered.gltf", bad.to_string());
        files.push(bad_file);

        let got = blender_import(d.path(), &files);
        assert_eq!(got.len(), files.len());
        eprintln!("Blender {}, glTF importer {}", got[0]["blender"], got[0]["importer"]);
        assert_eq!(got[0]["blender"], "3.4.1", "the mapping is 3.4.1's");
        for ((name, want), imported) in wants.iter().zip(&got) {
            eprintln!("{name}: {}", imported["materials"]);
            if let Err(diffs) = check(want, imported) {
                panic!("{name}: Blender's import differs from the mapping:\n{}", diffs.join("\n"));
            }
        }
        let diffs = check(&wants[4].1, &got[5]).expect_err("the altered file must fail the check");
        eprintln!("altered file: {diffs:?}");
        assert!(diffs.iter().any(|d| d.contains("Clearcoat")), "{diffs:?}");
        assert!(diffs.iter().any(|d| d.contains("velvet[0].Sigma")), "{diffs:?}");
    }
}

#[test]
fn the_mapping_check_fails_on_any_difference() {
    let gltf = json!({"materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 0.1, 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 0.5}, "extensions": {
        "KHR_materials_sheen": {"sheenColorFactor": [0.2, 0.2, 0.2], "sheenRoughnessFactor": 0.3},
        "KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [1.0, 1.0, 1.0]}}}]});
    let want = mapping(&gltf);
    // A grey specular colour on a coloured base: Specular = 0.04 / 0.08, tint 0.
    assert!((want["principled"]["Specular"].as_f64().unwrap() - 0.5).abs() < 1e-12);
    assert_eq!(want["principled"]["Specular Tint"], json!(0.0));
    assert_eq!(want["gltf_output"]["Specular"], json!(0.5));
    let imported = |m: Value| json!({"materials": [m]});
    let mut same = want.clone();
    same["principled"]["Base Color"] = json!([0.5, 0.25, 0.1, 1.0]);
    same["extra"] = json!("ignored");
    assert_eq!(check(&want, &imported(same.clone())), Ok(()));
    for (path, v) in [
        (&["principled", "Roughness"][..], json!(0.5001)),
        (&["velvet"][..], json!([])),
        (&["principled_reaches_output"][..], json!(false)),
        (&["gltf_output", "Specular"][..], json!(1.0)),
    ] {
        let mut g = same.clone();
        let mut at = &mut g;
        for k in path {
            at = &mut at[*k];
        }
        *at = v;
        assert!(check(&want, &imported(g)).is_err(), "{path:?}");
    }
    assert!(check(&want, &json!({"materials": []})).is_err());
}
