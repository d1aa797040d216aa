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
