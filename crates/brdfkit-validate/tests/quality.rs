//! Fit-quality metrics against closed forms, and the held-out validation.

use brdfkit_fit::synth::{Coverage, add_lognormal_noise, synth_data};
use brdfkit_fit::{FitConfig, FitData, Fitted, Loss};
use brdfkit_merl::{Dims, MerlTable};
use brdfkit_models::from_json_str;
use brdfkit_validate::quality::stratified_split;
use brdfkit_validate::{
    HeldOutOptions, QualityError, QualityOptions, QualityReport, fit_quality, fit_quality_with,
    fitted_from_json, held_out,
};
use std::f64::consts::PI;

fn dims() -> Dims {
    Dims::new(30, 30, 60).unwrap()
}

fn table(json: &str) -> MerlTable {
    MerlTable::from_brdf(from_json_str(json).unwrap().as_ref(), dims()).unwrap()
}

fn shared(json: &str) -> Fitted {
    Fitted::Shared(from_json_str(json).unwrap())
}

/// The quality of the model `fit_json` (shared by the channels) on the table of the
/// model `table_json`.
fn quality_of(table_json: &str, fit_json: &str) -> QualityReport {
    fit_quality(&table(table_json), &shared(fit_json)).unwrap()
}

#[test]
fn a_perfect_fit_scores_zero() {
    let json = r#"{"model": "lambert", "params": {"rho_d": [0.2, 0.5, 0.8]}}"#;
    let r = quality_of(json, json);
    for l in Loss::ALL {
        // The table stores value / scale: one ulp of round-off at most.
        assert!(
            r.losses.get(l).overall < 1e-15,
            "{l}: {:?}",
            r.losses.get(l)
        );
    }
    let p = r.relative_error.overall.unwrap();
    assert!(p.p99 < 1e-15, "{p:?}");
    for a in &r.albedo {
        let d = a.difference.unwrap();
        assert!(
            d.r().abs().max(d.g().abs()).max(d.b().abs()) < 1e-9,
            "{a:?}"
        );
        assert!((a.fit.g() - 0.5).abs() < 1e-9);
    }
}

