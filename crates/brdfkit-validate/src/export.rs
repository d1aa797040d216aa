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
use brdfkit_fit::FitConfig;
use brdfkit_fit::families::FamilyFitError;
use brdfkit_fit::target::{Target, TargetFit, fit_for};
use brdfkit_merl::Dims;
use brdfkit_models::cook_torrance::{CookTorrance, Fresnel, Shape};
use brdfkit_models::gltf_pbr::GltfPbr;
use brdfkit_models::gltf_pbr_ext::{Clearcoat, GltfPbrExt, Sheen, Specular};
use brdfkit_models::lambert::Lambert;
use brdfkit_models::rough_plastic::RoughPlastic;
use brdfkit_models::sheen::SheenVisibility;
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
                "lambert (-> diffuse), cook-torrance with conductor Fresnel, rho_d = 0, \
                 smith-separable masking, GGX or Beckmann with beckmann_g1 = rational (-> roughconductor) \
                 and rough-plastic (-> roughplastic)"
            }
            Renderer::Pbrt => {
                "lambert (-> diffuse), cook-torrance with conductor Fresnel, rho_d = 0, rho_s = 1, \
                 smith-correlated masking, GGX, alpha >= 1e-3 (-> conductor) and rough-plastic with \
                 rho_s = 1, nonlinear false, alpha >= 1e-3 (-> coateddiffuse, approximately)"
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
    /// A glTF 2.0 document with one metallic-roughness material
    /// ([`GltfMaterial::document`]).
    Gltf,
}

impl ExportForm {
    /// The renderer of the form (`None` for glTF, a format rather than a renderer).
    pub fn renderer(self) -> Option<Renderer> {
        match self {
            ExportForm::MitsubaXml | ExportForm::MitsubaDict => Some(Renderer::Mitsuba),
            ExportForm::Pbrt => Some(Renderer::Pbrt),
            ExportForm::Gltf => None,
        }
    }

