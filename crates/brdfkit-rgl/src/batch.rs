//! The batch evaluation of a `.bsdf` file: the steps of [`crate::bsdf`]'s module doc
//! over [`LANES`] pairs at a time, in f32, as Mitsuba 3's LLVM kernel runs them.
//!
//! Why it is shaped this way (docs/rgl.md, "Speed"): the f64 path evaluates one pair
//! at a time, and its time went to glibc's `atan2`/`asin`, to building each pair's
//! corner weights, and to table reads that waited on memory one pair after the other.
//! Here every stage is a loop over lanes of a structure of arrays:
//! 1. [`Geo`]: the fold of wi, the half vector, θ and φ by the polynomial
//!    [`atan2_f32`]/[`asin_f32`], the grid coordinates: branch-free arithmetic that
//!    the compiler vectorises;
//! 2. [`Place`]: the (φi, θi) interval (a count of grid values below θi, vectorised)
//!    and the up to four corner slices with their weights;
//! 3. the inverse VNDF warp, then the value, `ndf` and `sigma` lookups: gathers, with
//!    the lanes' loads independent of one another so many are in flight together.
//!
//! The tables are the f32 tables of [`Warp2D`], read as they are stored (Mitsuba holds
//! them in f32 and computes in f32). The results agree with the f64 path
//! ([`crate::RglBsdf::eval_stored`]) and with Mitsuba within the bound (tests/batch.rs,
//! tests/mitsuba.rs). On x86-64 CPUs with AVX2 the same code runs compiled for AVX2
//! (chosen at run time); IEEE arithmetic makes both builds give the same bits.

use crate::fastmath::{asin_f32, atan2_f32};
use crate::warp::Warp2D;
use std::f32::consts::PI;

/// Pairs per lane block.
pub(crate) const LANES: usize = 16;
const L: usize = LANES;

/// The per-file constants of the kernel.
pub(crate) struct Kernel<'a> {
    pub(crate) vndf: &'a Warp2D,
    pub(crate) ndf: &'a Warp2D,
    pub(crate) sigma: &'a Warp2D,
    /// The value table (`rgb` or `spectra`), its last parameter interleaved.
    pub(crate) values: &'a Warp2D,
    pub(crate) phi_i: &'a [f32],
    pub(crate) theta_i: &'a [f32],
    pub(crate) isotropic: bool,
    pub(crate) jacobian: bool,
    /// 1, 2 or 4: the fold of wi into the stored φi range.
    pub(crate) reduction: i32,
}

/// Step 1 for a lane block: the grid coordinates of the half vector (`um`) and of wi
/// (`uwi`), the parameters (φi, θi), and 1/cos θo (0 below the horizon).
struct Geo {
    um: [[f32; L]; 2],
    uwi: [[f32; L]; 2],
    param: [[f32; L]; 2],
    scale: [f32; L],
}

/// Step 2: the first corner slice of (φi, θi) and the corners' weights (θ low/high ×
/// φ low/high).
struct Place {
    slice: [usize; L],
    w: [[f32; 4]; L],
}

/// Elevation of a unit vector, stable near the pole (`measured.cpp`'s `elevation`):
/// 2 asin(|d − z| / 2).
#[inline(always)]
fn elevation(x: f32, y: f32, z: f32) -> f32 {
    let dist = (x * x + y * y + (z - 1.0) * (z - 1.0)).sqrt();
    2.0 * asin_f32((0.5 * dist).min(1.0))
}

/// `x` with its sign flipped where `mask` selects and `s`'s sign bit is clear (Dr.Jit's
/// `mulsign_neg` when `mask` is the sign bit; no change when it is 0).
#[inline(always)]
fn fold(x: f32, s: f32, mask: u32) -> f32 {
    f32::from_bits(x.to_bits() ^ (!s.to_bits() & mask))
}

#[inline(always)]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a - a * t + b * t
}

