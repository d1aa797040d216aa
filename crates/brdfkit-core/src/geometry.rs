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
use std::ops::{Add, Div, Mul};
use thiserror::Error;

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

/// The precisions geometry is computed in from directions: `f64` and `f32`. Only IEEE
/// operations that vectorise (no library calls), so loops over [`pair_columns_of`] run
/// in vector registers.
pub trait Component:
    Copy
    + Default
    + PartialOrd
    + Add<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Send
    + Sync
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Whether [`half_and_cos_d`] divides each component by |wi + wo| (three correctly
    /// rounded quotients: `f64`, for the bits of the per-pair code) or multiplies by one
    /// reciprocal (`f32`: two divisions fewer, within 1 ulp more).
    const DIVIDE_EACH: bool;
    /// Correctly rounded square root.
    fn sqrt(self) -> Self;
}

/// The two float widths differ only in [`Component::DIVIDE_EACH`].
macro_rules! impl_component {
    ($($t:ident: $divide_each:literal),*) => {$(
        impl Component for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const DIVIDE_EACH: bool = $divide_each;
            #[inline(always)]
            fn sqrt(self) -> Self {
                $t::sqrt(self)
            }
        }
    )*};
}

impl_component!(f64: true, f32: false);

/// `c ? a : b`, written so that LLVM emits a blend rather than a branch.
#[inline(always)]
fn select<T: Component>(c: bool, a: T, b: T) -> T {
    if c { a } else { b }
}

/// Unit half vector h = (wi + wo)/|wi + wo| of a pair and cos θd = wi·h, branch-free;
/// h is the normal (0, 0, 1) when wi + wo is zero or not a number (wi = −wo).
///
/// The one formula of every path: in `f64` it is what [`half_vector`] and
/// [`pair_columns`] return (the same operations in the same order as nalgebra's
/// `norm()`, component-wise division and `dot`), so geometry filled from raw directions
/// ([`Geometry::fill_from_dirs`]) has the bits of [`GeometryBatch::from_pairs`]. Inputs
/// are taken as they are, not normalised: for unit wi, wo this is the Rusinkiewicz half
/// vector and cos θd (conventions.md); for other lengths h is still a unit vector
/// (where wi + wo ≠ 0) but cos θd scales with |wi|. In `f32` the three quotients are
/// one reciprocal and three products ([`Component::DIVIDE_EACH`]).
#[inline(always)]
pub fn half_and_cos_d<T: Component>(wi: [T; 3], wo: [T; 3]) -> ([T; 3], T) {
    let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    // nalgebra: norm_squared = 0 + (x² + y² + z²), and 0 + v = v for v ≥ 0 and NaN.
    let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    let up = n > T::ZERO;
    let q = if T::DIVIDE_EACH {
        // Three divisions rather than one reciprocal: the bits of nalgebra's `s / n`.
        [s[0] / n, s[1] / n, s[2] / n]
    } else {
        let r = T::ONE / n;
        [s[0] * r, s[1] * r, s[2] * r]
    };
    let h = [
        select(up, q[0], T::ZERO),
        select(up, q[1], T::ZERO),
        select(up, q[2], T::ONE),
    ];
    (h, wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2])
}

/// The ten columns of one pair in precision `T`, in declaration order: wi, wo, the unit
/// half vector and cos θd ([`half_and_cos_d`]).
#[inline(always)]
pub fn pair_columns_of<T: Component>(wi: [T; 3], wo: [T; 3]) -> [T; 10] {
    let (h, cd) = half_and_cos_d(wi, wo);
    [
        wi[0], wi[1], wi[2], wo[0], wo[1], wo[2], h[0], h[1], h[2], cd,
    ]
}

/// A set of the ten geometry columns, by their place in [`pair_columns`]' order: what
/// a pass or a model reads ([`Model::geometry_columns`](crate::Model::geometry_columns)),
/// so that geometry computed where read (a table's cells) computes and stores only
/// those.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Columns(u16);

impl Columns {
    /// No column.
    pub const NONE: Columns = Columns(0);
    /// z of wi: cos θi.
    pub const WI_Z: Columns = Columns(1 << 2);
    /// z of wo: cos θo.
    pub const WO_Z: Columns = Columns(1 << 5);
    /// z of the half vector: cos θh.
    pub const H_Z: Columns = Columns(1 << 8);
    /// cos θd.
    pub const COS_D: Columns = Columns(1 << 9);
    /// The six components of wi and wo.
    pub const DIRS: Columns = Columns(0b11_1111);
    /// All ten.
    pub const ALL: Columns = Columns(0b11_1111_1111);

