use super::*;
use brdfkit_core::Rgb;
use serde_json::{Value, json};

fn ct(params: Value) -> Value {
    json!({"model": "cook-torrance", "params": params})
}

fn gold() -> Value {
    json!({"conductor": {"eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}})
}

#[test]
fn supported_configurations_map() {
    let m = renderer_material(
        &ct(json!({"rho_d": 0, "rho_s": 0.5, "alpha": 0.2, "fresnel": gold()})),
        Renderer::Mitsuba,
    )
    .unwrap();
    let d = m.mitsuba_dict();
    assert_eq!(d["type"], "roughconductor");
    assert_eq!(d["distribution"], "ggx");
    assert_eq!(d["alpha"], 0.2);
    assert_eq!(d["eta"]["value"], json!([0.143, 0.374, 1.442]));
    assert_eq!(d["k"]["value"], json!([3.983, 2.385, 1.603]));
    assert_eq!(d["specular_reflectance"]["value"], json!([0.5, 0.5, 0.5]));
    let m = renderer_material(
        &ct(
            json!({"rho_d": 0, "rho_s": 1, "alpha_x": 0.1, "alpha_y": 0.3,
                   "masking": "smith-correlated", "fresnel": gold()}),
        ),
        Renderer::Pbrt,
    )
    .unwrap();
    let p = m.pbrt("x", &[]);
    assert!(p.contains("\"float uroughness\" [ 0.1 ]"), "{p}");
    assert!(p.contains("\"float vroughness\" [ 0.3 ]"), "{p}");
    assert!(p.contains("\"bool remaproughness\" false"), "{p}");
    assert!(p.contains("\"rgb eta\" [ 0.143 0.374 1.442 ]"), "{p}");
    assert!(
        !p.contains("roughness\" [ 0.1 ]\n    \"float roughness"),
        "{p}"
    );
}

#[test]
fn lambert_maps_to_diffuse_on_both_renderers() {
    let v = json!({"model": "lambert", "params": {"rho_d": [0.25, 0.5, 0.75]}});
    for to in [Renderer::Mitsuba, Renderer::Pbrt] {
        let m = map_model(&v, to).unwrap();
        assert_eq!(m.model, "lambert");
        assert_eq!(
            m.material,
            RendererMaterial::Diffuse {
                reflectance: Rgb::new(0.25, 0.5, 0.75)
            }
        );
    }
    let m = renderer_material(&v, Renderer::Pbrt).unwrap();
    assert_eq!(
        m.pbrt("l", &[]),
        "# brdfkit export of l\nMaterial \"diffuse\" \"rgb reflectance\" [ 0.25 0.5 0.75 ]\n"
    );
    assert_eq!(
        m.mitsuba_dict(),
        json!({"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.25, 0.5, 0.75]}})
    );
}

#[test]
fn anisotropic_beckmann_writes_alpha_u_and_v() {
    let v = ct(
        json!({"rho_d": 0, "rho_s": [0.9, 0.6, 0.3], "alpha_x": 0.12,
        "alpha_y": 0.45, "distribution": "beckmann", "beckmann_g1": "rational",
        "fresnel": gold()}),
    );
    let m = map_model(&v, Renderer::Mitsuba).unwrap();
    assert_eq!(
        m.model,
        "cook-torrance (beckmann (beckmann_g1 rational), smith-separable, conductor Fresnel)"
    );
    let d = m.material.mitsuba_dict();
    assert_eq!(
        (d["alpha_u"].clone(), d["alpha_v"].clone()),
        (json!(0.12), json!(0.45))
    );
    assert!(d.get("alpha").is_none(), "{d}");
    assert_eq!(d["distribution"], "beckmann");
    let x = m.material.mitsuba_xml("s", &[]);
    for line in [
        "<bsdf type=\"roughconductor\" version=\"3.0.0\">",
        "    <string name=\"distribution\" value=\"beckmann\"/>",
        "    <float name=\"alpha_u\" value=\"0.12\"/>",
        "    <float name=\"alpha_v\" value=\"0.45\"/>",
        "    <rgb name=\"eta\" value=\"0.143, 0.374, 1.442\"/>",
        "    <rgb name=\"k\" value=\"3.983, 2.385, 1.603\"/>",
        "    <rgb name=\"specular_reflectance\" value=\"0.9, 0.6, 0.3\"/>",
        "</bsdf>",
    ] {
        assert!(x.lines().any(|l| l == line), "{line} missing in\n{x}");
    }
}

#[test]
fn unsupported_configurations_name_the_problem() {
    let cases = [
        (
            ct(json!({"rho_d": 0.1, "fresnel": gold()})),
            Renderer::Mitsuba,
            "rho_d",
        ),
        (ct(json!({"rho_d": 0})), Renderer::Mitsuba, "Schlick"),
        (
            ct(json!({"rho_d": 0, "masking": "v-cavity", "fresnel": gold()})),
            Renderer::Mitsuba,
            "v-cavity",
        ),
        (
            ct(json!({"rho_d": 0, "distribution": "beckmann", "fresnel": gold()})),
            Renderer::Mitsuba,
            "rational",
        ),
        (
            ct(
                json!({"rho_d": 0, "rho_s": 1, "masking": "smith-correlated",
                      "distribution": "beckmann", "fresnel": gold()}),
            ),
            Renderer::Pbrt,
            "Trowbridge-Reitz",
        ),
        (
            ct(json!({"rho_d": 0, "rho_s": 1, "fresnel": gold()})),
            Renderer::Pbrt,
            "height-correlated",
        ),
        (
            ct(json!({"rho_d": 0, "rho_s": 0.9, "masking": "smith-correlated", "fresnel": gold()})),
            Renderer::Pbrt,
            "rho_s",
        ),
        (
            ct(
                json!({"rho_d": 0, "rho_s": 1, "alpha": 1e-4, "masking": "smith-correlated", "fresnel": gold()}),
            ),
            Renderer::Pbrt,
            "mirror",
        ),
        (
            json!({"model": "ward", "params": {}}),
            Renderer::Mitsuba,
            "model `ward`",
        ),
    ];
    for (v, to, what) in cases {
        let e = renderer_material(&v, to).unwrap_err().to_string();
        assert!(e.contains(what), "{v}: {e}");
    }
}

#[test]
fn refusals_are_typed_and_worded_in_full() {
    let e = renderer_material(
        &ct(json!({"rho_d": 0.1, "fresnel": gold()})),
        Renderer::Pbrt,
    )
    .unwrap_err();
    assert!(matches!(
        e,
        ExportError::Unsupported {
            renderer: Renderer::Pbrt,
            reason: Refusal::DiffuseTerm(_),
            ..
        }
    ));
    assert_eq!(
        e.to_string(),
        "cook-torrance (ggx, smith-separable, conductor Fresnel): rho_d = [0.1, 0.1, 0.1] is \
         not 0 and pbrt-v4's conductor has no diffuse term (supported by pbrt-v4: lambert \
         (-> diffuse), cook-torrance with conductor Fresnel, rho_d = 0, rho_s = 1, \
         smith-correlated masking, GGX, alpha >= 1e-3 (-> conductor) and rough-plastic with \
         rho_s = 1, nonlinear false, alpha >= 1e-3 (-> coateddiffuse, approximately)); \
         the export setting `approximate` fits the nearest material the target has to the model and \
         reports the error, and a fit `for` the renderer fits it to the measured table"
    );
    let e =
        renderer_material(&json!({"model": "ward", "params": {}}), Renderer::Mitsuba).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "model `ward` has no counterpart in Mitsuba 3 (supported: {}); {APPROXIMATE_HINT}",
            Renderer::Mitsuba.supported()
        )
    );
    // Checked in order: the Fresnel first, whatever else is wrong.
    let e = renderer_material(
        &ct(json!({"rho_d": 0.3, "masking": "v-cavity"})),
        Renderer::Mitsuba,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            ExportError::Unsupported {
                reason: Refusal::NotConductorFresnel,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("Mitsuba 3's conductor takes"), "{e}");
    // Exactly at pbrt's smooth limit is still rough.
    let at = ct(json!({"rho_d": 0, "rho_s": 1, "alpha": PBRT_SMOOTH_ALPHA,
        "masking": "smith-correlated", "fresnel": gold()}));
    assert!(renderer_material(&at, Renderer::Pbrt).is_ok());
}

#[test]
fn invalid_descriptions_and_per_channel_fits_are_refused() {
    let e = renderer_material(
        &json!({"model": "lambert", "params": {"rho_d": 2}}),
        Renderer::Mitsuba,
    )
    .unwrap_err();
    assert!(
        matches!(e, ExportError::Model(_)) && e.to_string().contains("rho_d"),
        "{e}"
    );
    let e = renderer_material(
        &json!({"model": "lambert", "params": {"rho_d": 0.2}, "extra": 1}),
        Renderer::Mitsuba,
    )
    .unwrap_err();
    assert!(matches!(e, ExportError::Model(_)), "{e}");
    let e = renderer_material(
        &json!({"per_channel": [{"model": "lambert"}, {"model": "lambert"}, {"model": "lambert"}]}),
        Renderer::Pbrt,
    )
    .unwrap_err();
    assert!(matches!(e, ExportError::PerChannel), "{e}");
    assert!(e.to_string().contains("per-channel fit"), "{e}");
    let e = export_str("{", ExportForm::MitsubaXml, "x").unwrap_err();
    assert!(e.to_string().starts_with("not valid JSON"), "{e}");
}

#[test]
fn export_forms_carry_source_and_notes() {
    let v = ct(
        json!({"rho_d": 0, "rho_s": 1, "alpha": 0.2, "masking": "smith-correlated",
        "fresnel": gold()}),
    );
    let p = export(&v, ExportForm::Pbrt, "gold.json").unwrap();
    assert!(p.text.starts_with(
        "# brdfkit export of cook-torrance (ggx, smith-correlated, conductor Fresnel) from gold.json\n"
    ), "{}", p.text);
    assert_eq!(p.notes.len(), 2);
    for n in &p.notes {
        assert!(p.text.contains(&format!("# note: {n}\n")), "{}", p.text);
    }
    assert!(
        p.text.contains("    \"float roughness\" [ 0.2 ]\n"),
        "{}",
        p.text
    );
    // The same model is refused by Mitsuba (correlated masking).
    assert!(export(&v, ExportForm::MitsubaXml, "g").is_err());
    let l = json!({"model": "lambert", "params": {"rho_d": 0.4}});
    let d = export(&l, ExportForm::MitsubaDict, "l").unwrap();
    assert!(d.text.ends_with("}\n"));
    let back: Value = serde_json::from_str(&d.text).unwrap();
    assert_eq!(
        back,
        renderer_material(&l, Renderer::Mitsuba)
            .unwrap()
            .mitsuba_dict()
    );
    assert_eq!(d.notes.len(), 1);
    let x = export(&l, ExportForm::MitsubaXml, "l").unwrap();
    assert!(
        x.text
            .starts_with("<!-- brdfkit export of lambert from l -->\n")
    );
    assert!(x.text.contains("value=\"0.4, 0.4, 0.4\""), "{}", x.text);
    // Shortest round-trip numbers.
    let v = ct(json!({"rho_d": 0, "alpha": 0.1 + 0.2, "fresnel": gold()}));
    let x = export(&v, ExportForm::MitsubaXml, "s").unwrap().text;
    assert!(x.contains("value=\"0.30000000000000004\""), "{x}");
}

#[test]
fn gltf_and_plastic_map_and_the_rest_is_refused() {
    let g = json!({"model": "gltf-pbr", "params": {"base_color": [0.8, 0.5, 0.2],
        "metallic": 0.9, "roughness": 0.35, "masking": "smith-separable"}});
    let e = export(&g, ExportForm::Gltf, "g.json").unwrap();
    let v: Value = serde_json::from_str(&e.text).unwrap();
    let m = &v["materials"][0];
    assert_eq!(
        m["pbrMetallicRoughness"],
        json!({"baseColorFactor": [0.8, 0.5, 0.2, 1.0], "metallicFactor": 0.9,
               "roughnessFactor": 0.35})
    );
    assert_eq!(
        m["extras"]["brdfkit"]["source"],
        "gltf-pbr (smith-separable) from g.json"
    );
    assert_eq!(m["extras"]["brdfkit"]["notes"], json!(e.notes));
    for to in [ExportForm::MitsubaXml, ExportForm::Pbrt] {
        assert!(matches!(
            export(&g, to, "g").unwrap_err(),
            ExportError::UnsupportedModel { .. }
        ));
    }
    let e = export(&json!({"model": "lambert"}), ExportForm::Gltf, "l").unwrap_err();
    assert!(matches!(e, ExportError::NotGltf { .. }), "{e}");
    assert!(e.to_string().contains("setting `approximate`"), "{e}");
    let p = json!({"model": "rough-plastic", "params": {"rho_d": [0.6, 0.3, 0.1],
        "rho_s": 1, "alpha": 0.2, "eta": 1.5}});
    let d = renderer_material(&p, Renderer::Mitsuba)
        .unwrap()
        .mitsuba_dict();
    assert_eq!(
        d,
        json!({"type": "roughplastic", "distribution": "ggx", "alpha": 0.2,
            "int_ior": 1.5, "ext_ior": 1.0,
            "diffuse_reflectance": {"type": "rgb", "value": [0.6, 0.3, 0.1]},
            "specular_reflectance": {"type": "rgb", "value": [1.0, 1.0, 1.0]},
            "nonlinear": false})
    );
    let x = export(&p, ExportForm::Pbrt, "p").unwrap();
    for line in [
        "Material \"coateddiffuse\"",
        "    \"rgb reflectance\" [ 0.6 0.3 0.1 ]",
        "    \"float roughness\" [ 0.2 ]",
        "    \"bool remaproughness\" false",
        "    \"float eta\" [ 1.5 ]",
    ] {
        assert!(x.text.lines().any(|l| l == line), "{line} in\n{}", x.text);
    }
    assert!(
        x.notes.iter().any(|n| n.starts_with("APPROXIMATION")),
        "{:?}",
        x.notes
    );
    let mut nl = p.clone();
    nl["params"]["nonlinear"] = json!(true);
    let e = renderer_material(&nl, Renderer::Pbrt).unwrap_err();
    assert!(
        matches!(
            e,
            ExportError::Unsupported {
                reason: Refusal::Nonlinear,
                ..
            }
        ),
        "{e}"
    );
    assert!(renderer_material(&nl, Renderer::Mitsuba).is_ok());
}

#[test]
fn xml_comments_stay_well_formed() {
    let m = RendererMaterial::Diffuse {
        reflectance: Rgb::splat(0.5),
    };
    let x = m.mitsuba_xml("a -- b", &["c -- d".into()]);
    for line in x.lines().filter(|l| l.starts_with("<!--")) {
        let body = &line[4..line.len() - 3];
        assert!(!body.contains("--"), "{line}");
    }
}
