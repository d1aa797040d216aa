//! The report on scattered data against known answers: samples of a model scored
//! against the model itself (every loss and residual 0) and against the model at twice
//! its albedo (every residual band log10 2, the l2 loss the RMS of f by hand); a
//! `.bsdf`'s points rendered from the file; samples with no measured sphere.

use brdfkit_core::{Model, Vec3};
use brdfkit_fit::{FitData, Fitted, InputInfo, Measured, Sample};
use brdfkit_validate::html::{
    AnyReport, ModelFit, Origin, ReportOptions, ScatteredSide, build_any_report,
    build_scattered_report, renders::RenderOptions,
};
use std::path::Path;

fn lambert(rho: f64) -> Box<dyn Model> {
    brdfkit_models::from_json_str(&format!(
        r#"{{"model": "lambert", "params": {{"rho_d": [{rho}, {rho}, {rho}]}}}}"#
    ))
    .unwrap()
}

fn given(label: &str, m: Box<dyn Model>) -> ModelFit {
    ModelFit {
        label: label.into(),
        fitted: Fitted::Shared(m),
        record: None,
        origin: Origin::Given,
    }
}

/// `n` samples of `m` on a golden-ratio sequence over the hemisphere above 5°.
fn samples(m: &dyn Model, n: usize) -> FitData {
    let dir = |a: f64, b: f64| {
        let z = 0.0872 + (1.0 - 0.0872) * a;
        let (r, phi) = ((1.0 - z * z).sqrt(), std::f64::consts::TAU * b);
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    let g = [
        0.618_033_988_749_895,
        0.754_877_666_246_693,
        0.569_840_290_998_053,
        0.438_579_073_460_287,
    ];
    let s: Vec<Sample> = (1..=n)
        .map(|k| {
            let u: Vec<f64> = g.iter().map(|x| (k as f64 * x).fract()).collect();
            let (wi, wo) = (dir(u[0], u[1]), dir(u[2], u[3]));
            Sample {
                wi,
                wo,
                rgb: m.eval(&wi, &wo).0,
                weight: None,
            }
        })
        .collect();
    FitData::from_samples(&s, "samples", None).unwrap()
}

fn quick() -> ReportOptions {
    ReportOptions {
        render: Some(RenderOptions {
            size: 16,
            env_spp: 1,
            ..RenderOptions::default()
        }),
        checks: None,
        ..ReportOptions::default()
    }
}

#[test]
fn residuals_and_losses_of_an_exact_and_a_doubled_model() {
    let data = samples(lambert(0.4).as_ref(), 2000);
    let info = InputInfo {
        path: "s.csv".into(),
        kind: "samples".into(),
        cells: data.len(),
        samples: data.input().cloned(),
    };
    let fits = [given("exact", lambert(0.4)), given("double", lambert(0.8))];
    let r = build_scattered_report(
        &data,
        &ScatteredSide::Samples,
        info,
        &fits,
        None,
        &quick(),
        &(),
    )
    .unwrap();
    let d = &r.data;
    assert!(!d.summary.resampled && d.summary.measured_sphere.is_none());
    assert!(
        d.renders.is_empty(),
        "samples have no measured sphere to render against"
    );
    assert_eq!(d.plotted, 2000);
    for (m, want) in [(0usize, 0.0f64), (1, 2f64.log10())] {
        for bands in [&d.models[m].by_theta_h, &d.models[m].by_theta_d] {
            let n: usize = bands.iter().map(|b| b.samples).sum();
            assert_eq!(n, 2000);
            for b in bands.iter().filter(|b| b.samples > 0) {
                let got = b.mean_log10_ratio.unwrap();
                assert!(
                    (got - want).abs() < 1e-12,
                    "model {m} band {}: {got}",
                    b.lo_deg
                );
            }
        }
    }
    assert!(d.summary.models[0].losses.l2.overall < 1e-15);
    // Doubled: the l2 residual is f itself (0.4/π) at every sample, uniform weights.
    let l2 = d.summary.models[1].losses.l2.overall;
    let want = 0.4 / std::f64::consts::PI;
    assert!((l2 - want).abs() < 1e-12 * want, "{l2} vs {want}");
    assert!(r.html.contains("id=\"no-measured-sphere\""));
}

#[test]
fn a_bsdf_at_its_points_is_rendered_from_the_file() {
    let felt =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-synthetic/felt-synthetic.bsdf");
    let m = Measured::read(&felt, brdfkit_fit::BsdfInput::Points, true).unwrap();
    assert_eq!(m.kind(), "bsdf-points");
    let n = m.data.len();
    let fits = [given("lambert", lambert(0.5))];
    let AnyReport::Scattered(r) = build_any_report(m, &fits, None, &quick(), &()).unwrap() else {
        panic!("a .bsdf's points get the report on scattered data");
    };
    assert_eq!(r.data.summary.input.cells, n);
    assert_eq!(r.data.renders.len(), 2);
    for set in &r.data.renders {
        assert!(set.table_png.starts_with(b"\x89PNG"));
        // The file is not a Lambertian: the model's sphere differs from the file's.
        assert!(
            set.models[0].diff.rel_rms_radiance > 0.01,
            "{:?}",
            set.models[0].diff
        );
    }
    assert!(r.html.contains("id=\"measured-sphere\""));
    // The table route gives the table report.
    let t = Measured::read(&felt, brdfkit_fit::BsdfInput::Table, true).unwrap();
    assert!(matches!(
        build_any_report(t, &fits, None, &quick(), &()).unwrap(),
        AnyReport::Table(_)
    ));
}
