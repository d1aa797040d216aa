//! The measured points of a `.bsdf` file at their own directions, without resampling:
//! what a fit of the file's native samples sees (`fit X.bsdf`, docs/rgl.md "The
//! sample-set fit").
//!
//! Dupuy & Jakob 2018 ("An Adaptive Parameterization for Efficient Material
//! Acquisition and Rendering", §4–5) measure each incident slice (φi, θi) at the value
//! grid's nodes s = (x, y)/(n − 1) *through* the slice's VNDF warp W: node s stands for
//! the half vector with grid coordinates u_m = W(s) (u_θ = √(2θm/π), u_φ = (φm + π)/2π,
//! φm relative to φi in an isotropic file) and for wo = 2⟨wi, m⟩m − wi. The `valid`
//! bits (packed most significant bit first over (φi, θi, y, x); a grid may have other
//! row and column counts, s = (x/(cols − 1), y/(rows − 1))) mark the nodes that were
//! measured. Evaluation runs the other way (u_m → W⁻¹ → s: [`crate::Warp2D::invert`]);
//! here W is its inverse by bisection, as the writer finds it, so the reader's `eval`
//! at a point's pair lands on the point's own node.
//!
//! **Value.** The node's stored value v (RGB, or a spectrum turned into linear sRGB as
//! `eval` does) times the `jacobian` factor D(m)/(4σ(wi)) when the flag is set, over
//! cos θo: the f_r the reader's `eval` returns at the pair (tests/points.rs checks it
//! against `eval`). Negative values are kept (the fitter decides: it stores them as 0
//! and counts them).
//!
//! **Weight.** The measure of (wi, wo) pairs the point stands for, dω_i · dω_o (sr²),
//! the solid-angle weight a MERL cell carries:
//! - dω_o is the solid angle of the node's cell of the sample grid (the square of side
//!   1/(n − 1) centred on the node, clipped to the unit square) under the map
//!   s → u_m → m → wo, whose Jacobian is
//!   |dω_o/ds| = 4⟨wi, m⟩ · 2π² u_θ sin θm / p(u_m):
//!   1/p(u_m) from the warp (it carries the uniform measure on s to the density p on
//!   u_m, p the VNDF table's normalised bilinear density, Dupuy & Jakob 2018 §5);
//!   2π² u_θ sin θm from u_m to the half vector's solid angle (θ = πu²/2, φ = 2πu_φ);
//!   4⟨wi, m⟩ from the half vector to the reflected direction (Walter et al. 2007,
//!   "Microfacet Models for Refraction through Rough Surfaces", eq. 14). It is
//!   integrated over the cell with 2 × 2 Gauss–Legendre points (the Jacobian vanishes at
//!   the pole u_θ = 0, where the specular nodes lie, but their cells do not).
//! - dω_i is the slice's share of the incident hemisphere: the ring between the
//!   midpoints to the neighbouring θi (clipped to [0, π/2]), 2π(cos θa − cos θb), times
//!   the share of the φi range an anisotropic file's slice stands for.
//!
//! **Shared directions.** The nodes of column x = 0 (u_θ = 0) are all the half vector
//! at the pole (wo the mirror direction of wi), and row y = n − 1 (u_φ = 1) is row
//! y = 0 again (φ = ±π): each such group is one point, its weight the sum of the
//! nodes', its value the reader's `eval` at the pair (which node the reader reads
//! there is a matter of rounding).
//!
//! **Anisotropic files.** The same construction, with wi at the slice's own φi (the
//! stored range: a half or a quarter turn, which the reader folds every wi into) and
//! u_φ the half vector's absolute azimuth. wi is folded and its (φi, θi) taken exactly
//! as the reader does (`slice`), so every table is read at the reader's parameters.
//! At θi = 0 all φi slices are the one incident direction; the reader reads it from
//! the φi its `atan2(0, 0) = 0` clamps to (the last slice of a stored range ending at
//! −π/2 or 0), so that slice gives the pole's points, standing for the whole cap.
//!
//! Skipped (counted): slices with cos θi < [`MIN_COS_I`] (wi on the horizon, where
//! f_r · cos θi vanishes and the files hold no measurement), an anisotropic file's
//! θi = 0 slices that the reader does not read, and nodes whose wo is on or below the
//! horizon.