    /// The target a model is fitted for to be written in this form (`--approximate`).
    pub fn target(self) -> Target {
        match self {
            ExportForm::MitsubaXml | ExportForm::MitsubaDict => Target::Mitsuba,
            ExportForm::Pbrt => Target::Pbrt,
            ExportForm::Gltf => Target::Gltf,
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
    /// `rough-plastic`: Mitsuba's `roughplastic` (exact), pbrt's `coateddiffuse`
    /// (an approximation: a stochastic layered BSDF, see [`notes`]).
    Plastic {
        /// ρd: `diffuse_reflectance` / `reflectance`.
        diffuse: Rgb,
        /// ρs: Mitsuba's `specular_reflectance` (1 for pbrt).
        specular: Rgb,
        /// GGX α.
        alpha: f64,
        /// The coating's relative index (`int_ior`, `ext_ior` = 1; pbrt `eta`).
        eta: f64,
        /// Mitsuba's `nonlinear` (false for pbrt).
        nonlinear: bool,
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
    /// pbrt: a rough plastic with `nonlinear` (coateddiffuse has no such switch).
    Nonlinear,
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
                "rho_s = {} is not 1 and pbrt-v4's conductor and coateddiffuse have no specular scale \
                 (export to Mitsuba, whose specular_reflectance takes it, or fit with \
                 rho_s fixed at 1)",
                rgb_list(*s)
            ),
            Refusal::Smooth(a) => {
                format!("alpha {a} is below 1e-3, where pbrt-v4 renders a perfect mirror")
            }
            Refusal::Nonlinear => {
                "nonlinear = true: pbrt-v4's coateddiffuse has no such switch (fit with \
                 nonlinear false)"
                    .into()
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
    #[error("model `{model}` has no counterpart in {renderer} (supported: {}); {APPROXIMATE_HINT}", .renderer.supported())]
    UnsupportedModel {
        /// The model's name.
        model: String,
        /// The renderer asked for.
        renderer: Renderer,
    },
    /// A cook-torrance configuration the renderer evaluates differently.
    #[error("{config}: {} (supported by {renderer}: {}); {APPROXIMATE_HINT}", .reason.explain(*.renderer), .renderer.supported())]
    Unsupported {
        /// The configuration in words ([`describe_cook_torrance`]).
        config: String,
        /// The renderer asked for.
        renderer: Renderer,
        /// What the renderer lacks.
        reason: Refusal,
    },
    /// Another model than `gltf-pbr` or `gltf-pbr-ext` exported as glTF.
    #[error(
        "model `{model}` is not a glTF metallic-roughness material (glTF takes gltf-pbr \
         and gltf-pbr-ext); \
         {APPROXIMATE_HINT}"
    )]
    NotGltf {
        /// The model's name.
        model: String,
    },
    /// `--approximate`: fitting the target's configurations to the model failed.
    #[error("approximating the model: {0}")]
    Approximation(#[from] FamilyFitError),
}

/// The note on every pbrt-v4 `coateddiffuse` export.
pub const PBRT_COATED_NOTE: &str = "APPROXIMATION: pbrt-v4's coateddiffuse is a stochastic \
     layered BSDF (a random walk between a rough dielectric interface and a Lambertian base, \
     thickness 0.01, maxdepth 10), not rough-plastic's closed form: it also follows light \
     bouncing between coat and base and its interface transmittance is not Mitsuba's table, \
     so the diffuse colour and its falloff towards grazing angles differ; the size of the \
     difference is not measured here (pbrt-v4 could not be built on this machine, \
     docs/export.md)";

/// What a refusal suggests instead.
pub const APPROXIMATE_HINT: &str = "export --approximate fits the nearest material the target \
     has to the model and reports the error, and `fit --for` fits it to the measured table";

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
        "rough-plastic" => {
            let p = RoughPlastic::from_params_json(params)?;
            let model = format!("rough-plastic (ggx, eta {})", p.eta());
            match plastic_of(&p, to) {
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

/// The conditions of `to` on a rough plastic.
fn plastic_of(p: &RoughPlastic, to: Renderer) -> Result<RendererMaterial, Refusal> {
    if to == Renderer::Pbrt {
        let s = p.rho_s();
        if (0..3).any(|c| (s[c] - 1.0).abs() > 1e-12) {
            return Err(Refusal::SpecularScale(s));
        }
        if p.nonlinear() {
            return Err(Refusal::Nonlinear);
        }
        if p.alpha() < PBRT_SMOOTH_ALPHA {
            return Err(Refusal::Smooth(p.alpha()));
        }
    }
    Ok(RendererMaterial::Plastic {
        diffuse: p.rho_d(),
        specular: p.rho_s(),
        alpha: p.alpha(),
        eta: p.eta(),
        nonlinear: p.nonlinear(),
    })
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
            if matches!(m, RendererMaterial::Plastic { .. }) {
                n.push(
                    "roughplastic integrates its transmittance tables with its own quadrature: \
                     agreement with rough-plastic ~6e-4 relative (docs/export.md)"
                        .into(),
                );
            }
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
            if !matches!(m, RendererMaterial::Diffuse { .. }) {
                n.push("remaproughness is false: roughness is the microfacet alpha itself".into());
            }
            if matches!(m, RendererMaterial::Plastic { .. }) {
                n.push(PBRT_COATED_NOTE.into());
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
            RendererMaterial::Plastic {
                diffuse,
                specular,
                alpha,
                eta,
                nonlinear,
            } => {
                s += "<bsdf type=\"roughplastic\" version=\"3.0.0\">\n";
                s += "    <string name=\"distribution\" value=\"ggx\"/>\n";
                let _ = writeln!(s, "    <float name=\"alpha\" value=\"{alpha}\"/>");
                let _ = writeln!(s, "    <float name=\"int_ior\" value=\"{eta}\"/>");
                s += "    <float name=\"ext_ior\" value=\"1\"/>\n";
                for (name, c) in [
                    ("diffuse_reflectance", diffuse),
                    ("specular_reflectance", specular),
                ] {
                    let _ = writeln!(
                        s,
                        "    <rgb name=\"{name}\" value=\"{}\"/>",
                        rgb_text(*c, ", ")
                    );
                }
                let _ = writeln!(s, "    <boolean name=\"nonlinear\" value=\"{nonlinear}\"/>");
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
            RendererMaterial::Plastic {
                diffuse,
                specular,
                alpha,
                eta,
                nonlinear,
            } => json!({"type": "roughplastic", "distribution": "ggx", "alpha": alpha,
                "int_ior": eta, "ext_ior": 1.0, "diffuse_reflectance": rgb_value(*diffuse),
                "specular_reflectance": rgb_value(*specular), "nonlinear": nonlinear}),
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
            RendererMaterial::Plastic {
                diffuse,
                alpha,
                eta,
                ..
            } => {
                s += "Material \"coateddiffuse\"\n";
                let _ = writeln!(s, "    \"rgb reflectance\" [ {} ]", rgb_text(*diffuse, " "));
                let _ = writeln!(s, "    \"float roughness\" [ {alpha} ]");
                s += "    \"bool remaproughness\" false\n";
                let _ = writeln!(s, "    \"float eta\" [ {eta} ]");
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
    let Some(to) = form.renderer() else {
        let (m, model) = gltf_material(description)?;
        let notes = m.notes();
        let text = serde_json::to_string_pretty(
            &m.document(&format!("{model} from {source_name}"), &notes),
        )
        .expect("JSON of plain values")
            + "\n";
        return Ok(Exported { text, notes });
    };
    let Mapped { material, model } = map_model(description, to)?;
    let notes = notes(&material, to);
    let source = format!("{model} from {source_name}");
    let text = match form {
        ExportForm::MitsubaXml => material.mitsuba_xml(&source, &notes),
        ExportForm::MitsubaDict => {
            serde_json::to_string_pretty(&material.mitsuba_dict()).expect("JSON of plain values")
                + "\n"
        }
        // glTF returned above.
        ExportForm::Pbrt | ExportForm::Gltf => material.pbrt(&source, &notes),
    };
    Ok(Exported { text, notes })
}

/// A glTF 2.0 metallic-roughness material: the factors of `pbrMetallicRoughness`.
#[derive(Debug, Clone, PartialEq)]
pub struct GltfMaterial {
    /// `baseColorFactor` (RGB; alpha is 1).
    pub base_color: Rgb,
    /// `metallicFactor`.
    pub metallic: f64,
    /// `roughnessFactor`.
    pub roughness: f64,
    /// The masking the model was fitted with (glTF has no field for it: a note).
    pub masking: Masking,
    /// `KHR_materials_sheen`, if the model has it.
    pub sheen: Option<Sheen>,
    /// The sheen visibility the model was fitted with (a note).
    pub sheen_visibility: SheenVisibility,
    /// `KHR_materials_clearcoat`, if the model has it.
    pub clearcoat: Option<Clearcoat>,
    /// `KHR_materials_specular` and `KHR_materials_ior`, if the model has them.
    pub specular: Option<Specular>,
}

/// The glTF material of a `gltf-pbr` or `gltf-pbr-ext` description (and the model in
/// words), or why not.
pub fn gltf_material(description: &Value) -> Result<(GltfMaterial, String), ExportError> {
    if description.get("per_channel").is_some() {
        return Err(ExportError::PerChannel);
    }
    let model = brdfkit_models::from_json(description)?;
    let params = description.get("params").unwrap_or(&Value::Null);
    let g = match model.name() {
        "gltf-pbr" => GltfPbrExt::new(GltfPbr::from_params_json(params)?),
        "gltf-pbr-ext" => GltfPbrExt::from_params_json(params)?,
        other => {
            return Err(ExportError::NotGltf {
                model: other.into(),
            });
        }
    };
    let core = g.core();
    let mut words = format!("{} ({}", model.name(), core.masking().name());
    for e in g.extensions() {
        words += &format!(", {e}");
    }
    words += ")";
    Ok((
        GltfMaterial {
            base_color: core.base_color(),
            metallic: core.metallic(),
            roughness: core.roughness(),
            masking: core.masking(),
            sheen: g.sheen(),
            sheen_visibility: g.sheen_visibility(),
            clearcoat: g.clearcoat(),
            specular: g.specular(),
        },
        words,
    ))
}

impl GltfMaterial {
    /// What a glTF viewer does differently (the document's `extras`, stderr).
    pub fn notes(&self) -> Vec<String> {
        vec![
            format!(
                "fitted with the {} Smith term; glTF viewers differ here (the Khronos Sample \
                 Renderer, three.js and Filament use the height-correlated form, the \
                 specification's text the separable one): highlights of rough materials \
                 differ by a few percent",
                self.masking.name()
            ),
            "factors are linear RGB, as glTF's baseColorFactor is; viewers evaluate in float32"
                .into(),
        ]
        .into_iter()
        .chain(self.extension_notes())
        .collect()
    }

    /// Where viewers may differ from the model on its extensions.
    fn extension_notes(&self) -> Vec<String> {
        let mut v = Vec::new();
        if self.sheen.is_some() {
            v.push(format!(
                "sheen fitted with the {} visibility and brdfkit's own table of the sheen \
                 albedo E (clamped to 1); viewers choose their visibility and E table \
                 (three.js: Charlie D with the Ashikhmin form, its `V_Neubelt`), so grazing sheen differs; \
                 Blender 3.4's importer adds a Velvet BSDF (sheenColor, sigma = sheenRoughness) to \
                 the Principled BSDF instead, without scaling the base (docs/export.md)",
                self.sheen_visibility.name()
            ));
        }
        if self.clearcoat.is_some() {
            v.push(
                "clear coat layered with fresnel_coat's Fresnel at N·V, as \
                 KHR_materials_clearcoat specifies (three.js also puts Schlick's Fresnel at \
                 V·H on the coat lobe)"
                    .into(),
            );
        }
        if self.specular.is_some() {
            v.push(
                "Blender 3.4's importer maps specularColor and ior to the Principled Specular \
                 (lum(specularColor) · f0(ior) / 0.08) and Specular Tint and ignores \
                 specularFactor (kept on its glTF Material Output node only): a specularFactor \
                 far from 1 looks different there (docs/export.md)"
                    .into(),
            );
        }
        v
    }

    /// The `extensions` object of the material and the names for `extensionsUsed`.
    fn extensions(&self) -> (serde_json::Map<String, Value>, Vec<&'static str>) {
        let mut m = serde_json::Map::new();
        if let Some(s) = self.sheen {
            let c = s.color;
            m.insert(
                "KHR_materials_sheen".into(),
                json!({"sheenColorFactor": [c.r(), c.g(), c.b()], "sheenRoughnessFactor": s.roughness}),
            );
        }
        if let Some(c) = self.clearcoat {
            m.insert(
                "KHR_materials_clearcoat".into(),
                json!({"clearcoatFactor": c.factor, "clearcoatRoughnessFactor": c.roughness}),
            );
        }
        if let Some(s) = self.specular {
            let c = s.color;
            m.insert(
                "KHR_materials_specular".into(),
                json!({"specularFactor": s.factor, "specularColorFactor": [c.r(), c.g(), c.b()]}),
            );
            m.insert("KHR_materials_ior".into(), json!({"ior": s.ior}));
        }
        let used = [
            "KHR_materials_sheen",
            "KHR_materials_clearcoat",
            "KHR_materials_specular",
            "KHR_materials_ior",
        ]
        .into_iter()
        .filter(|k| m.contains_key(*k))
        .collect();
        (m, used)
    }

    /// A minimal glTF 2.0 document (JSON) holding this material alone:
    /// `asset.version` "2.0" and `materials[0].pbrMetallicRoughness` with
    /// `baseColorFactor` [r, g, b, 1], `metallicFactor` and `roughnessFactor`, the
    /// material's `KHR_materials_*` extensions (named in `extensionsUsed`); `source`
    /// and `notes` go into the material's `extras.brdfkit`.
    pub fn document(&self, source: &str, notes: &[String]) -> Value {
        let b = self.base_color;
        let (exts, used) = self.extensions();
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": concat!("brdfkit ", env!("CARGO_PKG_VERSION"))},
            "materials": [{
                "name": "brdfkit",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [b.r(), b.g(), b.b(), 1.0],
                    "metallicFactor": self.metallic,
                    "roughnessFactor": self.roughness,
                },
                "extras": {"brdfkit": {"source": source, "notes": notes}},
            }],
        });
        if !used.is_empty() {
            doc["extensionsUsed"] = json!(used);
            doc["materials"][0]["extensions"] = Value::Object(exts);
        }
        doc
    }
}

/// The grid `--approximate` samples a model on: 45 × 45 × 90 cells of the MERL
/// parameterisation (its θh spacing dense near the specular peak), ~180,000 valid cells.
pub const APPROXIMATE_DIMS: (i64, i64, i64) = (45, 45, 90);

/// An export by `--approximate`.
#[derive(Debug, Clone)]
pub struct Approximated {
    /// The export (exact, or of the best fitted configuration, the conversion's error in
    /// its notes).
    pub exported: Exported,
    /// The fits, or `None` when the model was exported exactly.
    pub fit: Option<TargetFit>,
    /// The best fit's relative error: the RMS of the difference over the RMS of the
    /// model's values (the l2 loss of the fit over that of f = 0), cell-weighted.
    pub relative_l2: f64,
}

/// Exports exactly when the form takes the model; otherwise fits every configuration the
/// target has ([`brdfkit_fit::target`]) to the model's values on the
/// [`APPROXIMATE_DIMS`] grid (cells above the horizon, solid-angle weights of `cfg`),
/// exports the best by `cfg`'s loss and states the conversion error in the notes. Never
/// writes something else silently: an invalid description is still an error.
pub fn export_approximate(
    description: &Value,
    form: ExportForm,
    source_name: &str,
    cfg: &FitConfig,
) -> Result<Approximated, ExportError> {
    match export(description, form, source_name) {
        Ok(exported) => {
            return Ok(Approximated {
                exported,
                fit: None,
                relative_l2: 0.0,
            });
        }
        Err(e @ (ExportError::Model(_) | ExportError::PerChannel)) => return Err(e),
        Err(_) => {}
    }
    let model = brdfkit_models::from_json(description)?;
    let (a, b, c) = APPROXIMATE_DIMS;
    let dims = Dims::new(a, b, c).expect("a valid grid");
    let data =
        brdfkit_fit::synth::synth_data(&*model, dims, brdfkit_fit::synth::Coverage::AboveHorizon)
            .map_err(|source| FamilyFitError {
            label: model.name().into(),
            source,
        })?;
    let fit = fit_for(&data, form.target(), cfg, &())?;
    let best = fit.best();
    let zero = Lambert::new(Rgb::ZERO)?;
    let scale = brdfkit_fit::evaluate_losses([&zero, &zero, &zero], &data, cfg.get_weighting())
        .l2
        .overall;
    let l = &best.record.losses_full;
    let relative_l2 = if scale > 0.0 {
        l.l2.overall / scale
    } else {
        0.0
    };
    let mut exported = export(&best.params, form, source_name)?;
    let note = format!(
        "approximation: `{}` is not exactly a {} material; fitted `{}` (best of {}) to it \
         over {} cells of a {a}x{b}x{c} grid: relative RMS error {:.3} %, {} loss {:.4e}",
        model.name(),
        form.target().name(),
        best.label,
        fit.outcomes
            .iter()
            .map(|o| o.label.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        best.record.cells_full,
        100.0 * relative_l2,
        cfg.get_loss(),
        l.get(cfg.get_loss()).overall,
    );
    // The note goes into the text as every other note does, and first.
    exported = with_first_note(exported, form, &note);
    Ok(Approximated {
        exported,
        fit: Some(fit),
        relative_l2,
    })
}

/// `e` with `note` added before its other notes, in the text as well.
fn with_first_note(e: Exported, form: ExportForm, note: &str) -> Exported {
    let mut notes = vec![note.to_string()];
    notes.extend(e.notes.iter().cloned());
    let text = match form {
        ExportForm::MitsubaXml => {
            let marker = "<bsdf ";
            let at = e.text.find(marker).unwrap_or(0);
            format!(
                "{}<!-- note: {} -->\n{}",
                &e.text[..at],
                note.replace("--", "- -"),
                &e.text[at..]
            )
        }
        ExportForm::Pbrt => {
            let at = e.text.find('\n').map_or(0, |i| i + 1);
            format!("{}# note: {note}\n{}", &e.text[..at], &e.text[at..])
        }
        // JSON: the dict has no comments (stderr only); glTF's extras take the notes.
        ExportForm::MitsubaDict => e.text,
        ExportForm::Gltf => {
            let mut v: Value = serde_json::from_str(&e.text).expect("our own JSON");
            v["materials"][0]["extras"]["brdfkit"]["notes"] = json!(notes);
            serde_json::to_string_pretty(&v).expect("JSON of plain values") + "\n"
        }
    };
    Exported { text, notes }
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

/// The measured-material target (`--to rgl`): any representation brdfkit holds as the
/// [`brdfkit_core::Brdf`] the RGL-EPFL writer (`brdfkit_rgl::write`) tabulates. A table
/// is read with the interpolated lookup (missing cells 0), a per-channel fit takes
/// channel c from model c, an NBRDF is its (clamped) `eval`.
pub fn measured_source(rep: &crate::compare::Representation) -> Box<dyn brdfkit_core::Brdf + '_> {
    use crate::compare::Representation;
    use brdfkit_fit::Fitted;
    match rep {
        Representation::Table(t) => Box::new(crate::table::table_brdf(
            t,
            brdfkit_merl::Lookup::Interpolated,
        )),
        Representation::Model(Fitted::Shared(m)) => Box::new(m.as_ref()),
        Representation::Model(f) => Box::new(PerChannel(f)),
        Representation::Nbrdf(n) => Box::new(n.as_ref()),
    }
}

/// A per-channel fit as one BRDF: channel c of model c.
struct PerChannel<'a>(&'a brdfkit_fit::Fitted);

impl brdfkit_core::Brdf for PerChannel<'_> {
    fn eval(&self, wi: &brdfkit_core::Vec3, wo: &brdfkit_core::Vec3) -> Rgb {
        Rgb([0, 1, 2].map(|c| self.0.channel_model(c).eval(wi, wo).0[c]))
    }
    fn is_isotropic(&self) -> bool {
        (0..3).all(|c| self.0.channel_model(c).is_isotropic())
    }
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
             (-> diffuse), cook-torrance with conductor Fresnel, rho_d = 0, rho_s = 1, \
             smith-correlated masking, GGX, alpha >= 1e-3 (-> conductor) and rough-plastic with \
             rho_s = 1, nonlinear false, alpha >= 1e-3 (-> coateddiffuse, approximately)); \
             export --approximate fits the nearest material the target has to the model and \
             reports the error, and `fit --for` fits it to the measured table"
        );
        let e = renderer_material(&json!({"model": "ward", "params": {}}), Renderer::Mitsuba)
            .unwrap_err();
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
        assert!(e.to_string().contains("--approximate"), "{e}");
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
}