    /// The set of a bit mask (bit c: column c); bits past the tenth are dropped.
    pub const fn from_bits(bits: u16) -> Columns {
        Columns(bits & Columns::ALL.0)
    }

    /// The bit mask (bit c: column c).
    pub const fn bits(self) -> u16 {
        self.0
    }

    /// The columns of either set.
    pub const fn union(self, other: Columns) -> Columns {
        Columns(self.0 | other.0)
    }

    /// Whether column `c` (0 … 9) is in the set.
    pub const fn has(self, c: usize) -> bool {
        c < 10 && self.0 & (1 << c) != 0
    }

    /// Whether every column of `other` is in the set.
    pub const fn covers(self, other: Columns) -> bool {
        other.0 & !self.0 == 0
    }
}

impl std::ops::BitOr for Columns {
    type Output = Columns;
    fn bitor(self, other: Columns) -> Columns {
        self.union(other)
    }
}

/// Unit half vector of a pair; the normal when wi = −wo (no half vector exists).
pub fn half_vector(wi: &Vec3, wo: &Vec3) -> Vec3 {
    let (h, _) = half_and_cos_d([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z]);
    Vec3::new(h[0], h[1], h[2])
}

/// The ten columns of one pair, in declaration order: wi, wo, the unit half vector
/// ([`half_vector`]) and cos θd = wi·h. What [`GeometryBatch::push`] stores; code that
/// fills a [`Geometry::zeroed`] batch in place writes the same numbers.
pub fn pair_columns(wi: &Vec3, wo: &Vec3) -> [f64; 10] {
    pair_columns_of([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z])
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

    /// A batch whose ten columns are `column()` each, made in declaration order.
    /// [`zeroed`](Self::zeroed) for columns from another allocator: brdfkit-fit builds
    /// a table's cells on huge pages (`brdfkit_merl::zeroed_f64`), where 4 KiB pages
    /// cost 22,000 first-touch faults for a MERL table's 89 MB of geometry.
    pub fn from_column_fn(mut column: impl FnMut() -> Vec<T>) -> Self {
        Geometry {
            wi_x: column(),
            wi_y: column(),
            wi_z: column(),
            wo_x: column(),
            wo_y: column(),
            wo_z: column(),
            h_x: column(),
            h_y: column(),
            h_z: column(),
            cos_d: column(),
        }
    }

    /// Empty batch with room for `n` pairs.
    pub fn with_capacity(n: usize) -> Self {
        Self::from_column_fn(|| Vec::with_capacity(n))
    }

    /// `n` pairs with every column zero, for filling in place (in parallel, by index)
    /// without a second copy.
    pub fn zeroed(n: usize) -> Self
    where
        T: Clone + Default,
    {
        Self::from_column_fn(|| vec![T::default(); n])
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

impl<T: Component> Geometry<T> {
    /// Sets every column to `n` rows (new rows zero), keeping the capacity: scratch
    /// to fill in place ([`columns_mut`](Self::columns_mut)).
    pub fn resize(&mut self, n: usize) {
        for c in self.column_vecs() {
            c.resize(n, T::ZERO);
        }
    }

    /// Replaces the batch by the pairs `(wi[k], wo[k])` (as many as the shorter slice
    /// holds), computed by [`pair_columns_of`]: in `f64` the bits of
    /// [`GeometryBatch::from_pairs`]. Reuses the columns' memory, and inlines into the
    /// caller so that a caller compiled for wider vectors (a `target_feature` copy, as
    /// `brdfkit_models::raw` runs it) vectorises the loop with them: it has no branch
    /// and uses only `+ × ÷ √`.
    #[inline(always)]
    pub fn fill_from_dirs(&mut self, wi: &[[T; 3]], wo: &[[T; 3]]) {
        let n = wi.len().min(wo.len());
        let (wi, wo) = (&wi[..n], &wo[..n]);
        self.fill_with(n, |k| (wi[k], wo[k]));
    }

    /// [`fill_from_dirs`](Self::fill_from_dirs) from rows of six values
    /// `[wi_x, wi_y, wi_z, wo_x, wo_y, wo_z]` (an N×6 array in row-major order).
    #[inline(always)]
    pub fn fill_from_rows(&mut self, rows: &[[T; 6]]) {
        self.fill_with(rows.len(), |k| {
            let r = rows[k];
            ([r[0], r[1], r[2]], [r[3], r[4], r[5]])
        });
    }

    /// Replaces the batch by the pairs of `dirs` ([`fill_from_dirs`](Self::fill_from_dirs)
    /// or [`fill_from_rows`](Self::fill_from_rows)).
    #[inline(always)]
    pub fn fill_from_pairs(&mut self, dirs: DirPairs<'_, T>) {
        match dirs {
            DirPairs::Split(wi, wo) => self.fill_from_dirs(wi, wo),
            DirPairs::Rows(rows) => self.fill_from_rows(rows),
        }
    }

    /// Replaces the batch by `n` pairs, pair k being `pair(k)` (k < n), with the
    /// columns of [`pair_columns_of`].
    #[inline(always)]
    pub fn fill_with(&mut self, n: usize, pair: impl Fn(usize) -> ([T; 3], [T; 3])) {
        self.resize(n);
        // Cut every column to exactly n rows so the loop below has no bounds checks.
        let [c0, c1, c2, c3, c4, c5, c6, c7, c8, c9] = self.columns_mut().map(|c| &mut c[..n]);
        for k in 0..n {
            let (wi, wo) = pair(k);
            let v = pair_columns_of(wi, wo);
            c0[k] = v[0];
            c1[k] = v[1];
            c2[k] = v[2];
            c3[k] = v[3];
            c4[k] = v[4];
            c5[k] = v[5];
            c6[k] = v[6];
            c7[k] = v[7];
            c8[k] = v[8];
            c9[k] = v[9];
        }
    }
}

/// A run of raw direction pairs, as a bulk evaluation from directions receives them
/// (`brdfkit_models::raw`): two slices of vectors, or rows of six values
/// `[wi_x, wi_y, wi_z, wo_x, wo_y, wo_z]` (an N×6 array in row-major order).
#[derive(Clone, Copy, Debug)]
pub enum DirPairs<'a, T> {
    /// `wi[k]` and `wo[k]` for pair k (the shorter slice sets the length).
    Split(&'a [[T; 3]], &'a [[T; 3]]),
    /// Row k holds wi then wo of pair k.
    Rows(&'a [[T; 6]]),
}

impl<T> DirPairs<'_, T> {
    /// Number of pairs.
    pub fn len(&self) -> usize {
        match self {
            DirPairs::Split(wi, wo) => wi.len().min(wo.len()),
            DirPairs::Rows(rows) => rows.len(),
        }
    }

    /// True when there is no pair.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Pairs `r` (panics, like slicing, when `r` reaches past [`len`](Self::len)).
    pub fn sub(&self, r: std::ops::Range<usize>) -> Self {
        match self {
            DirPairs::Split(wi, wo) => DirPairs::Split(&wi[r.clone()], &wo[r]),
            DirPairs::Rows(rows) => DirPairs::Rows(&rows[r]),
        }
    }
}

/// Direction and output arrays of a bulk evaluation from raw directions that do not fit
/// together (`brdfkit_models::raw`).
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum DirsError {
    /// `wi` and `wo` of different lengths.
    #[error("wi has {wi} directions but wo has {wo}: one wo per wi is needed")]
    Mismatch {
        /// Directions in `wi`.
        wi: usize,
        /// Directions in `wo`.
        wo: usize,
    },
    /// A flat array whose length is not a multiple of 6.
    #[error(
        "a flat direction array holds 6 values per pair (wi_x wi_y wi_z wo_x wo_y wo_z); \
         {len} values is not a multiple of 6"
    )]
    Flat {
        /// Values in the flat array.
        len: usize,
    },
    /// An output of the wrong length.
    #[error("the output holds {got} entries but {pairs} pairs need {need}")]
    Output {
        /// Direction pairs given.
        pairs: usize,
        /// Output entries they need.
        need: usize,
        /// Output entries given.
        got: usize,
    },
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
    pub fn columns(&self) -> [&'a [T]; 10] {
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

    /// The direction columns `[[wi x, y, z], [wo x, y, z]]`, each cut to [`Self::len`]
    /// so that a loop over `0..len` indexes them without bounds checks.
    pub fn dirs(&self) -> [[&'a [T]; 3]; 2] {
        let n = self.len();
        [
            [&self.wi_x[..n], &self.wi_y[..n], &self.wi_z[..n]],
            [&self.wo_x[..n], &self.wo_y[..n], &self.wo_z[..n]],
        ]
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

    /// Awkward pairs: unit, opposite, identical, grazing, below the horizon, not unit
    /// length, zero, huge, tiny and NaN components.
    fn awkward_pairs() -> Vec<(Vec3, Vec3)> {
        let mut v = Vec::new();
        let dirs = [
            spherical(0.4, 0.1),
            spherical(1.2, -2.0),
            spherical(std::f64::consts::FRAC_PI_2, 0.3),
            Vec3::new(0.6, 0.0, -0.8),
            Vec3::new(3.0, -1.0, 2.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1e-200, 0.0, 1e-200),
            Vec3::new(1e200, 1e200, 1e200),
            Vec3::new(f64::NAN, 0.0, 1.0),
            Vec3::new(0.0, f64::INFINITY, 1.0),
        ];
        for a in dirs {
            for b in dirs {
                v.push((a, b));
            }
            v.push((a, -a));
        }
        v
    }

    /// The branch-free half vector has the bits of nalgebra's `s / s.norm()` (what
    /// `half_vector` computed before), NaN included.
    #[test]
    fn half_vector_is_nalgebras_to_the_bit() {
        for (wi, wo) in awkward_pairs() {
            let s = wi + wo;
            let n = s.norm();
            let want = if n > 0.0 {
                s / n
            } else {
                Vec3::new(0.0, 0.0, 1.0)
            };
            let got = half_vector(&wi, &wo);
            for c in 0..3 {
                assert_eq!(got[c].to_bits(), want[c].to_bits(), "{wi:?} {wo:?}");
            }
            let cd = pair_columns(&wi, &wo)[9];
            assert_eq!(cd.to_bits(), wi.dot(&want).to_bits(), "{wi:?} {wo:?}");
        }
    }

    fn bits(g: &GeometryBatch) -> Vec<u64> {
        let s = g.as_slice();
        s.columns()
            .iter()
            .flat_map(|c| c.iter().map(|x| x.to_bits()))
            .collect()
    }

    /// Filling from raw directions (two slices or N×6 rows) gives the bits of
    /// `from_pairs`, reusing a longer batch; f32 fills compute the same formula in f32.
    #[test]
    fn fill_from_dirs_is_from_pairs_to_the_bit() {
        let pairs = awkward_pairs();
        let want = GeometryBatch::from_pairs(&pairs);
        let wi: Vec<[f64; 3]> = pairs.iter().map(|p| [p.0.x, p.0.y, p.0.z]).collect();
        let wo: Vec<[f64; 3]> = pairs.iter().map(|p| [p.1.x, p.1.y, p.1.z]).collect();
        let mut g = GeometryBatch::zeroed(pairs.len() + 5);
        g.fill_from_dirs(&wi, &wo);
        assert_eq!(bits(&g), bits(&want));
        let rows: Vec<[f64; 6]> = wi
            .iter()
            .zip(&wo)
            .map(|(a, b)| [a[0], a[1], a[2], b[0], b[1], b[2]])
            .collect();
        let mut r = GeometryBatch::default();
        r.fill_from_rows(&rows);
        assert_eq!(bits(&r), bits(&want));
        // Unequal slices: the shorter length.
        g.fill_from_dirs(&wi[..3], &wo);
        assert_eq!(g.len(), 3);
        assert_eq!(g.cos_d[2].to_bits(), want.cos_d[2].to_bits());

        let f = |v: [f64; 3]| v.map(|x| x as f32);
        let (wi32, wo32): (Vec<_>, Vec<_>) =
            wi.iter().zip(&wo).map(|(a, b)| (f(*a), f(*b))).unzip();
        let mut g32 = GeometryBatchF32::default();
        g32.fill_from_dirs(&wi32, &wo32);
        for k in 0..pairs.len() {
            let (h, cd) = half_and_cos_d(wi32[k], wo32[k]);
            assert_eq!(g32.h_x[k].to_bits(), h[0].to_bits());
            assert_eq!(g32.h_z[k].to_bits(), h[2].to_bits());
            assert_eq!(g32.cos_d[k].to_bits(), cd.to_bits());
            assert_eq!(g32.wo_y[k].to_bits(), wo32[k][1].to_bits());
        }
    }

    #[test]
    fn opposite_pair_takes_the_normal_as_half_vector() {
        let wi = Vec3::new(1.0, 0.0, 0.0);
        assert_eq!(half_vector(&wi, &-wi), Vec3::new(0.0, 0.0, 1.0));
    }
}