use crate::bsdf::u2theta;
use crate::bsdf::{Parts, RglBsdf, Values, incident_params, phi2u, theta2u};
use crate::cie;
use crate::error::RglError;
use crate::tensor::TensorFile;
use crate::write::tables::forward;
use brdfkit_core::direction::spherical;
use brdfkit_core::{Brdf, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::path::Path;

/// Slices with cos θi below this are skipped (θi > 89.94°).
pub const MIN_COS_I: f64 = 1e-3;

/// One measured point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// The slice's incident direction.
    pub wi: Vec3,
    /// The node's outgoing direction.
    pub wo: Vec3,
    /// f_r(wi, wo) in linear RGB (1/sr), as the reader's `eval` returns it.
    pub rgb: [f64; 3],
    /// dω_i · dω_o (sr²), see the module doc.
    pub weight: f64,
    /// (φi, θi, y, x) indices of the node.
    pub node: [usize; 4],
}

/// The measured points of a file and what was left out.
#[derive(Clone, Debug)]
pub struct MeasuredPoints {
    /// The file they come from.
    pub name: String,
    /// The points, in node order (φi, θi, y, x).
    pub points: Vec<Point>,
    /// Set `valid` bits (or every node of a file without `valid`).
    pub valid: usize,
    /// Valid nodes left out: on a horizon slice or with wo below the horizon.
    pub skipped: usize,
    /// Valid nodes merged into another node's point (the same direction pair: see
    /// the module doc).
    pub merged: usize,
}

/// 2-point Gauss–Legendre abscissae on [−1, 1] (weights 1).
const GAUSS: [f64; 2] = [-0.577_350_269_189_625_8, 0.577_350_269_189_625_8];

/// u_φ → relative azimuth (`measured.cpp`'s `u2phi`).
#[inline]
fn u2phi(u: f64) -> f64 {
    (2.0 * u - 1.0) * PI
}

/// One slice's geometry: wi, the warp's parameters (the reader's (φi, θi) of wi) and
/// the azimuth offset of m.
struct Slice {
    wi: Vec3,
    params: [f64; 2],
    phi_offset: f64,
    /// Whether the reader reads this slice's tables at wi (see [`slice`]).
    read: bool,
}

impl Slice {
    /// m and wo of sample position `s`, with |dω_o/ds| (module doc).
    fn map(&self, p: &Parts, s: [f64; 2]) -> (Vec3, Vec3, [f64; 2], f64) {
        let um = forward(p.vndf, s, &self.params);
        let (_, pdf) = p.vndf.invert(um, &self.params);
        let th = u2theta(um[0]);
        let m = spherical(th, u2phi(um[1]) + self.phi_offset);
        let c = self.wi.dot(&m);
        let wo = m * (2.0 * c) - self.wi;
        let jac = 4.0 * c.max(0.0) * 2.0 * PI * PI * um[0] * th.sin() / pdf;
        (m, wo, um, if jac.is_finite() { jac } else { 0.0 })
    }

    /// ∫ |dω_o/ds| over node (x, y)'s clipped cell of a grid of `[rows, cols]` nodes.
    fn cell_solid_angle(&self, p: &Parts, x: usize, y: usize, [rows, cols]: [usize; 2]) -> f64 {
        let span = |i: usize, n: usize| {
            let h = 1.0 / (n - 1) as f64;
            let c = i as f64 * h;
            ((c - 0.5 * h).max(0.0), (c + 0.5 * h).min(1.0))
        };
        let ((x0, x1), (y0, y1)) = (span(x, cols), span(y, rows));
        let mut sum = 0.0;
        for gy in GAUSS {
            for gx in GAUSS {
                let s = [
                    0.5 * (x0 + x1) + 0.5 * (x1 - x0) * gx,
                    0.5 * (y0 + y1) + 0.5 * (y1 - y0) * gy,
                ];
                sum += self.map(p, s).3;
            }
        }
        sum * 0.25 * (x1 - x0) * (y1 - y0)
    }
}

/// Bit `k` of a most-significant-bit-first packing (false past its end).
#[inline]
fn bit(bytes: &[u8], k: usize) -> bool {
    bytes.get(k / 8).is_some_and(|b| b & (0x80 >> (k % 8)) != 0)
}

/// The share of the incident directions slice `i` of `grid` stands for: the interval
/// between the midpoints to its neighbours, clipped to [lo, hi].
fn cell_of(grid: &[f32], i: usize, lo: f64, hi: f64) -> (f64, f64) {
    let g = |k: usize| f64::from(grid[k]);
    let a = if i == 0 { lo } else { 0.5 * (g(i - 1) + g(i)) };
    let b = if i + 1 == grid.len() {
        hi
    } else {
        0.5 * (g(i) + g(i + 1))
    };
    (a.max(lo), b.min(hi))
}