#[test]
fn losses_match_their_closed_forms() {
    // Table ρ = 0.5, fit ρ = 0.4: every cell is off by 0.1/π, relatively by 0.2.
    let t = table(r#"{"model": "lambert", "params": {"rho_d": 0.5}}"#);
    let r = fit_quality(
        &t,
        &shared(r#"{"model": "lambert", "params": {"rho_d": 0.4}}"#),
    )
    .unwrap();
    let d = 0.1 / PI;
    assert!(
        (r.losses.l2.overall - d).abs() < 1e-12 * d,
        "{:?}",
        r.losses.l2
    );
    for c in 0..3 {
        assert!((r.losses.l2.channels[c] - d).abs() < 1e-12 * d);
    }
    // cosine: sqrt(Σ w (d cos θi)² / Σ w), by hand over the same cells and weights.
    let data = FitData::from_table(&t).unwrap();
    let w = data.measure();
    let wsum: f64 = w.iter().sum();
    let cz = &data.geometry().wi_z;
    let cos_l = (w
        .iter()
        .zip(cz)
        .map(|(w, c)| w * (d * c).powi(2))
        .sum::<f64>()
        / wsum)
        .sqrt();
    assert!((r.losses.cosine.overall - cos_l).abs() < 1e-12 * cos_l);
    let cbrt_l = (w
        .iter()
        .zip(cz)
        .map(|(w, c)| w * ((0.4 / PI * c).cbrt() - (0.5 / PI * c).cbrt()).powi(2))
        .sum::<f64>()
        / wsum)
        .sqrt();
    assert!((r.losses.cbrt.overall - cbrt_l).abs() < 1e-12 * cbrt_l);
    // Every band sees the same constant l2 error.
    for b in r.theta_h_bands.iter().chain(&r.theta_d_bands) {
        let l = b
            .losses
            .as_ref()
            .expect("every band holds cells on a 30x30x60 grid");
        assert!((l.l2.overall - d).abs() < 1e-12 * d, "{b:?}");
    }
    let cells: usize = r.theta_h_bands.iter().map(|b| b.cells).sum();
    assert_eq!(cells, r.cells, "the θh bands partition the cells");
    let cells: usize = r.theta_d_bands.iter().map(|b| b.cells).sum();
    assert_eq!(cells, r.cells, "the θd bands partition the cells");
    let p = r.relative_error.overall.unwrap();
    for x in [p.p50, p.p90, p.p99] {
        assert!((x - 0.2).abs() < 1e-12, "{p:?}");
    }
    assert_eq!(r.relative_error.samples, 3 * r.cells);
    for a in &r.albedo {
        assert!((a.difference.unwrap().r() + 0.1).abs() < 1e-9, "{a:?}");
    }
}

#[test]
fn percentiles_follow_the_nearest_rank_definition() {
    // Fit 0.4 against a table whose channels are 0.5, 0.8 and 0.4: relative errors
    // 0.2, 0.5, 0 in equal numbers. Pooled, the 50th percentile is 0.2 (rank ⌈n/2⌉ of
    // 3m values sorted 0…0, 0.2…0.2, 0.5…0.5 falls in the middle third) and the
    // 90th and 99th are 0.5.
    let r = quality_of(
        r#"{"model": "lambert", "params": {"rho_d": [0.5, 0.8, 0.4]}}"#,
        r#"{"model": "lambert", "params": {"rho_d": 0.4}}"#,
    );
    let p = r.relative_error.overall.unwrap();
    assert!(
        (p.p50 - 0.2).abs() < 1e-12 && (p.p90 - 0.5).abs() < 1e-12 && (p.p99 - 0.5).abs() < 1e-12,
        "{p:?}"
    );
    let b = r.relative_error.channels[2].unwrap();
    assert!(b.p99 < 1e-15);
}

#[test]
fn bands_locate_a_missed_specular_peak() {
    // A glossy table fitted by its diffuse part only: the error sits at small θh.
    let t = table(
        r#"{"model": "cook-torrance", "params": {"rho_d": 0.3, "rho_s": 0.5, "alpha": 0.05, "fresnel": "none"}}"#,
    );
    let r = fit_quality(
        &t,
        &shared(r#"{"model": "lambert", "params": {"rho_d": 0.3}}"#),
    )
    .unwrap();
    let cbrt = |b: &brdfkit_validate::quality::Band| b.losses.as_ref().unwrap().cbrt.overall;
    let peak = cbrt(&r.theta_h_bands[0]);
    let far = cbrt(r.theta_h_bands.last().unwrap());
    assert!(peak > 10.0 * far, "peak {peak} far {far}");
    let text = r.to_string();
    assert!(
        text.contains("by θh band") && text.contains("by θd band"),
        "{text}"
    );
    // The fit misses the specular energy.
    assert!(
        r.albedo[0].difference.unwrap().r() < -0.1,
        "{:?}",
        r.albedo[0]
    );
}

#[test]
fn per_channel_fits_are_scored_channel_by_channel() {
    let t = table(r#"{"model": "lambert", "params": {"rho_d": [0.2, 0.5, 0.8]}}"#);
    let f = fitted_from_json(&serde_json::json!({"per_channel": [
        {"model": "lambert", "params": {"rho_d": 0.2}},
        {"model": "lambert", "params": {"rho_d": 0.5}},
        {"model": "lambert", "params": {"rho_d": [0.0, 0.0, 0.8]}},
    ]}))
    .unwrap();
    let r = fit_quality(&t, &f).unwrap();
    assert!(r.losses.cbrt.overall < 1e-15, "{:?}", r.losses.cbrt);
    assert!(fitted_from_json(&serde_json::json!({"per_channel": [1, 2]})).is_err());
}

#[test]
fn stratified_split_partitions_every_stratum() {
    let data = FitData::from_table(&table(r#"{"model": "lambert"}"#)).unwrap();
    let (a, b) = stratified_split(&data, 0.3, 7);
    assert_eq!(a.len() + b.len(), data.len());
    let frac = a.len() as f64 / data.len() as f64;
    assert!((frac - 0.3).abs() < 0.02, "{frac}");
    let (a2, _) = stratified_split(&data, 0.3, 7);
    assert_eq!(a.theta_h(), a2.theta_h(), "seeded");
    let (a3, _) = stratified_split(&data, 0.3, 8);
    assert_ne!(a.theta_h(), a3.theta_h());
}

#[test]
fn held_out_validation_of_a_well_posed_fit_generalises() {
    let truth =
        from_json_str(r#"{"model": "lambert", "params": {"rho_d": [0.2, 0.5, 0.8]}}"#).unwrap();
    let mut data = synth_data(truth.as_ref(), dims(), Coverage::AboveHorizon).unwrap();
    add_lognormal_noise(&mut data, 0.05, 3);
    let family = from_json_str(r#"{"model": "lambert"}"#).unwrap();
    let cfg = FitConfig::default().loss(Loss::Log);
    let h = held_out(family.as_ref(), &data, &cfg, 0.5, 11).unwrap();
    assert_eq!(h.train_cells + h.test_cells, data.len());
    assert_eq!(h.loss, Loss::Log);
    // One parameter per channel against thousands of noisy cells: no over-fitting.
    assert!((h.ratio - 1.0).abs() < 0.1, "ratio {}", h.ratio);
    let rho = &h.fitted["params"]["rho_d"];
    for (c, t) in [0.2, 0.5, 0.8].iter().enumerate() {
        let v = rho[c].as_f64().unwrap();
        assert!((v - t).abs() < 0.01, "rho_d[{c}] = {v}");
    }
    assert!(matches!(
        held_out(family.as_ref(), &data, &cfg, 1.0, 0),
        Err(QualityError::Option { .. })
    ));
}

#[test]
fn held_out_runs_from_the_options_and_the_report_round_trips() {
    let json = r#"{"model": "lambert", "params": {"rho_d": [0.2, 0.5, 0.8]}}"#;
    let t = table(json);
    let o = QualityOptions {
        held_out: Some(HeldOutOptions {
            family: serde_json::json!({"model": "lambert"}),
            config: FitConfig::default(),
            train_fraction: 0.25,
            seed: 5,
        }),
        ..QualityOptions::default()
    };
    let r = fit_quality_with(&t, &shared(json), &o).unwrap();
    let h = r.held_out.as_ref().unwrap();
    assert!(h.test.cbrt.overall < 1e-6, "{h:?}");
    let s = serde_json::to_string(&r).unwrap();
    let back: QualityReport = serde_json::from_str(&s).unwrap();
    assert_eq!(back, r);
    assert!(r.to_string().contains("held-out"));
    let bad = QualityOptions {
        theta_h_bands: vec![0.0, 0.2, 0.1],
        ..QualityOptions::default()
    };
    let e = fit_quality_with(&t, &shared(json), &bad).unwrap_err();
    assert!(e.to_string().contains("theta_h_bands"), "{e}");
}
