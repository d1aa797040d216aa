//! Where the time of `MerlTable::nearest_flat` goes (docs/performance.md, "Nearest
//! lookups"): the peers bench's case, 1,458,000 seeded random pairs (the same seed) on
//! the gold Cook-Torrance table of the MERL grid, on the global rayon pool, against
//!
//! - `nearest, planes`: a fresh copy of the table, whose batches of 65,536 pairs (below
//!   an eighth of the cells) read the three channel planes, one line in each;
//! - `memory`: a pass with the same runs that reads each pair's six components and one
//!   random 32-byte cell of a 47 MB array (the interleaved copy's size), its index from
//!   the pair's bits, and writes three values: the floor if the lookup were bound by
//!   its reads;
//! - `interpolated`: `interpolated_flat` of the same pairs.
//!
//! Prints the median and the minimum of `--reps N` runs (default 21) after a warm-up,
//! interleaved run by run, in wall time and in CPU time of all the process's threads
//! (`/proc/self/task/*/schedstat`; see `benches/raw.rs`). `--threads N` runs on a pool
//! of N threads; `--only K` runs the K-th case alone (from 0). Run with
//! `cargo bench --bench lookup [-- --reps N --threads N --only K]`.

use brdfkit::merl::{Dims, MerlTable};
use rayon::prelude::*;
use std::hint::black_box;

#[path = "common/cases.rs"]
mod cases;
use cases::{Case, Opts, main_with, time_cases};

const GOLD: &str = r#"{"model":"cook-torrance","params":{"rho_d":0.0,"rho_s":1.0,"alpha":0.2,
    "distribution":"ggx","masking":"smith-separable",
    "fresnel":{"conductor":{"eta":[0.143,0.374,1.442],"k":[3.983,2.385,1.603]}}}}"#;

fn main() {
    main_with(run);
}

fn run(opts: &Opts) {
    let model = brdfkit::models::from_json_str(GOLD).expect("the gold model");
    let table = MerlTable::from_brdf(model.as_ref(), Dims::MERL).expect("the gold table");
    let n = Dims::MERL.cells();
    let rows: Vec<f64> = brdfkit_study::choices::random_pairs(n, 0x4d45524c)
        .iter()
        .flat_map(|(a, b)| [a.x, a.y, a.z, b.x, b.y, b.z])
        .collect();
    let mut out = vec![0.0; 3 * n];
    table.nearest_flat(&rows, &mut out).expect("shapes");
    let found = out.chunks_exact(3).filter(|r| !r[0].is_nan()).count();

    let threads = rayon::current_num_threads();
    let cases: Vec<Case> = vec![
        ("nearest (interleaved copy)", {
            let (t, r, mut o) = (&table, &rows, vec![0.0; 3 * n]);
            Box::new(move || t.nearest_flat(black_box(r), &mut o).expect("shapes"))
        }),
        ("nearest, planes (batches of 65,536)", {
            let (t, r, mut o) = (table.clone(), &rows, vec![0.0; 3 * n]);
            Box::new(move || {
                for (p, o) in r.chunks(6 * 65_536).zip(o.chunks_mut(3 * 65_536)) {
                    t.nearest_flat(black_box(p), o).expect("shapes");
                }
            })
        }),
        ("nearest, 16,384 pairs repeated (input in cache)", {
            let (t, mut o) = (&table, vec![0.0; 3 * 16_384]);
            let r = &rows[6 * (n / 2)..6 * (n / 2 + 16_384)];
            Box::new(move || {
                for _ in 0..n / 16_384 {
                    t.nearest_flat(black_box(r), &mut o).expect("shapes");
                }
            })
        }),
        ("memory (read a pair and a random cell)", {
            let cells = vec![[0.0f64; 4]; n];
            let (r, mut o) = (&rows, vec![0.0; 3 * n]);
            Box::new(move || {
                o.par_chunks_mut(3 * 4096)
                    .zip(r.par_chunks(6 * 4096))
                    .for_each(|(o, p)| {
                        for (o, p) in o.chunks_exact_mut(3).zip(p.chunks_exact(6)) {
                            let h = (p[0].to_bits() ^ p[4].to_bits()).wrapping_mul(0x9e37_79b9);
                            let c = &cells[(h >> 20) as usize % n];
                            o[0] = c[0] + p[1];
                            o[1] = c[1] + p[3];
                            o[2] = c[2] + p[5];
                        }
                    });
                black_box(&o);
            })
        }),
        ("interpolated", {
            let (t, r, mut o) = (&table, &rows, vec![0.0; 3 * n]);
            Box::new(move || t.interpolated_flat(black_box(r), &mut o).expect("shapes"))
        }),
    ];
    time_cases(
        &format!("lookup bench: {n} random pairs ({found} found), {threads} threads"),
        cases,
        opts,
    );
}
