//! A brdfkit model as a renderer's material: the one mapping onto Mitsuba 3 and pbrt-v4,
//! used by `fit-brdf export` and by the Mitsuba cross-check ([`crate::mitsuba`]).
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
//! V-cavity masking, Beckmann with the exact erf G1, …) is an [`ExportError`] naming the
//! model and what the renderer lacks: an export never silently changes the BRDF.
//!
//! Approximations that remain, stated by [`notes`] (comments in the output, stderr):
//! - both renderers compute in float32; Mitsuba zeroes D where D(h) cos θh < 1e-20;
//! - in a spectral variant (Mitsuba) or pbrt-v4 (always spectral) RGB values are
//!   uplifted to spectra (pbrt: `RGBUnboundedSpectrum` for η and k, `RGBAlbedoSpectrum`
//!   for reflectances), so the rendered colour of a conductor is close to, not exactly,
//!   the RGB model's: the Fresnel term is non-linear in η and k. Mitsuba's `*_rgb`
//!   variants use the RGB values as they are (what the cross-check tests).
//!
//! ```
//! use brdfkit_validate::export::{ExportForm, export_str};
//! let e = export_str(
//!     r#"{"model": "lambert", "params": {"rho_d": 0.4}}"#,
//!     ExportForm::MitsubaXml,
//!     "params.json",
//! )?;
//! assert!(e.text.contains(r#"<bsdf type="diffuse" version="3.0.0">"#));
//! # Ok::<(), brdfkit_validate::export::ExportError>(())
//! ```

use brdfkit_core::scattering::{BeckmannG1, Distribution, Masking};
use brdfkit_core::{ModelError, Rgb};
use brdfkit_models::cook_torrance::{CookTorrance, Fresnel, Shape};
use brdfkit_models::lambert::Lambert;
use serde_json::{Value, json};
use std::fmt::{self, Write as _};
use thiserror::Error;

/// pbrt-v4 treats α below this as a perfect mirror (`EffectivelySmooth`).
pub const PBRT_SMOOTH_ALPHA: f64 = 1e-3;

/// The renderer an export is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Renderer {
    /// Mitsuba 3 (`diffuse`, `roughconductor`).
    Mitsuba,
    /// pbrt-v4 (`diffuse`, `conductor`).
    Pbrt,
}

impl Renderer {
    /// What the renderer takes, for messages.
    pub fn supported(self) -> &'static str {
        match self {
            Renderer::Mitsuba => {
                "lambert (-> diffuse) and cook-torrance with conductor Fresnel, rho_d = 0, \
                 smith-separable masking, GGX or Beckmann with beckmann_g1 = rational (-> roughconductor)"
            }
            Renderer::Pbrt => {
                "lambert (-> diffuse) and cook-torrance with conductor Fresnel, rho_d = 0, rho_s = 1, \
                 smith-correlated masking, GGX, alpha >= 1e-3 (-> conductor)"
            }
        }
    }
}

/// `Mitsuba 3` or `pbrt-v4`.
impl fmt::Display for Renderer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Renderer::Mitsuba => "Mitsuba 3",
            Renderer::Pbrt => "pbrt-v4",
        })
    }
}

/// The form of an export's text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportForm {
    /// A Mitsuba 3 `<bsdf>` element ([`RendererMaterial::mitsuba_xml`]).
    MitsubaXml,
    /// A Mitsuba 3 `load_dict` dictionary as JSON ([`RendererMaterial::mitsuba_dict`]).
    MitsubaDict,
    /// A pbrt-v4 `Material` directive ([`RendererMaterial::pbrt`]).
    Pbrt,
}

impl ExportForm {
    /// The renderer of the form.
    pub fn renderer(self) -> Renderer {
        match self {
            ExportForm::MitsubaXml | ExportForm::MitsubaDict => Renderer::Mitsuba,
            ExportForm::Pbrt => Renderer::Pbrt,
        }
    }
}

/// A material that brdfkit and the renderer evaluate with the same formula.
///
/// Not called `Material`: brdfkit-render's `material::Material` is a scene material and
/// brdfkit-study's `Material` a measured table; this is the renderer-side description.
#[derive(Debug, Clone, PartialEq)]
pub enum RendererMaterial {
    /// Lambert: Mitsuba's and pbrt's `diffuse`.
    Diffuse {
        /// ρd, the albedo (f_r = ρd/π).
        reflectance: Rgb,
    },
    /// Cook-Torrance with the exact conductor Fresnel and no diffuse term: Mitsuba's
    /// `roughconductor`, pbrt's `conductor`.
    Conductor {
        /// The microfacet distribution D.
        distribution: Distribution,
        /// α, or (αx, αy) along the tangent and the binormal.
        alpha: Shape,
        /// Real part of the relative index of refraction, per channel.
        eta: Rgb,
        /// Extinction coefficient, per channel.
        k: Rgb,
        /// ρs: Mitsuba's `specular_reflectance` (1 for pbrt, which has no such factor).
        specular: Rgb,
    },
}

