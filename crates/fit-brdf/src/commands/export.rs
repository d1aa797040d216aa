//! `fit-brdf export PARAMS.json --to mitsuba|pbrt`: the model as a renderer's material,
//! for the configurations the renderer evaluates with the same formula.
//!
//! | brdfkit | Mitsuba 3 | pbrt-v4 |
//! |---------|-----------|---------|
//! | `lambert` ρd | `diffuse`, `reflectance` = ρd | `diffuse`, `"rgb reflectance"` = ρd |
//! | `cook-torrance`, conductor Fresnel (η, k), ρd = 0 | `roughconductor`, `eta`, `k`, `specular_reflectance` = ρs | `conductor`, `"rgb eta"`, `"rgb k"`, ρs = 1 only |
//! | distribution | `ggx`, or `beckmann` with `beckmann_g1 = rational` | `ggx` only (Trowbridge-Reitz) |
//! | masking | `smith-separable` G1(wi)G1(wo) | `smith-correlated` 1/(1 + Λ(wi) + Λ(wo)) |
//! | α or (αx, αy) | `alpha` or `alpha_u`, `alpha_v` | `roughness` or `uroughness`, `vroughness`, `remaproughness` false; α ≥ 1e-3 |
//!
//! Why each condition (from the renderers' sources):
//! - Mitsuba 3 `roughconductor` (src/bsdfs/roughconductor.cpp) evaluates
//!   f_r = ρs · D(h) G1(wi) G1(wo) F(wi·h) / (4 cos θi cos θo), with Walter et al.'s
//!   rational G1 for Beckmann (EGSR 2007 eq. 27), the exact conductor Fresnel and its
//!   `specular_reflectance` as the factor ρs; it has no diffuse term.
//! - pbrt-v4 `ConductorBxDF::f` (src/pbrt/bxdfs.h) evaluates
//!   D(h) G(wo, wi) F(|wi·h|) / (4 cos θi cos θo) with Trowbridge-Reitz D, the
//!   height-correlated G = 1/(1 + Λ(wo) + Λ(wi)) and `FrConductor`; there is no factor
//!   for ρs, `remaproughness` (default true) would map roughness r to α = √r, and an α
//!   below 1e-3 makes the surface a perfect mirror (`EffectivelySmooth`).
//!
//! Everything else (another model, Schlick or dielectric Fresnel, ρd ≠ 0 on a conductor,
//! V-cavity masking, Beckmann with the exact erf G1, …) is an error (exit 2) naming the
//! model and what the renderer lacks: an export never silently changes the BRDF.
//!
//! Approximations that remain, stated in the output's comments and on stderr:
//! - both renderers compute in float32; Mitsuba zeroes D where D(h) cos θh < 1e-20;
//! - in a spectral variant (Mitsuba) or pbrt-v4 (always spectral) RGB values are
//!   uplifted to spectra (pbrt: `RGBUnboundedSpectrum` for η and k, `RGBAlbedoSpectrum`
//!   for reflectances), so the rendered colour of a conductor is close to, not exactly,
//!   the RGB model's: the Fresnel term is non-linear in η and k. Mitsuba's `*_rgb`
//!   variants use the RGB values as they are (what the cross-check tests).

use super::read_model;
use crate::cli::{ExportArgs, ExportFormat, Renderer};
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::write_text;
use brdfkit::core::Rgb;
use brdfkit::core::scattering::{BeckmannG1, Distribution, Masking};
use brdfkit::models::cook_torrance::{CookTorrance, Fresnel, Shape};
use brdfkit::models::lambert::Lambert;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::Path;

/// pbrt-v4 treats α below this as a perfect mirror (`EffectivelySmooth`).
pub const PBRT_SMOOTH_ALPHA: f64 = 1e-3;

