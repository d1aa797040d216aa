//! The 2D interpolants of the format: a bilinear density on a regular grid over the unit
//! square, optionally conditioned on up to three parameters (φi, θi, and λ or the colour
//! channel), with the marginal/conditional CDFs that warp it.
//!
//! This is the structure Mitsuba 3 calls `Marginal2D<Float, Dimension, Continuous =
//! true>` (`mitsuba/core/distr_2d.h`), after Jakob's "Hierarchical/marginal sample
//! warping" of Dupuy & Jakob 2018, §5: the density is piecewise bilinear; the conditional
//! CDF of each row integrates it along x with the trapezoid rule; the marginal CDF
//! integrates the row totals along y. Parameters interpolate *linearly between whole
//! slices* (data and CDFs alike), with weights clamped to [0, 1] outside the grid.
//!
//! The evaluation must match Mitsuba's to 1e-4 relative, so the tables are stored as
//! f32 exactly as Mitsuba stores them (CDFs accumulated in f64, then rounded) and the
//! arithmetic follows the same steps; it runs in f64. The batch kernel (`batch.rs`) runs
//! the same steps in f32 on a copy of these tables rearranged by cell.

/// A parameterised piecewise-bilinear 2D density.
#[derive(Clone, Debug)]
pub struct Warp2D {
    /// Grid resolution (x = columns = the last axis, y = rows).
    pub(crate) w: usize,
    pub(crate) h: usize,
    /// The grid values of each parameter (each of length ≥ 1, sorted).
    pub(crate) params: Vec<Vec<f32>>,
    /// Slice stride of each parameter (0 for a parameter with one value).
    strides: Vec<usize>,
    /// Densities, `slices × h × w` (scaled to integrate to 1 per slice if normalised).
    pub(crate) data: Vec<f32>,
    /// Marginal CDF, `slices × (h − 1)`; empty without sampling tables.
    pub(crate) marg: Vec<f32>,
    /// Conditional CDFs, `slices × h × (w − 1)`; empty without sampling tables.
    pub(crate) cond: Vec<f32>,
    pub(crate) normalized: bool,
    /// The densities again with the last parameter's slices interleaved (`… × h × w ×
    /// n_last`), built by [`interleave_last`](Self::interleave_last) for the value
    /// tables: [`eval_nodes`](Self::eval_nodes) then reads the three channels (or the
    /// wavelengths) of a grid point from one cache line instead of one line each.
    pub(crate) interleaved: Vec<f32>,
}

/// Where a point (φi, θi) lies on the incident-direction grids: on each, the interval
/// (`find_interval`) and the weight clamped to [0, 1]. Every table a pair reads (`vndf`,
/// `rgb`/`spectra`) is parameterised by the same two grids, so this is found once per
/// pair and turned into each table's corner slices by [`Warp2D::weights_at`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct ParamPos {
    at: [usize; 2],
    t: [f64; 2],
}

impl ParamPos {
    /// The position of `p` on `grids` (each sorted, of length ≥ 1).
    #[inline]
    pub(crate) fn new(grids: [&[f32]; 2], p: [f64; 2]) -> ParamPos {
        let mut out = ParamPos {
            at: [0; 2],
            t: [0.0; 2],
        };
        for (d, vals) in grids.iter().enumerate() {
            if vals.len() > 1 {
                (out.at[d], out.t[d]) = interval(vals, p[d]);
            }
        }
        out
    }
}

/// The largest i ≤ n − 2 with vals[i] < x (0 if none: `find_interval`), and x's weight
/// between vals[i] and vals[i + 1], clamped to [0, 1].
#[inline]
fn interval(vals: &[f32], x: f64) -> (usize, f64) {
    let i = vals[1..vals.len() - 1].partition_point(|&v| f64::from(v) < x);
    let (p0, p1) = (f64::from(vals[i]), f64::from(vals[i + 1]));
    (i, ((x - p0) / (p1 - p0)).clamp(0.0, 1.0))
}

/// The parameter interpolation at one point: the first slice and, for each of the up to
/// 2³ corner slices with a non-zero weight, its slice offset from the first and its
/// weight (the product of the parameters' linear weights).
pub(crate) struct Weights {
    offset: usize,
    corners: [(usize, f64); 8],
    n: usize,
}

