//! Stability: hard tables and far starts give finite parameters, a termination reason
//! and a bounded loss, never a panic or a NaN.

mod common;
use brdfkit_fit::synth::{Coverage, drop_cells};
use brdfkit_fit::{FitConfig, FitData, FitResult, fit};
use common::*;

/// Fits and checks the invariants every fit must keep; returns the result.
fn sane(start_json: &str, data: &FitData, cfg: &FitConfig) -> FitResult {
    let start = model(start_json);
    let res = fit(start.as_ref(), data, cfg, None).unwrap();
    for c in 0..3 {
        let p = res.fitted.channel_model(c).params();
        assert!(
            p.iter().all(|v| v.is_finite()),
            "NaN parameter: {}",
            show(&res)
        );
    }
    assert!(!res.record.termination.is_empty());
    for s in &res.record.starts {
        assert!(!s.termination.is_empty());
    }
    // Never worse than where it started (start 0 is always among the starts).
    let start_loss = {
        let m = start.as_ref();
        brdfkit_fit::evaluate_losses([m, m, m], data, cfg.get_weighting())
            .get(cfg.get_loss())
            .overall
    };
    let l = res.record.losses_full.get(cfg.get_loss()).overall;
    assert!(
        l.is_finite() && l <= start_loss * (1.0 + 1e-12),
        "{l} vs start {start_loss}"
    );
    res
}

#[test]
fn near_mirror_ggx() {
    let truth = model(
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":0.9}},"rho_d":0.05,"rho_s":0.8,"alpha":0.002}}"#,
    );
    let data = synth(truth.as_ref(), dims(90, 45, 90), Coverage::AboveHorizon);
    let res = sane(
        r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#,
        &data,
        &FitConfig::default().starts(3).unwrap(),
    );
    // The lobe lives in the first few θh bins; the fit finds it.
    let a = res.fitted.channel_model(0).params()[6];
    assert!(rel(a, 0.002) < 0.05, "alpha {a}: {}", show(&res));
}

#[test]
fn pure_lambert_drives_rho_s_to_zero() {
    let truth = model(r#"{"model":"lambert","params":{"rho_d":[0.2,0.5,0.8]}}"#);
    let data = synth(truth.as_ref(), dims(30, 30, 60), Coverage::AboveHorizon);
    let res = sane(
        r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#,
        &data,
        &FitConfig::default(),
    );
    let p = res.fitted.channel_model(0).params();
    for c in 0..3 {
        assert!(rel(p[c], [0.2, 0.5, 0.8][c]) < 1e-3, "rho_d {p:?}");
        assert!(p[3 + c] < 1e-3, "rho_s {p:?}");
    }
    assert!(res.record.losses_full.cbrt.overall < 1e-3, "{}", show(&res));
}

#[test]
fn sixty_percent_missing() {
    let truth = model(
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.15}}"#,
    );
    let full = synth(truth.as_ref(), dims(45, 45, 90), Coverage::AboveHorizon);
    let data = drop_cells(&full, 0.6, 5);
    assert!((data.len() as f64 / full.len() as f64 - 0.4).abs() < 0.01);
    let res = sane(
        r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#,
        &data,
        &FitConfig::default(),
    );
    let (err, name) = worst_param(&res, truth.as_ref());
    assert!(err < 1e-4, "{name} {err:e}");
}

#[test]
fn one_channel_all_zero() {
    let truth = model(
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":0.5}},"rho_d":[0.1,0.2,0.0],"rho_s":[0.5,0.4,0.0],"alpha":0.15}}"#,
    );
    let data = synth(truth.as_ref(), dims(30, 30, 60), Coverage::AboveHorizon);
    assert!(data.values()[2].iter().all(|&v| v == 0.0));
    for cfg in [
        FitConfig::default(),
        FitConfig::default().sharing(brdfkit_fit::Sharing::PerChannel),
    ] {
        let res = sane(
            r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#,
            &data,
            &cfg,
        );
        let p = res.fitted.channel_model(2).params();
        assert!(p[2] < 1e-3 && p[5] < 1e-3, "blue albedos {p:?}");
        let a = res.fitted.channel_model(0).params()[6];
        assert!(rel(a, 0.15) < 1e-3, "alpha {a}: {}", show(&res));
    }
}

#[test]
fn far_starts() {
    let truth = model(
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.15}}"#,
    );
    let data = synth(truth.as_ref(), dims(20, 20, 40), Coverage::AboveHorizon);
    for start in [
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":0.999}},"rho_d":0.999,"rho_s":0.0001,"alpha":50}}"#,
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":0.0}},"rho_d":0.0,"rho_s":1.0,"alpha":0.0001}}"#,
    ] {
        for solver in brdfkit_fit::SolverKind::ALL {
            let cfg = FitConfig::default().solver(solver).max_iters(300).unwrap();
            sane(start, &data, &cfg);
        }
    }
    let pp = model(r#"{"model":"plausible-phong","params":{"rho_d":0.3,"rho_s":0.3,"n":60}}"#);
    let data = synth(pp.as_ref(), dims(20, 20, 40), Coverage::AboveHorizon);
    sane(
        r#"{"model":"plausible-phong","params":{"n":10000,"rho_s":0.99,"rho_d":0.0}}"#,
        &data,
        &FitConfig::default(),
    );
}
