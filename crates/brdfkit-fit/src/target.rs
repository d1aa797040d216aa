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
//! | glTF 2.0 | + sheen + specular (`gltf-sheen-specular`) | `gltf-pbr-ext` (sheen, specular) | both blocks | ior = 1.5 |
//! | glTF 2.0 | + clearcoat + specular (`gltf-clearcoat-specular`) | `gltf-pbr-ext` (clearcoat, specular) | both blocks | ior = 1.5 |
//!
//! **glTF's configurations are nested** ([`GLTF_VARIANTS`]): sheenColor 0, clearcoat 0
//! and specular 1 with specularColor 1 are the core, and each combination contains its
//! subsets. They are fitted in that order, each **warm-started** from its subsets'
//! optima: start 0 is the fitted subset one extension smaller with the lowest loss, plus
//! the missing extension at its entry: sheenColor [`GLTF_ENTRY_WEIGHT`] = 0.1 in every
//! channel, clearcoatFactor 0.1 (each with the roughness the lowest-loss fitted
//! configuration with that extension reached), specular at its default (the core
//! exactly). A weight enters at 0.1, not 0, because it is fitted through a logit whose
//! slope x (1 − x) vanishes at 0: a start at 0 cannot move. So start 0 is within a small
//! change of a subset's optimum, and the fit (a descent) ends no worse than that subset
//! up to the
//! solver's tolerance (tested); the other starts spread the shape parameters about it.
//! A single extension is also fitted from its cold start (the default core, sheenColor
//! or clearcoat 0.5), and the lower loss kept: the core's optimum can have absorbed what
//! the extension would carry (a clear coat's sharp highlight taken by the core's lobe),
//! a basin the warm start does not leave (test `gltf_picks_the_extension_the_material_has`).
//! (Before, each extension started from the default core with sheenColor 0.5: on the
//! MERL fabrics the fit drove sheenColor to 0, where it stuck.)
//!
//! **The choice** keeps a configuration only if **each** of its extensions lowers the loss
//! by at least [`GLTF_MIN_GAIN`] = 1 % relative to the best fitted configuration without
//! that extension (for `gltf-sheen-specular`: sheen against the better of the core and
//! `gltf-specular`, specular against the better of the core and `gltf-sheen`), and takes
//! the lowest loss among those kept. Below 1 % an extension is noise bought with
//! parameters every viewer must then evaluate. The rule is the same for every extension
//! and every material; [`TargetFit::why`] gives each extension's gain and names a
//! lower-loss configuration that was refused. Specular configurations hold ior at 1.5:
//! for an opaque material ior and specularColor act only through their product.
//!
//! η and k of a conductor are fixed by default in an ordinary fit (they trade off against
//! ρs); here they are free, since the renderer takes them: the fitted colour shift is the
//! material's, not the start's. Every fitted model is one `export` writes without error
//! (the export's conditions are the held values above).

use crate::families::{Family, FamilyFitError, Outcome, fit_each};
use crate::{FitConfig, FitData, Fitted};
use brdfkit_core::progress::Observe;
use brdfkit_core::scattering::{BeckmannG1, Distribution, Masking};
use brdfkit_core::{Model, Rgb, downcast};
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
        Target::Gltf => GLTF_VARIANTS
            .iter()
            .map(|v| gltf_family(v, gltf_cold(v)))
            .collect(),
    }
}

/// A core loss at or below this is a reproduction of the table to round-off: no extension
/// can improve on it, whatever the relative figures of two round-off losses say.
pub const GLTF_EXACT_LOSS: f64 = 1e-9;

/// The least relative loss reduction each extension of a glTF configuration must bring
/// over the best fitted configuration without it for `--for gltf` to keep it (module
/// doc).
pub const GLTF_MIN_GAIN: f64 = 0.01;

/// The least weight (each sheenColor channel, clearcoatFactor) an extension enters a
/// warm start with (module doc): at 0 the logit's slope x (1 − x) vanishes and the fit
/// cannot move the weight; 0.1 keeps the start within a small change of the subset's
/// optimum.
pub const GLTF_ENTRY_WEIGHT: f64 = 0.1;

