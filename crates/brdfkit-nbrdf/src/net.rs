//! The network: loading the six files, the forward pass (scalar and in blocks of
//! [`LANES`] pairs), and the [`Brdf`] implementation.

use crate::error::NbrdfError;
use crate::npy::{ArrayF32, parse_f32, read_f32};
use brdfkit_core::lanes::{Run, dispatch};
use brdfkit_core::{Brdf, Rgb, Vec3, to_half_diff};
use rayon::prelude::*;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// The six parts of an NBRDF, in the order of the network, as they appear in the file
/// names `<stem>_<part>.npy`.
pub const PARTS: [&str; 6] = ["fc1", "b1", "fc2", "b2", "fc3", "b3"];

/// Inputs of the network: (h.x, h.y, h.z, d.x, d.y, d.z).
pub const INPUTS: usize = 6;

/// Pairs evaluated together by the batch paths. Eight f64 lanes fill four SSE2 or two
/// AVX registers per accumulator row, and the block's activations (2 × 21 × 8 f64 =
/// 2.7 KB for the published width) stay in L1.
pub const LANES: usize = 8;

/// Pairs per rayon task in the batch paths: large enough that scheduling is noise next
/// to ~600 multiply-adds per pair, small enough to balance two to a few dozen cores.
const RUN: usize = 4096;

/// A neural BRDF of Sztrajman et al. (2021): a 6 → h1 → h2 → 3 perceptron with ReLU
/// activations and an exp(y) − 1 output, read from its six `.npy` files (float32) and
/// evaluated in f64.
///
/// # The network
/// For Rusinkiewicz angles (θh, θd, φd), with φh = 0 (the network is isotropic):
///
/// - h = (sin θh, 0, cos θh), d = (sin θd cos φd, sin θd sin φd, cos θd),
///   x = (h.x, h.y, h.z, d.x, d.y, d.z);
/// - a1 = relu(x · fc1 + b1), a2 = relu(a1 · fc2 + b2), y = a2 · fc3 + b3 (row vector
///   times the in × out kernel);
/// - f = exp(y) − 1 per channel (R, G, B), in 1/sr, no cosine factor.
///
/// (`README.md` of the proxies; the Mitsuba plugin `nbrdf_npy.cpp` of the authors'
/// repository asztr/Neural-BRDF, which feeds d as computed from the direction pair,
/// φd unfolded, and sets φh = 0.) exp(y) − 1 is computed as `exp_m1(y)`, exact to an
/// ulp of the result also where y ≈ 0 (near-zero values, where `exp(y) - 1` would
/// lose digits to cancellation).
///
/// # Values
/// - [`raw`](Self::raw), [`raw_angles`](Self::raw_angles): the network's output as is,
///   possibly slightly negative (the fit's error near grazing angles);
/// - [`Brdf::eval`], [`eval_pairs`](Self::eval_pairs): zero when either direction is at
///   or below the horizon (z ≤ 0, the [`Brdf`] contract), otherwise the raw value with
///   negative channels clamped to 0 ([`clamp`]): a BRDF is non-negative;
/// - [`to_table`](Self::to_table): the same clamp, counted ([`crate::ResampleStats`]).
///
/// Per pair and batch paths perform the same operations in the same order on each
/// pair, so they agree bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub struct Nbrdf {
    name: String,
    h1: usize,
    h2: usize,
    /// fc1 transposed (out-major, `w1t[o · 6 + i] = fc1[i][o]`): a unit's weights are
    /// contiguous, and the pairs of a block are the vectorised axis.
    w1t: Vec<f64>,
    b1: Vec<f64>,
    /// fc2 transposed, `w2t[o · h1 + i] = fc2[i][o]`.
    w2t: Vec<f64>,
    b2: Vec<f64>,
    /// fc3 transposed, `w3t[c · h2 + i] = fc3[i][c]`.
    w3t: Vec<f64>,
    b3: [f64; 3],
}

