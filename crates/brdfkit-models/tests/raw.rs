//! `brdfkit_models::raw`: bulk evaluation from raw directions gives `eval`'s bits in f64
//! for every registered model (and the GGX kernel's configurations), on pools of 1 and
//! 3 threads, over lengths that leave short runs; the float32 path stays within its
//! documented tolerance of `eval`; bad lengths are errors, not panics.

use brdfkit_core::geometry::DirsError;
use brdfkit_core::{Model, Rgb, Vec3};
use brdfkit_models::par::RUN;
use brdfkit_models::raw::{GEOM_RUN, eval_dirs, eval_dirs_f32, eval_dirs_flat, eval_dirs_flat_f32};
use brdfkit_models::testing::{
    SplitMix64, dense_grid_pairs, f32_relative_error, hard_case_pairs, random_pairs,
};
use brdfkit_models::{MODEL_NAMES, default_model, from_json_str};

/// Every registered model at its defaults, plus Cook-Torrance configurations that take
/// other code (the GGX kernel's Fresnel kinds and anisotropy, Beckmann, the V-cavity)
/// and a steep and a rough lobe.
fn models() -> Vec<(String, Box<dyn Model>)> {
    let mut v: Vec<(String, Box<dyn Model>)> = MODEL_NAMES
        .iter()
        .map(|n| (n.to_string(), default_model(n).unwrap()))
        .collect();
    for p in [
        r#"{"distribution":"ggx","masking":"smith-separable","alpha":0.2,"rho_d":0,"rho_s":1,
            "fresnel":{"conductor":{"eta":[0.143,0.374,1.442],"k":[3.983,2.385,1.603]}}}"#,
        r#"{"distribution":"ggx","masking":"smith-correlated","alpha_x":0.1,"alpha_y":0.4,
            "fresnel":{"dielectric":{"eta":1.5}}}"#,
        r#"{"distribution":"ggx","alpha":0.02,"fresnel":"none"}"#,
        r#"{"distribution":"ggx","alpha":0.9,"fresnel":"schlick"}"#,
        r#"{"distribution":"beckmann","masking":"smith-separable","alpha":0.3}"#,
        r#"{"distribution":"beckmann","masking":"v-cavity","alpha":0.15}"#,
    ] {
        let json = format!(r#"{{"model":"cook-torrance","params":{p}}}"#);
        v.push((json.clone(), from_json_str(&json).unwrap()));
    }
    v
}

/// Random pairs over both hemispheres (so about three quarters have a direction below
/// the horizon), the hard cases (normal, grazing, just below the horizon, wi = wo, the
/// mirror), a dense grid, and awkward input: wi = −wo, zero, non-unit, huge, NaN.
fn pairs() -> Vec<(Vec3, Vec3)> {
    let mut v = random_pairs(7, 2 * RUN + GEOM_RUN + 37);
    let mut r = SplitMix64(11);
    for (k, p) in v.iter_mut().enumerate() {
        if k % 2 == 0 {
            p.0.z = -p.0.z * r.next_f64();
        }
        if k % 3 == 0 {
            p.1.z = -p.1.z;
        }
    }
    v.extend(hard_case_pairs());
    v.extend(dense_grid_pairs(12, 6));
    let w = Vec3::new(0.48, 0.6, 0.64);
    for (a, b) in [
        (w, -w),
        (Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.6, 0.0, 0.8)),
        (Vec3::zeros(), w),
        (w * 2.0, w),
        (w * 0.5, Vec3::new(0.0, 0.0, 1.0)),
        (Vec3::new(3.0, 4.0, 5.0), Vec3::new(-1.0, 0.2, 0.3)),
        (Vec3::new(f64::NAN, 0.0, 1.0), w),
        (Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, 1.0)),
    ] {
        v.push((a, b));
        v.push((b, a));
    }
    v
}

