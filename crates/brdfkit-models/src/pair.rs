//! The geometry of one pair as the half-vector kernels take it: wi, wo, the unit half
//! vector h and cos θd = wi·h as arrays, the same from a direction pair as from a
//! [`GeometryBatch`](brdfkit_core::GeometryBatch), so the slow and the fast paths of a
//! model share every operation.

use brdfkit_core::{GeomSlice, Rgb, Vec3};

/// `f(wi, wo)` of every pair of `g` whose directions are both above the horizon, into
/// `out` (the first `g.len()` entries), 0 for the others: the batch form of a
/// model whose `eval` returns 0 below the horizon and otherwise evaluates the pair.
#[inline(always)]
pub(crate) fn eval_above_horizon(
    g: &GeomSlice<'_>,
    out: &mut [Rgb],
    f: impl Fn([f64; 3], [f64; 3]) -> Rgb,
) {
    let n = g.len();
    let [[ix, iy, iz], [ox, oy, oz]] = g.dirs();
    for (k, o) in out[..n].iter_mut().enumerate() {
        *o = if iz[k] > 0.0 && oz[k] > 0.0 {
            f([ix[k], iy[k], iz[k]], [ox[k], oy[k], oz[k]])
        } else {
            Rgb::ZERO
        };
    }
}

/// One pair as a half-vector kernel takes it: the directions, the unit half vector
/// h = (wi + wo)/|wi + wo| and cos θd = wi·h (Rusinkiewicz 1998).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PairGeom {
    pub wi: [f64; 3],
    pub wo: [f64; 3],
    pub h: [f64; 3],
    pub cos_d: f64,
}

/// The geometry of one pair exactly as [`GeometryBatch::push`] computes it.
///
/// [`GeometryBatch::push`]: brdfkit_core::GeometryBatch::push
#[inline]
pub(crate) fn pair_geometry(wi: &Vec3, wo: &Vec3) -> PairGeom {
    let h = brdfkit_core::geometry::half_vector(wi, wo);
    PairGeom {
        wi: [wi.x, wi.y, wi.z],
        wo: [wo.x, wo.y, wo.z],
        h: [h.x, h.y, h.z],
        cos_d: wi.dot(&h),
    }
}

/// Pair `k` of a batch.
#[inline(always)]
pub(crate) fn batch_pair(g: &GeomSlice<'_>, k: usize) -> PairGeom {
    PairGeom {
        wi: [g.wi_x[k], g.wi_y[k], g.wi_z[k]],
        wo: [g.wo_x[k], g.wo_y[k], g.wo_z[k]],
        h: [g.h_x[k], g.h_y[k], g.h_z[k]],
        cos_d: g.cos_d[k],
    }
}

/// `eval_grad` of a [`Model`](brdfkit_core::Model) through its
/// `self.kernel(pair, grad)`: the pair by [`pair_geometry`], the gradient (at most `$p`
/// entries) by [`grad_via`](crate::params::grad_via).
macro_rules! pair_eval_grad {
    ($p:expr) => {
        fn eval_grad(
            &self,
            wi: &brdfkit_core::Vec3,
            wo: &brdfkit_core::Vec3,
            grad: &mut [brdfkit_core::Rgb],
        ) -> brdfkit_core::Rgb {
            let p = $crate::pair::pair_geometry(wi, wo);
            let np = brdfkit_core::Model::num_params(self);
            $crate::params::grad_via::<{ $p }>(np, grad, |g| self.kernel(p, Some(g)))
        }
    };
}
pub(crate) use pair_eval_grad;

/// The three evaluation methods of a [`Model`](brdfkit_core::Model) whose value and
/// gradient come from one `self.kernel(pair, grad)` per pair, the gradient (at most
/// `$p` entries, of which the kernel fills `num_params()`) into a fixed array: the
/// single pair through [`pair_geometry`] and [`grad_via`](crate::params::grad_via), the
/// batches through [`batch_pair`] and [`grad_batch_via`](crate::params::grad_batch_via).
macro_rules! pair_kernel_evals {
    ($p:expr) => {
        $crate::pair::pair_eval_grad!($p);

        fn eval_batch(&self, g: &brdfkit_core::GeomSlice<'_>, out: &mut [brdfkit_core::Rgb]) {
            for (k, o) in out.iter_mut().enumerate().take(g.len()) {
                *o = self.kernel($crate::pair::batch_pair(g, k), None);
            }
        }

        fn eval_grad_batch(
            &self,
            g: &brdfkit_core::GeomSlice<'_>,
            out: &mut [brdfkit_core::Rgb],
            grad: &mut [brdfkit_core::Rgb],
        ) {
            let np = brdfkit_core::Model::num_params(self);
            $crate::params::grad_batch_via::<{ $p }>(g.len(), np, out, grad, |k, gk| {
                self.kernel($crate::pair::batch_pair(g, k), Some(gk))
            });
        }
    };
}
pub(crate) use pair_kernel_evals;