#[inline]
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a - a * t + b * t
}

impl Warp2D {
    /// The interpolant of `data` (C order: the parameters' axes in `params` order, then
    /// rows `h`, then columns `w`), with marginal/conditional CDFs when `sampling`, and
    /// each slice scaled to unit integral when `normalize` (Mitsuba's constructor
    /// arguments). The caller has checked the lengths (the `.bsdf` reader does).
    pub fn new(
        data: &[f32],
        w: usize,
        h: usize,
        params: Vec<Vec<f32>>,
        normalize: bool,
        sampling: bool,
    ) -> Warp2D {
        assert!(
            w >= 2 && h >= 2 && params.len() <= 3,
            "checked by the reader"
        );
        let mut strides = vec![0; params.len()];
        let mut slices = 1;
        for (d, p) in params.iter().enumerate().rev() {
            strides[d] = if p.len() > 1 { slices } else { 0 };
            slices *= p.len();
        }
        assert_eq!(data.len(), slices * w * h, "checked by the reader");
        let mut out = Warp2D {
            w,
            h,
            params,
            strides,
            data: Vec::with_capacity(data.len()),
            marg: Vec::new(),
            cond: Vec::new(),
            normalized: normalize,
            interleaved: Vec::new(),
        };
        for slice in data.chunks_exact(w * h) {
            out.push_slice(slice, normalize, sampling);
        }
        out
    }

    /// Builds the interleaved copy of the densities that
    /// [`eval_nodes`](Self::eval_nodes) reads (same values, so the same results).
    pub(crate) fn interleave_last(mut self) -> Warp2D {
        let k = self.params.last().map_or(1, Vec::len);
        let n = self.w * self.h;
        let mut il = vec![0.0; self.data.len()];
        for (s, slice) in self.data.chunks_exact(n).enumerate() {
            let (outer, kk) = (s / k, s % k);
            for (cell, &v) in slice.iter().enumerate() {
                il[outer * n * k + cell * k + kk] = v;
            }
        }
        self.interleaved = il;
        self
    }

    /// Appends one slice: its CDFs (trapezoid rule along x, then along y over the row
    /// totals, in f64, as `distr_2d.h` builds them) and its scaled densities.
    fn push_slice(&mut self, d: &[f32], normalize: bool, sampling: bool) {
        let (w, h) = (self.w, self.h);
        let (sx, sy) = (0.5 / (w - 1) as f64, 0.5 / (h - 1) as f64);
        let mut norm = 1.0f32;
        if sampling {
            let mut row_sum = vec![0.0f64; h];
            let mut cond = Vec::with_capacity(h * (w - 1));
            for (y, row) in d.chunks_exact(w).enumerate() {
                let mut acc = 0.0;
                for x in 0..w - 1 {
                    acc += sx * (f64::from(row[x]) + f64::from(row[x + 1]));
                    cond.push(acc);
                }
                row_sum[y] = acc;
            }
            let mut marg = Vec::with_capacity(h - 1);
            let mut acc = 0.0;
            for y in 0..h - 1 {
                acc += sy * (row_sum[y] + row_sum[y + 1]);
                marg.push(acc);
            }
            if normalize {
                norm = (1.0 / acc) as f32;
            }
            let n = f64::from(norm);
            // Mitsuba rounds each CDF value to f32, then scales it in f32.
            self.cond
                .extend(cond.iter().map(|&c| ((c as f32) as f64 * n) as f32));
            self.marg
                .extend(marg.iter().map(|&c| ((c as f32) as f64 * n) as f32));
        } else if normalize {
            let mut sum = 0.0f64;
            for y in 0..h - 1 {
                for x in 0..w - 1 {
                    let i = y * w + x;
                    sum += [d[i], d[i + 1], d[i + w], d[i + w + 1]]
                        .iter()
                        .map(|&v| f64::from(v))
                        .sum::<f64>();
                }
            }
            norm = (1.0 / (sx * sy * sum)) as f32;
        }
        self.data.extend(d.iter().map(|&v| v * norm));
    }

