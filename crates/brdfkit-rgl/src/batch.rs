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

// The lane loops index several arrays of a structure of arrays by the lane, in step:
// written as `for l in 0..L` so the vectoriser sees one induction variable.
#![allow(clippy::needless_range_loop)]

use crate::fastmath::{asin_f32, atan2_f32};
use crate::warp::Warp2D;
use brdfkit_core::lanes;
use std::f32::consts::PI;

/// The largest grid (columns or rows) the kernel takes: f32 holds every cell index and
/// position of it exactly. Files with larger grids (none in the database, whose grids are
/// 32 to 128) are evaluated by the f64 path ([`crate::RglBsdf::eval_flat`] checks).
pub(crate) const MAX_GRID: usize = 1 << 24;

/// Pairs per lane block.
pub(crate) const LANES: usize = 32;
const L: usize = LANES;

/// One VNDF cell of one slice, all that the inverse warp reads there: the densities at
/// its corners (v00, v10, v01, v11), the conditional CDF just before it on its two rows
/// (0 in the first column), and the two rows' totals. 32 bytes, one aligned load, where
/// the tables of [`Warp2D`] take seven cache lines.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub(crate) struct VndfCell([f32; 8]);

/// Four floats, aligned: the corners (v00, v10, v01, v11) of one value channel of a cell.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
pub(crate) struct Quad([f32; 4]);

/// One value cell of an RGB file, corner-major: (r, g, b, 0) at v00, v10, v01 and v11.
/// One 64-byte line, which a lane mixes over the corner slices as one vector and
/// interpolates with the channels side by side (channel-major, the mix took one scalar
/// multiply-add per channel, corner and slice).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(crate) struct RgbCell([f32; 16]);

/// The tables rearranged by cell for the batch kernel, built once per file (lazily, on
/// the first batch evaluation): the same f32 numbers as the [`Warp2D`]s, so the same
/// results, with a cell's data together.
#[derive(Clone, Debug)]
pub(crate) struct Packed {
    /// `slices × (h − 1) × (w − 1)` cells of the VNDF.
    vndf: Vec<VndfCell>,
    /// The marginal CDF before each cell row (0 for the first) and its total, per slice.
    marg_before: Vec<f32>,
    marg_total: Vec<f32>,
    /// `slices × (h − 1) × (w − 1)` cells of the values of a spectral file, `stride`
    /// quads a cell (one a wavelength); empty for an RGB file.
    values: Vec<Quad>,
    stride: usize,
    /// The same cells of an RGB file; empty for a spectral one.
    rgb: Vec<RgbCell>,
}

impl Packed {
    pub(crate) fn new(vndf: &Warp2D, values: &Warp2D) -> Packed {
        let (w, h) = (vndf.w, vndf.h);
        let (n, nc, nm) = (w * h, h * (w - 1), h - 1);
        let slices = vndf.data.len() / n;
        let mut cells = Vec::with_capacity(slices * (h - 1) * (w - 1));
        for s in 0..slices {
            let d = &vndf.data[s * n..(s + 1) * n];
            let cond = &vndf.cond[s * nc..(s + 1) * nc];
            let cd = |row: usize, k: usize| cond[row * (w - 1) + k];
            for y in 0..h - 1 {
                for x in 0..w - 1 {
                    let i = y * w + x;
                    let (b0, b1) = if x > 0 {
                        (cd(y, x - 1), cd(y + 1, x - 1))
                    } else {
                        (0.0, 0.0)
                    };
                    cells.push(VndfCell([
                        d[i],
                        d[i + 1],
                        d[i + w],
                        d[i + w + 1],
                        b0,
                        b1,
                        cd(y, w - 2),
                        cd(y + 1, w - 2),
                    ]));
                }
            }
        }
        let marg = |s: usize, k: usize| vndf.marg[s * nm + k];
        let marg_before = (0..slices * nm)
            .map(|i| {
                if i % nm > 0 {
                    marg(i / nm, i % nm - 1)
                } else {
                    0.0
                }
            })
            .collect();
        let marg_total = (0..slices).map(|s| marg(s, nm - 1)).collect();
        let (values, stride, rgb) = pack_values(values);
        Packed {
            vndf: cells,
            marg_before,
            marg_total,
            values,
            stride,
            rgb,
        }
    }
}