/// Cell of `pos` (clamped to the unit square) on a `w` × `h` grid, and the position in it.
#[inline(always)]
fn cell(pos: [f32; 2], w: usize, h: usize) -> ([usize; 2], [f32; 2]) {
    let s = [
        pos[0].clamp(0.0, 1.0) * (w - 1) as f32,
        pos[1].clamp(0.0, 1.0) * (h - 1) as f32,
    ];
    let c = [(s[0] as usize).min(w - 2), (s[1] as usize).min(h - 2)];
    (c, [s[0] - c[0] as f32, s[1] - c[1] as f32])
}

/// Σ over the `NC` corner slices of weight × `table[i + offset · size]`.
#[inline(always)]
fn mix<const NC: usize>(table: &[f32], i: usize, size: usize, off: &[usize; 4], w: &[f32; 4]) -> f32 {
    let mut s = 0.0;
    for c in 0..NC {
        s += w[c] * table[i + off[c] * size];
    }
    s
}

impl Kernel<'_> {
    /// Step 1, vectorised over the lanes.
    #[inline(always)]
    fn geometry(&self, rows: &[[f64; 6]; L], g: &mut Geo) {
        let mask_y = if self.reduction >= 2 { 0x8000_0000 } else { 0 };
        let x_by_x = self.reduction == 4;
        for (l, r) in rows.iter().enumerate() {
            let above = r[2] > 0.0 && r[5] > 0.0;
            let v = r.map(|x| x as f32);
            // Below the horizon: the normal for both, so every later step stays finite.
            let [ix, iy, iz, ox, oy, oz] = if above { v } else { [0.0, 0.0, 1.0, 0.0, 0.0, 1.0] };
            let (sy, sx) = (iy, if x_by_x { ix } else { iy });
            let (ix, iy) = (fold(ix, sx, mask_y), fold(iy, sy, mask_y));
            let (ox, oy) = (fold(ox, sx, mask_y), fold(oy, sy, mask_y));
            let (hx, hy, hz) = (ix + ox, iy + oy, iz + oz);
            let inv = 1.0 / (hx * hx + hy * hy + hz * hz).sqrt();
            let (mx, my, mz) = (hx * inv, hy * inv, hz * inv);
            let (theta_i, phi_i) = (elevation(ix, iy, iz), atan2_f32(iy, ix));
            let (theta_m, phi_m) = (elevation(mx, my, mz), atan2_f32(my, mx));
            let to_u = 2.0 / PI;
            g.uwi[0][l] = (theta_i * to_u).sqrt();
            g.uwi[1][l] = (phi_i + PI) * (0.5 / PI);
            g.um[0][l] = (theta_m * to_u).sqrt();
            let dphi = if self.isotropic { phi_m - phi_i } else { phi_m };
            // In (−½, 3/2): the wrap to [0, 1) as two selects (u − ⌊u⌋).
            let u = (dphi + PI) * (0.5 / PI);
            let u = if u < 0.0 { u + 1.0 } else { u };
            g.um[1][l] = if u >= 1.0 { u - 1.0 } else { u };
            g.param[0][l] = phi_i;
            g.param[1][l] = theta_i;
            g.scale[l] = if above { 1.0 / oz } else { 0.0 };
        }
    }

    /// Step 2: the interval and weight of each parameter (`find_interval`, weight
    /// clamped to [0, 1]) and the corners they make.
    #[inline(always)]
    fn place(&self, g: &Geo, p: &mut Place) {
        let mut at = [[0usize; L]; 2];
        let mut t = [[0.0f32; L]; 2];
        for (d, grid) in [self.phi_i, self.theta_i].into_iter().enumerate() {
            let n = grid.len();
            if n < 2 {
                continue;
            }
            // The largest i ≤ n − 2 with grid[i] < x: a count, vectorised over lanes.
            for &v in &grid[1..n - 1] {
                for l in 0..L {
                    at[d][l] += usize::from(g.param[d][l] > v);
                }
            }
            for l in 0..L {
                let (p0, p1) = (grid[at[d][l]], grid[at[d][l] + 1]);
                t[d][l] = ((g.param[d][l] - p0) / (p1 - p0)).clamp(0.0, 1.0);
            }
        }
        let n_theta = self.theta_i.len();
        for l in 0..L {
            p.slice[l] = at[0][l] * n_theta + at[1][l];
            let ([tp, tt], [sp, st]) = ([t[0][l], t[1][l]], [1.0 - t[0][l], 1.0 - t[1][l]]);
            p.w[l] = [st * sp, tt * sp, st * tp, tt * tp];
        }
    }

    /// The corner slice offsets of [`Place::w`] (θ high is the next slice, φ high the
    /// next θ row; a grid of one value repeats its slice, with weight 0).
    fn offsets(&self) -> [usize; 4] {
        let dt = usize::from(self.theta_i.len() > 1);
        let dp = if self.phi_i.len() > 1 { self.theta_i.len() } else { 0 };
        [0, dt, dp, dp + dt]
    }

    /// Step 3a, the inverse VNDF warp at the half vector (`Warp2D::invert_with`).
    #[inline(always)]
    fn invert<const NC: usize>(&self, g: &Geo, p: &Place, l: usize, off: &[usize; 4]) -> [f32; 2] {
        let v = self.vndf;
        let (w, h, n) = (v.w, v.h, v.w * v.h);
        let (c, t) = cell([g.um[0][l], g.um[1][l]], w, h);
        let (s, wt) = (p.slice[l], &p.w[l]);
        let i = s * n + c[1] * w + c[0];
        let [v00, v10, v01, v11] = [0, 1, w, w + 1].map(|o| mix::<NC>(&v.data, i + o, n, off, wt));
        let (c0, c1) = (lerp(v00, v01, t[1]), lerp(v10, v11, t[1]));
        let (pw, ph) = (1.0 / (w - 1) as f32, 1.0 / (h - 1) as f32);
        let (nc, row) = (h * (w - 1), s * h * (w - 1) + c[1] * (w - 1));
        let cond = |k: usize| mix::<NC>(&v.cond, row + k, nc, off, wt);
        let mut x = t[0] * lerp(c0, c1, 0.5 * t[0]) * pw;
        let prev = c[0].max(1) - 1;
        let before = lerp(cond(prev), cond(prev + w - 1), t[1]);
        x += if c[0] > 0 { before } else { 0.0 };
        let (r0, r1) = (cond(w - 2), cond(2 * (w - 1) - 1));
        x /= lerp(r0, r1, t[1]);
        let mut y = t[1] * lerp(r0, r1, 0.5 * t[1]) * ph;
        let nm = h - 1;
        let marg = |k: usize| mix::<NC>(&v.marg, s * nm + k, nm, off, wt);
        let below = marg(c[1].max(1) - 1);
        y += if c[1] > 0 { below } else { 0.0 };
        if !v.normalized {
            y /= marg(nm - 1);
        }
        [x, y]
    }

    /// D(m) / (4 σ(wi)) (step 4's Jacobian), or 1 without the `jacobian` flag.
    #[inline(always)]
    fn jacobian(&self, g: &Geo, l: usize) -> f32 {
        if !self.jacobian {
            return 1.0;
        }
        plain(self.ndf, [g.um[0][l], g.um[1][l]]) / (4.0 * plain(self.sigma, [g.uwi[0][l], g.uwi[1][l]]))
    }

    /// Step 3b: the value table's `k` values at `pos` under the corners of lane `l`,
    /// times `scale`, into `out`.
    #[inline(always)]
    fn values<const NC: usize>(&self, pos: [f32; 2], p: &Place, l: usize, off: &[usize; 4], scale: f32, out: &mut [f32]) {
        let v = self.values;
        let k = out.len();
        let (c, t) = cell(pos, v.w, v.h);
        let size = v.w * v.h * k;
        let base = p.slice[l] * size + (c[1] * v.w + c[0]) * k;
        let [d00, d10, d01, d11] = [0, 1, v.w, v.w + 1].map(|d| base + d * k);
        for (j, o) in out.iter_mut().enumerate() {
            let [a, b, cc, d] = [d00, d10, d01, d11].map(|i| mix::<NC>(&v.interleaved, i + j, size, off, &p.w[l]));
            *o = lerp(lerp(a, b, t[0]), lerp(cc, d, t[0]), t[1]) * scale;
        }
    }

    /// Steps 1 to 4 for one lane block: the stored values (3 or the wavelengths a
    /// pair) times the Jacobian over cos θo, into `out` (`k` a lane).
    #[inline(always)]
    fn block<const NC: usize>(&self, rows: &[[f64; 6]; L], out: &mut [f32]) {
        let mut g = Geo {
            um: [[0.0; L]; 2],
            uwi: [[0.0; L]; 2],
            param: [[0.0; L]; 2],
            scale: [0.0; L],
        };
        self.geometry(rows, &mut g);
        let mut p = Place {
            slice: [0; L],
            w: [[0.0; 4]; L],
        };
        self.place(&g, &mut p);
        let off = self.offsets();
        let mut pos = [[0.0f32; 2]; L];
        let mut scale = [0.0f32; L];
        for l in 0..L {
            pos[l] = self.invert::<NC>(&g, &p, l, &off);
            scale[l] = self.jacobian(&g, l) * g.scale[l];
        }
        let k = out.len() / L;
        for (l, o) in out.chunks_exact_mut(k).enumerate() {
            self.values::<NC>(pos[l], &p, l, &off, scale[l], o);
        }
    }

    /// [`block`](Self::block) over whole rows (the last block padded with pairs below
    /// the horizon).
    #[inline(always)]
    fn rows_inline<const NC: usize>(&self, rows: &[[f64; 6]], out: &mut [f32]) {
        let k = out.len() / rows.len().max(1);
        for (r, o) in rows.chunks(L).zip(out.chunks_mut(L * k)) {
            if let Ok(r) = <&[[f64; 6]; L]>::try_from(r) {
                self.block::<NC>(r, o);
            } else {
                let mut pad = [[0.0; 6]; L];
                pad[..r.len()].copy_from_slice(r);
                let mut tmp = vec![0.0; L * k];
                self.block::<NC>(&pad, &mut tmp);
                o.copy_from_slice(&tmp[..o.len()]);
            }
        }
    }

    #[inline(always)]
    fn rows_any(&self, rows: &[[f64; 6]], out: &mut [f32]) {
        if self.phi_i.len() > 1 {
            self.rows_inline::<4>(rows, out);
        } else {
            self.rows_inline::<2>(rows, out);
        }
    }

    /// The same code compiled for AVX2 (and FMA, which changes no rounding: Rust does
    /// not contract `a * b + c`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn rows_avx2(&self, rows: &[[f64; 6]], out: &mut [f32]) {
        self.rows_any(rows, out);
    }

    /// The stored values of `rows` (as [`RglBsdf::eval_stored`], `out.len() / rows.len()`
    /// a pair) times the Jacobian over cos θo; 0 below the horizon.
    pub(crate) fn rows(&self, rows: &[[f64; 6]], out: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has the features `rows_avx2` is compiled for.
            unsafe { self.rows_avx2(rows, out) };
            return;
        }
        self.rows_any(rows, out);
    }
}

/// A table without parameters (`ndf`, `sigma`) at `pos` (`Warp2D::eval_plain`).
#[inline(always)]
fn plain(w: &Warp2D, pos: [f32; 2]) -> f32 {
    let (c, t) = cell(pos, w.w, w.h);
    let i = c[1] * w.w + c[0];
    let [v00, v10, v01, v11] = [0, 1, w.w, w.w + 1].map(|o| w.data[i + o]);
    lerp(lerp(v00, v10, t[0]), lerp(v01, v11, t[0]), t[1])
}
