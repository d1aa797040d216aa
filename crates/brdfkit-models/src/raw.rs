//! Bulk evaluation of any model from raw direction pairs: `(wi, wo)` arrays in, f_r out,
//! in `f64` or `f32`, on every thread of the current rayon pool.
//!
//! This is what a renderer or a script passes: directions, no precomputed geometry. Each
//! thread takes runs of [`RUN`] pairs (handed out as in [`crate::par`])
//! and cuts them into runs of [`GEOM_RUN`] pairs; for each it fills a per-thread
//! [`Geometry`] from the directions ([`Geometry::fill_from_dirs`]: the half vector and
//! cos θd, a branch-free loop compiled for AVX-512 or AVX2 where the processor has them)
//! and calls the model's [`Model::eval_batch`] or [`Model::eval_batch_f32`] on it, while
//! it is still in the L1/L2 cache. Nothing proportional to the input is allocated.
//! A model with its own fused kernel ([`Model::eval_dirs_fused`], Cook-Torrance with
//! GGX) reads the directions itself instead, one pass over memory.
//!
//! **Values.** In `f64` ([`eval_dirs`], [`eval_dirs_flat`]) pair k gets exactly the bits
//! of `m.eval(wi[k], wo[k])`: the geometry is [`GeometryBatch::from_pairs`]'s to the bit
//! (brdfkit-core's `half_and_cos_d`) and every model's `eval_batch` equals its `eval`
//! (tested for every registered model in `tests/raw.rs`). In `f32` ([`eval_dirs_f32`],
//! [`eval_dirs_flat_f32`]) the half vector and cos θd are computed in float32 from the
//! float32 directions, then the model's float32 path runs (`cook-torrance` with GGX: its
//! native float32 kernel; every other model: widened to `f64` and rounded). Against
//! `eval` on the same directions (widened to `f64`) the relative error stays below 5e-5
//! for every registered model (tested in `tests/raw.rs` over random, near-specular,
//! grazing and hard-case pairs; measured at most 9e-6, `ashikhmin-shirley`, and 1.3e-6
//! for Cook-Torrance with α from 0.02 to 0.9), and f_r is exactly 0 wherever `eval`
//! gives 0. Rounding the directions themselves to float32 is the caller's (it moves
//! f_r by the lobe's slope times ~6e-8 rad).
//!
//! **Inputs.** Directions are taken as they are, like [`Brdf::eval`](brdfkit_core::Brdf)
//! takes them: unit vectors in the local frame (z = normal), pointing away from the
//! surface (docs/conventions). They are not normalised: that would cost a square root
//! and a division per direction and give other bits than `eval`. A direction at or below
//! the horizon gives exactly 0; wi = −wo takes the normal as half vector; non-unit input
//! gives whatever `eval` gives for it. Lengths that do not fit together are a
//! [`DirsError`], never a panic.

use crate::lanes::{Run, dispatch};
use crate::par::{RUN, spread};
use brdfkit_core::geometry::{Component, DirsError};
use brdfkit_core::{DirPairs, Geometry, GeometryBatch, GeometryBatchF32, Model, Rgb};
use std::cell::RefCell;

/// Pairs per geometry run: a run's float32 geometry (10 columns) and its three output
/// planes take 52 KB, its f64 geometry 80 KB, so both stay in the L2 cache (1 MB or more
/// on current x86) between the fill and the model's loop; larger runs were no faster.
pub const GEOM_RUN: usize = 1024;

/// The fill of one geometry run, run by [`dispatch`] so that the inlined loop of
/// [`Geometry::fill_from_dirs`] is compiled with the widest vectors available.
struct Fill<'a, 'd, T> {
    g: &'a mut Geometry<T>,
    dirs: DirPairs<'d, T>,
}

impl<T: Component> Run for Fill<'_, '_, T> {
    #[inline(always)]
    fn run(&mut self) {
        self.g.fill_from_pairs(self.dirs);
    }
}

fn fill<T: Component>(g: &mut Geometry<T>, dirs: DirPairs<'_, T>) {
    dispatch(&mut Fill { g, dirs });
}