/// The value cells: for each outer slice and cell, the four corners of each node of the
/// last parameter (from [`Warp2D`]'s interleaved copy): as [`RgbCell`]s for an RGB file,
/// else as `stride` [`Quad`]s a cell.
fn pack_values(v: &Warp2D) -> (Vec<Quad>, usize, Vec<RgbCell>) {
    let (w, h) = (v.w, v.h);
    let k = v.params.last().map_or(1, Vec::len);
    let outer = v.interleaved.len() / (w * h * k);
    let n = outer * (h - 1) * (w - 1);
    let (mut quads, mut rgb) = (Vec::new(), Vec::new());
    if k == 3 {
        rgb = vec![RgbCell::default(); n];
    } else {
        quads = vec![Quad::default(); n * k];
    }
    for s in 0..outer {
        let il = &v.interleaved[s * w * h * k..(s + 1) * w * h * k];
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                let cell = (s * (h - 1) + y) * (w - 1) + x;
                let corners = [0, 1, w, w + 1].map(|d| y * w + x + d);
                for j in 0..k {
                    let at = corners.map(|c| il[c * k + j]);
                    if k == 3 {
                        for (c, &x) in at.iter().enumerate() {
                            rgb[cell].0[4 * c + j] = x;
                        }
                    } else {
                        quads[cell * k + j] = Quad(at);
                    }
                }
            }
        }
    }
    (quads, k, rgb)
}

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
    pub(crate) packed: &'a Packed,
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
    /// The VNDF cell of each lane's half vector (step 3a).
    vndf: Cells,
}