/// The Brdf clamp policy: negative channels become 0, others are kept bit for bit.
///
/// The network is a fit and dips slightly below zero where the measured values are near
/// zero (grazing angles, dark materials); a BRDF cannot be negative, so every value
/// leaving this crate as a BRDF value or a table cell goes through this. A NaN channel
/// (impossible with finite weights) would be kept, and rejected by the table builder.
#[inline]
pub fn clamp(v: Rgb) -> Rgb {
    Rgb(v.0.map(|x| if x < 0.0 { 0.0 } else { x }))
}

/// Network input for Rusinkiewicz angles, φh = 0 (see [`Nbrdf`]).
#[inline]
pub fn input(theta_h: f64, theta_d: f64, phi_d: f64) -> [f64; INPUTS] {
    input_sc(theta_h.sin_cos(), theta_d.sin_cos(), phi_d.sin_cos())
}

/// [`input`] from the (sin, cos) of each angle: the table path computes them once per
/// grid row instead of once per cell (a third of its time went to `sin_cos`).
#[inline]
pub(crate) fn input_sc(
    (sh, ch): (f64, f64),
    (sd, cd): (f64, f64),
    (sp, cp): (f64, f64),
) -> [f64; INPUTS] {
    [sh, 0.0, ch, sd * cp, sd * sp, cd]
}

#[inline(always)]
fn relu(x: f64) -> f64 {
    // Not `max`: its result for ±0 is unspecified and could differ between the scalar
    // and the vector code; this is +0.0 in both.
    if x > 0.0 { x } else { 0.0 }
}

/// Scratch activations of one block.
pub(crate) struct Scratch<const L: usize> {
    a1: Vec<[f64; L]>,
    a2: Vec<[f64; L]>,
}

impl<const L: usize> Scratch<L> {
    pub(crate) fn new(net: &Nbrdf) -> Self {
        Scratch {
            a1: vec![[0.0; L]; net.h1],
            a2: vec![[0.0; L]; net.h2],
        }
    }
}

impl Nbrdf {
    /// The six file paths of `dir_and_stem` (`DIR/NAME` → `DIR/NAME_fc1.npy`, ... in
    /// [`PARTS`] order). A path naming one of the six files (`DIR/NAME_fc1.npy`) is taken
    /// as its stem.
    pub fn files(dir_and_stem: &Path) -> Result<[PathBuf; 6], NbrdfError> {
        let stem = Self::stem(dir_and_stem)?;
        let dir = dir_and_stem.parent().unwrap_or(Path::new(""));
        Ok(PARTS.map(|p| {
            let mut f = OsString::from(&stem);
            f.push(format!("_{p}.npy"));
            dir.join(f)
        }))
    }

    fn stem(path: &Path) -> Result<String, NbrdfError> {
        let name = path
            .file_name()
            .ok_or_else(|| NbrdfError::NoStem {
                path: path.to_owned(),
            })?
            .to_string_lossy()
            .into_owned();
        let stem = PARTS
            .iter()
            .find_map(|p| name.strip_suffix(&format!("_{p}.npy")))
            .unwrap_or(&name);
        if stem.is_empty() {
            return Err(NbrdfError::NoStem {
                path: path.to_owned(),
            });
        }
        Ok(stem.to_owned())
    }

    /// Reads the six files `<dir_and_stem>_{fc1,b1,fc2,b2,fc3,b3}.npy`.
    ///
    /// Each must be float32 (`<f4`; big-endian and Fortran order are accepted and
    /// converted) with the layout's shapes: fc1 (6, h1), b1 (h1,), fc2 (h1, h2),
    /// b2 (h2,), fc3 (h2, 3), b3 (3,). The published networks have h1 = h2 = 21; any
    /// widths ≥ 1 are accepted when the six shapes agree, and a bias may also be stored
    /// as a (1, n) row. Every value must be finite. The weights are widened to f64
    /// exactly. Errors name the file ([`NbrdfError`]); the first failing file in
    /// [`PARTS`] order is reported.
    pub fn load(dir_and_stem: &Path) -> Result<Nbrdf, NbrdfError> {
        let name = Self::stem(dir_and_stem)?;
        let files = Self::files(dir_and_stem)?;
        Self::from_parts(name, &files, read_f32)
    }

