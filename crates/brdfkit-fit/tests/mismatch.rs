//! Model mismatch: Phong-type lobes and Ward fitted to a GGX table converge, and the
//! ranking by loss is the one the literature reports for microfacet data (Ngan et al.
//! 2005: microfacet models fit best; Phong-type lobes and Ward come after).

mod common;
use brdfkit_fit::synth::Coverage;
use brdfkit_fit::{FitConfig, FitData, fit};
use common::*;

fn loss_of(start_json: &str, data: &FitData) -> f64 {
    let start = model(start_json);
    let cfg = FitConfig::default().starts(4).unwrap();
    let res = fit(start.as_ref(), data, &cfg, None).unwrap();
    assert!(
        res.record.converged,
        "{} did not converge: {}",
        start.name(),
        show(&res)
    );
    let p = res.fitted.channel_model(0).params();
    assert!(p.iter().all(|v| v.is_finite()));
    let l = res.record.losses_full.cbrt.overall;
    eprintln!("{}: cbrt loss {l:.4e}, params {p:?}", start.name());
    l
}

#[test]
fn ranking_on_ggx_data() {
    let truth = model(
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},
            "rho_d":[0.05,0.1,0.15],"rho_s":[0.6,0.5,0.4],"alpha":0.12}}"#,
    );
    let data = synth(truth.as_ref(), dims(45, 45, 90), Coverage::AboveHorizon)
        .stratified_subsample(0.3, 1);
    let ggx = loss_of(
        r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#,
        &data,
    );
    let beckmann = loss_of(
        r#"{"model":"cook-torrance","params":{"distribution":"beckmann","fresnel":"schlick"}}"#,
        &data,
    );
    let blinn = loss_of(r#"{"model":"blinn-phong"}"#, &data);
    let pphong = loss_of(r#"{"model":"plausible-phong"}"#, &data);
    assert!(ggx < 1e-10, "the generating family fits exactly: {ggx}");
    assert!(ggx < beckmann, "{ggx} {beckmann}");
    // Microfacet beats the Phong-type lobes. (Blinn-Phong vs plausible-Phong is not
    // asserted: on this bright GGX lobe Blinn-Phong's ρs hits its bound of 1, which
    // costs it more than its half-vector shape gains; measured 0.0745 vs 0.0711.)
    assert!(
        beckmann < blinn.min(pphong),
        "{beckmann} vs {blinn}, {pphong}"
    );
    if registered("ward") {
        let ward = loss_of(r#"{"model":"ward"}"#, &data);
        assert!(beckmann < ward, "microfacet {beckmann} vs ward {ward}");
    }
    // A mismatched model still fits a GGX lobe to a few percent of a cube root.
    assert!(pphong < 0.2, "{pphong}");
}