pub use brdfkit_models::named::{GLTF_VARIANTS, GltfVariant};

/// The family of `v` starting at `model` (ior held with the specular extension: module
/// doc).
fn gltf_family(v: &GltfVariant, model: Box<dyn Model>) -> TargetFamily {
    TargetFamily {
        fixed: if v.extensions.contains(&"specular") {
            &["ior"]
        } else {
            &[]
        },
        ..TargetFamily::new(v.label, model)
    }
}

/// The start of a configuration with `exts` (module doc): `base` (a fitted subset one
/// extension smaller, or the default core) as fitted, plus each extension it lacks at
/// its entry: sheenColor [`GLTF_ENTRY_WEIGHT`] in every channel and clearcoatFactor
/// [`GLTF_ENTRY_WEIGHT`], with the roughness of the lowest-loss fitted configuration in
/// `donors` that has the extension (or the default); specular at its default, which is
/// the core exactly. With no extension the core model itself (`gltf-pbr`).
fn gltf_start(exts: &[&str], base: Option<&GltfPbrExt>, donors: &[&GltfPbrExt]) -> Box<dyn Model> {
    let Some(base) = base else {
        if exts.is_empty() {
            return Box::new(GltfPbr::default());
        }
        return gltf_start(exts, Some(&GltfPbrExt::new(GltfPbr::default())), donors);
    };
    let ok = "blocks of fitted models and the entry values are in their domains";
    let mut m = base.clone();
    let wanted = |ext: &str, present: bool| exts.contains(&ext) && !present;
    // `find_map`: the first donor with the block (`donors` come in order of loss).
    if wanted("sheen", base.sheen().is_some()) {
        let donor = donors.iter().find_map(|d| d.sheen());
        let roughness = donor.unwrap_or_default().roughness;
        let color = Rgb::splat(GLTF_ENTRY_WEIGHT);
        m = m.with_sheen(Sheen { color, roughness }).expect(ok);
    }
    if wanted("clearcoat", base.clearcoat().is_some()) {
        let donor = donors.iter().find_map(|d| d.clearcoat());
        let roughness = donor.unwrap_or_default().roughness;
        let factor = GLTF_ENTRY_WEIGHT;
        m = m.with_clearcoat(Clearcoat { factor, roughness }).expect(ok);
    }
    if wanted("specular", base.specular().is_some()) {
        m = m.with_specular(Specular::default()).expect(ok);
    }
    Box::new(m)
}

/// A fitted glTF configuration as the extended model (the core as one with none).
fn as_ext(fitted: &Fitted) -> GltfPbrExt {
    let model = fitted
        .shared()
        .expect("glTF configurations are fitted with shared parameters");
    match downcast::<GltfPbr>(model) {
        Some(core) => GltfPbrExt::new(core.clone()),
        None => downcast::<GltfPbrExt>(model)
            .expect("every glTF configuration is gltf-pbr or gltf-pbr-ext")
            .clone(),
    }
}

