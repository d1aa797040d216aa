//! The library surface the CLI uses: record contents and JSON, options (subsample,
//! cutoff, per-channel, fixed and freed parameters, weighting), every solver, the
//! observer, multi-start determinism, typed errors.

mod common;
use brdfkit_core::progress::Recorder;
use brdfkit_fit::synth::Coverage;
use brdfkit_fit::{
    Event, FitConfig, FitData, FitError, FitRecord, Loss, Sharing, SolverKind, Weighting, fit,
};
use common::*;
use std::sync::atomic::{AtomicUsize, Ordering};

const CT_TRUTH: &str = r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.15}}"#;
const CT_START: &str = r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#;

fn ct_data(d: (i64, i64, i64)) -> FitData {
    synth(
        model(CT_TRUTH).as_ref(),
        dims(d.0, d.1, d.2),
        Coverage::AboveHorizon,
    )
}

#[test]
fn record_has_every_loss_and_round_trips_through_json() {
    let data = ct_data((20, 20, 40));
    let cfg = FitConfig::default().starts(3).unwrap();
    let res = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
    let r = &res.record;
    assert_eq!(r.family, "cook-torrance");
    assert_eq!(r.loss, Loss::Cbrt);
    assert_eq!(r.starts.len(), 3);
    assert_eq!(r.starts.iter().filter(|s| s.kept).count(), 1);
    assert!(r.iterations > 0 && r.jacobian_evals > r.iterations / 2);
    let per_start: u64 = r
        .starts
        .iter()
        .map(|s| s.cost_evals + s.jacobian_evals)
        .sum();
    assert_eq!(per_start, r.cost_evals + r.jacobian_evals);
    assert!(r.wall_time_s > 0.0);
    assert_eq!(r.model, res.fitted.to_json());
    assert_eq!(r.params.len(), 10);
    assert_eq!(r.params[6].name, "alpha");
    assert_eq!(r.params[6].transform.as_deref(), Some("logit"));
    for l in Loss::ALL {
        let e = r.losses_full.get(l);
        assert!(
            e.overall < 1e-9 && e.channels.iter().all(|c| c.is_finite()),
            "{l}"
        );
    }
    let text = serde_json::to_string_pretty(r).unwrap();
    for key in [
        "\"losses_full\"",
        "\"cosine\"",
        "\"log\"",
        "\"l2\"",
        "\"termination\"",
        "\"starts\"",
        "\"wall_time_s\"",
        "\"jacobian_evals\"",
    ] {
        assert!(text.contains(key), "{key} missing");
    }
    let back: FitRecord = serde_json::from_str(&text).unwrap();
    assert_eq!(&back, r);
    // The settings are named as the Python arguments and CLI flags are; a record
    // written with the older names still reads.
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let o = v.as_object_mut().unwrap();
    for (new, old) in [
        ("theta_d_max", "theta_d_max_deg"),
        ("sample_fraction", "subsample"),
    ] {
        let x = o.remove(new).unwrap_or_else(|| panic!("{new} missing"));
        o.insert(old.to_string(), x);
    }
    let older: FitRecord = serde_json::from_value(v).unwrap();
    assert_eq!(&older, r);
    // The fitted model's JSON is the contract: it builds the same model.
    let m = brdfkit_models::from_json(&r.model).unwrap();
    assert_eq!(m.params(), res.fitted.channel_model(0).params());
}

