//! Parallel bulk evaluation of a model over a precomputed batch.
//!
//! Runs of [`RUN`] pairs are handed out from an atomic counter to every thread of the
//! current rayon pool, which [`rayon::broadcast`] wakes explicitly. With a plain
//! `par_chunks_mut` a job of a few milliseconds on a 2-thread pool was measured to run on
//! one thread in about a third of the repetitions (the second worker was still asleep
//! when the first had split and stolen all the work back; docs/performance.md); waking
//! every worker up front removed that bimodality.

use brdfkit_core::{GeomSlice, GeomSliceF32, Model, Rgb};

/// Pairs per unit of work: large enough that the per-run overhead (a counter increment,
/// an uncontended lock, the model's set-up) is negligible, small enough to balance.
pub const RUN: usize = 8192;

pub(crate) use brdfkit_core::par::spread;

/// [`Model::eval_batch`] over the whole of `g` on every thread of the current rayon pool:
/// `out[k]` for pair k (`out.len()` pairs are evaluated; at most `g.len()`).
pub fn eval_batch_par(m: &dyn Model, g: &GeomSlice<'_>, out: &mut [Rgb]) {
    let n = g.len().min(out.len());
    let runs: Vec<&mut [Rgb]> = out[..n].chunks_mut(RUN).collect();
    spread(runs, |i, o| {
        let a = i * RUN;
        m.eval_batch(&g.sub(a..a + o.len()), o);
    });
}

/// [`Model::eval_batch_f32`] over the whole of `g` on every thread of the current rayon
/// pool, into one plane per channel.
pub fn eval_batch_f32_par(m: &dyn Model, g: &GeomSliceF32<'_>, out: [&mut [f32]; 3]) {
    let [r, gg, b] = out;
    let n = g.len().min(r.len()).min(gg.len()).min(b.len());
    let runs: Vec<[&mut [f32]; 3]> = r[..n]
        .chunks_mut(RUN)
        .zip(gg[..n].chunks_mut(RUN))
        .zip(b[..n].chunks_mut(RUN))
        .map(|((r, g), b)| [r, g, b])
        .collect();
    spread(runs, |i, o| {
        let a = i * RUN;
        let len = o[0].len();
        m.eval_batch_f32(&g.sub(a..a + len), o);
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::random_pairs;
    use brdfkit_core::{GeometryBatch, GeometryBatchF32};

    /// The parallel drivers give exactly the serial results, for a length that leaves a
    /// short last run, on pools of 1 and 3 threads.
    #[test]
    fn parallel_equals_serial() {
        let pairs = random_pairs(5, 3 * RUN + 17);
        let b = GeometryBatch::from_pairs(&pairs);
        let s = b.as_slice();
        let b32 = GeometryBatchF32::from_slice(&s);
        let s32 = b32.as_slice();
        let n = pairs.len();
        for name in ["cook-torrance", "lafortune"] {
            let m = crate::default_model(name).unwrap();
            let mut want = vec![Rgb::ZERO; n];
            m.eval_batch(&s, &mut want);
            let mut w32 = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
            let [a, bb, c] = &mut w32;
            m.eval_batch_f32(&s32, [a, bb, c]);
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| {
                    let mut got = vec![Rgb::splat(-1.0); n];
                    eval_batch_par(m.as_ref(), &s, &mut got);
                    assert_eq!(got, want, "{name} on {threads} threads");
                    let mut g32 = [vec![-1f32; n], vec![-1f32; n], vec![-1f32; n]];
                    let [a, bb, c] = &mut g32;
                    eval_batch_f32_par(m.as_ref(), &s32, [a, bb, c]);
                    assert_eq!(g32, w32, "{name} f32 on {threads} threads");
                });
            }
        }
    }
}
