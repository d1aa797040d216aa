//! Robust losses (Huber, Cauchy): the IRLS normal equations against an independent
//! dense computation and finite differences of the robust cost; a scale above every
//! residual gives the plain problem back; outliers pull a plain fit off and the robust
//! fits recover the truth; the record reports the stage.

mod common;
use brdfkit_fit::problem::FitProblem;
use brdfkit_fit::synth::{Coverage, add_lognormal_noise};
use brdfkit_fit::{
    FitConfig, FitData, FitRecord, Loss, Robust, RobustKind, Weighting, fit, resolve_free,
};
use common::*;
use nalgebra::{DMatrix, DVector};

const TRUTH: &str = r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.15}}"#;
const START: &str = r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#;

/// Multiplies every `every`-th cell (all channels) by `factor`.
fn spike(data: &mut FitData, every: usize, offset: usize, factor: f64) -> usize {
    let n = data.len();
    let mut hit = 0;
    for plane in data.values_mut().iter_mut() {
        hit = 0;
        for k in (offset..n).step_by(every) {
            plane[k] *= factor;
            hit += 1;
        }
    }
    hit
}

#[test]
fn irls_normal_equations_match_a_dense_computation_and_finite_differences() {
    let truth = model(TRUTH);
    let mut data = synth(truth.as_ref(), dims(12, 12, 24), Coverage::AboveHorizon);
    add_lognormal_noise(&mut data, 0.05, 3);
    spike(&mut data, 97, 5, 1000.0);
    // As in jacobian.rs: off the horizon, where the cube-root slope is the true one.
    let data = data.filter(|m| data.geometry().wi_z[m] > 1e-9);
    let at = model(START);
    let free = resolve_free(at.as_ref(), &FitConfig::default()).unwrap();
    for loss in Loss::ALL {
        // Uniform weights: s = 1/sqrt(3n) for every cell, so e = r/s is known here.
        let plain = FitProblem::new(
            &data,
            at.as_ref(),
            free.clone(),
            vec![0, 1, 2],
            loss,
            Weighting::Uniform,
        )
        .unwrap();
        let u = plain.start_u();
        let r = plain.residuals(&u).unwrap();
        let j = plain.jacobian_dense(&u).unwrap();
        let s = (1.0 / (3.0 * data.len() as f64)).sqrt();
        let mut e: Vec<f64> = r.iter().map(|x| (x / s).abs()).collect();
        e.sort_by(f64::total_cmp);
        // A scale at the median residual: half the residuals beyond it.
        let c = e[e.len() / 2];
        for kind in [RobustKind::Huber, RobustKind::Cauchy] {
            let rb = Robust { kind, scale: c };
            let p = plain.with_robust(rb);
            let ne = p.normal_eq(&u);
            // Independent: F = ½ Σ s² ρ(e²), g = Σ ρ' r Jᵢ, H = Σ ρ' JᵢᵀJᵢ from the
            // dense plain residuals and Jacobian.
            let mut cost = 0.0;
            let mut wj = DMatrix::zeros(j.nrows(), j.ncols());
            let mut wr = DVector::zeros(r.len());
            for i in 0..r.len() {
                let ei = r[i] / s;
                let (rho, w) = rb.rho(ei * ei);
                cost += 0.5 * s * s * rho;
                wj.row_mut(i).copy_from(&(j.row(i) * w));
                wr[i] = w * r[i];
            }
            let h = j.transpose() * &wj;
            let g = j.transpose() * &wr;
            assert!(
                rel(ne.cost, cost) < 1e-12,
                "{loss} {kind}: cost {} vs {cost}",
                ne.cost
            );
            assert!(
                (&ne.jtr - &g).amax() <= 1e-11 * g.amax(),
                "{loss} {kind}: gradient"
            );
            assert!(
                (&ne.jtj - &h).amax() <= 1e-11 * h.amax(),
                "{loss} {kind}: IRLS matrix"
            );
            assert!(rel(p.cost_at(&u), cost) < 1e-12, "{loss} {kind}: cost pass");
            // The gradient is that of the robust cost itself (central differences).
            for q in 0..p.dim() {
                let fd = central_diff(&u, q, |v| p.cost_at(v));
                assert!(
                    (fd - ne.jtr[q]).abs() <= 1e-5 * ne.jtr.amax(),
                    "{loss} {kind}: ∂F/∂u of {}: fd {fd} vs {}",
                    p.free_names()[q],
                    ne.jtr[q]
                );
            }
            // Down-weighting: the robust cost never exceeds the plain one (ρ(z) ≤ z).
            assert!(ne.cost <= plain.cost_at(&u) * (1.0 + 1e-12));
        }
        // A Huber scale above every residual is the plain problem, exactly.
        let big = plain.with_robust(Robust {
            kind: RobustKind::Huber,
            scale: 2.0 * e[e.len() - 1],
        });
        let (a, b) = (plain.normal_eq(&u), big.normal_eq(&u));
        assert!(rel(a.cost, b.cost) < 1e-14);
        assert!((&a.jtr - &b.jtr).amax() <= 1e-14 * a.jtr.amax());
        assert!((&a.jtj - &b.jtj).amax() <= 1e-14 * a.jtj.amax());
        // No robust kind, or a meaningless scale: the plain problem.
        assert!(
            plain
                .with_robust(Robust {
                    kind: RobustKind::None,
                    scale: 1.0
                })
                .robust()
                .is_none()
        );
        assert!(
            plain
                .with_robust(Robust {
                    kind: RobustKind::Huber,
                    scale: 0.0
                })
                .robust()
                .is_none()
        );
    }
}

