//! The physical checks must pass on a correct model and fail on a broken one.

use brdfkit_core::model::Domain;
use brdfkit_core::{Brdf, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use brdfkit_models::from_json_str;
use brdfkit_models::testing::{dense_grid_pairs, max_reciprocity_error, random_pairs};
use brdfkit_validate::physical::{QuadPole, auto_pole};
use brdfkit_validate::{
    CheckOptions, PhysicalReport, PoleChoice, Verdict, check_model, check_model_with,
};
use std::f64::consts::PI;

/// What is wrong with a [`Faulty`] model.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    /// None: ρ/π, a Lambertian surface.
    None,
    /// Negative towards grazing: ρ/π − 0.5 (sin θi sin θo)⁸ (smooth, so the albedo
    /// quadrature still converges).
    Negative,
    /// Non-reciprocal: ρ/π · (1 + 0.5 θi).
    NonReciprocal,
    /// Depends on the absolute azimuths while claiming isotropy (reciprocal).
    Anisotropic,
    /// NaN when wo is within 1e-6 rad of the normal.
    NanNearNormal,
    /// Reflects too much: 1.3 ρ/π (albedo 1.3 ρ).
    TooBright,
    /// Infinite gradient at grazing wi (value fine).
    InfiniteGradient,
}

/// A Lambertian-like test model with one deliberate fault; one parameter ρ.
#[derive(Debug, Clone)]
struct Faulty {
    rho: f64,
    fault: Fault,
}

impl Faulty {
    fn value(&self, wi: &Vec3, wo: &Vec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let base = self.rho / PI;
        let ti = wi.z.clamp(-1.0, 1.0).acos();
        let to = wo.z.clamp(-1.0, 1.0).acos();
        match self.fault {
            Fault::None | Fault::InfiniteGradient => base,
            Fault::Negative => base - 0.5 * (ti.sin() * to.sin()).powi(8),
            Fault::NonReciprocal => base * (1.0 + 0.5 * ti),
            Fault::Anisotropic => base * (1.0 + 0.1 * (wi.x + wo.x)),
            Fault::NanNearNormal => {
                if to < 1e-6 {
                    f64::NAN
                } else {
                    base
                }
            }
            Fault::TooBright => 1.3 * base,
        }
    }
}

impl Brdf for Faulty {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        Rgb::splat(self.value(wi, wo))
    }
}

impl Model for Faulty {
    fn name(&self) -> &'static str {
        "faulty"
    }
    fn param_specs(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::shared("rho", Domain::closed(0.0, 1.0), 0.5)]
    }
    fn params(&self) -> Vec<f64> {
        vec![self.rho]
    }
    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        if p.len() != 1 {
            return Err(ModelError::ParamCount {
                expected: 1,
                got: p.len(),
            });
        }
        self.rho = p[0];
        Ok(())
    }
    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        let f = self.value(wi, wo);
        let d = if self.rho > 0.0 { f / self.rho } else { 0.0 };
        grad[0] = Rgb::splat(d);
        if self.fault == Fault::InfiniteGradient && wi.z > 0.0 && wi.z < 1e-3 {
            grad[0] = Rgb::splat(f64::INFINITY);
        }
        Rgb::splat(f)
    }
    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) {
        for (k, o) in out.iter_mut().enumerate() {
            let (wi, wo) = g.pair(k);
            *o = self.eval(&wi, &wo);
        }
    }
    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let n = g.len();
        let mut gk = [Rgb::ZERO];
        for (k, o) in out.iter_mut().enumerate() {
            let (wi, wo) = g.pair(k);
            *o = self.eval_grad(&wi, &wo, &mut gk);
            grad[k] = gk[0];
        }
        debug_assert_eq!(grad.len(), n);
    }
    fn to_json(&self) -> serde_json::Value {
        serde_json::json!({"model": "faulty", "params": {"rho": self.rho, "fault": format!("{:?}", self.fault)}})
    }
}

/// Fewer pairs than the default, to keep the debug-build tests quick; the checks are the
/// same.
fn quick() -> CheckOptions {
    CheckOptions {
        dense_theta: 19,
        dense_phi: 12,
        random_pairs: 4_000,
        ..CheckOptions::default()
    }
}

fn verdicts(r: &PhysicalReport) -> [Verdict; 5] {
    [
        r.non_negativity.verdict,
        r.reciprocity.verdict,
        r.energy.verdict,
        r.isotropy.verdict,
        r.finiteness.verdict,
    ]
}