    /// An NBRDF from the bytes of its six `.npy` files held in memory (in [`PARTS`]
    /// order), e.g. embedded in a binary with `include_bytes!`. The same checks as
    /// [`load`](Self::load); errors name `(embedded) <name>_<part>.npy`.
    pub fn from_npy_bytes(name: &str, parts: [&[u8]; 6]) -> Result<Nbrdf, NbrdfError> {
        let files = PARTS.map(|p| PathBuf::from(format!("(embedded) {name}_{p}.npy")));
        Self::from_parts(name.to_owned(), &files, |p| {
            let k = files.iter().position(|f| f == p).expect("one of the six");
            parse_f32(parts[k], p)
        })
    }

    fn from_parts(
        name: String,
        files: &[PathBuf; 6],
        read: impl Fn(&Path) -> Result<ArrayF32, NbrdfError>,
    ) -> Result<Nbrdf, NbrdfError> {
        let [f1, fb1, f2, fb2, f3, fb3] = files;
        let fc1 = read(f1)?;
        let (_, h1) = matrix(&fc1, f1, Some(INPUTS), None, "fc1: 6 inputs")?;
        let b1 = read(fb1)?;
        vector(&b1, fb1, h1, "the width of fc1")?;
        let fc2 = read(f2)?;
        let (_, h2) = matrix(&fc2, f2, Some(h1), None, "the width of fc1")?;
        let b2 = read(fb2)?;
        vector(&b2, fb2, h2, "the width of fc2")?;
        let fc3 = read(f3)?;
        matrix(&fc3, f3, Some(h2), Some(3), "the width of fc2, 3 channels")?;
        let b3 = read(fb3)?;
        vector(&b3, fb3, 3, "3 channels")?;
        for (a, p) in [
            (&fc1, f1),
            (&b1, fb1),
            (&fc2, f2),
            (&b2, fb2),
            (&fc3, f3),
            (&b3, fb3),
        ] {
            finite(a, p)?;
        }
        let wide = |a: &ArrayF32| a.data.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>();
        Ok(Nbrdf {
            name,
            h1,
            h2,
            w1t: transpose(&wide(&fc1), INPUTS, h1),
            b1: wide(&b1),
            w2t: transpose(&wide(&fc2), h1, h2),
            b2: wide(&b2),
            w3t: transpose(&wide(&fc3), h2, 3),
            b3: [b3.data[0], b3.data[1], b3.data[2]].map(f64::from),
        })
    }

    /// The material's name: the stem of its files.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Widths of the two hidden layers (21, 21 for the published networks).
    pub fn widths(&self) -> (usize, usize) {
        (self.h1, self.h2)
    }

    /// The forward pass for L pairs at once, up to y (before exp − 1).
    ///
    /// Every lane sees the same operations in the same order (accumulators start at the
    /// bias and add the inputs' products in input order), so a pair's result does not
    /// depend on L or on its neighbours: the L = 1 and L = [`LANES`] paths agree bit for
    /// bit. The lane loops are the innermost, of constant length, so they vectorise.
    #[inline(always)]
    fn forward<const L: usize>(&self, x: &[[f64; L]; INPUTS], s: &mut Scratch<L>) -> [[f64; L]; 3] {
        for (o, a) in s.a1.iter_mut().enumerate() {
            let w = &self.w1t[o * INPUTS..(o + 1) * INPUTS];
            let mut acc = [self.b1[o]; L];
            for (xi, &wi) in x.iter().zip(w) {
                for l in 0..L {
                    acc[l] += xi[l] * wi;
                }
            }
            *a = acc.map(relu);
        }
        let h1 = self.h1;
        for (o, a) in s.a2.iter_mut().enumerate() {
            let w = &self.w2t[o * h1..(o + 1) * h1];
            let mut acc = [self.b2[o]; L];
            for (ai, &wi) in s.a1.iter().zip(w) {
                for l in 0..L {
                    acc[l] += ai[l] * wi;
                }
            }
            *a = acc.map(relu);
        }
        let h2 = self.h2;
        let mut y = [[0.0; L]; 3];
        for (c, yc) in y.iter_mut().enumerate() {
            let w = &self.w3t[c * h2..(c + 1) * h2];
            let mut acc = [self.b3[c]; L];
            for (ai, &wi) in s.a2.iter().zip(w) {
                for l in 0..L {
                    acc[l] += ai[l] * wi;
                }
            }
            *yc = acc;
        }
        y
    }