/// Every configuration of [`GLTF_VARIANTS`] fitted in order, each warm-started
/// ([`gltf_start`]) from its fitted subsets: the core from the subset with the lowest
/// loss among those one extension smaller, the other extension's block from the
/// lowest-loss subset that has it.
fn fit_gltf(
    data: &FitData,
    cfg: &FitConfig,
    obs: &dyn Observe,
) -> Result<Vec<Outcome>, FamilyFitError> {
    let loss = cfg.get_loss();
    let mut outcomes: Vec<Outcome> = Vec::with_capacity(GLTF_VARIANTS.len());
    let mut fitted: Vec<GltfPbrExt> = Vec::with_capacity(GLTF_VARIANTS.len());
    for v in &GLTF_VARIANTS {
        let l = |j: usize| outcomes[j].record.losses_full.get(loss).overall;
        let mut subsets: Vec<usize> = (0..fitted.len())
            .filter(|&j| GLTF_VARIANTS[j].is_subset_of(v))
            .collect();
        subsets.sort_by(|&a, &b| l(a).total_cmp(&l(b)));
        let base = subsets
            .iter()
            .copied()
            .find(|&j| GLTF_VARIANTS[j].extensions.len() + 1 == v.extensions.len());
        let donors: Vec<&GltfPbrExt> = subsets.iter().map(|&j| &fitted[j]).collect();
        let start = gltf_start(v.extensions, base.map(|j| &fitted[j]), &donors);
        let mut o = fit_gltf_from(data, cfg, obs, v, start)?;
        if v.extensions.len() == 1 {
            // A single extension is also fitted from the cold start (the default core
            // and extension): the core's optimum can have absorbed what the extension
            // would carry (a coat's sharp highlight in the core's lobe), a basin the warm
            // start cannot leave. The lower loss is kept.
            let cold = fit_gltf_from(data, cfg, obs, v, gltf_cold(v))?;
            let lo = |o: &Outcome| o.record.losses_full.get(loss).overall;
            if lo(&cold) < lo(&o) {
                o = cold;
            }
        }
        fitted.push(as_ext(&o.fitted));
        outcomes.push(o);
    }
    Ok(outcomes)
}

/// Configuration `v` fitted from `start`.
fn fit_gltf_from(
    data: &FitData,
    cfg: &FitConfig,
    obs: &dyn Observe,
    v: &GltfVariant,
    start: Box<dyn Model>,
) -> Result<Outcome, FamilyFitError> {
    let tf = gltf_family(v, start);
    let tf_cfg = tf.config(cfg);
    Ok(fit_each(data, &[tf.family], &tf_cfg, obs)?.remove(0))
}

/// The cold start of `v`: the default core with each extension at its default.
fn gltf_cold(v: &GltfVariant) -> Box<dyn Model> {
    if v.extensions.is_empty() {
        return Box::new(GltfPbr::default());
    }
    let ok = "the extensions' defaults are in their domains";
    let mut m = GltfPbrExt::new(GltfPbr::default());
    if v.extensions.contains(&"sheen") {
        m = m.with_sheen(Sheen::default()).expect(ok);
    }
    if v.extensions.contains(&"clearcoat") {
        m = m.with_clearcoat(Clearcoat::default()).expect(ok);
    }
    if v.extensions.contains(&"specular") {
        m = m.with_specular(Specular::default()).expect(ok);
    }
    Box::new(m)
}

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
/// family's freed and held parameters) and picks the best by `cfg`'s loss on all cells
/// (for glTF by the rule of [`GLTF_MIN_GAIN`], each configuration warm-started from its
/// subsets' optima: module doc).
pub fn fit_for(
    data: &FitData,
    t: Target,
    cfg: &FitConfig,
    obs: &dyn Observe,
) -> Result<TargetFit, FamilyFitError> {
    let outcomes = if t == Target::Gltf {
        fit_gltf(data, cfg, obs)?
    } else {
        let mut outcomes = Vec::new();
        for tf in &target_families(t) {
            let one = [Family {
                label: tf.family.label.clone(),
                model: tf.family.model.clone(),
            }];
            outcomes.extend(fit_each(data, &one, &tf.config(cfg), obs)?);
        }
        outcomes
    };
    let loss = cfg.get_loss();
    let losses: Vec<f64> = outcomes
        .iter()
        .map(|o| o.record.losses_full.get(loss).overall)
        .collect();
    let (best, why) = if t == Target::Gltf {
        gltf_choice(&losses)
    } else {
        let lowest = (0..losses.len())
            .min_by(|&a, &b| losses[a].total_cmp(&losses[b]))
            .expect("every target has a configuration");
        (lowest, format!("lowest loss ({:.4e})", losses[lowest]))
    };
    Ok(TargetFit {
        outcomes,
        best,
        why,
    })
}