/// A material both sides agree on.
#[derive(Debug, Clone, PartialEq)]
pub enum Material {
    Diffuse {
        reflectance: Rgb,
    },
    Conductor {
        distribution: Distribution,
        alpha: Shape,
        eta: Rgb,
        k: Rgb,
        /// ρs.
        specular: Rgb,
    },
}

fn rgb_text(c: Rgb, sep: &str) -> String {
    format!("{}{sep}{}{sep}{}", c.r(), c.g(), c.b())
}

fn rgb_list(c: Rgb) -> String {
    format!("[{}, {}, {}]", c.r(), c.g(), c.b())
}

/// The cook-torrance configuration in words, for messages.
fn describe(ct: &CookTorrance) -> String {
    let fresnel = match ct.fresnel() {
        Fresnel::None => "no Fresnel",
        Fresnel::Schlick { .. } => "Schlick Fresnel",
        Fresnel::Conductor { .. } => "conductor Fresnel",
        Fresnel::Dielectric { .. } => "dielectric Fresnel",
    };
    let g1 = if ct.distribution() == Distribution::Beckmann {
        format!(" (beckmann_g1 {})", ct.beckmann_g1().name())
    } else {
        String::new()
    };
    format!(
        "cook-torrance ({}{g1}, {}, {fresnel})",
        ct.distribution().name(),
        ct.masking().name()
    )
}

/// Maps a model description to a material of `to`, or says why it cannot be.
pub fn material(v: &Value, to: Renderer) -> Result<Material, String> {
    let name = v["model"].as_str().unwrap_or("");
    let params = v.get("params").unwrap_or(&Value::Null);
    let target = match to {
        Renderer::Mitsuba => "Mitsuba 3",
        Renderer::Pbrt => "pbrt-v4",
    };
    let supported = match to {
        Renderer::Mitsuba => {
            "lambert (-> diffuse) and cook-torrance with conductor Fresnel, rho_d = 0, \
             smith-separable masking, GGX or Beckmann with beckmann_g1 = rational (-> roughconductor)"
        }
        Renderer::Pbrt => {
            "lambert (-> diffuse) and cook-torrance with conductor Fresnel, rho_d = 0, rho_s = 1, \
             smith-correlated masking, GGX, alpha >= 1e-3 (-> conductor)"
        }
    };
    match name {
        "lambert" => {
            let l = Lambert::from_params_json(params).map_err(|e| e.to_string())?;
            Ok(Material::Diffuse {
                reflectance: l.rho_d(),
            })
        }
        "cook-torrance" => {
            let ct = CookTorrance::from_params_json(params).map_err(|e| e.to_string())?;
            let what = describe(&ct);
            let no = |why: String| {
                Err(format!(
                    "{what}: {why} (supported by {target}: {supported})"
                ))
            };
            let Fresnel::Conductor { eta, k } = ct.fresnel() else {
                return no(format!(
                    "{target}'s conductor takes the exact conductor Fresnel with eta and k; \
                     refit with --fresnel conductor"
                ));
            };
            if ct.rho_d() != Rgb::ZERO {
                return no(format!(
                    "rho_d = {} is not 0 and {target}'s conductor has no diffuse term",
                    rgb_list(ct.rho_d())
                ));
            }
            match to {
                Renderer::Mitsuba => {
                    if ct.masking() != Masking::SmithSeparable {
                        return no(format!(
                            "{} masking: roughconductor uses the separable Smith G1(wi) G1(wo) \
                             (refit with --masking smith-separable)",
                            ct.masking().name()
                        ));
                    }
                    if ct.distribution() == Distribution::Beckmann
                        && ct.beckmann_g1() != BeckmannG1::Rational
                    {
                        return no("Mitsuba's Beckmann G1 is Walter's rational approximation: \
                                   set \"beckmann_g1\": \"rational\" in the model"
                            .into());
                    }
                }
                Renderer::Pbrt => {
                    if ct.distribution() != Distribution::Ggx {
                        return no(
                            "pbrt-v4's conductor has only the Trowbridge-Reitz (GGX) distribution"
                                .into(),
                        );
                    }
                    if ct.masking() != Masking::SmithCorrelated {
                        return no(format!(
                            "{} masking: pbrt-v4 uses the height-correlated Smith \
                             G = 1/(1 + Λ(wo) + Λ(wi)) (refit with --masking smith-correlated)",
                            ct.masking().name()
                        ));
                    }
                    let s = ct.rho_s();
                    if (0..3).any(|c| (s[c] - 1.0).abs() > 1e-12) {
                        return no(format!(
                            "rho_s = {} is not 1 and pbrt-v4's conductor has no specular scale \
                             (export to Mitsuba, whose specular_reflectance takes it, or fit with \
                             rho_s fixed at 1)",
                            rgb_list(s)
                        ));
                    }
                    let (ax, ay) = ct.alpha().xy();
                    if ax.min(ay) < PBRT_SMOOTH_ALPHA {
                        return no(format!(
                            "alpha {} is below 1e-3, where pbrt-v4 renders a perfect mirror",
                            ax.min(ay)
                        ));
                    }
                }
            }
            Ok(Material::Conductor {
                distribution: ct.distribution(),
                alpha: ct.alpha(),
                eta,
                k,
                specular: ct.rho_s(),
            })
        }
        other => Err(format!(
            "model `{other}` has no counterpart in {target} (supported: {supported})"
        )),
    }
}