    /// The slice offset and the corner weights of the first `dims` parameters at `p`
    /// (`find_interval` then a clamped weight per parameter, as
    /// `Distribution2D::interpolate_weights`; the corner slices combine them
    /// multilinearly as its recursive `lookup`).
    #[inline]
    fn weights(&self, p: &[f64], dims: usize) -> Weights {
        let mut at = [0; 3];
        let mut w = [[1.0, 0.0]; 3];
        for (d, vals) in self.params.iter().enumerate().take(dims) {
            if vals.len() > 1 {
                let (i, t) = interval(vals, p[d]);
                (at[d], w[d]) = (i, [1.0 - t, t]);
            }
        }
        self.combine(at, w, dims)
    }

    /// The corner slices of the first two parameters (φi, θi) at `pos`: the same
    /// weights as [`weights`](Self::weights) at the point `pos` was found for.
    #[inline]
    pub(crate) fn weights_at(&self, pos: &ParamPos) -> Weights {
        let mut at = [0; 3];
        let mut w = [[1.0, 0.0]; 3];
        for d in 0..2 {
            if self.params[d].len() > 1 {
                (at[d], w[d]) = (pos.at[d], [1.0 - pos.t[d], pos.t[d]]);
            }
        }
        self.combine(at, w, 2)
    }

    /// The first slice and the corner slices with a non-zero weight (the product of
    /// the parameters' linear weights, multilinear as the recursive `lookup` of
    /// `distr_2d.h`), of the parameters' intervals `at` and weights `w`.
    #[inline]
    fn combine(&self, at: [usize; 3], w: [[f64; 2]; 3], dims: usize) -> Weights {
        let offset = (0..dims).map(|d| self.strides[d] * at[d]).sum();
        let mut out = Weights {
            offset,
            corners: [(0, 0.0); 8],
            n: 0,
        };
        for mask in 0..1usize << dims {
            let (mut at, mut weight) = (0, 1.0);
            for (d, wd) in w.iter().enumerate().take(dims) {
                let bit = (mask >> d) & 1;
                weight *= wd[bit];
                at += bit * self.strides[d];
            }
            if weight != 0.0 {
                out.corners[out.n] = (at, weight);
                out.n += 1;
            }
        }
        out
    }

    /// `table[i]` interpolated over the parameters: Σ over the corner slices of weight ×
    /// value (each slice `size` long).
    #[inline]
    fn lookup(&self, table: &[f32], i: usize, size: usize, wt: &Weights) -> f64 {
        let base = i + wt.offset * size;
        wt.corners[..wt.n]
            .iter()
            .map(|&(at, w)| w * f64::from(table[base + at * size]))
            .sum()
    }

    /// Cell of `pos` (clamped to the unit square) and the position inside it.
    #[inline]
    fn cell(&self, pos: [f64; 2]) -> ([usize; 2], [f64; 2]) {
        let s = [
            pos[0].clamp(0.0, 1.0) * (self.w - 1) as f64,
            pos[1].clamp(0.0, 1.0) * (self.h - 1) as f64,
        ];
        let c = [
            (s[0] as usize).min(self.w - 2),
            (s[1] as usize).min(self.h - 2),
        ];
        (c, [s[0] - c[0] as f64, s[1] - c[1] as f64])
    }

    /// The four corner values of cell `c`: v00, v10, v01, v11.
    #[inline]
    fn corners(&self, c: [usize; 2], wt: &Weights) -> [f64; 4] {
        let n = self.w * self.h;
        let i = c[1] * self.w + c[0];
        [0, 1, self.w, self.w + 1].map(|o| self.lookup(&self.data, i + o, n, wt))
    }

    /// The bilinearly interpolated density at `pos` under parameters `p`.
    pub fn eval(&self, pos: [f64; 2], p: &[f64]) -> f64 {
        let wt = self.weights(p, self.params.len());
        let (c, t) = self.cell(pos);
        let [v00, v10, v01, v11] = self.corners(c, &wt);
        lerp(lerp(v00, v10, t[0]), lerp(v01, v11, t[0]), t[1])
    }

    /// [`eval`](Self::eval) of a table without parameters (`ndf`, `sigma`).
    #[inline]
    pub(crate) fn eval_plain(&self, pos: [f64; 2]) -> f64 {
        debug_assert!(self.params.is_empty());
        let (c, t) = self.cell(pos);
        let i = c[1] * self.w + c[0];
        let [v00, v10, v01, v11] = [0, 1, self.w, self.w + 1].map(|o| f64::from(self.data[i + o]));
        lerp(lerp(v00, v10, t[0]), lerp(v01, v11, t[0]), t[1])
    }