/// Why a cook-torrance configuration has no counterpart in the renderer.
#[derive(Debug, Clone, PartialEq)]
pub enum Refusal {
    /// Not the exact conductor Fresnel (Schlick, dielectric or none).
    NotConductorFresnel,
    /// ρd ≠ 0: neither conductor has a diffuse term.
    DiffuseTerm(Rgb),
    /// Mitsuba: another masking than the separable Smith G1(wi) G1(wo).
    NotSeparableMasking(Masking),
    /// Mitsuba: Beckmann with another G1 than Walter's rational approximation.
    NotRationalBeckmann,
    /// pbrt: another distribution than Trowbridge-Reitz (GGX).
    NotGgx,
    /// pbrt: another masking than the height-correlated Smith G.
    NotCorrelatedMasking(Masking),
    /// pbrt: ρs ≠ 1 (pbrt's conductor has no specular scale).
    SpecularScale(Rgb),
    /// pbrt: α below [`PBRT_SMOOTH_ALPHA`], a perfect mirror there.
    Smooth(f64),
}

impl Refusal {
    /// The reason in words, naming `renderer`.
    pub fn explain(&self, renderer: Renderer) -> String {
        match self {
            Refusal::NotConductorFresnel => format!(
                "{renderer}'s conductor takes the exact conductor Fresnel with eta and k; \
                 refit with --fresnel conductor"
            ),
            Refusal::DiffuseTerm(rho_d) => format!(
                "rho_d = {} is not 0 and {renderer}'s conductor has no diffuse term",
                rgb_list(*rho_d)
            ),
            Refusal::NotSeparableMasking(m) => format!(
                "{} masking: roughconductor uses the separable Smith G1(wi) G1(wo) \
                 (refit with --masking smith-separable)",
                m.name()
            ),
            Refusal::NotRationalBeckmann => "Mitsuba's Beckmann G1 is Walter's rational \
                                             approximation: set \"beckmann_g1\": \"rational\" in the model"
                .into(),
            Refusal::NotGgx => {
                "pbrt-v4's conductor has only the Trowbridge-Reitz (GGX) distribution".into()
            }
            Refusal::NotCorrelatedMasking(m) => format!(
                "{} masking: pbrt-v4 uses the height-correlated Smith \
                 G = 1/(1 + Λ(wo) + Λ(wi)) (refit with --masking smith-correlated)",
                m.name()
            ),
            Refusal::SpecularScale(s) => format!(
                "rho_s = {} is not 1 and pbrt-v4's conductor has no specular scale \
                 (export to Mitsuba, whose specular_reflectance takes it, or fit with \
                 rho_s fixed at 1)",
                rgb_list(*s)
            ),
            Refusal::Smooth(a) => {
                format!("alpha {a} is below 1e-3, where pbrt-v4 renders a perfect mirror")
            }
        }
    }
}

/// Why a model description cannot be exported.
#[derive(Debug, Error)]
pub enum ExportError {
    /// Not a valid model description (not JSON, unknown keys, a value out of its domain).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// `{"per_channel": [...]}`: three models, one per colour channel.
    #[error(
        "a per-channel fit (one model per colour channel, each with its own roughness) has no \
         single renderer material; export one channel's model (e.g. `jq '.per_channel[0]'`) or \
         refit without --per-channel"
    )]
    PerChannel,
    /// A model the renderer has no material for (`ward`, `sum`, …).
    #[error("model `{model}` has no counterpart in {renderer} (supported: {})", .renderer.supported())]
    UnsupportedModel {
        /// The model's name.
        model: String,
        /// The renderer asked for.
        renderer: Renderer,
    },
    /// A cook-torrance configuration the renderer evaluates differently.
    #[error("{config}: {} (supported by {renderer}: {})", .reason.explain(*.renderer), .renderer.supported())]
    Unsupported {
        /// The configuration in words ([`describe_cook_torrance`]).
        config: String,
        /// The renderer asked for.
        renderer: Renderer,
        /// What the renderer lacks.
        reason: Refusal,
    },
}

fn rgb_text(c: Rgb, sep: &str) -> String {
    format!("{}{sep}{}{sep}{}", c.r(), c.g(), c.b())
}