/// Notes on what the renderer does differently (comments in the output, stderr).
pub fn notes(m: &Material, to: Renderer) -> Vec<String> {
    let mut n = vec![];
    match to {
        Renderer::Mitsuba => {
            n.push(
                "Mitsuba evaluates in float32 (agreement ~1e-6 relative in the *_rgb variants)"
                    .to_string(),
            );
            if let Material::Conductor { .. } = m {
                n.push(
                    "Mitsuba zeroes D where D(h) cos(theta_h) < 1e-20 (values there are below ~1e-18)"
                        .into(),
                );
                n.push(
                    "rho_s is roughconductor's specular_reflectance; in spectral variants eta, k \
                     and reflectances are uplifted from RGB, so colours are approximate there"
                        .into(),
                );
            }
        }
        Renderer::Pbrt => {
            n.push(
                "pbrt-v4 renders spectrally: the RGB values are uplifted to spectra \
                 (RGBUnboundedSpectrum for eta and k, RGBAlbedoSpectrum for reflectance), so \
                 the rendered colour approximates the RGB model"
                    .into(),
            );
            if let Material::Conductor { .. } = m {
                n.push("remaproughness is false: roughness is the microfacet alpha itself".into());
            }
        }
    }
    n
}

/// The Mitsuba 3 XML `<bsdf>` element (loadable by `mitsuba.load_string`).
pub fn mitsuba_xml(m: &Material, source: &str, notes: &[String]) -> String {
    // "--" may not appear inside an XML comment.
    let safe = |t: &str| t.replace("--", "- -");
    let mut s = format!("<!-- brdfkit export of {} -->\n", safe(source));
    s += "<!-- standalone: mitsuba.load_string(text); inside a scene file, drop version=\"3.0.0\" \
          (Mitsuba accepts it on the root element only) -->\n";
    for n in notes {
        let _ = writeln!(s, "<!-- note: {} -->", safe(n));
    }
    match m {
        Material::Diffuse { reflectance } => {
            s += "<bsdf type=\"diffuse\" version=\"3.0.0\">\n";
            let _ = writeln!(
                s,
                "    <rgb name=\"reflectance\" value=\"{}\"/>",
                rgb_text(*reflectance, ", ")
            );
        }
        Material::Conductor {
            distribution,
            alpha,
            eta,
            k,
            specular,
        } => {
            s += "<bsdf type=\"roughconductor\" version=\"3.0.0\">\n";
            let _ = writeln!(
                s,
                "    <string name=\"distribution\" value=\"{}\"/>",
                distribution.name()
            );
            match *alpha {
                Shape::Isotropic(a) => {
                    let _ = writeln!(s, "    <float name=\"alpha\" value=\"{a}\"/>");
                }
                Shape::Anisotropic(x, y) => {
                    let _ = writeln!(s, "    <float name=\"alpha_u\" value=\"{x}\"/>");
                    let _ = writeln!(s, "    <float name=\"alpha_v\" value=\"{y}\"/>");
                }
            }
            let _ = writeln!(
                s,
                "    <rgb name=\"eta\" value=\"{}\"/>",
                rgb_text(*eta, ", ")
            );
            let _ = writeln!(s, "    <rgb name=\"k\" value=\"{}\"/>", rgb_text(*k, ", "));
            let _ = writeln!(
                s,
                "    <rgb name=\"specular_reflectance\" value=\"{}\"/>",
                rgb_text(*specular, ", ")
            );
        }
    }
    s += "</bsdf>\n";
    s
}