    /// The density at `pos` at every grid value of the last parameter into `out` (one
    /// per value), the other parameters at `p`: the same numbers as [`eval`](Self::eval)
    /// at each grid value (whose weights are exactly 1 and 0), with the weights and the
    /// cell found once.
    pub fn eval_nodes(&self, pos: [f64; 2], p: &[f64], out: &mut [f64]) {
        let wt = self.weights(p, self.params.len() - 1);
        self.eval_nodes_with(pos, wt, out);
    }

    /// [`eval_nodes`](Self::eval_nodes) with the weights of the other parameters given.
    #[inline]
    pub(crate) fn eval_nodes_with(&self, pos: [f64; 2], wt: Weights, out: &mut [f64]) {
        let (c, t) = self.cell(pos);
        let (w, n) = (self.w, self.w * self.h);
        let cell = c[1] * w + c[0];
        if self.interleaved.is_empty() {
            let mut wt = wt;
            let (base, step) = (wt.offset, self.strides[self.params.len() - 1]);
            for (k, o) in out.iter_mut().enumerate() {
                wt.offset = base + step * k;
                let [v00, v10, v01, v11] = self.corners(c, &wt);
                *o = lerp(lerp(v00, v10, t[0]), lerp(v01, v11, t[0]), t[1]);
            }
            return;
        }
        // Element (slice s, cell, node k) of the interleaved copy lies at
        // s·n + cell·K + k, s being the slice of node 0 (`wt` is over the other
        // parameters, whose strides are multiples of K).
        let kn = out.len();
        for (k, o) in out.iter_mut().enumerate() {
            let [v00, v10, v01, v11] = [0, 1, w, w + 1]
                .map(|d| self.lookup(&self.interleaved, (cell + d) * kn + k, n, &wt));
            *o = lerp(lerp(v00, v10, t[0]), lerp(v01, v11, t[0]), t[1]);
        }
    }

    /// The inverse of the warp: the uniform sample that `sample()` would map to `pos`
    /// (`invert_continuous`). The density at `pos` comes with it.
    ///
    /// In each cell the density is bilinear; along x at fixed y it is linear, c0 → c1,
    /// whose integral from 0 to t is t·lerp(c0, c1, t/2)·width (`invert_segment`); the
    /// CDF of the cells before adds to it and the row total at y divides it. y is
    /// handled the same way with the row totals r0 → r1 and the marginal CDF.
    pub fn invert(&self, pos: [f64; 2], p: &[f64]) -> ([f64; 2], f64) {
        self.invert_with(pos, &self.weights(p, self.params.len()))
    }

    /// [`invert`](Self::invert) with the parameters' weights given.
    #[inline]
    pub(crate) fn invert_with(&self, pos: [f64; 2], wt: &Weights) -> ([f64; 2], f64) {
        let (c, t) = self.cell(pos);
        let [v00, v10, v01, v11] = self.corners(c, wt);
        let (c0, c1) = (lerp(v00, v01, t[1]), lerp(v10, v11, t[1]));
        let pdf = lerp(c0, c1, t[0]);
        let (pw, ph) = (1.0 / (self.w - 1) as f64, 1.0 / (self.h - 1) as f64);
        let n_cond = self.h * (self.w - 1);
        let row = c[1] * (self.w - 1);
        let cond = |k: usize| self.lookup(&self.cond, row + k, n_cond, wt);
        let mut x = t[0] * lerp(c0, c1, 0.5 * t[0]) * pw;
        if c[0] > 0 {
            x += lerp(cond(c[0] - 1), cond(c[0] - 1 + self.w - 1), t[1]);
        }
        let (r0, r1) = (cond(self.w - 2), cond(2 * (self.w - 1) - 1));
        x /= lerp(r0, r1, t[1]);
        let mut y = t[1] * lerp(r0, r1, 0.5 * t[1]) * ph;
        let n_marg = self.h - 1;
        if c[1] > 0 {
            y += self.lookup(&self.marg, c[1] - 1, n_marg, wt);
        }
        if !self.normalized {
            y /= self.lookup(&self.marg, n_marg - 1, n_marg, wt);
        }
        ([x, y], pdf)
    }
}