    /// The raw (unclamped) value of one network input.
    fn raw_input(&self, x: [f64; INPUTS]) -> Rgb {
        let mut s = Scratch::<1>::new(self);
        let y = self.forward(&x.map(|v| [v]), &mut s);
        Rgb(y.map(|c| c[0].exp_m1()))
    }

    /// The network's raw output at Rusinkiewicz angles (radians; φh ignored): f in 1/sr,
    /// **not** clamped (it can be slightly negative), for any angles.
    pub fn raw(&self, theta_h: f64, theta_d: f64, phi_d: f64) -> Rgb {
        self.raw_input(input(theta_h, theta_d, phi_d))
    }

    /// Raw values of a block of inputs into `out` (same length), [`LANES`] at a time;
    /// the last block is padded with copies of its last input. The loop runs in the
    /// widest vector instructions the processor has ([`brdfkit_core::lanes`]: a block's
    /// eight lanes are one AVX-512 register instead of four SSE2 ones), with the same
    /// bits as the baseline loop.
    pub(crate) fn raw_block_into(
        &self,
        xs: &[[f64; INPUTS]],
        out: &mut [Rgb],
        s: &mut Scratch<LANES>,
    ) {
        debug_assert_eq!(xs.len(), out.len());
        struct Blocks<'a> {
            net: &'a Nbrdf,
            xs: &'a [[f64; INPUTS]],
            out: &'a mut [Rgb],
            s: &'a mut Scratch<LANES>,
        }
        impl Run for Blocks<'_> {
            #[inline(always)]
            fn run(&mut self) {
                for (xc, oc) in self.xs.chunks(LANES).zip(self.out.chunks_mut(LANES)) {
                    let mut x = [[0.0; LANES]; INPUTS];
                    for l in 0..LANES {
                        let xl = xc[l.min(xc.len() - 1)];
                        for (i, xi) in x.iter_mut().enumerate() {
                            xi[l] = xl[i];
                        }
                    }
                    let y = self.net.forward(&x, self.s);
                    for (l, o) in oc.iter_mut().enumerate() {
                        *o = Rgb([y[0][l].exp_m1(), y[1][l].exp_m1(), y[2][l].exp_m1()]);
                    }
                }
            }
        }
        dispatch(&mut Blocks {
            net: self,
            xs,
            out,
            s,
        });
    }

    /// Raw (unclamped) values at many (θh, θd, φd) triples, in parallel: equal bit for
    /// bit to [`raw`](Self::raw) of each.
    pub fn raw_angles(&self, angles: &[[f64; 3]]) -> Vec<Rgb> {
        self.par_raw(angles, |t| input(t[0], t[1], t[2]), |_, _| {})
    }

    /// [`Brdf::eval`] of many direction pairs, in parallel: zero below the horizon,
    /// clamped otherwise; equal bit for bit to `eval` of each pair.
    pub fn eval_pairs(&self, pairs: &[(Vec3, Vec3)]) -> Vec<Rgb> {
        // Below-horizon pairs are evaluated too (at their angles, harmless) and zeroed
        // after: no compaction pass for what is usually a few.
        self.par_raw(
            pairs,
            |(wi, wo)| pair_input(wi, wo),
            |o, p| {
                for (v, (wi, wo)) in o.iter_mut().zip(p) {
                    *v = if above(wi, wo) { clamp(*v) } else { Rgb::ZERO };
                }
            },
        )
    }

    /// Raw values at the inputs of many `items`, in parallel runs of [`RUN`] (one
    /// [`Scratch`] per task), each run then passed to `finish` with its items.
    fn par_raw<T: Sync>(
        &self,
        items: &[T],
        to_input: impl Fn(&T) -> [f64; INPUTS] + Sync,
        finish: impl Fn(&mut [Rgb], &[T]) + Sync,
    ) -> Vec<Rgb> {
        let mut out = vec![Rgb::ZERO; items.len()];
        out.par_chunks_mut(RUN)
            .zip(items.par_chunks(RUN))
            .for_each_init(
                || Scratch::<LANES>::new(self),
                |s, (o, run)| {
                    let xs: Vec<[f64; INPUTS]> = run.iter().map(&to_input).collect();
                    self.raw_block_into(&xs, o, s);
                    finish(o, run);
                },
            );
        out
    }
}

