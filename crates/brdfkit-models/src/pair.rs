//! The geometry of one pair as the half-vector kernels take it: wi, wo, the unit half
//! vector h and cos θd = wi·h as arrays, the same from a direction pair as from a
//! [`GeometryBatch`](brdfkit_core::GeometryBatch), so the slow and the fast paths of a
//! model share every operation.

use brdfkit_core::{GeomSlice, Vec3};

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