fn rgb_list(c: Rgb) -> String {
    format!("[{}, {}, {}]", c.r(), c.g(), c.b())
}

/// A cook-torrance configuration in words, for messages and the export's header:
/// `cook-torrance (beckmann (beckmann_g1 rational), smith-separable, conductor Fresnel)`.
pub fn describe_cook_torrance(ct: &CookTorrance) -> String {
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

/// The conditions of `to` on a cook-torrance model, in the order they are reported.
fn conductor_of(ct: &CookTorrance, to: Renderer) -> Result<RendererMaterial, Refusal> {
    let Fresnel::Conductor { eta, k } = ct.fresnel() else {
        return Err(Refusal::NotConductorFresnel);
    };
    if ct.rho_d() != Rgb::ZERO {
        return Err(Refusal::DiffuseTerm(ct.rho_d()));
    }
    match to {
        Renderer::Mitsuba => {
            if ct.masking() != Masking::SmithSeparable {
                return Err(Refusal::NotSeparableMasking(ct.masking()));
            }
            if ct.distribution() == Distribution::Beckmann
                && ct.beckmann_g1() != BeckmannG1::Rational
            {
                return Err(Refusal::NotRationalBeckmann);
            }
        }
        Renderer::Pbrt => {
            if ct.distribution() != Distribution::Ggx {
                return Err(Refusal::NotGgx);
            }
            if ct.masking() != Masking::SmithCorrelated {
                return Err(Refusal::NotCorrelatedMasking(ct.masking()));
            }
            let s = ct.rho_s();
            if (0..3).any(|c| (s[c] - 1.0).abs() > 1e-12) {
                return Err(Refusal::SpecularScale(s));
            }
            let (ax, ay) = ct.alpha().xy();
            if ax.min(ay) < PBRT_SMOOTH_ALPHA {
                return Err(Refusal::Smooth(ax.min(ay)));
            }
        }
    }
    Ok(RendererMaterial::Conductor {
        distribution: ct.distribution(),
        alpha: ct.alpha(),
        eta,
        k,
        specular: ct.rho_s(),
    })
}

/// A model description mapped onto a renderer.
#[derive(Debug, Clone, PartialEq)]
pub struct Mapped {
    /// The material.
    pub material: RendererMaterial,
    /// The model in words: `lambert`, or [`describe_cook_torrance`]'s text.
    pub model: String,
}

/// Maps a model description (`{"model": ..., "params": {...}}`) onto `to`, or says why
/// it cannot be. The description is validated first (unknown keys, domains).
pub fn map_model(description: &Value, to: Renderer) -> Result<Mapped, ExportError> {
    // A per-channel fit is three models: say so before the generic errors.
    if description.get("per_channel").is_some() {
        return Err(ExportError::PerChannel);
    }
    brdfkit_models::from_json(description)?;
    let name = description["model"].as_str().unwrap_or("");
    let params = description.get("params").unwrap_or(&Value::Null);
    match name {
        "lambert" => Ok(Mapped {
            material: RendererMaterial::Diffuse {
                reflectance: Lambert::from_params_json(params)?.rho_d(),
            },
            model: "lambert".into(),
        }),
        "cook-torrance" => {
            let ct = CookTorrance::from_params_json(params)?;
            let model = describe_cook_torrance(&ct);
            match conductor_of(&ct, to) {
                Ok(material) => Ok(Mapped { material, model }),
                Err(reason) => Err(ExportError::Unsupported {
                    config: model,
                    renderer: to,
                    reason,
                }),
            }
        }
        other => Err(ExportError::UnsupportedModel {
            model: other.into(),
            renderer: to,
        }),
    }
}

/// The material of a model description for `to` ([`map_model`] without the words).
pub fn renderer_material(
    description: &Value,
    to: Renderer,
) -> Result<RendererMaterial, ExportError> {
    map_model(description, to).map(|m| m.material)
}

/// Notes on what `to` does differently with `m` (comments in the output, stderr).
pub fn notes(m: &RendererMaterial, to: Renderer) -> Vec<String> {
    let conductor = matches!(m, RendererMaterial::Conductor { .. });
    let mut n = vec![];
    match to {
        Renderer::Mitsuba => {
            n.push(
                "Mitsuba evaluates in float32 (agreement ~1e-6 relative in the *_rgb variants)"
                    .to_string(),
            );
            if conductor {
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
            if conductor {
                n.push("remaproughness is false: roughness is the microfacet alpha itself".into());
            }
        }
    }
    n
}

fn rgb_value(c: Rgb) -> Value {
    json!({"type": "rgb", "value": [c.r(), c.g(), c.b()]})
}

impl RendererMaterial {
    /// The Mitsuba 3 XML `<bsdf>` element (loadable by `mitsuba.load_string`), with
    /// `source` and `notes` as comments. For a material mapped for [`Renderer::Mitsuba`].
    pub fn mitsuba_xml(&self, source: &str, notes: &[String]) -> String {
        // "--" may not appear inside an XML comment.
        let safe = |t: &str| t.replace("--", "- -");
        let mut s = format!("<!-- brdfkit export of {} -->\n", safe(source));
        s += "<!-- standalone: mitsuba.load_string(text); inside a scene file, drop version=\"3.0.0\" \
              (Mitsuba accepts it on the root element only) -->\n";
        for n in notes {
            let _ = writeln!(s, "<!-- note: {} -->", safe(n));
        }
        match self {
            RendererMaterial::Diffuse { reflectance } => {
                s += "<bsdf type=\"diffuse\" version=\"3.0.0\">\n";
                let _ = writeln!(
                    s,
                    "    <rgb name=\"reflectance\" value=\"{}\"/>",
                    rgb_text(*reflectance, ", ")
                );
            }
            RendererMaterial::Conductor {
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

    /// The Mitsuba 3 dictionary (for `mitsuba.load_dict`), as JSON: a JSON object with
    /// these values is also a Python dict literal. For a material mapped for
    /// [`Renderer::Mitsuba`]; the cross-check evaluates exactly this dictionary.
    pub fn mitsuba_dict(&self) -> Value {
        match self {
            RendererMaterial::Diffuse { reflectance } => {
                json!({"type": "diffuse", "reflectance": rgb_value(*reflectance)})
            }
            RendererMaterial::Conductor {
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

    /// The pbrt-v4 `Material` directive, with `source` and `notes` as comments. For a
    /// material mapped for [`Renderer::Pbrt`] (ρs = 1: pbrt has no specular scale, so
    /// `specular` is not written).
    pub fn pbrt(&self, source: &str, notes: &[String]) -> String {
        let mut s = format!("# brdfkit export of {source}\n");
        for n in notes {
            let _ = writeln!(s, "# note: {n}");
        }
        match self {
            RendererMaterial::Diffuse { reflectance } => {
                let _ = writeln!(
                    s,
                    "Material \"diffuse\" \"rgb reflectance\" [ {} ]",
                    rgb_text(*reflectance, " ")
                );
            }
            RendererMaterial::Conductor { alpha, eta, k, .. } => {
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
}

/// An export: the text and the notes on what the renderer does differently.
#[derive(Debug, Clone, PartialEq)]
pub struct Exported {
    /// The file's text (XML, JSON or pbrt), ending in a newline.
    pub text: String,
    /// The notes, also in the text as comments (XML and pbrt).
    pub notes: Vec<String>,
}

/// Exports a model description in `form`; `source_name` (e.g. the file name) goes into
/// the header comment: `brdfkit export of <model> from <source_name>`.
pub fn export(
    description: &Value,
    form: ExportForm,
    source_name: &str,
) -> Result<Exported, ExportError> {
    let to = form.renderer();
    let Mapped { material, model } = map_model(description, to)?;
    let notes = notes(&material, to);
    let source = format!("{model} from {source_name}");
    let text = match form {
        ExportForm::MitsubaXml => material.mitsuba_xml(&source, &notes),
        ExportForm::MitsubaDict => {
            serde_json::to_string_pretty(&material.mitsuba_dict()).expect("JSON of plain values")
                + "\n"
        }
        ExportForm::Pbrt => material.pbrt(&source, &notes),
    };
    Ok(Exported { text, notes })
}

/// [`export`] of a description's JSON text (a parse failure is [`ExportError::Model`],
/// worded as [`brdfkit_models::from_json_str`] words it).
pub fn export_str(
    description: &str,
    form: ExportForm,
    source_name: &str,
) -> Result<Exported, ExportError> {
    let v: Value = serde_json::from_str(description)
        .map_err(|e| ModelError::Invalid(format!("not valid JSON: {e}")))?;
    export(&v, form, source_name)
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
             (-> diffuse) and cook-torrance with conductor Fresnel, rho_d = 0, rho_s = 1, \
             smith-correlated masking, GGX, alpha >= 1e-3 (-> conductor))"
        );
        let e = renderer_material(&json!({"model": "ward", "params": {}}), Renderer::Mitsuba)
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "model `ward` has no counterpart in Mitsuba 3 (supported: {})",
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
}