/// Three planes into `[r, g, b]` rows (vectorised: the planes are cut to the rows'
/// length, so the loop has no bounds checks).
struct Interleave<'a, 'o> {
    planes: [&'a [f32]; 3],
    out: &'o mut [[f32; 3]],
}

impl Run for Interleave<'_, '_> {
    #[inline(always)]
    fn run(&mut self) {
        let n = self.out.len();
        let [r, g, b] = self.planes.map(|p| &p[..n]);
        for (k, o) in self.out.iter_mut().enumerate() {
            *o = [r[k], g[k], b[k]];
        }
    }
}

/// A thread's buffers: one geometry run per precision and its values.
#[derive(Default)]
struct Scratch {
    g64: GeometryBatch,
    vals: Vec<Rgb>,
    g32: GeometryBatchF32,
    planes: [Vec<f32>; 3],
}

thread_local! {
    /// Kept for the thread's life: about 0.2 MB per thread once used.
    static SCRATCH: RefCell<Scratch> = RefCell::default();
}

/// Runs `f` with this thread's scratch (a fresh one if it is in use further up the
/// stack, which the drivers below never do, but a model could).
fn with_scratch(f: impl FnOnce(&mut Scratch)) {
    SCRATCH.with(|s| match s.try_borrow_mut() {
        Ok(mut s) => f(&mut s),
        Err(_) => f(&mut Scratch::default()),
    })
}

/// Runs `f(run index, run)` for every run: on the calling thread when there is only one
/// (no wake-up of the pool for small batches), else spread over the current rayon pool.
fn for_runs<O: Send>(runs: Vec<O>, f: impl Fn(usize, O) + Sync) {
    if runs.len() <= 1 {
        runs.into_iter().for_each(|o| f(0, o));
    } else {
        spread(runs, f);
    }
}

/// An f64 output layout: [`Rgb`] (written by `eval_batch` directly) or `[r, g, b]` rows.
trait Out64: Send + Sized {
    /// f_r of the pairs of `g` into `o`, `vals` a scratch buffer.
    fn eval(m: &dyn Model, g: &GeometryBatch, o: &mut [Self], vals: &mut Vec<Rgb>);
    /// The model's fused kernel into `o` ([`Model::eval_dirs_fused`]); false when it
    /// has none.
    fn fused(m: &dyn Model, dirs: DirPairs<'_, f64>, o: &mut [Self]) -> bool;
}

impl Out64 for Rgb {
    fn eval(m: &dyn Model, g: &GeometryBatch, o: &mut [Self], _: &mut Vec<Rgb>) {
        m.eval_batch(&g.as_slice(), o);
    }
    fn fused(m: &dyn Model, dirs: DirPairs<'_, f64>, o: &mut [Self]) -> bool {
        m.eval_dirs_fused(dirs, o)
    }
}

impl Out64 for [f64; 3] {
    fn fused(m: &dyn Model, dirs: DirPairs<'_, f64>, o: &mut [Self]) -> bool {
        m.eval_dirs_fused_rows(dirs, o)
    }
    fn eval(m: &dyn Model, g: &GeometryBatch, o: &mut [Self], vals: &mut Vec<Rgb>) {
        vals.resize(o.len(), Rgb::ZERO);
        m.eval_batch(&g.as_slice(), vals);
        for (o, v) in o.iter_mut().zip(vals.iter()) {
            *o = v.0;
        }
    }
}

/// The f64 driver: pair `k` of `dirs` into `out[k]`.
fn drive64<O: Out64>(m: &dyn Model, dirs: DirPairs<'_, f64>, out: &mut [O]) {
    let runs: Vec<&mut [O]> = out.chunks_mut(RUN).collect();
    for_runs(runs, |i, o| {
        let a = i * RUN;
        // A model's own fused kernel (Cook-Torrance's GGX loop) reads the directions in
        // one pass; the fill, the kernel and a copy cost more on 2 cores
        // (docs/performance.md).
        if O::fused(m, dirs.sub(a..a + o.len()), o) {
            return;
        }
        with_scratch(|s| {
            for (j, o) in o.chunks_mut(GEOM_RUN).enumerate() {
                let a = i * RUN + j * GEOM_RUN;
                fill(&mut s.g64, dirs.sub(a..a + o.len()));
                O::eval(m, &s.g64, o, &mut s.vals);
            }
        })
    });
}

/// The f32 driver: pair `k` of `dirs` into `out[k]`.
fn drive32(m: &dyn Model, dirs: DirPairs<'_, f32>, out: &mut [[f32; 3]]) {
    let runs: Vec<&mut [[f32; 3]]> = out.chunks_mut(RUN).collect();
    for_runs(runs, |i, o| {
        let a = i * RUN;
        if m.eval_dirs_fused_f32(dirs.sub(a..a + o.len()), o) {
            return;
        }
        with_scratch(|s| {
            for (j, o) in o.chunks_mut(GEOM_RUN).enumerate() {
                let a = i * RUN + j * GEOM_RUN;
                let n = o.len();
                fill(&mut s.g32, dirs.sub(a..a + n));
                let [r, g, b] = &mut s.planes;
                for p in [&mut *r, &mut *g, &mut *b] {
                    p.resize(n, 0.0);
                }
                m.eval_batch_f32(&s.g32.as_slice(), [&mut r[..n], &mut g[..n], &mut b[..n]]);
                dispatch(&mut Interleave {
                    planes: [&r[..n], &g[..n], &b[..n]],
                    out: o,
                });
            }
        })
    });
}

fn check(wi: usize, wo: usize, out: usize) -> Result<(), DirsError> {
    if wi != wo {
        return Err(DirsError::Mismatch { wi, wo });
    }
    if out != wi {
        return Err(DirsError::Output {
            pairs: wi,
            need: wi,
            got: out,
        });
    }
    Ok(())
}

/// N×6 direction rows and N×3 output rows.
type Flat<'a, 'b, T> = (&'a [[T; 6]], &'b mut [[T; 3]]);

/// N×6 values as rows; the output of N×3 values as rows of three.
fn flat<'a, 'b, T>(dirs: &'a [T], out: &'b mut [T]) -> Result<Flat<'a, 'b, T>, DirsError> {
    let (rows, rest) = dirs.as_chunks::<6>();
    if !rest.is_empty() {
        return Err(DirsError::Flat { len: dirs.len() });
    }
    let n = rows.len();
    if out.len() != 3 * n {
        return Err(DirsError::Output {
            pairs: n,
            need: 3 * n,
            got: out.len(),
        });
    }
    let (o, _) = out.as_chunks_mut::<3>();
    Ok((rows, o))
}

/// f_r of `m` for every pair `(wi[k], wo[k])` into `out[k]`, in `f64`, on the current
/// rayon pool: exactly `m.eval(wi[k], wo[k])` (module doc). `wi`, `wo` and `out` must
/// have the same length.
pub fn eval_dirs(
    m: &dyn Model,
    wi: &[[f64; 3]],
    wo: &[[f64; 3]],
    out: &mut [Rgb],
) -> Result<(), DirsError> {
    check(wi.len(), wo.len(), out.len())?;
    drive64(m, DirPairs::Split(wi, wo), out);
    Ok(())
}

/// [`eval_dirs`] on an N×6 row-major array `[wi_x, wi_y, wi_z, wo_x, wo_y, wo_z]` per
/// pair (a NumPy `(N, 6)` float64 array), into an N×3 array `[r, g, b]` per pair.
pub fn eval_dirs_flat(m: &dyn Model, dirs: &[f64], out: &mut [f64]) -> Result<(), DirsError> {
    let (rows, out) = flat(dirs, out)?;
    drive64(m, DirPairs::Rows(rows), out);
    Ok(())
}

/// f_r of `m` in single precision for every pair `(wi[k], wo[k])` into `out[k]` (`[r, g,
/// b]`), on the current rayon pool: the half vector in float32 and the model's
/// [`Model::eval_batch_f32`] (module doc for its error). `wi`, `wo` and `out` must have
/// the same length.
pub fn eval_dirs_f32(
    m: &dyn Model,
    wi: &[[f32; 3]],
    wo: &[[f32; 3]],
    out: &mut [[f32; 3]],
) -> Result<(), DirsError> {
    check(wi.len(), wo.len(), out.len())?;
    drive32(m, DirPairs::Split(wi, wo), out);
    Ok(())
}

/// [`eval_dirs_f32`] on an N×6 row-major float32 array, into an N×3 float32 array (as
/// [`eval_dirs_flat`]).
pub fn eval_dirs_flat_f32(m: &dyn Model, dirs: &[f32], out: &mut [f32]) -> Result<(), DirsError> {
    let (rows, out) = flat(dirs, out)?;
    drive32(m, DirPairs::Rows(rows), out);
    Ok(())
}
