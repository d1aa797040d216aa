//! Per-pair geometry precomputed once, as a structure of arrays.
//!
//! A fit evaluates the same million direction pairs hundreds of times with different
//! parameters. Everything that depends only on the directions (the vectors, the half
//! vector, cos θd) is computed once here; [`Model::eval_batch`](crate::Model::eval_batch)
//! then runs tight loops over plain `f64` slices that the compiler can vectorise, and
//! rayon splits a batch into [`GeomSlice`]s. The same columns rounded to `f32`
//! ([`GeometryBatchF32`]) feed the single-precision path
//! ([`Model::eval_batch_f32`](crate::Model::eval_batch_f32)).

use crate::Vec3;

/// Geometry of many direction pairs, one column per quantity, in precision `T`.
///
/// For pair k: `wi = (wi_x[k], wi_y[k], wi_z[k])`, likewise `wo`; `h` is the unit
/// half vector (the normal when wi = −wo), `cos_d = wi·h` (= wo·h = cos θd).
/// `wi_z` and `wo_z` are cos θi and cos θo.
#[derive(Clone, Debug, Default)]
pub struct Geometry<T> {
    /// x of `wi`.
    pub wi_x: Vec<T>,
    /// y of `wi`.
    pub wi_y: Vec<T>,
    /// z of `wi`: cos θi.
    pub wi_z: Vec<T>,
    /// x of `wo`.
    pub wo_x: Vec<T>,
    /// y of `wo`.
    pub wo_y: Vec<T>,
    /// z of `wo`: cos θo.
    pub wo_z: Vec<T>,
    /// x of the unit half vector h.
    pub h_x: Vec<T>,
    /// y of the unit half vector h.
    pub h_y: Vec<T>,
    /// z of the unit half vector h: cos θh.
    pub h_z: Vec<T>,
    /// wi·h = wo·h = cos θd.
    pub cos_d: Vec<T>,
}

/// A borrowed run of a [`Geometry`]: the unit a model's fast path works on.
#[derive(Clone, Copy, Debug)]
pub struct GeomSliceOf<'a, T> {
    /// x of `wi`.
    pub wi_x: &'a [T],
    /// y of `wi`.
    pub wi_y: &'a [T],
    /// z of `wi`: cos θi.
    pub wi_z: &'a [T],
    /// x of `wo`.
    pub wo_x: &'a [T],
    /// y of `wo`.
    pub wo_y: &'a [T],
    /// z of `wo`: cos θo.
    pub wo_z: &'a [T],
    /// x of the unit half vector h.
    pub h_x: &'a [T],
    /// y of the unit half vector h.
    pub h_y: &'a [T],
    /// z of the unit half vector h: cos θh.
    pub h_z: &'a [T],
    /// wi·h = wo·h = cos θd.
    pub cos_d: &'a [T],
}

/// The double-precision geometry every model evaluates.
pub type GeometryBatch = Geometry<f64>;
/// A run of a [`GeometryBatch`].
pub type GeomSlice<'a> = GeomSliceOf<'a, f64>;
/// The columns of a [`GeometryBatch`] rounded to `f32` ([`GeometryBatchF32::from_slice`]),
/// for the models' single-precision fast path: half the bytes per pair and twice the
/// vector lanes.
pub type GeometryBatchF32 = Geometry<f32>;
/// A run of a [`GeometryBatchF32`].
pub type GeomSliceF32<'a> = GeomSliceOf<'a, f32>;

/// Unit half vector of a pair; the normal when wi = −wo (no half vector exists).
pub fn half_vector(wi: &Vec3, wo: &Vec3) -> Vec3 {
    let s = wi + wo;
    let n = s.norm();
    if n > 0.0 {
        s / n
    } else {
        Vec3::new(0.0, 0.0, 1.0)
    }
}

/// The ten columns of one pair, in declaration order: wi, wo, the unit half vector
/// ([`half_vector`]) and cos θd = wi·h. What [`GeometryBatch::push`] stores; code that
/// fills a [`Geometry::zeroed`] batch in place writes the same numbers.
pub fn pair_columns(wi: &Vec3, wo: &Vec3) -> [f64; 10] {
    let h = half_vector(wi, wo);
    [
        wi.x,
        wi.y,
        wi.z,
        wo.x,
        wo.y,
        wo.z,
        h.x,
        h.y,
        h.z,
        wi.dot(&h),
    ]
}

