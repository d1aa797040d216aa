//! Every model of the JSON contract, built through the registry at its default start,
//! passes the shared checks: JSON round trip, the four evaluation paths agreeing, zero
//! below the horizon, finiteness on the hard-case grid, non-negativity, reciprocity
//! where claimed, and gradients against finite differences.

use brdfkit::models::{MODEL_NAMES, default_model, from_json, testing::*};

#[test]
fn every_model_name_is_registered_and_round_trips_through_json() {
    for name in MODEL_NAMES {
        let m = default_model(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.name(), *name);
        let j = m.to_json();
        assert_eq!(j["model"], *name);
        let back = from_json(&j).unwrap_or_else(|e| panic!("{name}: {e} in {j}"));
        assert_eq!(back.params(), m.params(), "{name}");
        assert_eq!(back.to_json(), j, "{name}");
        let specs = m.param_specs();
        assert_eq!(specs.len(), m.num_params(), "{name}");
        assert_eq!(specs.len(), m.params().len(), "{name}");
        for (s, v) in specs.iter().zip(m.params()) {
            assert!(
                s.domain.contains(v),
                "{name}: {} = {v} outside {}",
                s.name,
                s.domain
            );
            assert!(
                s.domain.contains(s.default),
                "{name}: default of {}",
                s.name
            );
        }
    }
}

#[test]
fn every_model_passes_the_shared_checks_at_its_default_start() {
    let pairs = random_pairs(2026, 300);
    for name in MODEL_NAMES {
        let m = default_model(name).unwrap();
        let m = &*m;
        assert_paths_agree(m, &pairs, 1e-12);
        assert_paths_agree(m, &hard_case_pairs(), 1e-12);
        assert_zero_below_horizon(m);
        assert_finite_everywhere(m, &hard_case_pairs());
        assert_nonnegative(m, &dense_grid_pairs(24, 12));
        if m.is_reciprocal() {
            assert_reciprocal(m, &pairs, 1e-12);
        }
        assert_gradient_matches_fd(m, &pairs[..60], 1e-6, 1e-5);
    }
}

#[test]
fn set_params_rejects_wrong_lengths_and_leaves_the_model_unchanged() {
    for name in MODEL_NAMES {
        let mut m = default_model(name).unwrap();
        let before = m.params();
        let mut p = before.clone();
        p.push(0.5);
        assert!(m.set_params(&p).is_err(), "{name}");
        assert!(m.set_params(&before[..before.len() - 1]).is_err(), "{name}");
        let mut nan = before.clone();
        nan[0] = f64::NAN;
        assert!(m.set_params(&nan).is_err(), "{name}: NaN accepted");
        assert_eq!(m.params(), before, "{name}");
    }
}
