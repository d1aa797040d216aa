//! The one mapping of a brdfkit model onto a renderer's material, and its notes.

use crate::*;
use brdfkit_core::scattering::{BeckmannG1, Distribution, Masking};
use brdfkit_core::{Rgb, downcast};
use brdfkit_models::cook_torrance::{CookTorrance, Fresnel, Shape};
use brdfkit_models::lambert::Lambert;
use brdfkit_models::rough_plastic::RoughPlastic;
use serde_json::{Value, json};
use std::fmt;

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

/// The note on every pbrt-v4 `coateddiffuse` export.
pub const PBRT_COATED_NOTE: &str = "APPROXIMATION: pbrt-v4's coateddiffuse is a stochastic \
     layered BSDF (a random walk between a rough dielectric interface and a Lambertian base, \
     thickness 0.01, maxdepth 10), not rough-plastic's closed form: it also follows light \
     bouncing between coat and base and its interface transmittance is not Mitsuba's table, \
     so the diffuse colour and its falloff towards grazing angles differ; the size of the \
     difference is not measured here (pbrt-v4 could not be built on this machine, \
     docs/export.md)";

/// What a refusal suggests instead.
pub const APPROXIMATE_HINT: &str = "the export setting `approximate` fits the nearest material \
     the target has to the model and reports the error, and a fit `for` the renderer fits it \
     to the measured table";

pub(crate) fn rgb_text(c: Rgb, sep: &str) -> String {
    format!("{}{sep}{}{sep}{}", c.r(), c.g(), c.b())
}

pub(crate) fn rgb_list(c: Rgb) -> String {
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
pub(crate) fn conductor_of(ct: &CookTorrance, to: Renderer) -> Result<RendererMaterial, Refusal> {
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
    let model = brdfkit_models::from_json(description)?;
    let refused = |model: String, reason| ExportError::Unsupported {
        config: model,
        renderer: to,
        reason,
    };
    if let Some(l) = downcast::<Lambert>(model.as_ref()) {
        let material = RendererMaterial::Diffuse {
            reflectance: l.rho_d(),
        };
        let model = Lambert::NAME.into();
        Ok(Mapped { material, model })
    } else if let Some(ct) = downcast::<CookTorrance>(model.as_ref()) {
        let model = describe_cook_torrance(ct);
        match conductor_of(ct, to) {
            Ok(material) => Ok(Mapped { material, model }),
            Err(reason) => Err(refused(model, reason)),
        }
    } else if let Some(p) = downcast::<RoughPlastic>(model.as_ref()) {
        let model = format!("{} (ggx, eta {})", RoughPlastic::NAME, p.eta());
        match plastic_of(p, to) {
            Ok(material) => Ok(Mapped { material, model }),
            Err(reason) => Err(refused(model, reason)),
        }
    } else {
        Err(ExportError::UnsupportedModel {
            model: model.name().into(),
            renderer: to,
        })
    }
}

/// The conditions of `to` on a rough plastic.
pub(crate) fn plastic_of(p: &RoughPlastic, to: Renderer) -> Result<RendererMaterial, Refusal> {
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

/// A conductor's roughness as the renderer's entries: `names.0` for an isotropic α,
/// `names.1` then `names.2` for an anisotropic (αu, αv); one rule for every exporter.
pub(crate) fn alpha_entries(
    alpha: brdfkit_models::cook_torrance::Shape,
    names: (&'static str, &'static str, &'static str),
) -> Vec<(&'static str, f64)> {
    use brdfkit_models::cook_torrance::Shape;
    match alpha {
        Shape::Isotropic(a) => vec![(names.0, a)],
        Shape::Anisotropic(x, y) => vec![(names.1, x), (names.2, y)],
    }
}

pub(crate) fn rgb_value(c: Rgb) -> Value {
    json!({"type": "rgb", "value": [c.r(), c.g(), c.b()]})
}