/// The outlier table of the crate's own check: 2 % noise, 1 cell in 211 (0.47 %)
/// multiplied by 1000.
fn outlier_data() -> (Box<dyn brdfkit_core::Model>, FitData) {
    let truth = model(TRUTH);
    let mut data = synth(truth.as_ref(), dims(24, 24, 48), Coverage::AboveHorizon);
    add_lognormal_noise(&mut data, 0.02, 11);
    spike(&mut data, 211, 17, 1000.0);
    (truth, data)
}

#[test]
fn robust_fits_recover_what_outliers_pull_off() {
    let (truth, data) = outlier_data();
    let start = model(START);
    let plain = fit(start.as_ref(), &data, &FitConfig::default(), None).unwrap();
    let (pe, pn) = worst_param(&plain, truth.as_ref());
    eprintln!("plain: worst {pn} {pe:.3e}");
    for kind in [RobustKind::Huber, RobustKind::Cauchy] {
        let cfg = FitConfig::default().robust(kind, None).unwrap();
        let res = fit(start.as_ref(), &data, &cfg, None).unwrap();
        let (re, rn) = worst_param(&res, truth.as_ref());
        eprintln!("{kind}: worst {rn} {re:.3e}; {:?}", res.record.robust);
        let rr = res.record.robust.as_ref().expect("robust record");
        assert_eq!(rr.kind, kind);
        assert_eq!(rr.scale_source, "auto");
        assert!(rr.scale[0] > 0.0 && rr.scale[0].is_finite());
        assert!(res.record.converged, "{}", show(&res));
        assert!(re < 0.01, "{kind}: {rn} off by {re:e}");
        assert!(pe > 10.0 * re, "plain {pe:e} vs {kind} {re:e}");
        // The record round-trips with its robust stage.
        let text = serde_json::to_string(&res.record).unwrap();
        let back: FitRecord = serde_json::from_str(&text).unwrap();
        assert_eq!(back, res.record);
    }
    assert!(
        pe > 0.05,
        "the outliers should pull the plain fit off: {pn} {pe:e}"
    );
    // A plain record has no robust entry, and reads back.
    assert!(plain.record.robust.is_none());
    let v = serde_json::to_value(&plain.record).unwrap();
    assert!(v.get("robust").is_none());
}

#[test]
fn a_given_scale_is_used_from_the_start() {
    let (truth, data) = outlier_data();
    let start = model(START);
    let cfg = FitConfig::default()
        .robust(RobustKind::Cauchy, Some(0.01))
        .unwrap();
    let res = fit(start.as_ref(), &data, &cfg, None).unwrap();
    let rr = res.record.robust.as_ref().unwrap();
    assert_eq!(
        (rr.scale.as_slice(), rr.scale_source.as_str()),
        (&[0.01][..], "given")
    );
    assert!(rr.plain_stage_loss.is_empty());
    let (re, rn) = worst_param(&res, truth.as_ref());
    assert!(re < 0.01, "{rn} {re:e}");
    // Per-channel fits get a scale per pass.
    let cfg = FitConfig::default()
        .robust(RobustKind::Huber, None)
        .unwrap()
        .sharing(brdfkit_fit::Sharing::PerChannel);
    let res = fit(start.as_ref(), &data, &cfg, None).unwrap();
    let rr = res.record.robust.as_ref().unwrap();
    assert_eq!(rr.scale.len(), 3);
    assert_eq!(rr.plain_stage_loss.len(), 3);
    assert!(rr.objective.iter().all(|v| v.is_finite()));
}
