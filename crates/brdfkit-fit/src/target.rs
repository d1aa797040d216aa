//! Fits for a renderer (`fit-brdf fit --for mitsuba|pbrt|gltf`, `export --approximate`):
//! exactly the configurations the renderer evaluates, with the renderer's free
//! parameters free, each fitted in turn on the same cells and the best taken by the
//! optimised loss.
//!
//! | target | material | brdfkit family | free | held |
//! |--------|----------|----------------|------|------|
//! | Mitsuba 3 | `diffuse` | `lambert` | ρd | |
//! | Mitsuba 3 | `roughconductor` (GGX) | `cook-torrance` GGX, smith-separable, conductor | ρs, α, η, k | ρd = 0 |
//! | Mitsuba 3 | `roughconductor` (Beckmann) | `cook-torrance` Beckmann (rational G1), smith-separable, conductor | ρs, α, η, k | ρd = 0 |
//! | pbrt-v4 | `diffuse` | `lambert` | ρd | |
//! | Mitsuba 3 | `roughplastic` | `rough-plastic` (GGX) | ρd, ρs, α, η | |
//! | pbrt-v4 | `conductor` | `cook-torrance` GGX, smith-correlated, conductor | α, η, k | ρd = 0, ρs = 1 |
//! | pbrt-v4 | `coateddiffuse` (approximately, docs/export.md) | `rough-plastic` (GGX) | ρd, α, η | ρs = 1 |
//! | glTF 2.0 | metallic-roughness | `gltf-pbr` | baseColor, metallic, roughness | |
//! | glTF 2.0 | + `KHR_materials_sheen` (`gltf-sheen`) | `gltf-pbr-ext` (sheen) | core, sheenColor, sheenRoughness | |
//! | glTF 2.0 | + `KHR_materials_clearcoat` (`gltf-clearcoat`) | `gltf-pbr-ext` (clearcoat) | core, clearcoat, clearcoatRoughness | |
//! | glTF 2.0 | + `KHR_materials_specular` (`gltf-specular`) | `gltf-pbr-ext` (specular) | core, specular, specularColor | ior = 1.5 |
//!
//! glTF's extension configurations each contain the core (sheenColor 0, clearcoat 0 and
//! specular 1 with specularColor 1 are the core), so on the optimised loss one of them is
//! never worse than the core up to the solver's tolerance. An extension is kept only when
//! it lowers the loss by at least [`GLTF_MIN_GAIN`] of the core's: below that it is noise
//! bought with parameters every viewer must then evaluate, and the core is kept
//! ([`TargetFit::why`] says which happened). The specular configuration holds ior at 1.5:
//! for an opaque material ior and specularColor act only through their product.
//!
//! η and k of a conductor are fixed by default in an ordinary fit (they trade off against
//! ρs); here they are free, since the renderer takes them: the fitted colour shift is the
//! material's, not the start's. Every fitted model is one `export` writes without error
//! (the export's conditions are the held values above).

use crate::families::{Family, FamilyFitError, FamilyObserver, Outcome, fit_each};
use crate::{FitConfig, FitData};
use brdfkit_core::scattering::{BeckmannG1, Distribution, Masking};
use brdfkit_core::{Model, Rgb};
use brdfkit_models::cook_torrance::{CookTorrance, Fresnel};
use brdfkit_models::gltf_pbr::GltfPbr;
use brdfkit_models::gltf_pbr_ext::{Clearcoat, GltfPbrExt, Sheen, Specular};
use brdfkit_models::lambert::Lambert;
use brdfkit_models::rough_plastic::RoughPlastic;

/// A renderer or format a model is fitted for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// Mitsuba 3.
    Mitsuba,
    /// pbrt-v4.
    Pbrt,
    /// A glTF 2.0 metallic-roughness material.
    Gltf,
}

impl Target {
    /// Every target.
    pub const ALL: [Target; 3] = [Target::Mitsuba, Target::Pbrt, Target::Gltf];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Target::Mitsuba => "mitsuba",
            Target::Pbrt => "pbrt",
            Target::Gltf => "gltf",
        }
    }
}

brdfkit_core::named_choice!(Target, "target");

