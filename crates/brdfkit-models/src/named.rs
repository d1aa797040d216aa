//! The named families: the model lists and variants that fitting, reports and the
//! database run refer to by name, kept here beside the models so that no other crate
//! spells a family's name.
//!
//! A *family* is what a fit starts from: a model of the JSON contract at its default
//! start (`cook-torrance`), or a named variant built from the models
//! ([`NAMED_FAMILIES`]: several lobes, another distribution), or a glTF configuration
//! ([`GLTF_VARIANTS`]).

use crate::cook_torrance::CookTorrance;
use crate::gltf_pbr::GltfPbr;
use crate::lafortune::{Lafortune, LafortuneLobe};
use crate::sum::Sum;
use brdfkit_core::scattering::Distribution;
use brdfkit_core::{Model, ModelError, Rgb};

/// The family a fit uses when none is named: Cook-Torrance with GGX, Smith
/// height-correlated masking and Schlick's Fresnel, the best one-lobe family of the
/// database run (docs/measured.md).
pub const DEFAULT_FAMILY: &str = CookTorrance::NAME;

/// The model families of the report and the demo, in the order they are shown.
pub const REPORT_MODELS: &str = "lambert,plausible-phong,ward,lafortune,cook-torrance";

/// The families of a whole-database run: every model family of issue 12, one- and
/// multi-lobe.
pub const DATABASE_MODELS: &str = "lambert,oren-nayar,plausible-phong,blinn-phong,ward,\
lafortune,lafortune-2,ashikhmin-shirley,cook-torrance,cook-torrance-beckmann,cook-torrance-2";

/// The named families beyond the models' own names: variants and multi-lobe models
/// that measured materials need. The literature finds two-lobe Cook-Torrance and
/// Lafortune with 2–3 lobes best for many MERL materials (A. Ngan, F. Durand,
/// W. Matusik, "Experimental Analysis of BRDF Models", EGSR 2005, sec. 5; E. Lafortune
/// et al., "Non-Linear Approximation of Reflectance Functions", SIGGRAPH 1997).
pub const NAMED_FAMILIES: [&str; 4] = [
    "cook-torrance-beckmann",
    "cook-torrance-2",
    "lafortune-2",
    "lafortune-3",
];

/// The start of a named family ([`NAMED_FAMILIES`]), or None for any other name.
///
/// Multi-lobe starts are a broad and a narrow lobe (roughness or exponent a decade
/// apart, on either side of the one-lobe default), so that from the first iteration
/// each lobe has its own part of the data to follow: two equal lobes would share every
/// gradient and stay equal. The multi-start grid then varies both shapes.
/// - `cook-torrance-beckmann`: Cook-Torrance with the Beckmann distribution.
/// - `cook-torrance-2`: the `sum` of two Cook-Torrance (GGX) lobes, α = 0.3 and 0.03,
///   the second lobe's ρd held at 0 (diffuse parts add up: only one is identifiable).
/// - `lafortune-N` (N = 2, 3): N Phong-like lobes (cxy = −1, cz = 1) with exponents
///   spread a decade apart from 5, each ρ set so the lobe's albedo bound 2πρ/(n+2)
///   (see `LafortuneLobe::albedo_bound`) is 0.1.
pub fn named_family(name: &str) -> Option<Result<Box<dyn Model>, ModelError>> {
    Some(match name {
        "cook-torrance-beckmann" => {
            Ok(Box::new(CookTorrance::new().with_distribution(Distribution::Beckmann)) as _)
        }
        "cook-torrance-2" => two_lobe_cook_torrance(),
        "lafortune-2" => lafortune_lobes(2),
        "lafortune-3" => lafortune_lobes(3),
        _ => return None,
    })
}