/// Step 3a's VNDF cells of a lane block, each lane's mixed over its corner slices, and
/// the marginal CDF before its row and the total, mixed the same way.
struct Stage {
    cell: [[f32; 8]; L],
    before: [f32; L],
    total: [f32; L],
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

/// [`lerp`] of four channels at once.
#[inline(always)]
fn lerp4(a: [f32; 4], b: [f32; 4], t: f32) -> [f32; 4] {
    let mut o = [0.0; 4];
    for j in 0..4 {
        o[j] = lerp(a[j], b[j], t);
    }
    o
}

/// The cells of a lane block's positions on a grid: each lane's column and row and its
/// position in the cell.
struct Cells {
    col: [u32; L],
    row: [u32; L],
    t: [[f32; L]; 2],
}

/// The [`Cells`] of the positions `u` (clamped to the unit square) on a `w` × `h` grid,
/// vectorised over the lanes (through i32: the grid is at most [`MAX_GRID`] wide).
#[inline(always)]
fn cells(u: [&[f32; L]; 2], w: usize, h: usize) -> Cells {
    let mut c = Cells {
        col: [0; L],
        row: [0; L],
        t: [[0.0; L]; 2],
    };
    debug_assert!(w <= MAX_GRID && h <= MAX_GRID, "RglBsdf::batch_fits");
    let last = [w, h].map(|n| (n - 2).min(MAX_GRID) as i32);
    let scale = [(w - 1) as f32, (h - 1) as f32];
    for l in 0..L {
        for d in 0..2 {
            // max before min: NaN becomes 0 (as the f64 path's `as usize` makes it);
            // `clamp` would keep the NaN.
            #[allow(clippy::manual_clamp)]
            let s = u[d][l].max(0.0).min(1.0) * scale[d];
            // SAFETY: s is finite, in [0, w − 1], and w ≤ 2²⁴ (`MAX_GRID`); the checked
            // `as i32` compiles to scalar code with saturation, this to one vector
            // instruction.
            let i = unsafe { s.to_int_unchecked::<i32>() }.min(last[d]);
            c.t[d][l] = s - i as f32;
            if d == 0 {
                c.col[l] = i as u32;
            } else {
                c.row[l] = i as u32;
            }
        }
    }
    c
}

/// Σ over the `NC` corner slices of weight × `table[i + offset · size]`.
#[inline(always)]
fn mix<const NC: usize>(
    table: &[f32],
    i: usize,
    size: usize,
    off: &[usize; 4],
    w: &[f32; 4],
) -> f32 {
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
            let [ix, iy, iz, ox, oy, oz] = if above {
                v
            } else {
                [0.0, 0.0, 1.0, 0.0, 0.0, 1.0]
            };
            let (sy, sx) = (iy, if x_by_x { ix } else { iy });
            let (ix, iy) = (fold(ix, sx, mask_y), fold(iy, sy, mask_y));
            let (ox, oy) = (fold(ox, sx, mask_y), fold(oy, sy, mask_y));
            let (hx, hy, hz) = (ix + ox, iy + oy, iz + oz);
            let (r2, len) = (hx * hx + hy * hy, (hx * hx + hy * hy + hz * hz).sqrt());
            let (mx, my) = (hx / len, hy / len);
            // mz − 1 without the cancellation: −(hx² + hy²) / (|h| (hz + |h|)). In f32,
            // mz = hz/|h| is 1 − 6e-8 where m is at the pole, and √ of the elevation
            // (the grid's u) turns that into an error of 2e-4 in u.
            let mz1 = -r2 / (len * (hz + len));
            let (theta_i, phi_i) = (elevation(ix, iy, iz), atan2_f32(iy, ix));
            let dist_m = (mx * mx + my * my + mz1 * mz1).sqrt();
            let (theta_m, phi_m) = (2.0 * asin_f32((0.5 * dist_m).min(1.0)), atan2_f32(my, mx));
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
            // The largest i ≤ n − 2 with grid[i] < x: a count, and grid[i], grid[i + 1]
            // kept by selects as it grows (the grid is sorted, so the last value below
            // x is grid[i]), vectorised over lanes: read back as grid[i] lane by lane,
            // they were scalar loads.
            let (mut p0, mut p1) = ([grid[0]; L], [grid[1]; L]);
            for (&v, &next) in grid[1..n - 1].iter().zip(&grid[2..]) {
                for l in 0..L {
                    let below = g.param[d][l] > v;
                    at[d][l] += usize::from(below);
                    p0[l] = if below { v } else { p0[l] };
                    p1[l] = if below { next } else { p1[l] };
                }
            }
            for l in 0..L {
                t[d][l] = ((g.param[d][l] - p0[l]) / (p1[l] - p0[l])).clamp(0.0, 1.0);
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
        let dp = if self.phi_i.len() > 1 {
            self.theta_i.len()
        } else {
            0
        };
        [0, dt, dp, dp + dt]
    }

    /// The index of lane `l`'s VNDF cell in corner slice 0.
    #[inline(always)]
    fn vndf_cell(&self, p: &Place, l: usize) -> usize {
        let (w, h) = (self.vndf.w, self.vndf.h);
        let (col, row) = (p.vndf.col[l] as usize, p.vndf.row[l] as usize);
        p.slice[l] * (h - 1) * (w - 1) + row * (w - 1) + col
    }

    /// Step 3a, first half: every lane's VNDF cells (one per corner slice) mixed with
    /// the corner weights, a lane at a time: a [`VndfCell`] is one vector, so the mix
    /// is a vector multiply and add per slice (mixed field by field over lanes, it took
    /// one scalar multiply-add per field and slice). The lanes are independent, so
    /// their loads (prefetched a block ahead) overlap.
    #[inline(always)]
    fn gather_vndf<const NC: usize>(&self, p: &Place, off: &[usize; 4], st: &mut Stage) {
        let v = self.vndf;
        let per = (v.h - 1) * (v.w - 1);
        let nm = v.h - 1;
        for l in 0..L {
            let (i, wt) = (self.vndf_cell(p, l), &p.w[l]);
            // The same sums, in the same order, as before: (0 + w₀ x₀) + w₁ x₁ …
            let mut m = [0.0f32; 8];
            for k in 0..NC {
                for (m, x) in m.iter_mut().zip(&self.packed.vndf[i + off[k] * per].0) {
                    *m += wt[k] * x;
                }
            }
            st.cell[l] = m;
            let s = p.slice[l];
            let row = s * nm + p.vndf.row[l] as usize;
            st.before[l] = mix::<NC>(&self.packed.marg_before, row, nm, off, wt);
            if !v.normalized {
                st.total[l] = mix::<NC>(&self.packed.marg_total, s, 1, off, wt);
            }
        }
    }

    /// Step 3a, second half: the inverse VNDF warp at every lane's half vector
    /// (`Warp2D::invert_with`, the same arithmetic on the lanes' mixed [`VndfCell`]s),
    /// into `pos`. The arithmetic reads each lane's mixed record in place and runs over
    /// lanes (vectorised); turned into one array per field first, the records were
    /// written with AVX-512 scatters, slower than the arithmetic they fed.
    #[inline(always)]
    fn invert(&self, p: &Place, st: &Stage, pos: &mut [[f32; L]; 2]) {
        let v = self.vndf;
        let (w, h) = (v.w, v.h);
        let (pw, ph) = (1.0 / (w - 1) as f32, 1.0 / (h - 1) as f32);
        let [tx, ty] = &p.vndf.t;
        let (before, total) = (&st.before, &st.total);
        for l in 0..L {
            let [v00, v10, v01, v11, b0, b1, r0, r1] = st.cell[l];
            let (c0, c1) = (lerp(v00, v01, ty[l]), lerp(v10, v11, ty[l]));
            let mut x = tx[l] * lerp(c0, c1, 0.5 * tx[l]) * pw;
            x += lerp(b0, b1, ty[l]);
            x /= lerp(r0, r1, ty[l]);
            let mut y = ty[l] * lerp(r0, r1, 0.5 * ty[l]) * ph;
            y += before[l];
            // 1 for a normalised VNDF (every `.bsdf`'s): an exact division.
            y /= total[l];
            [pos[0][l], pos[1][l]] = [x, y];
        }
    }

    /// D(m) / (4 σ(wi)) (step 4's Jacobian; 1 without the `jacobian` flag) over
    /// cos θo, each lane's into `scale`.
    #[inline(always)]
    fn jacobians(&self, g: &Geo, scale: &mut [f32; L]) {
        if !self.jacobian {
            *scale = g.scale;
            return;
        }
        let (n, s) = (self.ndf, self.sigma);
        let cn = cells([&g.um[0], &g.um[1]], n.w, n.h);
        let cs = cells([&g.uwi[0], &g.uwi[1]], s.w, s.h);
        let (dn, ds) = (plain(n, &cn), plain(s, &cs));
        for l in 0..L {
            scale[l] = dn[l] / (4.0 * ds[l]) * g.scale[l];
        }
    }

    /// Each lane's value cell in corner slice 0 (an index of [`Packed`]'s cells), and
    /// the cells.
    #[inline(always)]
    fn value_cells(&self, pos: &[[f32; L]; 2], p: &Place) -> ([usize; L], Cells) {
        let v = self.values;
        let c = cells([&pos[0], &pos[1]], v.w, v.h);
        let per = (v.h - 1) * (v.w - 1);
        let mut first = [0; L];
        for (l, f) in first.iter_mut().enumerate() {
            let cell = c.row[l] as usize * (v.w - 1) + c.col[l] as usize;
            *f = p.slice[l] * per + cell;
        }
        (first, c)
    }

    /// Step 3b: the value table's `k` values of the quads `q(j, corner)` at position
    /// `t` in the cell, mixed with the corner weights `wt`, times `scale`, into `out`.
    #[inline(always)]
    fn values<const NC: usize>(
        &self,
        q: impl Fn(usize, usize) -> Quad,
        t: [f32; 2],
        wt: &[f32; 4],
        scale: f32,
        out: &mut [f32],
    ) {
        for (j, o) in out.iter_mut().enumerate() {
            let mut m = [0.0f32; 4];
            for (k, w) in wt.iter().enumerate().take(NC) {
                for (m, x) in m.iter_mut().zip(q(j, k).0) {
                    *m += w * x;
                }
            }
            let [a, b, c, d] = m;
            *o = lerp(lerp(a, b, t[0]), lerp(c, d, t[0]), t[1]) * scale;
        }
    }

    /// Step 3b for a lane block whose value cells are `at`: an RGB file's a lane at a
    /// time, each [`RgbCell`] mixed over the corner slices and interpolated as vectors of
    /// its channels; a spectral file's, lane by lane over its [`Quad`]s.
    #[inline(always)]
    fn all_values<const NC: usize>(
        &self,
        p: &Place,
        off: &[usize; 4],
        at: &([usize; L], Cells),
        scale: &[f32; L],
        out: &mut [f32],
    ) {
        let k = out.len() / L;
        let per = (self.values.h - 1) * (self.values.w - 1);
        let (first, c) = at;
        if !self.packed.rgb.is_empty() {
            debug_assert_eq!(k, 3);
            let rgb = &self.packed.rgb;
            let mut v = [[0.0f32; 4]; L];
            for l in 0..L {
                // The same sums, in the same order, as Σ weight × corner slice per
                // channel and corner: (0 + w₀ x₀) + w₁ x₁ …
                let mut m = [[0.0f32; 4]; 4];
                for (k, &w) in p.w[l].iter().enumerate().take(NC) {
                    let cell = &rgb[first[l] + off[k] * per].0;
                    for (m, x) in m.as_flattened_mut().iter_mut().zip(cell) {
                        *m += w * x;
                    }
                }
                let (tx, ty) = (c.t[0][l], c.t[1][l]);
                let [a, b, cc, d] = m;
                let ab = lerp4(a, b, tx);
                v[l] = lerp4(ab, lerp4(cc, d, tx), ty).map(|x| x * scale[l]);
            }
            // The channels of every lane computed as one vector (the fourth, the
            // padding, dropped here: computed in place, the compiler split them into two
            // and one).
            for (o, v) in out.chunks_exact_mut(3).zip(&v) {
                o.copy_from_slice(&v[..3]);
            }
        } else {
            let (vals, stride) = (&self.packed.values, self.packed.stride);
            for (l, o) in out.chunks_exact_mut(k).enumerate() {
                let i = first[l] * stride;
                self.values::<NC>(
                    |j, k| vals[i + off[k] * per * stride + j],
                    [c.t[0][l], c.t[1][l]],
                    &p.w[l],
                    scale[l],
                    o,
                );
            }
        }
    }

    /// Steps 1 and 2 of a lane block, and a prefetch of the VNDF cells its step 3
    /// reads: issued one block ahead, their cache misses are served while the block
    /// before is finished.
    #[inline(always)]
    fn front<const NC: usize>(&self, rows: &[[f64; 6]; L], g: &mut Geo, p: &mut Place) {
        self.geometry(rows, g);
        self.place(g, p);
        p.vndf = cells([&g.um[0], &g.um[1]], self.vndf.w, self.vndf.h);
        let off = self.offsets();
        let per = (self.vndf.h - 1) * (self.vndf.w - 1);
        for l in 0..L {
            let i = self.vndf_cell(p, l);
            for o in &off[..NC] {
                prefetch(&self.packed.vndf[i + o * per]);
            }
        }
    }

    /// [`front`](Self::front) of lane block `b` of `rows` (a method, not a closure: a
    /// closure is compiled apart, without the AVX2 of its caller).
    #[inline(always)]
    fn front_at<const NC: usize>(&self, rows: &[[f64; 6]], b: usize, (g, p): &mut (Geo, Place)) {
        let r = &rows[b * L..rows.len().min(b * L + L)];
        if let Ok(r) = <&[[f64; 6]; L]>::try_from(r) {
            self.front::<NC>(r, g, p);
        } else {
            let mut pad = [[0.0; 6]; L];
            pad[..r.len()].copy_from_slice(r);
            self.front::<NC>(&pad, g, p);
        }
    }

    /// Steps 3 and 4 of a lane block whose [`front`](Self::front) is `g`, `p`: the
    /// stored values (3 or the wavelengths a pair) times the Jacobian over cos θo,
    /// into `out` (`k` a lane).
    #[inline(always)]
    fn back<const NC: usize>(&self, g: &Geo, p: &Place, out: &mut [f32]) {
        let off = self.offsets();
        let mut st = Stage {
            cell: [[0.0; 8]; L],
            before: [0.0; L],
            total: [1.0; L],
        };
        self.gather_vndf::<NC>(p, &off, &mut st);
        let mut pos = [[0.0f32; L]; 2];
        self.invert(p, &st, &mut pos);
        // The value cells are fetched while the Jacobians are computed.
        let at = self.value_cells(&pos, p);
        let per = (self.values.h - 1) * (self.values.w - 1);
        let (rgb, stride) = (&self.packed.rgb, self.packed.stride);
        for i in at.0 {
            for o in &off[..NC] {
                if rgb.is_empty() {
                    prefetch(&self.packed.values[(i + o * per) * stride]);
                } else {
                    prefetch(&rgb[i + o * per]);
                }
            }
        }
        let mut scale = [0.0f32; L];
        self.jacobians(g, &mut scale);
        self.all_values::<NC>(p, &off, &at, &scale, out);
    }

    /// Steps 1 to 4 over whole rows, a lane block at a time, each block's
    /// [`front`](Self::front) run before the previous block's [`back`](Self::back)
    /// (the last block padded with pairs below the horizon).
    #[inline(always)]
    fn rows_inline<const NC: usize>(&self, rows: &[[f64; 6]], out: &mut [f32]) {
        let k = out.len() / rows.len().max(1);
        let n = rows.len().div_ceil(L);
        let new = || {
            let g = Geo {
                um: [[0.0; L]; 2],
                uwi: [[0.0; L]; 2],
                param: [[0.0; L]; 2],
                scale: [0.0; L],
            };
            (
                g,
                Place {
                    slice: [0; L],
                    w: [[0.0; 4]; L],
                    vndf: cells([&[0.0; L], &[0.0; L]], 2, 2),
                },
            )
        };
        // Two sets of stage buffers, used in turn (moving them would copy them).
        let mut bufs = [new(), new()];
        if n > 0 {
            self.front_at::<NC>(rows, 0, &mut bufs[0]);
        }
        for (b, o) in out.chunks_mut(L * k).enumerate() {
            let [x, y] = &mut bufs;
            let (cur, next) = if b % 2 == 0 { (x, y) } else { (y, x) };
            if b + 1 < n {
                self.front_at::<NC>(rows, b + 1, next);
            }
            // The input rows a few blocks ahead (the hardware prefetcher alone left the
            // row loads waiting on memory, `perf annotate`): every 64-byte line of them
            // (a row is 48 bytes; one row in four left two lines in three unfetched).
            let ahead = rows.get((b + 4) * L..).unwrap_or_default();
            let ahead = ahead[..ahead.len().min(L)].as_flattened();
            for x in ahead.iter().step_by(8) {
                prefetch(x);
            }
            if o.len() == L * k {
                self.back::<NC>(&cur.0, &cur.1, o);
            } else {
                let mut tmp = vec![0.0; L * k];
                self.back::<NC>(&cur.0, &cur.1, &mut tmp);
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

    /// The stored values of `rows` (as [`RglBsdf::eval_stored`], `out.len() / rows.len()`
    /// a pair) times the Jacobian over cos θo; 0 below the horizon. Compiled for the
    /// widest vectors the processor has ([`lanes::dispatch`]: AVX-512, AVX2 + FMA; the
    /// same bits in each, Rust not contracting `a * b + c`).
    pub(crate) fn rows(&self, rows: &[[f64; 6]], out: &mut [f32]) {
        lanes::dispatch(&mut RowsRun {
            tables: self,
            rows,
            out,
        });
    }
}

/// [`Kernel::rows`] as a [`lanes::Run`].
struct RowsRun<'a> {
    tables: &'a Kernel<'a>,
    rows: &'a [[f64; 6]],
    out: &'a mut [f32],
}

impl lanes::Run for RowsRun<'_> {
    #[inline(always)]
    fn run(&mut self) {
        self.tables.rows_any(self.rows, self.out);
    }
}

/// A hint to fetch `x`'s cache line.
#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint: it reads nothing and cannot fault (SSE, in every
    // x86-64 CPU).
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// A table without parameters (`ndf`, `sigma`) in each lane's cell of `c`
/// (`Warp2D::eval_plain`): the corners loaded lane by lane, then interpolated over the
/// lanes (vectorised; a lane at a time, the interpolation and the Jacobian's division
/// were scalar).
#[inline(always)]
fn plain(w: &Warp2D, c: &Cells) -> [f32; L] {
    let mut v = [[0.0f32; L]; 4];
    for l in 0..L {
        let i = c.row[l] as usize * w.w + c.col[l] as usize;
        // One bounds check for the four corners.
        let d = &w.data[i..i + w.w + 2];
        for (v, o) in v.iter_mut().zip([0, 1, w.w, w.w + 1]) {
            v[l] = d[o];
        }
    }
    let [v00, v10, v01, v11] = &v;
    let [tx, ty] = &c.t;
    let mut out = [0.0f32; L];
    for l in 0..L {
        out[l] = lerp(
            lerp(v00[l], v10[l], tx[l]),
            lerp(v01[l], v11[l], tx[l]),
            ty[l],
        );
    }
    out
}