/// One configuration a target renders: the material's name in the renderer, the
/// brdfkit family at its start, and the parameters freed or held beyond the model's
/// defaults.
pub struct TargetFamily {
    /// The family (label: the renderer's material name).
    pub family: Family,
    /// Parameters freed (fixed by default in the model).
    pub free: &'static [&'static str],
    /// Parameters held at the start's value.
    pub fixed: &'static [&'static str],
}

impl TargetFamily {
    fn new(label: &str, model: Box<dyn Model>) -> Self {
        TargetFamily {
            family: Family {
                label: label.into(),
                model,
            },
            free: &[],
            fixed: &[],
        }
    }

    /// `cfg` with this family's freed and held parameters.
    pub fn config(&self, cfg: &FitConfig) -> FitConfig {
        cfg.clone()
            .free_params(self.free.iter().copied())
            .fix_params(self.fixed.iter().copied())
    }
}

/// A conductor start: ρd = 0 (held), GGX or Beckmann with Walter's rational G1 (what
/// Mitsuba evaluates), the conductor Fresnel at its default η, k.
fn conductor(dist: Distribution, masking: Masking, rho_s: f64) -> Box<dyn Model> {
    let ct = CookTorrance::new()
        .with_rho_d(Rgb::ZERO)
        .and_then(|c| c.with_rho_s(Rgb::splat(rho_s)))
        .and_then(|c| c.with_fresnel(Fresnel::DEFAULT_CONDUCTOR))
        .expect("the defaults are in their domains")
        .with_distribution(dist)
        .with_masking(masking)
        .with_beckmann_g1(BeckmannG1::Rational);
    Box::new(ct)
}

/// The configurations `t` renders (module table), in the order they are fitted.
pub fn target_families(t: Target) -> Vec<TargetFamily> {
    const ETA_K: &[&str] = &["eta", "k"];
    let diffuse = || TargetFamily::new("diffuse", Box::new(Lambert::default()));
    match t {
        Target::Mitsuba => vec![
            diffuse(),
            TargetFamily {
                free: ETA_K,
                fixed: &["rho_d"],
                ..TargetFamily::new(
                    "roughconductor-ggx",
                    conductor(Distribution::Ggx, Masking::SmithSeparable, 1.0),
                )
            },
            TargetFamily {
                free: ETA_K,
                fixed: &["rho_d"],
                ..TargetFamily::new(
                    "roughconductor-beckmann",
                    conductor(Distribution::Beckmann, Masking::SmithSeparable, 1.0),
                )
            },
            TargetFamily {
                free: &["eta"],
                ..TargetFamily::new("roughplastic", Box::new(RoughPlastic::default()))
            },
        ],
        Target::Pbrt => vec![
            diffuse(),
            TargetFamily {
                free: ETA_K,
                fixed: &["rho_d", "rho_s"],
                ..TargetFamily::new(
                    "conductor",
                    conductor(Distribution::Ggx, Masking::SmithCorrelated, 1.0),
                )
            },
            TargetFamily {
                free: &["eta"],
                fixed: &["rho_s"],
                ..TargetFamily::new("coateddiffuse", Box::new(RoughPlastic::default()))
            },
        ],
        Target::Gltf => {
            let ext = || GltfPbrExt::new(GltfPbr::default());
            let ok = "the extensions' defaults are in their domains";
            vec![
                TargetFamily::new("gltf-pbr", Box::new(GltfPbr::default())),
                TargetFamily::new(
                    "gltf-sheen",
                    Box::new(ext().with_sheen(Sheen::default()).expect(ok)),
                ),
                TargetFamily::new(
                    "gltf-clearcoat",
                    Box::new(ext().with_clearcoat(Clearcoat::default()).expect(ok)),
                ),
                TargetFamily {
                    fixed: &["ior"],
                    ..TargetFamily::new(
                        "gltf-specular",
                        Box::new(ext().with_specular(Specular::default()).expect(ok)),
                    )
                },
            ]
        }
    }
}

/// A core loss at or below this is a reproduction of the table to round-off: no extension
/// can improve on it, whatever the relative figures of two round-off losses say.
pub const GLTF_EXACT_LOSS: f64 = 1e-9;

/// The least relative loss reduction for which `--for gltf` keeps an extension over the
/// core material (module doc).
pub const GLTF_MIN_GAIN: f64 = 0.01;