impl MeasuredPoints {
    /// Reads a `.bsdf` file and its measured points.
    pub fn read(path: &Path) -> Result<(RglBsdf, MeasuredPoints), RglError> {
        let tf = TensorFile::read(path)?;
        let bsdf = RglBsdf::from_tensor(&tf)?;
        // from_tensor has checked `valid`'s dtype and length.
        let valid = tf.get("valid").map(|f| tf.data(f).to_vec());
        let pts = MeasuredPoints::of(&bsdf, valid.as_deref());
        Ok((bsdf, pts))
    }

    /// The points of `bsdf` whose bit is set in `valid` (packed as the file's `valid`
    /// field; `None`: every node, as for a file without the field).
    pub fn of(bsdf: &RglBsdf, valid: Option<&[u8]>) -> MeasuredPoints {
        let p = bsdf.parts();
        let grid = bsdf.summary().value_grid;
        let n = grid[0] * grid[1];
        let (nphi, nth) = (p.phi_i.len(), p.theta_i.len());
        let is_valid = |k: usize| valid.is_none_or(|v| bit(v, k));
        let slices: Vec<(usize, usize)> = (0..nphi)
            .flat_map(|a| (0..nth).map(move |b| (a, b)))
            .collect();
        let per: Vec<(SlicePoints, usize)> = slices
            .par_iter()
            .map(|&(a, b)| {
                let base = (a * nth + b) * n;
                let nodes: Vec<usize> = (0..n).filter(|&k| is_valid(base + k)).collect();
                (slice_points(&p, bsdf, [a, b], &nodes, grid), nodes.len())
            })
            .collect();
        let mut out = MeasuredPoints {
            name: bsdf.name().into(),
            points: Vec::new(),
            valid: 0,
            skipped: 0,
            merged: 0,
        };
        for (sp, v) in per {
            out.points.extend(sp.points);
            out.valid += v;
            out.skipped += sp.skipped;
            out.merged += sp.merged;
        }
        out
    }
}

/// How far (rad) the reader's φi of a slice's wi, clamped to the φi grid, may lie from
/// the slice's own φi for the slice to be the one the reader reads there: the f32
/// rounding of the grid and the fold move it by ~1e-7; at the pole the reader's φi is 0,
/// the far end of a stored range that ends at −π/2.
const PHI_TOL: f64 = 1e-5;

/// The slice's incident geometry, as the reader sees it. wi is built at the slice's
/// (φi, θi) (an isotropic file's at φ = −π), then folded by the reader's own
/// [`RglBsdf::fold`] and its parameters taken by the reader's own
/// [`incident_params`]: so the pair built from them is the pair `eval` evaluates, and
/// every table is read at the parameters `eval` reads it at.
///
/// This is where an anisotropic file went wrong before (the earlier 10× mismatch): the
/// f32 grid value −π is −3.14159274, whose sine is +8.7e-8, so the wi built there had
/// y > 0 and the reader mirrored the whole pair (4-fold: m's azimuth negated; 2-fold:
/// turned by π, onto the other end of the range) before its lookup; and at θi = 0 the
/// reader's φi is Dr.Jit's atan2(0, 0) = 0, which reads the *last* φi slice of the
/// stored range, not the first. Now wi is built at the f64 −π (y < 0), exact zeros
/// are put on the stored side (−0), the reader's fold is applied (a no-op then, kept so
/// the pair is the reader's whatever the grid), and a slice whose wi the reader reads
/// from another slice gives no point (`read`).
fn slice(p: &Parts, bsdf: &RglBsdf, [a, b]: [usize; 2]) -> Slice {
    let (phi, theta) = (f64::from(p.phi_i[a]), f64::from(p.theta_i[b]));
    // The f64 −π, not the f32 grid's −3.14159274: inside the range, y < 0.
    let mut built = spherical(theta, if p.isotropic { -PI } else { phi.max(-PI) });
    // An exact +0 (φ = 0, or the pole) as −0: the stored side of the fold's sign bits.
    let stored_side = |c: f64| if c == 0.0 { -0.0 } else { c };
    (built.x, built.y) = (stored_side(built.x), stored_side(built.y));
    let (wi, _) = bsdf.fold(built, built);
    let params = incident_params(&wi);
    let (lo, hi) = (f64::from(p.phi_i[0]), f64::from(p.phi_i[p.phi_i.len() - 1]));
    Slice {
        wi,
        params,
        phi_offset: if p.isotropic { params[0] } else { 0.0 },
        read: p.isotropic || (params[0].clamp(lo, hi) - phi).abs() < PHI_TOL,
    }
}

