//! Scoring without fitting: every loss of given parameters against a table, on the
//! cells and with the weights a fit's final loss report uses.
//!
//! A fit reports its losses over all valid cells that pass its cell filters
//! ([`FitRecord::losses_full`](crate::FitRecord::losses_full)). [`score`] takes the
//! same cells ([`CellFilter`], which [`crate::fit`] itself uses to pick them) and the
//! same function ([`evaluate_losses`]), so the losses of a fitted model, re-scored
//! with the fit's weighting and cutoff, equal its record's bit for bit.
//!
//! [`losses_of_values`] gives the same losses for values that come from no model (a
//! second table, a neural BRDF tabulated on the grid), for comparisons of two
//! representations.

pub use crate::config::CellFilter;
use crate::data::FitData;
use crate::error::FitError;
use crate::fitted::Fitted;
use crate::loss::{Loss, LossReport, Weighting};
use crate::{FitConfig, evaluate_losses};
use brdfkit_core::ModelError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Why given parameters cannot be scored against a table.
#[derive(Debug, thiserror::Error)]
pub enum ScoreError {
    /// The description is not a model the library knows (or has a bad parameter).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A model that depends on the half vector's azimuth: a MERL table is isotropic
    /// (it has no φh), so a score would depend on an arbitrary orientation.
    #[error(
        "model `{model}` is anisotropic; an isotropic table (θh, θd, φd, no φh) cannot be compared with it"
    )]
    Anisotropic {
        /// The model.
        model: String,
    },
    /// No cell to score on, or inconsistent cells.
    #[error(transparent)]
    Fit(#[from] FitError),
}

/// A score: every loss of a model against a table's cells, and what they were taken
/// over.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// The model scored (`{"model": ..., "params": ...}` or `{"per_channel": [...]}`).
    pub model: Value,
    /// Every loss per channel and overall; `losses.cells` is the number of cells
    /// scored.
    pub losses: LossReport,
    /// The cell weights.
    pub weighting: Weighting,
    /// The θd cutoff (degrees), if any; written `theta_d_max`, the setting's name
    /// (older: `theta_d_max_deg`).
    #[serde(rename = "theta_d_max", alias = "theta_d_max_deg")]
    pub theta_d_max_deg: Option<f64>,
    /// Valid cells of the table before the cutoff.
    pub cells_valid: usize,
}

impl Score {
    /// The entry of one loss, overall.
    pub fn overall(&self, loss: Loss) -> f64 {
        self.losses.get(loss).overall
    }
}

/// Every loss of `fitted` on the valid cells `data` (all of a table's valid cells, as
/// [`FitData::from_table`] builds them) under the cell filter and weighting of
/// `config`: the computation of a fit's `losses_full`, without fitting.
///
/// Fails on an anisotropic model (see [`ScoreError::Anisotropic`]) and when the cutoff
/// leaves no cell.
pub fn score(fitted: &Fitted, data: &FitData, config: &FitConfig) -> Result<Score, ScoreError> {
    check_isotropic(fitted)?;
    let filter = CellFilter::of(config);
    let cells = filter.apply(data)?;
    let weighting = config.get_weighting();
    Ok(Score {
        model: fitted.to_json(),
        losses: evaluate_losses(fitted.channel_models(), &cells, weighting),
        weighting,
        theta_d_max_deg: filter.theta_d_max.map(f64::to_degrees),
        cells_valid: data.len(),
    })
}

/// An error unless every channel's model is isotropic: a table's cells have φh = 0
/// only, so an anisotropic model's values there depend on its orientation.
pub fn check_isotropic(fitted: &Fitted) -> Result<(), ScoreError> {
    match fitted
        .channel_models()
        .into_iter()
        .find(|m| !m.is_isotropic())
    {
        Some(m) => Err(ScoreError::Anisotropic {
            model: m.name().into(),
        }),
        None => Ok(()),
    }
}