/// Every configuration of a target fitted, and the best.
#[derive(Debug, Clone)]
pub struct TargetFit {
    /// One outcome per configuration, in [`target_families`] order.
    pub outcomes: Vec<Outcome>,
    /// The index of the best outcome by the optimised loss over all fitted cells (for
    /// glTF, with the rule of [`GLTF_MIN_GAIN`]).
    pub best: usize,
    /// Why `best` was chosen, in one sentence.
    pub why: String,
}

impl TargetFit {
    /// The best outcome.
    pub fn best(&self) -> &Outcome {
        &self.outcomes[self.best]
    }
}

/// Fits every configuration of `t` on `data` with the settings of `cfg` (plus each
/// family's freed and held parameters) and picks the best by `cfg`'s loss on all cells.
pub fn fit_for(
    data: &FitData,
    t: Target,
    cfg: &FitConfig,
    obs: &dyn FamilyObserver,
) -> Result<TargetFit, FamilyFitError> {
    let fams = target_families(t);
    let mut outcomes = Vec::with_capacity(fams.len());
    for tf in &fams {
        let one = [Family {
            label: tf.family.label.clone(),
            model: tf.family.model.clone(),
        }];
        outcomes.extend(fit_each(data, &one, &tf.config(cfg), obs)?);
    }
    let loss = cfg.get_loss();
    let l = |i: usize| outcomes[i].record.losses_full.get(loss).overall;
    let lowest = (0..outcomes.len())
        .min_by(|&a, &b| l(a).total_cmp(&l(b)))
        .expect("every target has a configuration");
    let (best, why) = if t == Target::Gltf {
        gltf_choice(&outcomes, lowest, l(0), l(lowest))
    } else {
        (lowest, format!("lowest loss ({:.4e})", l(lowest)))
    };
    Ok(TargetFit {
        outcomes,
        best,
        why,
    })
}

