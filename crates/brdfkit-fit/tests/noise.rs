//! Recovery under 5 % log-normal noise with the MERL missing pattern (cells whose
//! directions are below the horizon are missing): parameters within 1 % (shape) and
//! 1 % (albedo-like) of the truth, and the loss at the noise level.

mod common;
use brdfkit_fit::synth::{Coverage, add_lognormal_noise};
use common::*;

/// The bound this test proves.
const BOUND: f64 = 0.01;

fn noisy(truth_json: &str, start_json: &str) -> f64 {
    let truth = model(truth_json);
    let start = model(start_json);
    let mut data = synth(truth.as_ref(), dims(45, 45, 90), Coverage::AboveHorizon);
    add_lognormal_noise(&mut data, 0.05, 11);
    let (res, err, name) = fit_recovers(start.as_ref(), truth.as_ref(), &data, BOUND);
    // cbrt residual of 5 % noise: ∛(1.05) − 1 ≈ 1.6 % of each cube root.
    let l = res.record.losses_full.cbrt.overall;
    assert!(l > 1e-3 && l < 0.05, "{l}");
    eprintln!(
        "{}: worst parameter {name} {err:.2e}, cbrt loss {l:.3e}",
        truth.name()
    );
    err
}

#[test]
fn lambert_noisy() {
    noisy(
        r#"{"model":"lambert","params":{"rho_d":[0.2,0.5,0.8]}}"#,
        r#"{"model":"lambert"}"#,
    );
}

#[test]
fn cook_torrance_ggx_noisy() {
    noisy(
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},
            "rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.15}}"#,
        r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#,
    );
}

#[test]
fn cook_torrance_beckmann_noisy() {
    noisy(
        r#"{"model":"cook-torrance","params":{"distribution":"beckmann","fresnel":{"schlick":{"f0":[0.05,0.1,0.2]}},
            "rho_d":[0.3,0.2,0.1],"rho_s":[0.6,0.6,0.5],"alpha":0.3}}"#,
        r#"{"model":"cook-torrance","params":{"distribution":"beckmann","fresnel":"schlick"}}"#,
    );
}

#[test]
fn phong_family_noisy() {
    noisy(
        r#"{"model":"plausible-phong","params":{"rho_d":[0.3,0.2,0.1],"rho_s":[0.2,0.3,0.4],"n":60}}"#,
        r#"{"model":"plausible-phong"}"#,
    );
    noisy(
        r#"{"model":"blinn-phong","params":{"rho_d":[0.3,0.2,0.1],"rho_s":[0.2,0.3,0.4],"n":150}}"#,
        r#"{"model":"blinn-phong"}"#,
    );
}

#[test]
fn lafortune_and_oren_nayar_noisy() {
    noisy(
        r#"{"model":"lafortune","params":{"rho_d":[0.3,0.2,0.1],"lobes":[{"cxy":-0.9,"cz":1,"n":30,"rho":[2,3,4]}]}}"#,
        r#"{"model":"lafortune"}"#,
    );
    noisy(
        r#"{"model":"oren-nayar","params":{"rho_d":[0.3,0.5,0.7],"sigma":0.4}}"#,
        r#"{"model":"oren-nayar"}"#,
    );
}

#[test]
fn ward_and_ashikhmin_shirley_noisy() {
    noisy(
        r#"{"model":"ward","params":{"rho_d":[0.2,0.1,0.3],"rho_s":[0.3,0.4,0.2],"alpha":0.12}}"#,
        r#"{"model":"ward"}"#,
    );
    noisy(
        r#"{"model":"ashikhmin-shirley","params":{"rho_d":[0.4,0.3,0.2],"rho_s":[0.1,0.2,0.3],"n":300}}"#,
        r#"{"model":"ashikhmin-shirley"}"#,
    );
}