/// `impl Brdf for $t`: `eval` through the model's pair kernel (see
/// [`pair_kernel_evals`]); with `isotropic: field`, isotropic when that lobe shape is
/// symmetric.
macro_rules! pair_kernel_brdf {
    ($t:ty $(, isotropic: $shape:ident)?) => {
        impl brdfkit_core::Brdf for $t {
            fn eval(&self, wi: &brdfkit_core::Vec3, wo: &brdfkit_core::Vec3) -> brdfkit_core::Rgb {
                self.kernel($crate::pair::pair_geometry(wi, wo), None)
            }
            $(
                fn is_isotropic(&self) -> bool {
                    self.$shape.is_symmetric()
                }
            )?
        }
    };
}
pub(crate) use pair_kernel_brdf;

/// A half-vector model's per-pair kernel in the form the lane loops of
/// [`lane_batch`] take (a `Copy` value holding the model's parameters, which the loops
/// copy into locals): the channel-free factors of a pair ([`PairTerms::Terms`]),
/// branch-free and with no library call (so a loop of them vectorises), then the value
/// and the `M` gradient entries assembled from them. The model's `eval` and `eval_grad`
/// call the same three functions, so every path gives the same bits.
pub(crate) trait PairTerms<const M: usize>: Copy {
    /// The factors of one pair.
    type Terms: Copy + Default;
    /// The factors of a pair; where `above` is false (a direction at or below the
    /// horizon) factors for which [`PairTerms::value`] and [`PairTerms::gradient`] are
    /// +0 (the geometry there may give any finite or non-finite number, selected away).
    fn terms(&self, above: bool, wi: [f64; 3], wo: [f64; 3], h: [f64; 3]) -> Self::Terms;
    /// f from the factors.
    fn value(&self, t: &Self::Terms) -> Rgb;
    /// ∂f/∂p from the factors, all `M` entries (those past the model's parameter count
    /// are ignored).
    fn gradient(&self, t: &Self::Terms) -> [Rgb; M];
}

/// `eval` and (with `grad`) `eval_grad` of one pair through a [`PairTerms`] kernel.
#[inline(always)]
pub(crate) fn pair_terms_kernel<const M: usize, K: PairTerms<M>>(
    k: &K,
    p: PairGeom,
    grad: Option<&mut [Rgb; M]>,
) -> Rgb {
    let above = p.wi[2] > 0.0 && p.wo[2] > 0.0;
    let t = k.terms(above, p.wi, p.wo, p.h);
    if let Some(gr) = grad {
        *gr = k.gradient(&t);
    }
    k.value(&t)
}

/// `eval_batch` (`grad` None) and `eval_grad_batch` (the first `np` gradient columns,
/// parameter-major) of a [`PairTerms`] kernel as lane loops run through
/// [`lanes::dispatch`](crate::lanes::dispatch): the value loop in one pass; the gradient
/// loop computes the factors of blocks of [`BLOCK`] pairs into a local array (a loop
/// with no `Rgb` store, which vectorises: stores to several columns in one loop kept
/// it scalar), then writes the value and the columns.
pub(crate) fn lane_batch<const M: usize, K: PairTerms<M>>(
    k: &K,
    np: usize,
    g: &GeomSlice<'_>,
    out: &mut [Rgb],
    grad: Option<&mut [Rgb]>,
) {
    crate::lanes::dispatch(&mut LaneBatch::<K, M> {
        k,
        np,
        g,
        out,
        grad,
    });
}

/// Pairs per block of [`lane_batch`]'s gradient loop.
const BLOCK: usize = 64;

/// The nine geometry columns wi, wo, h of a batch, each cut to its length (so the
/// loops over them carry no bounds checks).
type Cols<'a> = [&'a [f64]; 9];