fn rgb_value(c: Rgb) -> Value {
    json!({"type": "rgb", "value": [c.r(), c.g(), c.b()]})
}

/// The Mitsuba 3 dictionary (for `mitsuba.load_dict`), as JSON: a JSON object with these
/// values is also a Python dict literal.
pub fn mitsuba_dict(m: &Material) -> Value {
    match m {
        Material::Diffuse { reflectance } => {
            json!({"type": "diffuse", "reflectance": rgb_value(*reflectance)})
        }
        Material::Conductor {
            distribution,
            alpha,
            eta,
            k,
            specular,
        } => {
            let mut d = json!({"type": "roughconductor", "distribution": distribution.name(),
                "eta": rgb_value(*eta), "k": rgb_value(*k),
                "specular_reflectance": rgb_value(*specular)});
            match *alpha {
                Shape::Isotropic(a) => d["alpha"] = json!(a),
                Shape::Anisotropic(x, y) => {
                    d["alpha_u"] = json!(x);
                    d["alpha_v"] = json!(y);
                }
            }
            d
        }
    }
}

/// The pbrt-v4 `Material` directive.
pub fn pbrt(m: &Material, source: &str, notes: &[String]) -> String {
    let mut s = format!("# brdfkit export of {source}\n");
    for n in notes {
        let _ = writeln!(s, "# note: {n}");
    }
    match m {
        Material::Diffuse { reflectance } => {
            let _ = writeln!(
                s,
                "Material \"diffuse\" \"rgb reflectance\" [ {} ]",
                rgb_text(*reflectance, " ")
            );
        }
        Material::Conductor { alpha, eta, k, .. } => {
            s += "Material \"conductor\"\n";
            match *alpha {
                Shape::Isotropic(a) => {
                    let _ = writeln!(s, "    \"float roughness\" [ {a} ]");
                }
                Shape::Anisotropic(x, y) => {
                    let _ = writeln!(s, "    \"float uroughness\" [ {x} ]");
                    let _ = writeln!(s, "    \"float vroughness\" [ {y} ]");
                }
            }
            s += "    \"bool remaproughness\" false\n";
            let _ = writeln!(s, "    \"rgb eta\" [ {} ]", rgb_text(*eta, " "));
            let _ = writeln!(s, "    \"rgb k\" [ {} ]", rgb_text(*k, " "));
        }
    }
    s
}