/// dω_i of slice (a, b) (module doc).
fn incident_measure(p: &Parts, [a, b]: [usize; 2]) -> f64 {
    let (t0, t1) = cell_of(p.theta_i, b, 0.0, PI / 2.0);
    let ring = 2.0 * PI * (t0.cos() - t1.cos());
    // At θi = 0 one slice stands for the whole cap: the pole is one incident direction.
    if p.isotropic || p.phi_i.len() < 2 || p.theta_i[b] == 0.0 {
        return ring;
    }
    let (lo, hi) = (f64::from(p.phi_i[0]), f64::from(p.phi_i[p.phi_i.len() - 1]));
    let (f0, f1) = cell_of(p.phi_i, a, lo, hi);
    ring * (f1 - f0) / (hi - lo)
}

/// What one slice gives: its points, and its valid nodes skipped and merged.
struct SlicePoints {
    points: Vec<Point>,
    skipped: usize,
    merged: usize,
}

/// The points of one slice's valid `nodes` (indices y·cols + x, ascending) on a grid of
/// `[rows, cols]` nodes. Nodes that share a direction become one point with their
/// weights summed, valued by the reader's `eval` at the pair (the node it reads there is
/// a matter of rounding): column x = 0 (u_θ = 0, every row is the half vector at the
/// pole, wo the mirror direction) and rows y = 0 and y = rows − 1 (u_φ = 0 and 1, one
/// azimuth).
fn slice_points(
    p: &Parts,
    bsdf: &RglBsdf,
    ab: [usize; 2],
    nodes: &[usize],
    grid: [usize; 2],
) -> SlicePoints {
    let [rows, cols] = grid;
    let sl = slice(p, bsdf, ab);
    let mut out = SlicePoints {
        points: Vec::with_capacity(nodes.len()),
        skipped: 0,
        merged: 0,
    };
    // At θi = 0 every φi slice is the one incident direction, and the reader reads one
    // of them there (see `slice`): the others' nodes are not what it evaluates.
    if sl.wi.z < MIN_COS_I || !sl.read {
        out.skipped = nodes.len();
        return out;
    }
    let d_i = incident_measure(p, ab);
    let step = [1.0 / (cols - 1) as f64, 1.0 / (rows - 1) as f64];
    let sigma = p
        .sigma
        .eval_plain([theta2u(sl.params[1]), phi2u(sl.params[0])]);
    let mut stored = vec![0.0; bsdf.stored_len()];
    let mut row0: Vec<Option<usize>> = vec![None; cols];
    let (mut pole, mut pole_nodes) = (0.0, 0);
    let point = |wo: Vec3, rgb: [f64; 3], weight: f64, y: usize, x: usize| Point {
        wi: sl.wi,
        wo,
        rgb,
        weight,
        node: [ab[0], ab[1], y, x],
    };
    for &k in nodes {
        let (y, x) = (k / cols, k % cols);
        let s = [x as f64 * step[0], y as f64 * step[1]];
        let (_, wo, um, _) = sl.map(p, s);
        if wo.z <= 0.0 {
            out.skipped += 1;
            continue;
        }
        let weight = d_i * sl.cell_solid_angle(p, x, y, grid);
        if x == 0 {
            (pole, pole_nodes) = (pole + weight, pole_nodes + 1);
            continue;
        }
        if y == rows - 1 {
            match row0[x] {
                Some(i) => {
                    out.points[i].weight += weight;
                    out.merged += 1;
                }
                None => out
                    .points
                    .push(point(wo, bsdf.eval(&sl.wi, &wo).0, weight, y, x)),
            }
            continue;
        }
        let jac = if p.jacobian {
            p.ndf.eval_plain(um) / (4.0 * sigma)
        } else {
            1.0
        } / wo.z;
        let rgb = if y == 0 {
            // Shared with row n − 1: the reader's value (see above).
            row0[x] = Some(out.points.len());
            bsdf.eval(&sl.wi, &wo).0
        } else {
            node_rgb(p.values, s, &sl.params, &mut stored).map(|v| v * jac)
        };
        out.points.push(point(wo, rgb, weight, y, x));
    }
    if pole_nodes > 0 {
        let wo = Vec3::new(-sl.wi.x, -sl.wi.y, sl.wi.z);
        out.points
            .push(point(wo, bsdf.eval(&sl.wi, &wo).0, pole, 0, 0));
        out.merged += pole_nodes - 1;
    }
    out
}

/// The stored value at sample position `s` of the slice `params` in linear RGB.
fn node_rgb(values: &Values, s: [f64; 2], params: &[f64; 2], stored: &mut [f64]) -> [f64; 3] {
    match values {
        Values::Rgb(w) => {
            let mut v = [0.0; 3];
            w.eval_nodes(s, params, &mut v);
            v
        }
        Values::Spectral { warp, to_srgb, .. } => {
            warp.eval_nodes(s, params, stored);
            [0, 1, 2].map(|c| cie::dot(&to_srgb[c], stored))
        }
    }
}