/// The gain of each extension of configuration `i` of [`GLTF_VARIANTS`]: the extension,
/// the lowest-loss fitted configuration without it, and 1 − loss(i)/its loss.
fn gltf_gains(losses: &[f64], i: usize) -> Vec<(&'static str, usize, f64)> {
    let v = &GLTF_VARIANTS[i];
    v.extensions
        .iter()
        .map(|&e| {
            let without = (0..losses.len())
                .filter(|&j| {
                    let w = &GLTF_VARIANTS[j];
                    w.is_subset_of(v) && !w.extensions.contains(&e)
                })
                .min_by(|&a, &b| losses[a].total_cmp(&losses[b]))
                .expect("the core is without every extension");
            (e, without, 1.0 - losses[i] / losses[without])
        })
        .collect()
}

/// glTF's choice (module doc) from the losses of [`GLTF_VARIANTS`] in order: the
/// lowest-loss configuration each of whose extensions lowers the loss by at least
/// [`GLTF_MIN_GAIN`] over the best fitted configuration without it.
fn gltf_choice(losses: &[f64]) -> (usize, String) {
    let core = losses[0];
    if core <= GLTF_EXACT_LOSS {
        return (
            0,
            format!("the core material reproduces the table (loss {core:.4e}): the core is kept"),
        );
    }
    let earns = |i: usize| gltf_gains(losses, i).iter().all(|g| g.2 >= GLTF_MIN_GAIN);
    let pick = (0..losses.len())
        .filter(|&i| earns(i))
        .min_by(|&a, &b| losses[a].total_cmp(&losses[b]))
        .expect("the core has no extension to earn");
    let lowest = (0..losses.len())
        .min_by(|&a, &b| losses[a].total_cmp(&losses[b]))
        .expect("glTF has configurations");
    let describe = |i: usize| {
        gltf_gains(losses, i)
            .iter()
            .map(|(e, j, g)| format!("{e} {:.1} % over {}", 100.0 * g, GLTF_VARIANTS[*j].label))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut why = if pick == 0 {
        format!("the core material is kept (loss {core:.4e})")
    } else {
        format!(
            "{} lowers the core's loss by {:.1} % ({core:.4e} -> {:.4e}; {})",
            GLTF_VARIANTS[pick].label,
            100.0 * (1.0 - losses[pick] / core),
            losses[pick],
            describe(pick)
        )
    };
    if lowest != pick {
        why += &format!(
            "; {} has a lower loss ({:.4e}) but not every extension of it earns {:.0} % ({})",
            GLTF_VARIANTS[lowest].label,
            losses[lowest],
            100.0 * GLTF_MIN_GAIN,
            describe(lowest)
        );
    }
    (pick, why)
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
        let best = r.best().fitted.shared().unwrap();
        let back = downcast::<CookTorrance>(best).unwrap();
        let Fresnel::Conductor { eta, k } = back.fresnel() else {
            panic!("{}", r.best().params())
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

    /// The rule of [`GLTF_MIN_GAIN`]: each extension against the best configuration
    /// without it, not only against the core.
    #[test]
    fn gltf_choice_asks_every_extension_to_earn_its_place() {
        // core, sheen, clearcoat, specular, sheen+specular, clearcoat+specular
        let (pick, why) = gltf_choice(&[1.0, 0.995, 0.98, 0.6, 0.55, 0.598]);
        assert_eq!(GLTF_VARIANTS[pick].label, "gltf-sheen-specular", "{why}");
        assert!(why.contains("sheen 8.3 % over gltf-specular"), "{why}");
        assert!(why.contains("specular 44.7 % over gltf-sheen"), "{why}");
        // Sheen alone (0.5 %) does not earn its place; with specular it does (8.3 %).
        let (pick, why) = gltf_choice(&[1.0, 0.995, 0.98, 0.6, 0.597, 0.596]);
        assert_eq!(GLTF_VARIANTS[pick].label, "gltf-specular", "{why}");
        assert!(
            why.contains("gltf-clearcoat-specular has a lower loss")
                && why.contains("clearcoat 0.7 % over gltf-specular"),
            "{why}"
        );
        let (pick, why) = gltf_choice(&[1.0, 0.995, 0.992, 0.999, 0.99, 0.985]);
        assert_eq!(pick, 0, "{why}");
        assert!(why.contains("core material is kept"), "{why}");
        let (pick, why) = gltf_choice(&[1e-12, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(pick, 0, "{why}");
        assert!(why.contains("reproduces"), "{why}");
        // Every configuration comes after its subsets (the warm starts need them).
        for (i, v) in GLTF_VARIANTS.iter().enumerate() {
            for (j, w) in GLTF_VARIANTS.iter().enumerate() {
                if w.is_subset_of(v) && w != v {
                    assert!(j < i, "{} before {}", w.label, v.label);
                }
            }
        }
    }

    /// A warm start begins at its subset's optimum with the new extension at its entry
    /// ([`GLTF_ENTRY_WEIGHT`], the donor's roughness), whatever the donor's weight was.
    #[test]
    fn gltf_warm_starts_take_the_subsets_optima() {
        let core = GltfPbr::new(Rgb::new(0.2, 0.3, 0.4), 0.1, 0.7).unwrap();
        let spec = GltfPbrExt::new(core.clone())
            .with_specular(Specular {
                factor: 0.3,
                color: Rgb::new(2.0, 3.0, 4.0),
                ior: 1.5,
            })
            .unwrap();
        let dark_sheen = GltfPbrExt::new(GltfPbr::default())
            .with_sheen(Sheen {
                color: Rgb::new(1e-19, 0.4, 0.0),
                roughness: 0.3,
            })
            .unwrap();
        let m = gltf_start(&["sheen", "specular"], Some(&spec), &[&spec, &dark_sheen]);
        let want = spec
            .clone()
            .with_sheen(Sheen {
                color: Rgb::splat(GLTF_ENTRY_WEIGHT),
                roughness: 0.3,
            })
            .unwrap();
        assert_eq!(m.to_json(), want.to_json());
        let m = gltf_start(&["clearcoat"], Some(&GltfPbrExt::new(core.clone())), &[]);
        let want = GltfPbrExt::new(core.clone())
            .with_clearcoat(Clearcoat {
                factor: GLTF_ENTRY_WEIGHT,
                ..Clearcoat::default()
            })
            .unwrap();
        assert_eq!(m.to_json(), want.to_json());
        // Specular enters at its default, the core exactly.
        let m = gltf_start(&["sheen", "specular"], Some(&dark_sheen), &[&spec]);
        let want = dark_sheen
            .clone()
            .with_specular(Specular::default())
            .unwrap();
        assert_eq!(m.to_json(), want.to_json());
        assert_eq!(gltf_start(&[], None, &[]).name(), "gltf-pbr");
    }

    /// `fit --for gltf` on tables of a known glTF material: the extension the table has
    /// is picked (with its reason), and a core material keeps the core.
    #[test]
    fn gltf_picks_the_extension_the_material_has() {
        let base = GltfPbr::new(Rgb::new(0.3, 0.05, 0.05), 0.0, 0.6).unwrap();
        let sheen = Sheen {
            color: Rgb::new(0.9, 0.6, 0.5),
            roughness: 0.4,
        };
        let cases: [(Box<dyn Model>, &str); 4] = [
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
            (
                Box::new(
                    GltfPbrExt::new(base.clone())
                        .with_sheen(sheen)
                        .and_then(|m| {
                            m.with_specular(Specular {
                                factor: 0.3,
                                color: Rgb::new(1.0, 2.0, 3.0),
                                ior: 1.5,
                            })
                        })
                        .unwrap(),
                ),
                "gltf-sheen-specular",
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
            // Warm-started from its subsets, no configuration ends worse than one of
            // them (beyond the solver's tolerance).
            let l = |i: usize| r.outcomes[i].record.losses_full.cbrt.overall;
            for (i, v) in GLTF_VARIANTS.iter().enumerate() {
                for (j, w) in GLTF_VARIANTS.iter().enumerate() {
                    if w.is_subset_of(v) {
                        assert!(
                            l(i) <= l(j) * 1.001 + 1e-9,
                            "{}: {} > {}",
                            v.label,
                            l(i),
                            l(j)
                        );
                    }
                }
            }
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
