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
//! arithmetic follows the same steps; it runs in f64.

/// A parameterised piecewise-bilinear 2D density.
#[derive(Clone, Debug)]
pub struct Warp2D {
    /// Grid resolution (x = columns = the last axis, y = rows).
    w: usize,
    h: usize,
    /// The grid values of each parameter (each of length ≥ 1, sorted).
    params: Vec<Vec<f32>>,
    /// Slice stride of each parameter (0 for a parameter with one value).
    strides: Vec<usize>,
    /// Densities, `slices × h × w` (scaled to integrate to 1 per slice if normalised).
    data: Vec<f32>,
    /// Marginal CDF, `slices × (h − 1)`; empty without sampling tables.
    marg: Vec<f32>,
    /// Conditional CDFs, `slices × h × (w − 1)`; empty without sampling tables.
    cond: Vec<f32>,
    normalized: bool,
}

/// The parameter interpolation at one point: the first slice and, for each of the up to
/// 2³ corner slices with a non-zero weight, its slice offset from the first and its
/// weight (the product of the parameters' linear weights).
struct Weights {
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
        };
        for slice in data.chunks_exact(w * h) {
            out.push_slice(slice, normalize, sampling);
        }
        out
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
        let mut offset = 0;
        let mut w = [[1.0, 0.0]; 3];
        for (d, vals) in self.params.iter().enumerate().take(dims) {
            if vals.len() == 1 {
                continue;
            }
            let x = p[d];
            // The largest i ≤ n − 2 with vals[i] < x (0 if none): find_interval.
            let i = vals[1..vals.len() - 1].partition_point(|&v| f64::from(v) < x);
            let (p0, p1) = (f64::from(vals[i]), f64::from(vals[i + 1]));
            let t = ((x - p0) / (p1 - p0)).clamp(0.0, 1.0);
            w[d] = [1.0 - t, t];
            offset += self.strides[d] * i;
        }
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

    /// The density at `pos` at every grid value of the last parameter into `out` (one
    /// per value), the other parameters at `p`: the same numbers as [`eval`](Self::eval)
    /// at each grid value (whose weights are exactly 1 and 0), with the weights and the
    /// cell found once.
    pub fn eval_nodes(&self, pos: [f64; 2], p: &[f64], out: &mut [f64]) {
        let last = self.params.len() - 1;
        let mut wt = self.weights(p, last);
        let (c, t) = self.cell(pos);
        let base = wt.offset;
        for (k, o) in out.iter_mut().enumerate() {
            wt.offset = base + self.strides[last] * k;
            let [v00, v10, v01, v11] = self.corners(c, &wt);
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
        let wt = self.weights(p, self.params.len());
        let (c, t) = self.cell(pos);
        let [v00, v10, v01, v11] = self.corners(c, &wt);
        let (c0, c1) = (lerp(v00, v01, t[1]), lerp(v10, v11, t[1]));
        let pdf = lerp(c0, c1, t[0]);
        let (pw, ph) = (1.0 / (self.w - 1) as f64, 1.0 / (self.h - 1) as f64);
        let n_cond = self.h * (self.w - 1);
        let row = c[1] * (self.w - 1);
        let cond = |k: usize| self.lookup(&self.cond, row + k, n_cond, &wt);
        let mut x = t[0] * lerp(c0, c1, 0.5 * t[0]) * pw;
        if c[0] > 0 {
            x += lerp(cond(c[0] - 1), cond(c[0] - 1 + self.w - 1), t[1]);
        }
        let (r0, r1) = (cond(self.w - 2), cond(2 * (self.w - 1) - 1));
        x /= lerp(r0, r1, t[1]);
        let mut y = t[1] * lerp(r0, r1, 0.5 * t[1]) * ph;
        let n_marg = self.h - 1;
        if c[1] > 0 {
            y += self.lookup(&self.marg, c[1] - 1, n_marg, &wt);
        }
        if !self.normalized {
            y /= self.lookup(&self.marg, n_marg - 1, n_marg, &wt);
        }
        ([x, y], pdf)
    }
}