/// Splits `N` equally long columns into consecutive runs of `lens` rows each (one array
/// of sub-slices per run), so that parallel tasks can fill disjoint stretches of the
/// final columns without copies. `lens` must not sum past the columns' length.
pub fn split_runs<'a, T, const N: usize>(
    cols: [&'a mut [T]; N],
    lens: &[usize],
) -> Vec<[&'a mut [T]; N]> {
    let mut rest = cols;
    lens.iter()
        .map(|&len| {
            std::array::from_fn(|c| {
                let (a, b) = std::mem::take(&mut rest[c]).split_at_mut(len);
                rest[c] = b;
                a
            })
        })
        .collect()
}

impl<T> Geometry<T> {
    /// The ten columns as vectors, in declaration order.
    fn column_vecs(&mut self) -> [&mut Vec<T>; 10] {
        [
            &mut self.wi_x,
            &mut self.wi_y,
            &mut self.wi_z,
            &mut self.wo_x,
            &mut self.wo_y,
            &mut self.wo_z,
            &mut self.h_x,
            &mut self.h_y,
            &mut self.h_z,
            &mut self.cos_d,
        ]
    }

    /// Empty batch with room for `n` pairs.
    pub fn with_capacity(n: usize) -> Self {
        let v = || Vec::with_capacity(n);
        Geometry {
            wi_x: v(),
            wi_y: v(),
            wi_z: v(),
            wo_x: v(),
            wo_y: v(),
            wo_z: v(),
            h_x: v(),
            h_y: v(),
            h_z: v(),
            cos_d: v(),
        }
    }

    /// `n` pairs with every column zero, for filling in place (in parallel, by index)
    /// without a second copy.
    pub fn zeroed(n: usize) -> Self
    where
        T: Clone + Default,
    {
        let z = || vec![T::default(); n];
        Geometry {
            wi_x: z(),
            wi_y: z(),
            wi_z: z(),
            wo_x: z(),
            wo_y: z(),
            wo_z: z(),
            h_x: z(),
            h_y: z(),
            h_z: z(),
            cos_d: z(),
        }
    }

    /// The ten columns as mutable slices, in the order of [`pair_columns`], for filling
    /// a [`zeroed`](Self::zeroed) batch in place (split them with [`split_runs`]).
    pub fn columns_mut(&mut self) -> [&mut [T]; 10] {
        self.column_vecs().map(|c| c.as_mut_slice())
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.wi_x.len()
    }

    /// True when there are no pairs.
    pub fn is_empty(&self) -> bool {
        self.wi_x.is_empty()
    }

    /// The whole batch as a slice.
    pub fn as_slice(&self) -> GeomSliceOf<'_, T> {
        GeomSliceOf {
            wi_x: &self.wi_x,
            wi_y: &self.wi_y,
            wi_z: &self.wi_z,
            wo_x: &self.wo_x,
            wo_y: &self.wo_y,
            wo_z: &self.wo_z,
            h_x: &self.h_x,
            h_y: &self.h_y,
            h_z: &self.h_z,
            cos_d: &self.cos_d,
        }
    }

    /// Pairs `range` of the batch.
    pub fn slice(&self, range: std::ops::Range<usize>) -> GeomSliceOf<'_, T> {
        self.as_slice().sub(range)
    }

    /// Bytes held by the columns (for memory reports).
    pub fn heap_bytes(&self) -> usize {
        10 * self.wi_x.capacity() * std::mem::size_of::<T>()
    }

    /// Removes every pair, keeping the columns' capacity.
    pub fn clear(&mut self) {
        for c in self.column_vecs() {
            c.clear();
        }
    }
}

impl GeometryBatch {
    /// Geometry of the given pairs.
    pub fn from_pairs(pairs: &[(Vec3, Vec3)]) -> Self {
        let mut b = Self::with_capacity(pairs.len());
        for (wi, wo) in pairs {
            b.push(wi, wo);
        }
        b
    }

    /// Appends one pair.
    pub fn push(&mut self, wi: &Vec3, wo: &Vec3) {
        for (c, v) in self.column_vecs().into_iter().zip(pair_columns(wi, wo)) {
            c.push(v);
        }
    }
}

impl GeometryBatchF32 {
    /// Rounds every column of `g` to `f32` (once, to nearest), so both precisions
    /// describe the same pairs.
    pub fn from_slice(g: &GeomSlice<'_>) -> Self {
        let mut out = Geometry::with_capacity(g.len());
        for (dst, src) in out.column_vecs().into_iter().zip(g.columns()) {
            dst.extend(src.iter().map(|&x| x as f32));
        }
        out
    }
}

impl<'a, T> GeomSliceOf<'a, T> {
    /// The ten columns, in declaration order.
    fn columns(&self) -> [&'a [T]; 10] {
        [
            self.wi_x, self.wi_y, self.wi_z, self.wo_x, self.wo_y, self.wo_z, self.h_x, self.h_y,
            self.h_z, self.cos_d,
        ]
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.wi_x.len()
    }

