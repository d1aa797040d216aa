//! Where the time of `brdfkit::models::raw::eval_dirs` goes (docs/performance.md, "Raw
//! directions in f64"): Cook-Torrance GGX with the exact conductor (the gold of the
//! `peers` bench, Mitsuba 3's `roughconductor`) over the 1,458,000 MERL grid pairs, on
//! the global rayon pool, against
//!
//! - `memory`: a pass over the same arrays with the same runs that only reads both
//!   directions and writes three values per pair (the bytes of `eval_dirs`, no
//!   arithmetic): the floor if the kernel were bound by memory;
//! - `in cache`: the kernel over one L2-sized block of the same pairs, repeated to the
//!   same pair count: the time of the arithmetic alone;
//! - `fresh output`: into a newly allocated output, so that its pages are faulted in
//!   inside the timed region (what a caller that allocates per call pays);
//! - `all above`: as many random pairs with both directions above the horizon (no pair
//!   gives an exact 0; the MERL grid has 24 % such pairs).
//!
//! Prints the median and the minimum of `--reps N` runs (default 21) after a warm-up,
//! interleaving the variants run by run so that a change of load hits all alike, in wall
//! time and in CPU time (of all the process's threads, from `/proc/self/task/*/schedstat`,
//! in nanoseconds): on a loaded machine the wall time stretches with the other jobs
//! while the CPU time stays near what the work needs. `--threads N` runs on a pool of N
//! threads (default: the global pool); with 1 thread the CPU time has no idle spinning
//! of other workers in it; `--only K` runs the K-th case alone (from 0). Run with
//! `cargo bench --bench raw [-- --reps N --threads N --only K]`.

use brdfkit::core::{Brdf, Model, Rgb};
use brdfkit::models::par::RUN;
use brdfkit::models::raw::{eval_dirs, eval_dirs_f32};
use brdfkit::models::testing::random_pairs;
use rayon::prelude::*;
use std::hint::black_box;

#[path = "common/cases.rs"]
mod cases;
#[path = "common/pairs.rs"]
mod pairs;
use cases::{Case, Opts, main_with, time_cases};
use pairs::merl_pairs;

const GOLD: &str = r#"{"model":"cook-torrance","params":{"rho_d":0.0,"rho_s":1.0,"alpha":0.2,
    "distribution":"ggx","masking":"smith-separable",
    "fresnel":{"conductor":{"eta":[0.143,0.374,1.442],"k":[3.983,2.385,1.603]}}}}"#;

/// Pairs of the in-cache block: its directions and values take 72 B per pair in f64,
/// 1.2 MB for both threads' blocks, within the L2 caches.
const BLOCK: usize = 8192;

type Dirs = (Vec<[f64; 3]>, Vec<[f64; 3]>);

fn arrays(p: &[(brdfkit::core::Vec3, brdfkit::core::Vec3)]) -> Dirs {
    p.iter()
        .map(|(a, b)| ([a.x, a.y, a.z], [b.x, b.y, b.z]))
        .unzip()
}

fn main() {
    main_with(run);
}

fn run(opts: &Opts) {
    let model = brdfkit::models::from_json_str(GOLD).expect("the gold model");
    let m: &dyn Model = model.as_ref();
    let grid = merl_pairs();
    let n = grid.len();
    let (wi, wo) = arrays(&grid);
    let (ri, ro) = arrays(&random_pairs(5, n));
    let r32 =
        |v: &Vec<[f64; 3]>| -> Vec<[f32; 3]> { v.iter().map(|d| d.map(|x| x as f32)).collect() };
    let (wi32, wo32) = (r32(&wi), r32(&wo));
    let mut out = vec![Rgb::ZERO; n];
    let mut out32 = vec![[0f32; 3]; n];

    // eval_dirs gives eval's bits (the contract this bench must not trade away).
    eval_dirs(m, &wi, &wo, &mut out).expect("lengths");
    let differ = (0..n)
        .filter(|&k| out[k] != Brdf::eval(m, &grid[k].0, &grid[k].1))
        .count();
    assert_eq!(differ, 0, "eval_dirs must give eval's values");
    let zero = out.iter().filter(|v| v.max_channel() == 0.0).count();

    let threads = rayon::current_num_threads();
    let cases: Vec<Case> = vec![
        (
            "eval_dirs f64",
            Box::new(|| eval_dirs(m, &wi, &wo, &mut out).expect("lengths")),
        ),
        (
            "eval_dirs f32",
            Box::new(|| eval_dirs_f32(m, &wi32, &wo32, &mut out32).expect("lengths")),
        ),
        ("memory f64 (read 48 B, write 24 B a pair)", {
            let mut o = vec![Rgb::ZERO; n];
            let (wi, wo) = (&wi, &wo);
            Box::new(move || {
                o.par_chunks_mut(RUN).enumerate().for_each(|(c, o)| {
                    let a = c * RUN;
                    for (k, o) in o.iter_mut().enumerate() {
                        let (i, j) = (wi[a + k], wo[a + k]);
                        *o = Rgb([i[0] + j[0], i[1] + j[1], i[2] + j[2]]);
                    }
                });
                black_box(&o);
            })
        }),
        ("eval_dirs f64 in cache", {
            let len = BLOCK * threads;
            let mut o = vec![Rgb::ZERO; len];
            // From the middle of the grid (its first rows are near normal incidence),
            // with the grid's mix of pairs below the horizon.
            let (bi, bo) = (&wi[n / 2..n / 2 + len], &wo[n / 2..n / 2 + len]);
            Box::new(move || {
                for _ in 0..n / len {
                    eval_dirs(m, bi, bo, &mut o).expect("lengths");
                }
                black_box(&o);
            })
        }),
        ("eval_dirs f64 fresh output", {
            let (wi, wo) = (&wi, &wo);
            Box::new(move || {
                let mut o = vec![Rgb::ZERO; n];
                eval_dirs(m, wi, wo, &mut o).expect("lengths");
                black_box(&o);
            })
        }),
        ("eval_dirs f64 all above", {
            let mut o = vec![Rgb::ZERO; n];
            let (ri, ro) = (&ri, &ro);
            Box::new(move || {
                eval_dirs(m, ri, ro, &mut o).expect("lengths");
                black_box(&o);
            })
        }),
    ];
    time_cases(
        &format!("raw bench: {n} MERL grid pairs ({zero} exactly 0), {threads} threads"),
        cases,
        opts,
    );
}
