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

/// The three evaluation methods of a [`Model`](brdfkit_core::Model) whose value and
/// gradient come from one `self.kernel(pair, grad)` per pair, the gradient (at most
/// `$p` entries, of which the kernel fills `num_params()`) into a fixed array: the
/// single pair through [`pair_geometry`] and [`grad_via`](crate::params::grad_via), the
/// batches through [`batch_pair`] and [`grad_batch_via`](crate::params::grad_batch_via).
macro_rules! pair_kernel_evals {
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