#[test]
fn subsample_is_stratified_seeded_and_reports_the_full_loss() {
    let data = ct_data((30, 30, 60));
    let a = data.stratified_subsample(0.1, 1);
    let b = data.stratified_subsample(0.1, 1);
    let c = data.stratified_subsample(0.1, 2);
    assert_eq!(a.theta_h(), b.theta_h());
    assert_ne!(a.theta_h(), c.theta_h());
    let frac = a.len() as f64 / data.len() as f64;
    assert!((frac - 0.1).abs() < 0.01, "{frac}");
    // Multiplicities make the subsample's total measure that of the full set.
    let wa: f64 = a.weights(Weighting::SolidAngle).iter().sum();
    let wf: f64 = data.weights(Weighting::SolidAngle).iter().sum();
    assert!(rel(wa, wf) < 0.05, "{wa} vs {wf}");
    let wu: f64 = a.weights(Weighting::Uniform).iter().sum();
    assert!(rel(wu, data.len() as f64) < 1e-12);

    let cfg = FitConfig::default().subsample(0.1, 1).unwrap();
    let res = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
    assert_eq!(res.record.cells_fit, a.len());
    assert_eq!(res.record.cells_full, data.len());
    assert_eq!(res.record.losses_full.cells, data.len());
    assert_eq!(res.record.subsample, Some(0.1));
    // Noise-free: the subsample recovers the truth, and the full table agrees.
    assert!(
        res.record.losses_full.cbrt.overall < 1e-10,
        "{}",
        show(&res)
    );
}

#[test]
fn theta_d_cutoff_leaves_out_grazing_cells() {
    let data = ct_data((20, 20, 40));
    let cut = 80f64.to_radians();
    let expect = data.theta_d().iter().filter(|&&t| t <= cut).count();
    assert!(expect < data.len());
    let cfg = FitConfig::default().theta_d_max_deg(80.0).unwrap();
    let res = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
    assert_eq!(res.record.cells_full, expect);
    assert_eq!(res.record.theta_d_max_deg, Some(80.0));
}

#[test]
fn per_channel_fits_three_models() {
    let data = ct_data((20, 20, 40));
    let cfg = FitConfig::default()
        .sharing(Sharing::PerChannel)
        .starts(2)
        .unwrap();
    let res = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
    let j = res.fitted.to_json();
    assert_eq!(j["per_channel"].as_array().unwrap().len(), 3);
    assert!(res.fitted.shared().is_none());
    assert_eq!(res.record.starts.len(), 6);
    assert_eq!(res.record.starts.iter().filter(|s| s.kept).count(), 3);
    let truth = model(CT_TRUTH).params();
    for c in 0..3 {
        let p = res.fitted.channel_model(c).params();
        // Each channel's own albedos and the (common) roughness come back.
        for q in [c, 3 + c, 6, 7 + c] {
            assert!(
                rel(p[q], truth[q]) < 1e-4,
                "channel {c} param {q}: {} vs {}",
                p[q],
                truth[q]
            );
        }
    }
    assert!(
        res.record.termination.starts_with("r: "),
        "{}",
        res.record.termination
    );
}