#[test]
fn lambert_passes_every_check_with_albedo_rho() {
    let m = from_json_str(r#"{"model": "lambert", "params": {"rho_d": [0.2, 0.5, 1.0]}}"#).unwrap();
    let r = check_model(m.as_ref());
    assert!(r.passed, "{r}");
    assert_eq!(verdicts(&r), [Verdict::Pass; 5], "{r}");
    assert_eq!(r.reciprocity.max_rel_error, 0.0);
    assert_eq!(r.isotropy.max_rel_change, 0.0);
    // The dense grid reaches 90°, where `spherical` gives z = 6e-17 > 0: still ρ/π.
    assert_eq!(r.non_negativity.min_value, 0.2 / PI);
    let rho = [0.2, 0.5, 1.0];
    for (k, p) in r.energy.curve.iter().enumerate() {
        for c in 0..3 {
            for (what, a) in [("a(wo)", p.a_wo), ("a(wi)", p.a_wi)] {
                assert!(
                    (a[c] - rho[c]).abs() <= 1e-6,
                    "{what} at θ = {}: {} vs {}",
                    p.theta.to_degrees(),
                    a[c],
                    rho[c]
                );
            }
        }
        // A constant integrand peaks where cos θi does: the normal (at θ = 0 the three
        // candidates coincide).
        if k > 0 {
            assert_eq!(p.poles, [QuadPole::Normal, QuadPole::Normal]);
        }
    }
    assert!((r.energy.max_albedo - 1.0).abs() <= 1e-6);
    assert!(r.energy.convergence <= 1e-9, "{}", r.energy.convergence);
    // The albedo curve covers the grazing end.
    assert!(
        r.energy
            .curve
            .iter()
            .any(|p| p.theta >= 89.5f64.to_radians())
    );
    let text = r.to_string();
    for w in [
        "non-negativity",
        "reciprocity",
        "energy",
        "isotropy",
        "finiteness",
        "PASS",
    ] {
        assert!(text.contains(w), "{text}");
    }
    assert!(!text.contains("FAIL"), "{text}");
}

#[test]
fn lambert_albedo_is_exact_with_every_fixed_pole() {
    // The Lambertian albedo is exact to 1e-6 even about the wrong pole, up to 89.5°:
    // the fine rule's error with the pole 0.1° from the horizon is what this bounds.
    let m = from_json_str(r#"{"model": "lambert", "params": {"rho_d": 0.7}}"#).unwrap();
    for pole in [QuadPole::Mirror, QuadPole::Retro, QuadPole::Normal] {
        let o = CheckOptions {
            pole: PoleChoice::Fixed(pole),
            ..quick()
        };
        let r = check_model_with(m.as_ref(), &o);
        for p in &r.energy.curve {
            assert!(
                (p.a_wo.r() - 0.7).abs() <= 1e-6,
                "{pole:?} θ {}: {}",
                p.theta,
                p.a_wo.r()
            );
        }
        assert!(r.passed, "{pole:?}: {r}");
    }
}

#[test]
fn phong_is_reported_non_reciprocal_and_over_unit_albedo() {
    // Phong's reflected fraction a(wi) = ∫ f cos θo dωo grows like 1/cos θi: with
    // kd = 0.2, ks = 0.5, n = 10 it exceeds 1 towards grazing incidence.
    let m = from_json_str(r#"{"model": "phong", "params": {"k_d": 0.2, "k_s": 0.5, "n": 10}}"#)
        .unwrap();
    let r = check_model_with(m.as_ref(), &quick());
    assert!(!r.passed);
    assert_eq!(r.reciprocity.verdict, Verdict::Fail, "{r}");
    assert!(r.reciprocity.max_rel_error > 0.1, "{r}");
    assert!(!r.reciprocity.declared);
    assert_eq!(r.energy.verdict, Verdict::Fail, "{r}");
    assert!(r.energy.max_albedo > 1.0);
    assert_eq!(r.energy.max_reading, "a(wi)");
    assert!(!r.energy.declared);
    // a(wo) = kd π + ks ∫ cosⁿθr dωi stays below kd π + ks 2π/(n+1) (equal at normal
    // incidence, where the whole lobe is above the horizon), while a(wi) blows up.
    let bound = 0.2 * PI + 0.5 * 2.0 * PI / 11.0;
    for p in &r.energy.curve {
        assert!(
            p.a_wo.r() <= bound + 1e-6,
            "a(wo) {} at {}",
            p.a_wo.r(),
            p.theta
        );
    }
    let last = r.energy.curve.last().unwrap();
    assert!(last.a_wi.r() > 4.0, "a(wi) at 89.5° = {}", last.a_wi.r());
    // The other checks hold for Phong.
    assert_eq!(r.non_negativity.verdict, Verdict::Pass);
    assert_eq!(r.isotropy.verdict, Verdict::Pass);
    assert_eq!(r.finiteness.verdict, Verdict::Pass, "{r}");
    // Every point of the curve converged (the search keeps the first pole whose
    // estimate is within a hundredth of the 1e-4 bound).
    assert!(r.energy.convergence <= 1e-6, "{}", r.energy.convergence);
    let text = r.to_string();
    assert!(text.contains("reciprocity     FAIL"), "{text}");
    assert!(text.contains("energy          FAIL"), "{text}");
}

#[test]
fn phong_reciprocity_figure_is_the_models_harness_figure() {
    let m =
        from_json_str(r#"{"model": "phong", "params": {"k_d": 0.1, "k_s": 0.3, "n": 5}}"#).unwrap();
    let o = quick();
    let r = check_model_with(m.as_ref(), &o);
    let mut pairs = dense_grid_pairs(o.dense_theta, o.dense_phi);
    pairs.extend(random_pairs(o.seed, o.random_pairs));
    assert_eq!(
        r.reciprocity.max_rel_error,
        max_reciprocity_error(m.as_ref(), &pairs)
    );
    // The located worst pair reproduces the figure.
    let w = r.reciprocity.worst.as_ref().unwrap();
    let (wi, wo) = (Vec3::from(w.wi), Vec3::from(w.wo));
    let (a, b) = (m.eval(&wi, &wo)[w.channel], m.eval(&wo, &wi)[w.channel]);
    assert_eq!(
        (a - b).abs() / a.abs().max(b.abs()),
        r.reciprocity.max_rel_error
    );
}

#[test]
fn faulty_models_are_flagged_by_the_right_check() {
    let cases: [(Fault, usize); 6] = [
        (Fault::Negative, 0),
        (Fault::NonReciprocal, 1),
        (Fault::TooBright, 2),
        (Fault::Anisotropic, 3),
        (Fault::NanNearNormal, 4),
        (Fault::InfiniteGradient, 4),
    ];
    for (fault, which) in cases {
        let m = Faulty { rho: 0.9, fault };
        let r = check_model_with(&m, &quick());
        let v = verdicts(&r);
        assert_eq!(v[which], Verdict::Fail, "{fault:?}: {r}");
        assert!(!r.passed, "{fault:?}");
        // The fault shows in no unrelated check, except that the non-reciprocal model
        // raises a(wo) above 1 (0.9 (1 + 0.5 θi) averages above 1/0.9), and a NaN
        // albedo bounds nothing.
        for (k, vk) in v.iter().enumerate() {
            let related = k == which
                || (fault == Fault::NonReciprocal && k == 2)
                || (fault == Fault::NanNearNormal && k == 2);
            if !related {
                assert_eq!(*vk, Verdict::Pass, "{fault:?}: check {k} {r}");
            }
        }
    }
    let ok = Faulty {
        rho: 0.9,
        fault: Fault::None,
    };
    assert!(check_model_with(&ok, &quick()).passed);
}

/// The quick checks of a Lambertian ρ = 0.5 with `fault`.
fn check_faulty(fault: Fault) -> PhysicalReport {
    check_model_with(&Faulty { rho: 0.5, fault }, &quick())
}

#[test]
fn faults_are_located() {
    let r = check_faulty(Fault::Negative);
    let nn = &r.non_negativity;
    assert!(
        (nn.min_value - (0.5 / PI - 0.5)).abs() < 1e-12,
        "{}",
        nn.min_value
    );
    assert!(nn.negative > 0);
    let [ti, _, to, _] = nn.worst.as_ref().unwrap().angles_deg();
    assert!(ti > 60.0 && to > 60.0);

    let r = check_faulty(Fault::NanNearNormal);
    let f = &r.finiteness;
    assert!(
        f.nonfinite_values > 0 && f.first.as_ref().unwrap().contains("NaN"),
        "{f:?}"
    );
    // Values are counted on four paths, gradients on two; the gradient f/ρ is NaN too.
    assert_eq!(2 * f.nonfinite_gradients, f.nonfinite_values);

    let r = check_faulty(Fault::InfiniteGradient);
    let f = &r.finiteness;
    assert_eq!(f.nonfinite_values, 0);
    assert!(f.nonfinite_gradients > 0);
    assert!(f.first.as_ref().unwrap().contains("∂f/∂rho"), "{f:?}");

    let r = check_model_with(
        &Faulty {
            rho: 0.9,
            fault: Fault::TooBright,
        },
        &quick(),
    );
    assert!(
        (r.energy.max_albedo - 1.17).abs() < 1e-6,
        "{}",
        r.energy.max_albedo
    );
}

#[test]
fn energy_threshold_is_applied_as_documented() {
    // ρ = 1 passes (albedo 1 to round-off), 1.3 × 0.77 = 1.001 fails the 1e-4 bound.
    let m = Faulty {
        rho: 0.77,
        fault: Fault::TooBright,
    };
    let r = check_model_with(&m, &quick());
    assert_eq!(r.energy.verdict, Verdict::Fail);
    let m = Faulty {
        rho: 1.0,
        fault: Fault::None,
    };
    assert_eq!(check_model_with(&m, &quick()).energy.verdict, Verdict::Pass);
    // A tolerance that covers the excess passes it.
    let mut o = quick();
    o.thresholds.energy = 2e-3;
    let m = Faulty {
        rho: 0.77,
        fault: Fault::TooBright,
    };
    assert_eq!(check_model_with(&m, &o).energy.verdict, Verdict::Pass);
}

#[test]
fn auto_pole_follows_the_lobe() {
    let phong =
        from_json_str(r#"{"model": "phong", "params": {"k_d": 0.0, "k_s": 1.0, "n": 100}}"#)
            .unwrap();
    let w = brdfkit_core::direction::spherical(0.8, 0.3);
    assert_eq!(auto_pole(phong.as_ref(), &w), QuadPole::Mirror);
    let lambert = from_json_str(r#"{"model": "lambert"}"#).unwrap();
    assert_eq!(auto_pole(lambert.as_ref(), &w), QuadPole::Normal);
}

#[test]
fn report_round_trips_through_json() {
    let m = from_json_str(r#"{"model": "phong", "params": {"k_d": 0.2, "k_s": 0.5, "n": 10}}"#)
        .unwrap();
    let r = check_model_with(m.as_ref(), &quick());
    let s = serde_json::to_string_pretty(&r).unwrap();
    let back: PhysicalReport = serde_json::from_str(&s).unwrap();
    assert_eq!(back, r);
    let v: serde_json::Value = serde_json::from_str(&s).unwrap();
    assert_eq!(v["reciprocity"]["verdict"], "fail");
    assert_eq!(v["thresholds"]["reciprocity"], 1e-9);
    assert_eq!(v["model"]["model"], "phong");
    assert_eq!(v["passed"], false);
}

#[test]
fn sharp_and_anisotropic_lobes_converge() {
    // A Beckmann lobe of α = 0.01 with F = 1 near grazing needs ~36/ε azimuths about
    // the mirror pole (ε its elevation): with the core's 128 the estimate was 2.5e-2.
    let sharp = from_json_str(
        r#"{"model":"cook-torrance","params":{"rho_d":0,"rho_s":1,"alpha":0.01,"distribution":"beckmann","beckmann_g1":"exact","fresnel":"none"}}"#,
    )
    .unwrap();
    let r = check_model_with(sharp.as_ref(), &quick());
    assert!(r.passed, "{r}");
    assert!(r.energy.convergence <= 1e-6, "{r}");
    // The exact Smith G1 keeps the albedo of a perfect reflector at or below 1.
    assert!((r.energy.max_albedo - 1.0).abs() < 1e-6, "{r}");
    // An anisotropic lobe: not isotropic (reported, not required), energy converged.
    let aniso = from_json_str(
        r#"{"model":"cook-torrance","params":{"rho_d":0.5,"rho_s":0.5,"alpha_x":0.05,"alpha_y":0.4,"fresnel":"none"}}"#,
    )
    .unwrap();
    let r = check_model_with(aniso.as_ref(), &quick());
    assert!(
        !r.isotropy.required && r.isotropy.verdict == Verdict::Fail,
        "{r}"
    );
    assert!(r.isotropy.max_rel_change > 0.1);
    assert_eq!(r.energy.verdict, Verdict::Pass, "{r}");
    assert!(
        r.energy.curve.iter().any(|p| p.phi > 0.0),
        "azimuths for an anisotropic model"
    );
    assert!(r.passed, "{r}");
    assert!(r.to_string().contains("not required"));
}
