//! The table checks pass on a clean table and flag holes, bad negatives and excess
//! albedo.

use brdfkit_core::Rgb;
use brdfkit_merl::{Dims, Lookup, MerlTable, cell_directions};
use brdfkit_models::from_json_str;
use brdfkit_validate::table::{TableCheckOptions, TableReport, check_table_with};
use brdfkit_validate::{Verdict, check_table};
use std::f64::consts::PI;

fn dims() -> Dims {
    Dims::new(30, 30, 60).unwrap()
}

fn lambert(rho: f64) -> MerlTable {
    let m = from_json_str(&format!(
        r#"{{"model": "lambert", "params": {{"rho_d": {rho}}}}}"#
    ))
    .unwrap();
    MerlTable::from_brdf(m.as_ref(), dims()).unwrap()
}

#[test]
fn a_lambertian_table_passes_with_albedo_rho() {
    let t = lambert(0.6);
    let r = check_table(&t);
    assert!(r.passed, "{r}");
    assert_eq!(r.coverage.missing_above, 0);
    assert_eq!(r.coverage.missing, t.cells() - t.valid_count());
    assert_eq!(r.negative.partially_negative, 0);
    assert_eq!(
        r.negative.markers, r.coverage.missing,
        "from_brdf marks with −1 in every channel"
    );
    assert_eq!(r.finiteness.nonfinite, 0);
    for p in &r.energy.curve {
        // f = ρ/π wherever a lookup finds a sample; missing ones take the mean.
        let a = p.albedo.unwrap();
        assert!(
            (a.r() - 0.6).abs() < 1e-6,
            "θo {}: {a:?}",
            p.theta.to_degrees()
        );
    }
    let text = r.to_string();
    assert!(
        text.contains("built into the grid") && text.contains("PASS"),
        "{text}"
    );
}

#[test]
fn holes_above_the_horizon_fail_coverage() {
    let mut t = lambert(0.5);
    let d = t.dims();
    // Knock out 2 % of the above-horizon cells.
    let mut n = 0;
    let above: Vec<(usize, usize, usize)> = (0..d.cells())
        .map(|x| d.unflatten(x))
        .filter(|&(i, j, k)| cell_directions(d, i, j, k).3)
        .collect();
    for (m, &(i, j, k)) in above.iter().enumerate() {
        if m % 50 == 0 {
            t.set(i, j, k, None).unwrap();
            n += 1;
        }
    }
    let r = check_table(&t);
    assert_eq!(r.coverage.verdict, Verdict::Fail, "{r}");
    assert_eq!(r.coverage.missing_above, n);
    assert!((r.coverage.missing_above_fraction - n as f64 / above.len() as f64).abs() < 1e-15);
    // Interpolation renormalises isolated holes away; nearest lookups see them, and
    // the albedo fills them with the mean: still ρ.
    assert!(
        (r.energy.max_albedo - 0.5).abs() < 1e-6,
        "{}",
        r.energy.max_albedo
    );
    assert!(r.energy.curve.iter().all(|p| p.missing_weight == 0.0));
    let o = TableCheckOptions {
        lookup: Lookup::Nearest,
        ..TableCheckOptions::default()
    };
    let rn = check_table_with(&t, &o);
    assert!(
        rn.energy.curve.iter().any(|p| p.missing_weight > 0.005),
        "{rn}"
    );
    for p in &rn.energy.curve {
        assert!((p.albedo.unwrap().r() - 0.5).abs() < 1e-6, "{rn}");
    }
    // A looser threshold passes it.
    let mut o = TableCheckOptions::default();
    o.thresholds.missing_above = 0.05;
    assert_eq!(check_table_with(&t, &o).coverage.verdict, Verdict::Pass);
}

#[test]
fn partially_negative_cells_are_flagged_and_located() {
    let t = lambert(0.5);
    let d = t.dims();
    let mut raw = t.raw().to_vec();
    let n = d.cells();
    // Cell (3, 4, 5), green channel negative only.
    let idx = d.index(3, 4, 5);
    raw[n + idx] = -2.0;
    let t = MerlTable::from_raw(d, raw).unwrap();
    let r = check_table(&t);
    assert_eq!(r.negative.verdict, Verdict::Fail, "{r}");
    assert_eq!(r.negative.partially_negative, 1);
    let (ijk, vals) = r.negative.first.unwrap();
    assert_eq!(ijk, [3, 4, 5]);
    assert_eq!(vals[1], -2.0);
    assert!(!r.passed);
}

#[test]
fn too_much_albedo_fails_energy() {
    // f = 1.2/π in every cell above the horizon: albedo 1.2.
    let d = dims();
    let t = MerlTable::from_fn(d, |i, j, k| {
        cell_directions(d, i, j, k)
            .3
            .then_some(Rgb::splat(1.2 / PI))
    })
    .unwrap();
    let r = check_table(&t);
    assert_eq!(r.energy.verdict, Verdict::Fail, "{r}");
    assert!((r.energy.max_albedo - 1.2).abs() < 1e-6);
    // Just under the bound passes.
    let t = MerlTable::from_fn(d, |i, j, k| {
        cell_directions(d, i, j, k)
            .3
            .then_some(Rgb::splat(1.0 / PI))
    })
    .unwrap();
    assert_eq!(check_table(&t).energy.verdict, Verdict::Pass);
}

#[test]
fn the_report_serialises() {
    let t = lambert(0.3);
    let r = check_table(&t);
    let s = serde_json::to_string(&r).unwrap();
    let back: TableReport = serde_json::from_str(&s).unwrap();
    assert_eq!(back, r);
    let v: serde_json::Value = serde_json::from_str(&s).unwrap();
    assert_eq!(v["lookup"], "interpolated");
    assert_eq!(v["coverage"]["verdict"], "pass");
    assert_eq!(v["dims"], serde_json::json!([30, 30, 60]));
}