#[test]
fn fixed_and_freed_parameters() {
    let data = ct_data((20, 20, 40));
    // alpha fixed at a wrong value: it stays there.
    let start = model(r#"{"model":"cook-torrance","params":{"fresnel":"schlick","alpha":0.3}}"#);
    let cfg = FitConfig::default().fix_params(["alpha"]);
    let res = fit(start.as_ref(), &data, &cfg, None).unwrap();
    assert_eq!(res.fitted.channel_model(0).params()[6], 0.3);
    assert!(!res.record.params[6].free);
    assert!(!res.record.free_params.contains(&"alpha".to_string()));
    // Lafortune's cz is fixed by default and can be freed by name.
    let l = model(r#"{"model":"lafortune"}"#);
    let specs = l.param_specs();
    let cz = specs.iter().position(|s| s.name == "lobes[0].cz").unwrap();
    let lt = model(
        r#"{"model":"lafortune","params":{"rho_d":0.2,"lobes":[{"cxy":-0.9,"cz":1,"n":30,"rho":2}]}}"#,
    );
    let ldata = synth(lt.as_ref(), dims(15, 15, 30), Coverage::AboveHorizon);
    let res = fit(
        l.as_ref(),
        &ldata,
        &FitConfig::default().max_iters(5).unwrap(),
        None,
    )
    .unwrap();
    assert!(!res.record.params[cz].free);
    let res = fit(
        l.as_ref(),
        &ldata,
        &FitConfig::default()
            .free_params(["lobes[0].cz"])
            .max_iters(5)
            .unwrap(),
        None,
    )
    .unwrap();
    assert!(res.record.params[cz].free);
    assert_eq!(res.record.params[cz].transform.as_deref(), Some("asinh"));
    // Group names: `rho_d` frees or fixes all three channels.
    let res = fit(
        start.as_ref(),
        &data,
        &FitConfig::default().fix_params(["rho_d"]),
        None,
    )
    .unwrap();
    assert!(res.record.params[..3].iter().all(|p| !p.free));
}

#[test]
fn typed_errors() {
    let data = ct_data((10, 10, 20));
    let e = fit(
        model(CT_START).as_ref(),
        &data,
        &FitConfig::default().fix_params(["alhpa"]),
        None,
    )
    .unwrap_err();
    assert!(matches!(e, FitError::UnknownParam { .. }));
    assert!(
        e.to_string().contains("alhpa") && e.to_string().contains("alpha"),
        "{e}"
    );
    let all = ["rho_d", "rho_s", "alpha", "f0"];
    let e = fit(
        model(CT_START).as_ref(),
        &data,
        &FitConfig::default().fix_params(all),
        None,
    )
    .unwrap_err();
    assert!(matches!(e, FitError::NothingToFit(_)), "{e}");
    let e = FitData::from_parts(
        data.geometry().clone(),
        [vec![0.0; 3], vec![0.0; 3], vec![0.0; 3]],
        vec![1.0; 3],
    )
    .unwrap_err();
    assert!(e.to_string().contains("values"), "{e}");
    let mut bad = data.values().clone();
    bad[1][4] = f64::NAN;
    let e = FitData::from_parts(data.geometry().clone(), bad, data.measure().to_vec()).unwrap_err();
    assert!(
        e.to_string().contains("channel 1") && e.to_string().contains("cell 4"),
        "{e}"
    );
    let empty = brdfkit_merl::MerlTable::all_missing(dims(4, 4, 8));
    assert!(matches!(
        FitData::from_table(&empty),
        Err(FitError::NoCells(_))
    ));
}

#[test]
fn every_solver_reaches_the_truth_on_an_easy_problem() {
    let truth = model(
        r#"{"model":"plausible-phong","params":{"rho_d":[0.3,0.2,0.1],"rho_s":[0.2,0.3,0.4],"n":60}}"#,
    );
    let data = synth(truth.as_ref(), dims(20, 20, 40), Coverage::AboveHorizon);
    let start = model(r#"{"model":"plausible-phong","params":{"rho_d":0.25,"rho_s":0.25,"n":40}}"#);
    for (solver, tol) in [
        (SolverKind::Lm, 1e-8),
        (SolverKind::GaussNewton, 1e-8),
        (SolverKind::TrustRegion, 1e-5),
        (SolverKind::Lbfgs, 1e-4),
        (SolverKind::NelderMead, 1e-2),
    ] {
        let res = fit(
            start.as_ref(),
            &data,
            &FitConfig::default().solver(solver),
            None,
        )
        .unwrap();
        let (err, name) = worst_param(&res, truth.as_ref());
        assert!(err < tol, "{solver}: {name} off by {err:e}: {}", show(&res));
        assert_eq!(res.record.solver, solver);
        eprintln!(
            "{solver}: worst {err:.1e}, iterations {}, {}",
            res.record.iterations, res.record.termination
        );
    }
}

#[test]
fn uniform_weighting_and_every_loss_recover_the_truth() {
    let data = ct_data((20, 20, 40));
    for loss in Loss::ALL {
        for w in [Weighting::SolidAngle, Weighting::Uniform] {
            let cfg = FitConfig::default().loss(loss).weighting(w);
            let res = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
            let (err, name) = worst_param(&res, model(CT_TRUTH).as_ref());
            assert!(err < 1e-4, "{loss} {w:?}: {name} {err:e}: {}", show(&res));
        }
    }
}

/// The events of a fit, recorded: the plan first, every iteration of every start, each
/// start's end after all of its iterations, and each stage's end in the order they run.
#[test]
fn observer_sees_every_start_and_iteration() {
    let data = ct_data((15, 15, 30));
    let rec = Recorder::new();
    let cfg = FitConfig::default().starts(4).unwrap();
    let res = fit(model(CT_START).as_ref(), &data, &cfg, Some(&rec)).unwrap();
    let ev = rec.events();
    assert!(
        matches!(&ev[0], Event::FitPlanned(p) if p.starts == 4 && p.passes == 1),
        "{:?}",
        ev[0]
    );
    assert_eq!(
        ev.iter()
            .filter(|e| matches!(e, Event::FitPlanned(_)))
            .count(),
        1
    );
    let mut done = [false; 4];
    let mut iters = 0u64;
    let mut stages = Vec::new();
    for e in &ev[1..] {
        match e {
            Event::Iteration(i) => {
                assert!(i.cost.is_finite() && i.start < 4, "{i:?}");
                assert!(
                    !done[i.start],
                    "an iteration of start {} after its end",
                    i.start
                );
                iters += 1;
            }
            Event::StartDone(d) => {
                assert!(d.loss.is_finite(), "{d:?}");
                assert!(!done[d.start], "start {} ended twice", d.start);
                done[d.start] = true;
            }
            Event::StageDone {
                stage,
                channel: None,
                seconds,
            } => {
                stages.push((*stage, *seconds));
            }
            other => panic!("a fit sent {other:?}"),
        }
    }
    assert_eq!(done, [true; 4]);
    // The same figures as the result's stage times, bit for bit.
    assert_eq!(stages, res.stages.stages());
    let total: u64 = res.record.starts.iter().map(|s| s.iterations).sum();
    assert_eq!(iters, total);
}

#[test]
fn starts_are_deterministic_and_spread_over_the_shape_parameter() {
    let data = ct_data((15, 15, 30));
    let cfg = FitConfig::default().starts(5).unwrap().seed(9);
    let a = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
    let b = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
    let sa: Vec<Vec<f64>> = a.record.starts.iter().map(|s| s.start.clone()).collect();
    let sb: Vec<Vec<f64>> = b.record.starts.iter().map(|s| s.start.clone()).collect();
    assert_eq!(sa, sb);
    let finals_a: Vec<Option<f64>> = a.record.starts.iter().map(|s| s.final_loss).collect();
    let finals_b: Vec<Option<f64>> = b.record.starts.iter().map(|s| s.final_loss).collect();
    assert_eq!(finals_a, finals_b, "same seed, same fits");
    // alpha (index 6 of the free list) differs between starts; albedos do not.
    let alphas: Vec<f64> = sa.iter().map(|s| s[6]).collect();
    for i in 0..alphas.len() {
        for j in 0..i {
            assert_ne!(alphas[i], alphas[j]);
        }
    }
    assert!(sa.iter().all(|s| s[0] == sa[0][0]));
    // The grid spans two decades either side of the default.
    let (lo, hi) = alphas
        .iter()
        .fold((f64::MAX, 0.0f64), |(l, h), &a| (l.min(a), h.max(a)));
    assert!(lo < 0.02 && hi > 0.9, "{alphas:?}");
}

/// The warm-up changes the path, not the answer: on a noisy table big enough to use it,
/// the fit with and without warm-up ends at the same parameters.
#[test]
fn warm_up_does_not_change_the_optimum() {
    let mut data = ct_data((90, 45, 90));
    brdfkit_fit::synth::add_lognormal_noise(&mut data, 0.05, 4);
    let cfg = FitConfig::default();
    assert!(
        cfg.warm_up_cells_for(data.len()).is_some(),
        "{} cells",
        data.len()
    );
    let warm = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
    let cold_cfg = FitConfig::default().warm_up(None).unwrap();
    let cold = fit(model(CT_START).as_ref(), &data, &cold_cfg, None).unwrap();
    assert!(warm.record.starts[0].warm_up.is_some());
    assert!(cold.record.starts[0].warm_up.is_none());
    let a = warm.fitted.channel_model(0).params();
    let b = cold.fitted.channel_model(0).params();
    for (x, y) in a.iter().zip(&b) {
        assert!(rel(*x, *y) < 1e-6, "{a:?} vs {b:?}");
    }
    // And the full-table stage after a warm-up needs only a few iterations.
    assert!(warm.record.iterations <= 5, "{}", show(&warm));
}

/// A run that stops on its iteration cap is reported as such, not as converged, and
/// keeps the best point it reached.
#[test]
fn an_iteration_cap_is_not_convergence() {
    let data = ct_data((15, 15, 30));
    let cfg = FitConfig::default().max_iters(1).unwrap();
    let res = fit(model(CT_START).as_ref(), &data, &cfg, None).unwrap();
    assert!(!res.record.converged, "{}", show(&res));
    assert_eq!(res.record.termination, "maximum iterations reached");
    assert!(!res.record.starts[0].converged);
    let start_loss = {
        let m = model(CT_START);
        let m: &dyn brdfkit_core::Model = m.as_ref();
        brdfkit_fit::evaluate_losses([m, m, m], &data, Weighting::SolidAngle)
            .cbrt
            .overall
    };
    assert!(res.record.losses_full.cbrt.overall < start_loss);
}

/// The table path: a MERL table written to disk, read back and fitted.
#[test]
fn fit_a_table_read_from_disk() {
    let truth = model(CT_TRUTH);
    let table = brdfkit_merl::MerlTable::from_brdf(truth.as_ref(), dims(30, 30, 60)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ct.binary");
    table.write(&path).unwrap();
    let back = brdfkit_merl::MerlTable::read(&path).unwrap();
    let res = brdfkit_fit::fit_table(model(CT_START).as_ref(), &back, &FitConfig::default(), None)
        .unwrap();
    assert_eq!(res.record.cells_full, table.valid_count());
    // The table stores raw = value / scale, so values come back within an ulp or so:
    // the parameters within 1e-9.
    let (err, name) = worst_param(&res, truth.as_ref());
    assert!(err < 1e-9, "{name} {err:e}");
}

#[test]
fn a_closure_can_observe() {
    let data = ct_data((10, 10, 20));
    let n = AtomicUsize::new(0);
    let count = |e: &Event| {
        if matches!(e, Event::Iteration(_)) {
            n.fetch_add(1, Ordering::Relaxed);
        }
    };
    let res = fit(
        model(CT_START).as_ref(),
        &data,
        &FitConfig::default(),
        Some(&count),
    )
    .unwrap();
    assert_eq!(
        n.load(Ordering::Relaxed) as u64,
        res.record.starts[0].iterations
    );
}

/// Per-channel fits are independent: a table whose channels come from models with
/// different roughness gives each channel its own α back (a shared fit cannot).
#[test]
fn per_channel_fits_recover_different_roughness_per_channel() {
    let alphas = [0.1, 0.15, 0.25];
    let base = ct_data((20, 20, 40));
    let mut data = base.clone();
    for (c, a) in alphas.iter().enumerate() {
        let m = model(&format!(
            r#"{{"model":"cook-torrance","params":{{"fresnel":{{"schlick":{{"f0":0.5}}}},"rho_d":0.2,"rho_s":0.4,"alpha":{a}}}}}"#
        ));
        let v = base.with_model_values(m.as_ref());
        data.values_mut()[c] = v.values()[c].clone();
    }
    let per = fit(
        model(CT_START).as_ref(),
        &data,
        &FitConfig::default().sharing(Sharing::PerChannel),
        None,
    )
    .unwrap();
    for (c, a) in alphas.iter().enumerate() {
        let got = per.fitted.channel_model(c).params()[6];
        assert!(rel(got, *a) < 1e-8, "channel {c}: alpha {got} vs {a}");
    }
    assert!(per.record.losses_full.cbrt.overall < 1e-12);
    let shared = fit(model(CT_START).as_ref(), &data, &FitConfig::default(), None).unwrap();
    assert!(
        shared.record.losses_full.cbrt.overall > 1e-3,
        "one α cannot fit three"
    );
}