/// Every loss of `values` (one plane per channel, one value per cell of `data`, 1/sr)
/// against the cells' measured values, with the transforms and weights of
/// [`evaluate_losses`] (the same figures up to the order of the sums: a model's values
/// give its losses to within round-off).
pub fn losses_of_values(
    data: &FitData,
    values: &[Vec<f64>; 3],
    weighting: Weighting,
) -> Result<LossReport, FitError> {
    let n = data.len();
    crate::data::check_channel_lengths(values, n)?;
    let cos_i = &data.geometry().wi_z;
    let measured = data.values();
    type Sums = ([[f64; 3]; 4], [[f64; 3]; 4], [f64; 4]);
    let zero = || -> Sums { ([[0.0; 3]; 4], [[0.0; 3]; 4], [0.0; 4]) };
    let (sums, psums, pw) = (0..n)
        .into_par_iter()
        .fold(zero, |mut acc, m| {
            let w = data.weight_at(weighting, m);
            let residual = |loss: &Loss, c: usize| {
                loss.transform(values[c][m], cos_i[m]) - loss.transform(measured[c][m], cos_i[m])
            };
            for (l, loss) in Loss::ALL.iter().enumerate() {
                for c in 0..3 {
                    let d = residual(loss, c);
                    acc.0[l][c] += w * d * d;
                }
            }
            // The published metrics: Σ w g r² per metric and channel, and Σ w g.
            for (l, loss) in Loss::PUBLISHED.iter().enumerate() {
                let g = w * data.loss_factor_at(*loss, m);
                acc.2[l] += g;
                for c in 0..3 {
                    let d = residual(loss, c);
                    acc.1[l][c] += g * d * d;
                }
            }
            acc
        })
        .reduce(zero, |mut a, b| {
            for (x, y) in a.0.iter_mut().flatten().zip(b.0.iter().flatten()) {
                *x += y;
            }
            for (x, y) in a.1.iter_mut().flatten().zip(b.1.iter().flatten()) {
                *x += y;
            }
            for (x, y) in a.2.iter_mut().zip(b.2.iter()) {
                *x += y;
            }
            a
        });
    Ok(LossReport::from_sums(
        sums,
        data.weight_sum(weighting),
        (psums, pw),
        n,
    ))
}

/// Published parameter conventions that differ from brdfkit's, converted to its model
/// JSON (the worked example of `docs/scoring.md`).
pub mod published {
    use brdfkit_models::cook_torrance::CookTorrance;
    use serde_json::{Value, json};

    /// The smallest GGX α of [`metallic_roughness`]: Burley's BRDF Explorer clamps
    /// α = max(0.001, r²) (`disney.brdf`), which also keeps α in the model's domain.
    pub const MIN_ALPHA: f64 = 1e-3;

