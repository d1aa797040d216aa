//! Times the passes a fit is made of on the full synthetic MERL grid (Cook-Torrance
//! GGX + Schlick, cbrt loss): a cost pass, a normal-equation pass, a model-only pass and
//! the loss report. `cargo run --release -p brdfkit-fit --example passes`.

use brdfkit_core::Rgb;
use brdfkit_fit::data::PASS_CHUNK_CELLS;
use brdfkit_fit::problem::FitProblem;
use brdfkit_fit::synth::{Coverage, synth_data};
use brdfkit_fit::{FitConfig, Loss, Weighting, evaluate_losses, resolve_free};
use rayon::prelude::*;
use std::time::Instant;

fn time<T>(what: &str, reps: usize, mut f: impl FnMut() -> T) -> T {
    let mut out = None;
    let t = Instant::now();
    for _ in 0..reps {
        out = Some(f());
    }
    println!(
        "{what}: {:.1} ms",
        1e3 * t.elapsed().as_secs_f64() / reps as f64
    );
    out.expect("reps > 0")
}

fn main() {
    let truth = brdfkit_models::from_json_str(
        r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.08}}"#,
    )
    .expect("model");
    let mut data = synth_data(
        truth.as_ref(),
        brdfkit_merl::Dims::MERL,
        Coverage::AboveHorizon,
    )
    .expect("data");
    if std::env::args().any(|a| a == "--noisy") {
        brdfkit_fit::synth::add_lognormal_noise(&mut data, 0.05, 2026);
    }
    let start = brdfkit_models::from_json_str(
        r#"{"model":"cook-torrance","params":{"fresnel":"schlick"}}"#,
    )
    .expect("start");
    let free = resolve_free(start.as_ref(), &FitConfig::default()).expect("free");
    let p = FitProblem::new(
        &data,
        start.as_ref(),
        free,
        vec![0, 1, 2],
        Loss::Cbrt,
        Weighting::SolidAngle,
    )
    .expect("problem");
    let u = p.start_u();
    println!("cells {}", data.len());
    let n = data.len();
    let g = data.geometry();
    let np = start.num_params();
    time("model eval_batch only (parallel)", 5, || {
        (0..n.div_ceil(PASS_CHUNK_CELLS))
            .into_par_iter()
            .for_each_init(
                || vec![Rgb::ZERO; PASS_CHUNK_CELLS],
                |out, ci| {
                    let s = ci * PASS_CHUNK_CELLS;
                    let e = (s + PASS_CHUNK_CELLS).min(n);
                    start.eval_batch(&g.slice(s..e), &mut out[..e - s]);
                },
            )
    });
    time("model eval_grad_batch only (parallel)", 5, || {
        (0..n.div_ceil(PASS_CHUNK_CELLS))
            .into_par_iter()
            .for_each_init(
                || {
                    (
                        vec![Rgb::ZERO; PASS_CHUNK_CELLS],
                        vec![Rgb::ZERO; np * PASS_CHUNK_CELLS],
                    )
                },
                |(out, gr), ci| {
                    let s = ci * PASS_CHUNK_CELLS;
                    let e = (s + PASS_CHUNK_CELLS).min(n);
                    start.eval_grad_batch(
                        &g.slice(s..e),
                        &mut out[..e - s],
                        &mut gr[..np * (e - s)],
                    );
                },
            )
    });
    time("cost pass", 5, || p.cost_at(&u));
    let mut v = u.clone();
    time("normal-equation pass", 5, || {
        v[0] += 1e-9; // defeat the cache
        p.normal_eq(&v)
    });
    let m = p.model_at(&u).expect("model");
    let mm: &dyn brdfkit_core::Model = m.as_ref();
    time("loss report (4 losses)", 3, || {
        evaluate_losses([mm, mm, mm], &data, Weighting::SolidAngle)
    });
    time("stratified subsample 65k", 3, || {
        data.stratified_subsample(65_536.0 / data.len() as f64, 1)
    });
    let free = resolve_free(start.as_ref(), &FitConfig::default()).expect("free");
    time("problem set-up (targets)", 3, || {
        FitProblem::new(
            &data,
            start.as_ref(),
            free.clone(),
            vec![0, 1, 2],
            Loss::Cbrt,
            Weighting::SolidAngle,
        )
        .expect("p")
    });
    time("whole fit, default config", 5, || {
        brdfkit_fit::fit(start.as_ref(), &data, &FitConfig::default(), None).expect("fit")
    });
}