fn arrays(p: &[(Vec3, Vec3)]) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    p.iter()
        .map(|(a, b)| ([a.x, a.y, a.z], [b.x, b.y, b.z]))
        .unzip()
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// The same bits, NaN included (a NaN input gives the same NaN as `eval`).
fn same_bits(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

#[test]
fn f64_is_eval_to_the_bit_for_every_model() {
    let p = pairs();
    let (wi, wo) = arrays(&p);
    let flat: Vec<f64> = wi
        .iter()
        .zip(&wo)
        .flat_map(|(a, b)| [a[0], a[1], a[2], b[0], b[1], b[2]])
        .collect();
    for (name, m) in models() {
        let want: Vec<Rgb> = p.iter().map(|(a, b)| m.eval(a, b)).collect();
        for threads in [1, 3] {
            pool(threads).install(|| {
                // Whole, short (one run, on the calling thread) and empty batches.
                for n in [p.len(), 100, 0] {
                    let mut got = vec![Rgb::splat(-1.0); n];
                    eval_dirs(m.as_ref(), &wi[..n], &wo[..n], &mut got).unwrap();
                    let mut got_flat = vec![-1.0; 3 * n];
                    eval_dirs_flat(m.as_ref(), &flat[..6 * n], &mut got_flat).unwrap();
                    for k in 0..n {
                        for c in 0..3 {
                            assert!(
                                same_bits(got[k][c], want[k][c]),
                                "{name} on {threads} threads, pair {k} {:?} channel {c}: \
                                 eval {} vs eval_dirs {}",
                                p[k],
                                want[k][c],
                                got[k][c]
                            );
                            assert!(
                                same_bits(got_flat[3 * k + c], want[k][c]),
                                "{name} flat, pair {k} channel {c}"
                            );
                        }
                    }
                }
            });
        }
    }
}

/// Relative error of the float32 path against the f64 `eval` of the same (float32)
/// directions: below 5e-5 for every model (raw.rs module doc; measured: 9e-6 at worst,
/// `ashikhmin-shirley`, 1.3e-6 for Cook-Torrance with α from 0.02 to 0.9), also near
/// the specular peak of a steep lobe.
#[test]
fn f32_is_eval_within_its_tolerance() {
    // Unit directions only: the tolerance is about round-off, not about garbage input.
    let mut p = random_pairs(9, 2 * RUN + 99);
    // Half of them near the specular peak (h within ~0.05 rad of the normal), where a
    // steep lobe amplifies the rounding of h most.
    let mut r = SplitMix64(3);
    for (wi, wo) in p.iter_mut().skip(1).step_by(2) {
        let t = 0.05 * r.next_f64();
        let f = r.uniform(-3.0, 3.0);
        let h = Vec3::new(t.sin() * f.cos(), t.sin() * f.sin(), t.cos());
        *wo = 2.0 * wi.dot(&h) * h - *wi;
        if wo.z <= 0.0 {
            *wo = Vec3::new(0.0, 0.0, 1.0);
        }
    }
    p.extend(hard_case_pairs());
    p.extend(dense_grid_pairs(20, 8));
    let f = |v: &Vec3| [v.x as f32, v.y as f32, v.z as f32];
    let (wi, wo): (Vec<[f32; 3]>, Vec<[f32; 3]>) = p.iter().map(|(a, b)| (f(a), f(b))).unzip();
    let wide = |v: [f32; 3]| Vec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
    let flat: Vec<f32> = wi
        .iter()
        .zip(&wo)
        .flat_map(|(a, b)| [a[0], a[1], a[2], b[0], b[1], b[2]])
        .collect();
    let n = p.len();
    for (name, m) in models() {
        let tol = if name.contains("\"alpha\":0.02") {
            2e-3
        } else {
            1e-4
        };
        let mut got = vec![[-1f32; 3]; n];
        pool(2).install(|| eval_dirs_f32(m.as_ref(), &wi, &wo, &mut got).unwrap());
        let mut got_flat = vec![-1f32; 3 * n];
        eval_dirs_flat_f32(m.as_ref(), &flat, &mut got_flat).unwrap();
        let mut worst: f64 = 0.0;
        for k in 0..n {
            let want = m.eval(&wide(wi[k]), &wide(wo[k]));
            for c in 0..3 {
                assert_eq!(got_flat[3 * k + c], got[k][c], "{name}: flat at {k}");
                let g = got[k][c] as f64;
                worst = worst.max(f32_relative_error(g, want[c], || format!("{name} at {k}")));
            }
        }
        eprintln!("{name}: worst relative error of f32 {worst:e}");
        assert!(
            worst < tol,
            "{name}: f32 off by {worst:e} (tolerance {tol:e})"
        );
    }
}

#[test]
fn lengths_that_do_not_fit_are_errors() {
    let m = default_model("lambert").unwrap();
    let d = [[0.0, 0.0, 1.0]; 4];
    let mut out = vec![Rgb::ZERO; 4];
    assert_eq!(
        eval_dirs(m.as_ref(), &d, &d[..3], &mut out),
        Err(DirsError::Mismatch { wi: 4, wo: 3 })
    );
    assert_eq!(
        eval_dirs(m.as_ref(), &d, &d, &mut out[..2]),
        Err(DirsError::Output {
            pairs: 4,
            need: 4,
            got: 2
        })
    );
    let mut o = vec![0.0; 6];
    let e = eval_dirs_flat(m.as_ref(), &[0.0; 13], &mut o).unwrap_err();
    assert_eq!(e, DirsError::Flat { len: 13 });
    assert!(
        e.to_string().contains("13 values is not a multiple of 6"),
        "{e}"
    );
    let e = eval_dirs_flat(m.as_ref(), &[0.0; 12], &mut o[..5]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "the output holds 5 entries but 2 pairs need 6"
    );
    let d32 = [[0f32, 0.0, 1.0]; 2];
    let mut o32 = [[0f32; 3]; 3];
    assert!(eval_dirs_f32(m.as_ref(), &d32, &d32, &mut o32).is_err());
    assert!(eval_dirs_flat_f32(m.as_ref(), &[0f32; 7], &mut [0f32; 3]).is_err());
    // Nothing in, nothing out.
    eval_dirs_flat_f32(m.as_ref(), &[], &mut []).unwrap();
}

/// The float32 path is the model's `eval_batch_f32` over geometry filled from the same
/// float32 directions, to the bit: Cook-Torrance's fused GGX loop computes exactly what
/// its kernel computes on `Geometry::fill_from_dirs`, and so does every other model.
#[test]
fn f32_is_eval_batch_f32_of_the_filled_geometry_to_the_bit() {
    let p = pairs();
    let f = |v: &Vec3| [v.x as f32, v.y as f32, v.z as f32];
    let (wi, wo): (Vec<[f32; 3]>, Vec<[f32; 3]>) = p.iter().map(|(a, b)| (f(a), f(b))).unzip();
    let n = p.len();
    let mut g = brdfkit_core::GeometryBatchF32::default();
    g.fill_from_dirs(&wi, &wo);
    for (name, m) in models() {
        let mut want = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
        let [a, b, c] = &mut want;
        m.eval_batch_f32(&g.as_slice(), [a, b, c]);
        let mut got = vec![[-1f32; 3]; n];
        pool(2).install(|| eval_dirs_f32(m.as_ref(), &wi, &wo, &mut got).unwrap());
        for k in 0..n {
            for ch in 0..3 {
                let (x, y) = (got[k][ch], want[ch][k]);
                assert!(
                    x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                    "{name}: pair {k} channel {ch}: {x} vs {y}"
                );
            }
        }
    }
}