pub fn run(a: ExportArgs) -> CliResult<()> {
    if a.to == Renderer::Pbrt && a.format.is_some() {
        return Err(bad_msg(
            "--format applies to --to mitsuba (pbrt-v4 has one scene format)",
        ));
    }
    // A per-channel fit is three models: say so before the generic JSON errors.
    if let Ok(text) = std::fs::read_to_string(&a.params)
        && let Ok(v) = serde_json::from_str::<Value>(&text)
        && v.get("per_channel").is_some()
    {
        return Err(bad_msg(format!(
            "{}: a per-channel fit (one model per colour channel, each with its own \
             roughness) has no single renderer material; export one channel's model \
             (e.g. `jq '.per_channel[0]'`) or refit without --per-channel",
            a.params.display()
        )));
    }
    // Validates the description: unknown keys, domains.
    let model = read_model(&a.params)?;
    let text = std::fs::read_to_string(&a.params).map_err(runtime)?;
    let v: Value = serde_json::from_str(&text).map_err(runtime)?;
    let m = material(&v, a.to).map_err(|e| bad_msg(format!("{}: {e}", a.params.display())))?;
    let source = format!(
        "{} from {}",
        match v["model"].as_str() {
            Some("cook-torrance") => {
                let ct = CookTorrance::from_params_json(&v["params"]).map_err(runtime)?;
                describe(&ct)
            }
            _ => model.name().to_string(),
        },
        a.params.file_name().map_or_else(
            || a.params.display().to_string(),
            |n| n.to_string_lossy().into_owned()
        )
    );
    let notes = notes(&m, a.to);
    let out = match (a.to, a.format.unwrap_or(ExportFormat::Xml)) {
        (Renderer::Pbrt, _) => pbrt(&m, &source, &notes),
        (Renderer::Mitsuba, ExportFormat::Xml) => mitsuba_xml(&m, &source, &notes),
        (Renderer::Mitsuba, ExportFormat::Dict) => {
            serde_json::to_string_pretty(&mitsuba_dict(&m)).map_err(runtime)? + "\n"
        }
    };
    if !a.quiet {
        for n in &notes {
            eprintln!("note: {n}");
        }
    }
    write_text(a.out.as_deref(), &out)?;
    if !a.quiet
        && let Some(p) = &a.out
    {
        eprintln!("wrote {}", Path::new(p).display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ct(params: Value) -> Value {
        json!({"model": "cook-torrance", "params": params})
    }

    fn gold() -> Value {
        json!({"conductor": {"eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603]}})
    }

    #[test]
    fn supported_configurations_map() {
        let m = material(
            &ct(json!({"rho_d": 0, "rho_s": 0.5, "alpha": 0.2, "fresnel": gold()})),
            Renderer::Mitsuba,
        )
        .unwrap();
        let d = mitsuba_dict(&m);
        assert_eq!(d["type"], "roughconductor");
        assert_eq!(d["alpha"], 0.2);
        assert_eq!(d["specular_reflectance"]["value"], json!([0.5, 0.5, 0.5]));
        let m = material(
            &ct(
                json!({"rho_d": 0, "rho_s": 1, "alpha_x": 0.1, "alpha_y": 0.3,
                       "masking": "smith-correlated", "fresnel": gold()}),
            ),
            Renderer::Pbrt,
        )
        .unwrap();
        let p = pbrt(&m, "x", &[]);
        assert!(p.contains("\"float uroughness\" [ 0.1 ]"), "{p}");
        assert!(p.contains("\"float vroughness\" [ 0.3 ]"), "{p}");
        assert!(p.contains("\"bool remaproughness\" false"), "{p}");
        assert!(p.contains("\"rgb eta\" [ 0.143 0.374 1.442 ]"), "{p}");
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
                ct(
                    json!({"rho_d": 0, "rho_s": 0.9, "masking": "smith-correlated", "fresnel": gold()}),
                ),
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
            let e = material(&v, to).unwrap_err();
            assert!(e.contains(what), "{v}: {e}");
        }
    }

    #[test]
    fn xml_comments_stay_well_formed() {
        let m = Material::Diffuse {
            reflectance: Rgb::splat(0.5),
        };
        let x = mitsuba_xml(&m, "a -- b", &["c -- d".into()]);
        for line in x.lines().filter(|l| l.starts_with("<!--")) {
            let body = &line[4..line.len() - 3];
            assert!(!body.contains("--"), "{line}");
        }
    }
}