/// `cook-torrance-2` (see [`named_family`]).
fn two_lobe_cook_torrance() -> Result<Box<dyn Model>, ModelError> {
    let ct = |alpha: f64, rho_d: f64| -> Result<Box<dyn Model>, ModelError> {
        let lobe = CookTorrance::new()
            .with_alpha(alpha)?
            .with_rho_d(Rgb::splat(rho_d))?;
        Ok(Box::new(lobe))
    };
    let sum = Sum::new(vec![ct(0.3, 0.3)?, ct(0.03, 0.0)?])?;
    Ok(Box::new(sum.with_fixed(&["terms[1].rho_d"])?))
}

/// `lafortune-N` (see [`named_family`]).
fn lafortune_lobes(n: usize) -> Result<Box<dyn Model>, ModelError> {
    let lobes = (0..n)
        .map(|j| {
            let e = 5.0 * 10f64.powi(j as i32);
            let rho = 0.1 * (e + 2.0) / (2.0 * std::f64::consts::PI);
            LafortuneLobe::new(-1.0, 1.0, e, Rgb::splat(rho))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Box::new(Lafortune::new(Rgb::splat(0.5), lobes)?))
}

/// One glTF configuration `--for gltf` fits: its label and the extensions (names of
/// [`crate::gltf_pbr_ext::EXTENSION_NAMES`]) it adds to the core.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GltfVariant {
    /// The label (the record's family).
    pub label: &'static str,
    /// The extensions added to the core.
    pub extensions: &'static [&'static str],
}

impl GltfVariant {
    /// Whether every extension of `self` is in `other`.
    pub fn is_subset_of(&self, other: &GltfVariant) -> bool {
        self.extensions.iter().all(|e| other.extensions.contains(e))
    }

    /// Whether this is the core model alone (no extension).
    pub fn is_core(&self) -> bool {
        self.extensions.is_empty()
    }
}

/// The configurations of `--for gltf`, each after every one of its subsets (the order
/// the warm starts need).
pub const GLTF_VARIANTS: [GltfVariant; 6] = [
    GltfVariant {
        label: GltfPbr::NAME,
        extensions: &[],
    },
    GltfVariant {
        label: "gltf-sheen",
        extensions: &["sheen"],
    },
    GltfVariant {
        label: "gltf-clearcoat",
        extensions: &["clearcoat"],
    },
    GltfVariant {
        label: "gltf-specular",
        extensions: &["specular"],
    },
    GltfVariant {
        label: "gltf-sheen-specular",
        extensions: &["sheen", "specular"],
    },
    GltfVariant {
        label: "gltf-clearcoat-specular",
        extensions: &["clearcoat", "specular"],
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_named_family_builds_and_no_other_name_does() {
        for name in NAMED_FAMILIES {
            let m = named_family(name).expect(name).expect(name);
            assert!(m.num_params() > 0, "{name}");
        }
        assert!(named_family(CookTorrance::NAME).is_none());
    }

    #[test]
    fn two_lobe_cook_torrance_is_the_documented_start() {
        let m = two_lobe_cook_torrance().unwrap();
        let j = m.to_json();
        let terms = &j["params"]["terms"];
        assert_eq!(terms[0]["params"]["alpha"], 0.3, "{j}");
        assert_eq!(terms[1]["params"]["alpha"], 0.03, "{j}");
        assert_eq!(
            terms[1]["params"]["rho_d"],
            serde_json::json!([0.0, 0.0, 0.0]),
            "{j}"
        );
    }

    #[test]
    fn every_database_and_report_family_is_known() {
        for name in DATABASE_MODELS.split(',').chain(REPORT_MODELS.split(',')) {
            let known = named_family(name).is_some() || crate::default_model(name).is_ok();
            assert!(known, "{name}");
        }
    }

    #[test]
    fn gltf_variants_come_after_their_subsets() {
        for (i, v) in GLTF_VARIANTS.iter().enumerate() {
            for w in &GLTF_VARIANTS[i + 1..] {
                assert!(
                    !w.is_subset_of(v) || w == v,
                    "{} before {}",
                    v.label,
                    w.label
                );
            }
        }
        assert!(GLTF_VARIANTS[0].is_core());
    }
}
