//! The geometry of one pair as the half-vector kernels take it: wi, wo, the unit half
//! vector h and cos θd = wi·h as arrays, the same from a direction pair as from a
//! [`GeometryBatch`](brdfkit_core::GeometryBatch), so the slow and the fast paths of a
//! model share every operation.

use brdfkit_core::{GeomSlice, Rgb, Vec3};

/// The geometry of one pair exactly as [`GeometryBatch::push`] computes it.
///
/// [`GeometryBatch::push`]: brdfkit_core::GeometryBatch::push
#[inline]
pub(crate) fn pair_geometry(wi: &Vec3, wo: &Vec3) -> ([f64; 3], [f64; 3], [f64; 3], f64) {
    let h = brdfkit_core::geometry::half_vector(wi, wo);
    (
        [wi.x, wi.y, wi.z],
        [wo.x, wo.y, wo.z],
        [h.x, h.y, h.z],
        wi.dot(&h),
    )
}

/// Pair `k` of a batch as arrays.
#[inline(always)]
pub(crate) fn batch_pair(g: &GeomSlice<'_>, k: usize) -> ([f64; 3], [f64; 3], [f64; 3], f64) {
    (
        [g.wi_x[k], g.wi_y[k], g.wi_z[k]],
        [g.wo_x[k], g.wo_y[k], g.wo_z[k]],
        [g.h_x[k], g.h_y[k], g.h_z[k]],
        g.cos_d[k],
    )
}

/// `eval_batch` (`grad` None) or `eval_grad_batch` of a model whose pair kernel takes
/// [`batch_pair`]'s arrays and an optional gradient of `P` entries: the values into
/// `out`, the parameter-major gradient (`grad[p * n + k]`) into `grad`.
pub(crate) fn batch_by_pairs<const P: usize>(
    g: &GeomSlice<'_>,
    out: &mut [Rgb],
    mut grad: Option<&mut [Rgb]>,
    kernel: impl Fn([f64; 3], [f64; 3], [f64; 3], f64, Option<&mut [Rgb]>) -> Rgb,
) {
    let n = g.len();
    let mut gk = [Rgb::ZERO; P];
    for (k, o) in out.iter_mut().enumerate().take(n) {
        let (i, w, h, cd) = batch_pair(g, k);
        match grad.as_deref_mut() {
            None => *o = kernel(i, w, h, cd, None),
            Some(gr) => {
                *o = kernel(i, w, h, cd, Some(&mut gk));
                for (p, v) in gk.iter().enumerate() {
                    gr[p * n + k] = *v;
                }
            }
        }
    }
}

/// The three evaluation methods of a [`Model`](brdfkit_core::Model) whose value and
/// gradient come from one `self.kernel(i, o, h, cos_d, grad)` per pair, with `$p`
/// parameters: the single pair through [`pair_geometry`], the batches through
/// [`batch_by_pairs`].
macro_rules! pair_kernel_evals {
    ($p:literal) => {
        fn eval_grad(
            &self,
            wi: &brdfkit_core::Vec3,
            wo: &brdfkit_core::Vec3,
            grad: &mut [brdfkit_core::Rgb],
        ) -> brdfkit_core::Rgb {
            let (i, o, h, cd) = $crate::pair::pair_geometry(wi, wo);
            self.kernel(i, o, h, cd, Some(grad))
        }

        fn eval_batch(&self, g: &brdfkit_core::GeomSlice<'_>, out: &mut [brdfkit_core::Rgb]) {
            $crate::pair::batch_by_pairs::<$p>(g, out, None, |i, w, h, cd, gr| {
                self.kernel(i, w, h, cd, gr)
            });
        }

        fn eval_grad_batch(
            &self,
            g: &brdfkit_core::GeomSlice<'_>,
            out: &mut [brdfkit_core::Rgb],
            grad: &mut [brdfkit_core::Rgb],
        ) {
            $crate::pair::batch_by_pairs::<$p>(g, out, Some(grad), |i, w, h, cd, gr| {
                self.kernel(i, w, h, cd, gr)
            });
        }
    };
}
pub(crate) use pair_kernel_evals;

/// `impl Brdf for $t`: `eval` through the model's pair kernel (see
/// [`pair_kernel_evals`]).
macro_rules! pair_kernel_brdf {
    ($t:ty) => {
        impl brdfkit_core::Brdf for $t {
            fn eval(&self, wi: &brdfkit_core::Vec3, wo: &brdfkit_core::Vec3) -> brdfkit_core::Rgb {
                let (i, o, h, cd) = $crate::pair::pair_geometry(wi, wo);
                self.kernel(i, o, h, cd, None)
            }
        }
    };
}
pub(crate) use pair_kernel_brdf;
