//! A brdfkit model as a renderer's material: the one mapping onto Mitsuba 3 and pbrt-v4,
//! used by `fit-brdf export` and by the Mitsuba cross-check (`brdfkit_validate::mitsuba`).
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
//! use brdfkit_export::{ExportForm, export_str};
//! let e = export_str(
//!     r#"{"model": "lambert", "params": {"rho_d": 0.4}}"#,
//!     ExportForm::MitsubaXml,
//!     "params.json",
//! )?;
//! assert!(e.text.contains(r#"<bsdf type="diffuse" version="3.0.0">"#));
//! # Ok::<(), brdfkit_export::ExportError>(())
//! ```

mod approximate;
mod gltf;
mod material;
mod mitsuba;
mod pbrt;
#[cfg(test)]
mod tests;

pub use approximate::*;
pub use gltf::*;
pub use material::*;

use brdfkit_core::ModelError;
use brdfkit_fit::families::FamilyFitError;
use brdfkit_fit::target::Target;
use serde_json::Value;

use thiserror::Error;

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
         refit without the `per-channel` setting"
    )]
    PerChannel,
    /// A model the renderer has no material for (`ward`, `sum`, …).
    /// (This and the next two end with [`APPROXIMATE_HINT`]: [`ExportError::hints_approximate`].)
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

impl ExportError {
    /// True for the refusals whose message suggests the `approximate` setting and a fit
    /// for the renderer ([`APPROXIMATE_HINT`]), so a front end can add its own spelling.
    pub fn hints_approximate(&self) -> bool {
        matches!(
            self,
            ExportError::UnsupportedModel { .. }
                | ExportError::Unsupported { .. }
                | ExportError::NotGltf { .. }
        )
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