/// Both directions strictly above the horizon: the [`Brdf`] contract's domain.
#[inline]
fn above(wi: &Vec3, wo: &Vec3) -> bool {
    wi.z > 0.0 && wo.z > 0.0
}

/// Network input of a direction pair: its angles by the MERL reference conversion
/// ([`to_half_diff`]), φd as it comes (in (−π, π]; not folded, as in the authors'
/// plugin).
#[inline]
fn pair_input(wi: &Vec3, wo: &Vec3) -> [f64; INPUTS] {
    let c = to_half_diff(wi, wo);
    input(c.theta_h, c.theta_d, c.phi_d)
}

impl Brdf for Nbrdf {
    /// Zero when wi.z ≤ 0 or wo.z ≤ 0; otherwise the network at the pair's Rusinkiewicz
    /// angles, negative channels clamped to 0 ([`clamp`]).
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if !above(wi, wo) {
            return Rgb::ZERO;
        }
        clamp(self.raw_input(pair_input(wi, wo)))
    }
}

/// Checks a 2-axis shape (rows, cols), each fixed or free (≥ 1); returns it.
fn matrix(
    a: &ArrayF32,
    path: &Path,
    rows: Option<usize>,
    cols: Option<usize>,
    why: &str,
) -> Result<(usize, usize), NbrdfError> {
    let ok = |n: u64, want: Option<usize>| n >= 1 && want.is_none_or(|w| n == w as u64);
    match a.shape[..] {
        [r, c] if ok(r, rows) && ok(c, cols) => Ok((r as usize, c as usize)),
        _ => {
            let dim = |d: Option<usize>| d.map_or("n".to_string(), |d| d.to_string());
            Err(NbrdfError::Shape {
                path: path.to_owned(),
                found: a.shape.clone(),
                expected: format!("({}, {}) ({why})", dim(rows), dim(cols)),
            })
        }
    }
}

/// Checks a bias shape: (n,) or (1, n).
fn vector(a: &ArrayF32, path: &Path, n: usize, why: &str) -> Result<(), NbrdfError> {
    match a.shape[..] {
        [m] | [1, m] if m == n as u64 => Ok(()),
        _ => Err(NbrdfError::Shape {
            path: path.to_owned(),
            found: a.shape.clone(),
            expected: format!("({n},) ({why})"),
        }),
    }
}

/// The first non-finite value of an array, as an error.
fn finite(a: &ArrayF32, path: &Path) -> Result<(), NbrdfError> {
    let Some(at) = a.data.iter().position(|x| !x.is_finite()) else {
        return Ok(());
    };
    let index = match a.shape[..] {
        [_, c] => vec![at / c as usize, at % c as usize],
        _ => vec![at],
    };
    Err(NbrdfError::NonFinite {
        path: path.to_owned(),
        index,
        value: a.data[at],
    })
}

/// Transposes a row-major rows × cols matrix into cols × rows.
fn transpose(m: &[f64], rows: usize, cols: usize) -> Vec<f64> {
    let mut t = vec![0.0; m.len()];
    for r in 0..rows {
        for c in 0..cols {
            t[c * rows + r] = m[r * cols + c];
        }
    }
    t
}