    /// True when there are no pairs.
    pub fn is_empty(&self) -> bool {
        self.wi_x.is_empty()
    }

    /// A sub-run of this slice.
    pub fn sub(&self, r: std::ops::Range<usize>) -> GeomSliceOf<'a, T> {
        let [wi_x, wi_y, wi_z, wo_x, wo_y, wo_z, h_x, h_y, h_z, cos_d] =
            self.columns().map(|c| &c[r.clone()]);
        GeomSliceOf {
            wi_x,
            wi_y,
            wi_z,
            wo_x,
            wo_y,
            wo_z,
            h_x,
            h_y,
            h_z,
            cos_d,
        }
    }

    /// Splits into runs of at most `size` pairs (the last may be shorter).
    pub fn chunks(&self, size: usize) -> impl Iterator<Item = GeomSliceOf<'a, T>> + '_ {
        let n = self.len();
        let size = size.max(1);
        (0..n.div_ceil(size)).map(move |c| self.sub(c * size..((c + 1) * size).min(n)))
    }
}

impl GeomSlice<'_> {
    /// Pair `k` as vectors (for slow paths and tests).
    pub fn pair(&self, k: usize) -> (Vec3, Vec3) {
        (
            Vec3::new(self.wi_x[k], self.wi_y[k], self.wi_z[k]),
            Vec3::new(self.wo_x[k], self.wo_y[k], self.wo_z[k]),
        )
    }
}

impl GeomSliceF32<'_> {
    /// Widens pairs `r` back to `f64` columns, appending them to `out` (the default
    /// single-precision path of a model evaluates these in double precision).
    pub fn widen_into(&self, r: std::ops::Range<usize>, out: &mut GeometryBatch) {
        for (dst, src) in out.column_vecs().into_iter().zip(self.columns()) {
            dst.extend(src[r.clone()].iter().map(|&x| x as f64));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::direction::spherical;

    #[test]
    fn batch_columns_hold_the_pair_geometry() {
        let wi = spherical(0.4, 0.1);
        let wo = spherical(0.9, 2.0);
        let b = GeometryBatch::from_pairs(&[(wi, wo), (wo, wi)]);
        assert_eq!(b.len(), 2);
        let s = b.as_slice();
        let (a, c) = s.pair(0);
        assert_eq!(a, wi);
        assert_eq!(c, wo);
        let h = (wi + wo).normalize();
        assert!((s.h_z[0] - h.z).abs() < 1e-15);
        assert!((s.cos_d[0] - wi.dot(&h)).abs() < 1e-15);
        assert!((s.cos_d[0] - wo.dot(&h)).abs() < 1e-15);
    }

    #[test]
    fn chunks_cover_the_batch() {
        let pairs: Vec<_> = (0..10)
            .map(|k| (spherical(0.1 * k as f64, 0.0), spherical(0.2, 1.0)))
            .collect();
        let b = GeometryBatch::from_pairs(&pairs);
        let lens: Vec<usize> = b.as_slice().chunks(4).map(|c| c.len()).collect();
        assert_eq!(lens, vec![4, 4, 2]);
        assert_eq!(b.slice(3..5).wi_z[0], b.wi_z[3]);
    }

    #[test]
    fn float32_batch_rounds_each_column_once_and_widens_back() {
        let pairs: Vec<_> = (0..7)
            .map(|k| {
                (
                    spherical(0.2 * k as f64, 0.3),
                    spherical(0.1, 1.0 + k as f64),
                )
            })
            .collect();
        let b = GeometryBatch::from_pairs(&pairs);
        let f = GeometryBatchF32::from_slice(&b.as_slice());
        assert_eq!(f.len(), 7);
        assert_eq!(f.heap_bytes(), 10 * 7 * 4);
        assert_eq!(f.wo_y[3], b.wo_y[3] as f32);
        assert_eq!(f.cos_d[6], b.cos_d[6] as f32);
        let mut w = GeometryBatch::with_capacity(4);
        w.push(&pairs[0].0, &pairs[0].1);
        w.clear();
        assert!(w.is_empty());
        f.as_slice().widen_into(2..5, &mut w);
        assert_eq!(w.len(), 3);
        assert_eq!(w.h_x[0], f.h_x[2] as f64);
        assert_eq!(f.slice(2..5).wi_z[1], f.wi_z[3]);
        assert!((w.wi_z[2] - b.wi_z[4]).abs() <= 1e-7 * b.wi_z[4].abs());
    }

    #[test]
    fn opposite_pair_takes_the_normal_as_half_vector() {
        let wi = Vec3::new(1.0, 0.0, 0.0);
        assert_eq!(half_vector(&wi, &-wi), Vec3::new(0.0, 0.0, 1.0));
    }
}