    /// The metallic-roughness convention of Burley 2012 and Karis 2013 (Unreal Engine
    /// 4; glTF 2.0 uses the same) as a brdfkit `cook-torrance`.
    ///
    /// The convention's parameters: base colour c (linear RGB), metallic m ∈ [0, 1],
    /// perceptual roughness r ∈ [0, 1] and specular s ∈ [0, 1] (0.5 by default, F0 =
    /// 0.04). Its BRDF, with a Lambertian diffuse as in Karis 2013 (§ "Shading Model"):
    ///
    /// ```text
    /// f = (1 − m) c / π + D(h) G F / (4 cos θi cos θo)
    /// D = GGX (Trowbridge-Reitz) with α = r²              Burley 2012 §5.4, Karis 2013
    /// F = F0 + (1 − F0)(1 − wi·h)⁵                        Schlick 1994
    /// F0 = lerp(0.08 s, c, m) = (1 − m) 0.08 s + m c      Burley 2012 (disney.brdf: Cspec0)
    /// G = Smith's masking-shadowing for GGX
    /// ```
    ///
    /// brdfkit's `cook-torrance` is f = ρd/π + ρs D G F / (4 cos θi cos θo) (Walter et
    /// al. 2007 eq. 20), so ρd = (1 − m) c, ρs = 1, α = max(0.001, r²), GGX, Schlick F
    /// with that F0, and G = `smith-separable` (exact G1(wi) G1(wo), Walter et al. 2007
    /// eq. 34). Two real-time approximations of Karis 2013 are not copied: its G is
    /// Schlick's with k = α/2 (an approximation of the same Smith G1) and its Fresnel
    /// power is a spherical-Gaussian fit of (1 − x)⁵; the exact forms are what they
    /// approximate.
    ///
    /// Sources: B. Burley, "Physically-Based Shading at Disney", SIGGRAPH 2012 course
    /// notes, §5.4 and its BRDF Explorer file `disney.brdf`; B. Karis, "Real Shading in
    /// Unreal Engine 4", SIGGRAPH 2013 course notes.
    pub fn metallic_roughness(
        base_color: [f64; 3],
        metallic: f64,
        roughness: f64,
        specular: f64,
    ) -> Value {
        let rho_d = base_color.map(|c| (1.0 - metallic) * c);
        let f0 = base_color.map(|c| (1.0 - metallic) * 0.08 * specular + metallic * c);
        json!({
            "model": CookTorrance::NAME,
            "params": {
                "rho_d": rho_d,
                "rho_s": 1.0,
                "alpha": (roughness * roughness).max(MIN_ALPHA),
                "distribution": "ggx",
                "masking": "smith-separable",
                "fresnel": {"schlick": {"f0": f0}},
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_core::Model;
    use brdfkit_merl::{Dims, MerlTable};

    fn table() -> MerlTable {
        let m = brdfkit_models::from_json_str(
            r#"{"model": "cook-torrance", "params": {"rho_d": [0.3, 0.1, 0.05], "rho_s": 0.8, "alpha": 0.2}}"#,
        )
        .unwrap();
        MerlTable::from_brdf(m.as_ref(), Dims::new(16, 16, 32).unwrap()).unwrap()
    }

    fn lambert(r: f64) -> Box<dyn Model> {
        brdfkit_models::from_json_str(&format!(
            r#"{{"model": "lambert", "params": {{"rho_d": {r}}}}}"#
        ))
        .unwrap()
    }

    #[test]
    fn a_constant_model_scores_its_closed_form() {
        // A table that is a constant c, a model that is a constant k: the l2 loss is
        // |k − c| on every channel, whatever the weights.
        let dims = Dims::new(8, 8, 16).unwrap();
        let c = 0.2 / std::f64::consts::PI;
        let t = MerlTable::from_brdf(lambert(0.2).as_ref(), dims).unwrap();
        let data = FitData::from_table(&t).unwrap();
        let s = score(&Fitted::Shared(lambert(0.5)), &data, &FitConfig::default()).unwrap();
        let k = 0.5 / std::f64::consts::PI;
        for ch in s.losses.l2.channels {
            // The table stores value / scale: exact to a few ulp.
            assert!((ch - (k - c)).abs() < 1e-14 * k, "{ch}");
        }
        assert_eq!(s.losses.cells, t.valid_count());
        assert_eq!(s.cells_valid, t.valid_count());
    }

    #[test]
    fn the_cutoff_and_the_weights_are_those_of_a_fit() {
        let data = FitData::from_table(&table()).unwrap();
        let cfg = FitConfig::default()
            .theta_d_max_deg(60.0)
            .unwrap()
            .weighting(Weighting::Uniform);
        let f = Fitted::Shared(lambert(0.3));
        let s = score(&f, &data, &cfg).unwrap();
        let cut = data.with_theta_d_max(60f64.to_radians());
        assert_eq!(s.losses.cells, cut.len());
        assert!(cut.len() < data.len());
        let direct = evaluate_losses(f.channel_models(), &cut, Weighting::Uniform);
        assert_eq!(s.losses, direct);
        // As the fit record states it (radians back to degrees).
        assert!((s.theta_d_max_deg.unwrap() - 60.0).abs() < 1e-12);
        // Uniform weights are not solid-angle weights.
        let sa = score(
            &f,
            &data,
            &FitConfig::default().theta_d_max_deg(60.0).unwrap(),
        )
        .unwrap();
        assert_ne!(sa.losses, s.losses);
    }

    #[test]
    fn values_give_the_losses_of_the_model_they_come_from() {
        let data = FitData::from_table(&table()).unwrap();
        let m = lambert(0.25);
        let vals = data.with_model_values(m.as_ref());
        for w in [Weighting::SolidAngle, Weighting::Uniform] {
            let a = evaluate_losses([m.as_ref(); 3], &data, w);
            let b = losses_of_values(&data, vals.values(), w).unwrap();
            for loss in Loss::ALL {
                for c in 0..3 {
                    let (x, y) = (a.get(loss).channels[c], b.get(loss).channels[c]);
                    assert!((x - y).abs() <= 1e-12 * x.abs(), "{loss} {c}: {x} vs {y}");
                }
            }
            assert_eq!(a.cells, b.cells);
        }
        let short = [vec![0.0; 3], vec![], vec![]];
        assert!(losses_of_values(&data, &short, Weighting::Uniform).is_err());
    }

    #[test]
    fn bad_models_are_refused() {
        let data = FitData::from_table(&table()).unwrap();
        let aniso = brdfkit_models::from_json_str(
            r#"{"model": "ward", "params": {"rho_d": 0.2, "rho_s": 0.1, "alpha_x": 0.1, "alpha_y": 0.3}}"#,
        )
        .unwrap();
        let e = score(&Fitted::Shared(aniso), &data, &FitConfig::default()).unwrap_err();
        assert!(matches!(e, ScoreError::Anisotropic { .. }), "{e}");
        // Cells all beyond the cutoff: a typed error, not an empty score.
        let grazing = data.filter(|m| data.theta_d()[m] > 0.5);
        let cfg = FitConfig::default().theta_d_max_deg(10.0).unwrap();
        let e = score(&Fitted::Shared(lambert(0.2)), &grazing, &cfg).unwrap_err();
        assert!(matches!(e, ScoreError::Fit(FitError::NoCells(_))), "{e}");
        let bad = serde_json::json!({"per_channel": [{"model": "lambert"}]});
        assert!(Fitted::from_json(&bad).is_err());
    }

    /// The metallic-roughness BRDF transcribed from its formulas (Burley 2012, Karis
    /// 2013, with the exact Smith G1 of GGX, Walter et al. 2007 eq. 34), independently
    /// of the model code.
    fn metallic_roughness_brdf(
        c: [f64; 3],
        m: f64,
        r: f64,
        s: f64,
        wi: [f64; 3],
        wo: [f64; 3],
    ) -> [f64; 3] {
        let a = (r * r).max(1e-3);
        let a2 = a * a;
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let h = h.map(|x| x / n);
        let nh = h[2];
        let d = a2 / (std::f64::consts::PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
        let g1 = |z: f64| 2.0 * z / (z + (a2 + (1.0 - a2) * z * z).sqrt());
        let g = g1(wi[2]) * g1(wo[2]);
        let vh = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2];
        [0, 1, 2].map(|k| {
            let f0 = (1.0 - m) * 0.08 * s + m * c[k];
            let f = f0 + (1.0 - f0) * (1.0 - vh).powi(5);
            (1.0 - m) * c[k] / std::f64::consts::PI + d * g * f / (4.0 * wi[2] * wo[2])
        })
    }

    #[test]
    fn metallic_roughness_converts_to_the_same_brdf() {
        let dir = |t: f64, p: f64| [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
        for &(c, m, r, s) in &[
            ([1.0, 0.766, 0.336], 1.0, 0.35, 0.5),
            ([0.5, 0.1, 0.05], 0.0, 0.6, 0.5),
            ([0.3, 0.6, 0.9], 0.4, 0.12, 0.8),
        ] {
            let v = published::metallic_roughness(c, m, r, s);
            let model = brdfkit_models::from_json(&v).unwrap();
            for &(ti, pi, to, po) in &[
                (0.3, 0.0, 0.5, 3.0),
                (1.2, 1.0, 0.1, 2.0),
                (0.7, 0.2, 0.7, 3.3),
                (1.5, 0.0, 1.4, 0.4),
            ] {
                let (wi, wo) = (dir(ti, pi), dir(to, po));
                let want = metallic_roughness_brdf(c, m, r, s, wi, wo);
                let got = model.eval(
                    &brdfkit_core::Vec3::new(wi[0], wi[1], wi[2]),
                    &brdfkit_core::Vec3::new(wo[0], wo[1], wo[2]),
                );
                for k in 0..3 {
                    assert!(
                        (got[k] - want[k]).abs() <= 1e-12 * want[k].abs(),
                        "{k}: {} vs {}",
                        got[k],
                        want[k]
                    );
                }
            }
        }
        // r = 0 is clamped into the model's domain, as the BRDF Explorer does.
        let v = published::metallic_roughness([0.5; 3], 1.0, 0.0, 0.5);
        assert_eq!(
            v["params"]["alpha"],
            serde_json::json!(published::MIN_ALPHA)
        );
    }

    #[test]
    fn json_forms_are_read() {
        let one = serde_json::json!({"model": "lambert", "params": {"rho_d": 0.2}});
        let f = Fitted::from_json(&one).unwrap();
        assert!(f.shared().is_some());
        let pc = serde_json::json!({"per_channel": [one, one, one]});
        let f = Fitted::from_json(&pc).unwrap();
        assert!(f.shared().is_none());
        assert_eq!(
            Fitted::from_json(&f.to_json()).unwrap().to_json(),
            f.to_json()
        );
        // A fit record: its `model`.
        let record = serde_json::json!({"model": one, "losses_full": {}, "family": "lambert"});
        assert_eq!(
            Fitted::from_json(&record).unwrap().to_json(),
            f.channel_model(0).to_json()
        );
        // A description with a `model` name and no record fields is itself.
        assert_eq!(
            Fitted::from_json(&one).unwrap().to_json(),
            f.channel_model(0).to_json()
        );
    }
}
