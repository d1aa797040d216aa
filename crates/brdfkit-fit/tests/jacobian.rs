//! The Jacobian of the residuals (model gradient × loss-transform slope × the
//! reparameterisation's dx/du) against central finite differences of the residuals, for
//! every loss; and the normal equations of the parallel fold against the dense JᵀJ, Jᵀr.

mod common;
use brdfkit_fit::problem::FitProblem;
use brdfkit_fit::synth::{Coverage, add_lognormal_noise};
use brdfkit_fit::{FitConfig, Loss, Weighting, resolve_free};
use common::*;

fn check(truth_json: &str, at_json: &str) {
    let truth = model(truth_json);
    let at = model(at_json);
    let mut data = synth(truth.as_ref(), dims(12, 12, 24), Coverage::AboveHorizon);
    add_lognormal_noise(&mut data, 0.05, 3);
    // Cells on the horizon to round-off (cos θi ~ 6e-17, f cos θi below the cube-root
    // floor) take the guarded slope, which differs from the true one by design; the
    // guard has its own test below.
    let data = data.filter(|m| data.geometry().wi_z[m] > 1e-9);
    let free = resolve_free(at.as_ref(), &FitConfig::default()).unwrap();
    for loss in Loss::EVERY {
        for w in [Weighting::SolidAngle, Weighting::Uniform] {
            let p =
                FitProblem::new(&data, at.as_ref(), free.clone(), vec![0, 1, 2], loss, w).unwrap();
            let u = p.start_u();
            let j = p.jacobian_dense(&u).unwrap();
            let r0 = p.residuals(&u).unwrap();
            let mut worst = 0.0f64;
            for q in 0..p.dim() {
                let fd = central_diff(&u, q, |v| p.residuals(v).unwrap());
                let col = j.column(q);
                let scale = col.amax().max(fd.amax());
                assert!(
                    scale > 0.0,
                    "{}: column {q} identically zero",
                    p.free_names()[q]
                );
                let diff = col - &fd;
                let err = diff.amax() / scale;
                worst = worst.max(err);
                assert!(
                    err < 1e-6,
                    "{} {loss} {w:?}: ∂r/∂u of {}: relative error {err:e}",
                    at.name(),
                    p.free_names()[q]
                );
            }
            // The fold gives the same JᵀJ, Jᵀr and cost as the dense matrix.
            let ne = p.normal_eq(&u);
            let jtj = j.transpose() * &j;
            let jtr = j.transpose() * &r0;
            let e1 = (&ne.jtj - &jtj).amax() / jtj.amax();
            let e2 = (&ne.jtr - &jtr).amax() / jtr.amax();
            let e3 = rel(ne.cost, 0.5 * r0.norm_squared());
            assert!(
                e1 < 1e-12 && e2 < 1e-12 && e3 < 1e-12,
                "{loss}: {e1:e} {e2:e} {e3:e}"
            );
            assert!(rel(p.cost_at(&u), ne.cost) < 1e-12);
            assert!(worst < 1e-6);
        }
    }
}

#[test]
fn cook_torrance_ggx_schlick() {
    check(
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.15}}"#,
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.5,0.4,0.2]}},"rho_d":[0.2,0.1,0.3],"rho_s":[0.3,0.6,0.2],"alpha":0.3}}"#,
    );
}

#[test]
fn plausible_phong() {
    check(
        r#"{"model":"plausible-phong","params":{"rho_d":[0.3,0.2,0.1],"rho_s":[0.2,0.3,0.4],"n":60}}"#,
        r#"{"model":"plausible-phong","params":{"rho_d":[0.2,0.25,0.15],"rho_s":[0.1,0.35,0.3],"n":25}}"#,
    );
}

#[test]
fn lafortune_with_signed_coefficient() {
    check(
        r#"{"model":"lafortune","params":{"rho_d":[0.3,0.2,0.1],"lobes":[{"cxy":-0.9,"cz":1,"n":30,"rho":[2,3,4]}]}}"#,
        r#"{"model":"lafortune","params":{"rho_d":[0.2,0.3,0.1],"lobes":[{"cxy":-1.1,"cz":1,"n":12,"rho":[1,2,3]}]}}"#,
    );
}

#[test]
fn oren_nayar() {
    check(
        r#"{"model":"oren-nayar","params":{"rho_d":[0.3,0.5,0.7],"sigma":0.4}}"#,
        r#"{"model":"oren-nayar","params":{"rho_d":[0.4,0.4,0.6],"sigma":0.2}}"#,
    );
}

/// The cube-root guard: a model that is exactly 0 where the table is positive gives
/// finite residuals and Jacobian entries.
#[test]
fn cbrt_guard_keeps_the_jacobian_finite_at_zero_model_values() {
    let truth = model(r#"{"model":"lambert","params":{"rho_d":[0.2,0.5,0.8]}}"#);
    let data = synth(truth.as_ref(), dims(8, 8, 16), Coverage::AboveHorizon);
    // ρd = 0 in red: f = 0 in every cell; the logit start is moved inside by 1e-6.
    let at = model(r#"{"model":"lambert","params":{"rho_d":[0.0,0.5,0.8]}}"#);
    let p = FitProblem::new(
        &data,
        at.as_ref(),
        vec![0, 1, 2],
        vec![0, 1, 2],
        Loss::Cbrt,
        Weighting::SolidAngle,
    )
    .unwrap();
    let mut u = p.start_u();
    u[0] = -800.0; // beyond U_MAX: f is ρ = e^-700 ≈ 1e-304 → f·cos below the floor
    let j = p.jacobian_dense(&u).unwrap();
    assert!(j.iter().all(|v| v.is_finite()));
    let ne = p.normal_eq(&u);
    assert!(ne.cost.is_finite() && ne.jtr.iter().all(|v| v.is_finite()));
}

#[test]
fn ward_and_ashikhmin_shirley() {
    check(
        r#"{"model":"ward","params":{"rho_d":[0.2,0.1,0.3],"rho_s":[0.3,0.4,0.2],"alpha":0.12}}"#,
        r#"{"model":"ward","params":{"rho_d":[0.3,0.2,0.2],"rho_s":[0.2,0.3,0.3],"alpha":0.3}}"#,
    );
    check(
        r#"{"model":"ashikhmin-shirley","params":{"rho_d":[0.4,0.3,0.2],"rho_s":[0.1,0.2,0.3],"n":300}}"#,
        r#"{"model":"ashikhmin-shirley","params":{"rho_d":[0.3,0.3,0.3],"rho_s":[0.2,0.2,0.2],"n":80}}"#,
    );
}