/// Pair k of [`Cols`]: whether both directions are above the horizon, wi, wo, h.
#[inline(always)]
fn pair_of(d: &Cols<'_>, k: usize) -> (bool, [f64; 3], [f64; 3], [f64; 3]) {
    let wi = [d[0][k], d[1][k], d[2][k]];
    let wo = [d[3][k], d[4][k], d[5][k]];
    let h = [d[6][k], d[7][k], d[8][k]];
    (wi[2] > 0.0 && wo[2] > 0.0, wi, wo, h)
}

/// The loops of [`lane_batch`].
struct LaneBatch<'a, 'g, K, const M: usize> {
    k: &'a K,
    np: usize,
    g: &'a GeomSlice<'g>,
    out: &'a mut [Rgb],
    grad: Option<&'a mut [Rgb]>,
}

impl<const M: usize, K: PairTerms<M>> crate::lanes::Run for LaneBatch<'_, '_, K, M> {
    #[inline(always)]
    fn run(&mut self) {
        // A local copy: loads through the struct's reference are not known to be
        // unaffected by the stores to `out` and stay in the loop (kept it scalar).
        let (k, g, n) = (*self.k, self.g, self.g.len());
        let d: Cols<'_> = [
            g.wi_x, g.wi_y, g.wi_z, g.wo_x, g.wo_y, g.wo_z, g.h_x, g.h_y, g.h_z,
        ]
        .map(|c| &c[..n]);
        let out = &mut self.out[..n];
        let Some(grad) = self.grad.as_deref_mut() else {
            for (i, o) in out.iter_mut().enumerate() {
                let (above, wi, wo, h) = pair_of(&d, i);
                *o = k.value(&k.terms(above, wi, wo, h));
            }
            return;
        };
        let grad = &mut grad[..self.np * n];
        for s in (0..n).step_by(BLOCK) {
            let e = (s + BLOCK).min(n);
            let t = terms_block(&k, &d.map(|c| &c[s..e]));
            for (i, j) in (s..e).enumerate() {
                out[j] = k.value(&t[i]);
                for (p, v) in k.gradient(&t[i]).iter().enumerate().take(self.np) {
                    grad[p * n + j] = *v;
                }
            }
        }
    }
}

/// The gradient entries of a model whose first six parameters are a diffuse and a
/// specular colour entering f as d[c] · `dd` + s[c] · `ds`: ∂f/∂d = `dd`, ∂f/∂s = `ds`,
/// each in its own channel; the other entries 0.
#[inline(always)]
pub(crate) fn diffuse_specular_grad<const M: usize>(dd: f64, ds: f64) -> [Rgb; M] {
    let mut gr = [Rgb::ZERO; M];
    for c in 0..3 {
        gr[c].0[c] = dd;
        gr[3 + c].0[c] = ds;
    }
    gr
}

/// The factors of a block of at most [`BLOCK`] pairs into a local array.
#[inline(always)]
fn terms_block<const M: usize, K: PairTerms<M>>(k: &K, d: &Cols<'_>) -> [K::Terms; BLOCK] {
    let mut q = [K::Terms::default(); BLOCK];
    let len = d[0].len().min(BLOCK);
    for (i, q) in q[..len].iter_mut().enumerate() {
        let (above, wi, wo, h) = pair_of(d, i);
        *q = k.terms(above, wi, wo, h);
    }
    q
}

/// The three evaluation methods of a [`Model`](brdfkit_core::Model) whose value and
/// gradient come from a [`PairTerms`]`<$p>` kernel: `eval_grad` through the model's
/// `kernel(pair, grad)` (which calls [`pair_terms_kernel`]) and
/// [`grad_via`](crate::params::grad_via), the batches through the model's
/// `batch(g, out, grad)` (which calls [`lane_batch`]). With [`pair_kernel_brdf`],
/// `eval` is the same kernel.
macro_rules! pair_terms_evals {
    ($p:expr) => {
        $crate::pair::pair_eval_grad!($p);

        fn eval_batch(&self, g: &brdfkit_core::GeomSlice<'_>, out: &mut [brdfkit_core::Rgb]) {
            self.batch(g, out, None);
        }

        fn eval_grad_batch(
            &self,
            g: &brdfkit_core::GeomSlice<'_>,
            out: &mut [brdfkit_core::Rgb],
            grad: &mut [brdfkit_core::Rgb],
        ) {
            self.batch(g, out, Some(grad));
        }
    };
}
pub(crate) use pair_terms_evals;