/// glTF's choice (module doc): outcome 0 is the core; `lowest` the lowest loss.
fn gltf_choice(outcomes: &[Outcome], lowest: usize, core: f64, low: f64) -> (usize, String) {
    if lowest == 0 {
        return (
            0,
            format!("the core material has the lowest loss ({core:.4e})"),
        );
    }
    if core <= GLTF_EXACT_LOSS {
        return (
            0,
            format!("the core material reproduces the table (loss {core:.4e}): the core is kept"),
        );
    }
    let gain = (core - low) / core;
    let label = &outcomes[lowest].label;
    if gain >= GLTF_MIN_GAIN {
        (
            lowest,
            format!(
                "{label} lowers the core's loss by {:.1} % ({core:.4e} -> {low:.4e})",
                100.0 * gain
            ),
        )
    } else {
        (
            0,
            format!(
                "the best extension ({label}) lowers the core's loss by only {:.2} % \
                 (< {:.0} %): the core is kept",
                100.0 * gain,
                100.0 * GLTF_MIN_GAIN
            ),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{Coverage, synth_data};
    use crate::{Loss, resolve_free};
    use brdfkit_merl::Dims;

    #[test]
    fn the_conductors_free_eta_and_k_and_hold_what_the_renderer_lacks() {
        for t in Target::ALL {
            for tf in target_families(t) {
                let cfg = tf.config(&FitConfig::default());
                let free = resolve_free(&*tf.family.model, &cfg).unwrap();
                let names: Vec<String> = free
                    .iter()
                    .map(|&p| tf.family.model.param_specs()[p].name.clone())
                    .collect();
                if tf.family.label.contains("conductor") {
                    for n in ["eta.r", "k.b", "alpha"] {
                        assert!(
                            names.iter().any(|x| x == n),
                            "{}: {names:?}",
                            tf.family.label
                        );
                    }
                    assert!(!names.iter().any(|x| x.starts_with("rho_d")), "{names:?}");
                    assert_eq!(
                        names.iter().any(|x| x.starts_with("rho_s")),
                        t == Target::Mitsuba,
                        "{}: {names:?}",
                        tf.family.label
                    );
                } else {
                    let has = |f: &str| {
                        names
                            .iter()
                            .any(|x| x == f || x.starts_with(&format!("{f}.")))
                    };
                    assert!(
                        tf.free.iter().all(|f| has(f)),
                        "{}: {names:?}",
                        tf.family.label
                    );
                    assert!(
                        !tf.fixed.iter().any(|f| has(f)),
                        "{}: {names:?}",
                        tf.family.label
                    );
                    assert!(!names.is_empty());
                }
            }
        }
        assert_eq!("pbrt".parse::<Target>().unwrap(), Target::Pbrt);
        assert!("blender".parse::<Target>().is_err());
    }

    #[test]
    fn a_conductor_is_recovered_with_its_eta_and_k_and_chosen_over_diffuse() {
        // A gold-like conductor as pbrt renders it: the fit must find η, k (not keep the
        // start's) and pick `conductor`.
        let truth = CookTorrance::new()
            .with_rho_d(Rgb::ZERO)
            .and_then(|c| c.with_rho_s(Rgb::splat(1.0)))
            .and_then(|c| {
                c.with_fresnel(Fresnel::Conductor {
                    eta: Rgb::new(0.143, 0.374, 1.442),
                    k: Rgb::new(3.983, 2.385, 1.603),
                })
            })
            .unwrap()
            .with_masking(Masking::SmithCorrelated)
            .with_alpha(0.25)
            .unwrap();
        let data = synth_data(
            &truth,
            Dims::new(30, 30, 60).unwrap(),
            Coverage::AboveHorizon,
        )
        .unwrap();
        let cfg = FitConfig::default().loss(Loss::Cbrt).starts(2).unwrap();
        let r = fit_for(&data, Target::Pbrt, &cfg, &()).unwrap();
        assert_eq!(r.best().label, "conductor");
        let loss = r.best().record.losses_full.cbrt.overall;
        assert!(loss < 1e-3, "loss {loss}");
        let back = CookTorrance::from_params_json(&r.best().params["params"]).unwrap();
        let Fresnel::Conductor { eta, k } = back.fresnel() else {
            panic!("{}", r.best().params)
        };
        // F(θ) of the fit matches the truth's (η, k are identifiable only through F).
        for c in [0.05, 0.5, 1.0] {
            for ch in 0..3 {
                let want = brdfkit_core::scattering::fresnel::conductor(
                    c,
                    [0.143, 0.374, 1.442][ch],
                    [3.983, 2.385, 1.603][ch],
                );
                let got = brdfkit_core::scattering::fresnel::conductor(c, eta[ch], k[ch]);
                assert!(
                    (got - want).abs() < 0.02,
                    "cos {c} ch {ch}: {got} vs {want}"
                );
            }
        }
        assert!(r.outcomes[0].record.losses_full.cbrt.overall > 10.0 * loss);
    }

    /// `fit --for gltf` on tables of a known glTF material: the extension the table has
    /// is picked (with its reason), and a core material keeps the core.
    #[test]
    fn gltf_picks_the_extension_the_material_has() {
        use brdfkit_models::gltf_pbr_ext::{Clearcoat, GltfPbrExt, Sheen};
        let base = GltfPbr::new(Rgb::new(0.3, 0.05, 0.05), 0.0, 0.6).unwrap();
        let cases: [(Box<dyn Model>, &str); 3] = [
            (
                Box::new(
                    GltfPbrExt::new(base.clone())
                        .with_sheen(Sheen {
                            color: Rgb::new(0.9, 0.6, 0.5),
                            roughness: 0.4,
                        })
                        .unwrap(),
                ),
                "gltf-sheen",
            ),
            (
                Box::new(
                    GltfPbrExt::new(base.clone())
                        .with_clearcoat(Clearcoat {
                            factor: 1.0,
                            roughness: 0.08,
                        })
                        .unwrap(),
                ),
                "gltf-clearcoat",
            ),
            (Box::new(base.clone()), "gltf-pbr"),
        ];
        for (truth, want) in cases {
            let data = synth_data(
                &*truth,
                Dims::new(24, 24, 48).unwrap(),
                Coverage::AboveHorizon,
            )
            .unwrap();
            let cfg = FitConfig::default().loss(Loss::Cbrt).starts(2).unwrap();
            let r = fit_for(&data, Target::Gltf, &cfg, &()).unwrap();
            assert_eq!(r.best().label, want, "{}", r.why);
            if want == "gltf-pbr" {
                assert!(r.why.contains("core"), "{}", r.why);
            } else {
                assert!(
                    r.why.contains(want) && r.why.contains("lowers"),
                    "{}",
                    r.why
                );
            }
        }
    }
}
