//! The RGL-EPFL `.bsdf` model (Dupuy & Jakob 2018, "An Adaptive Parameterization for
//! Efficient Material Acquisition and Rendering"), evaluated as Mitsuba 3's `measured`
//! plugin (`src/bsdfs/measured.cpp`) and `powitacq` (rgl-epfl/brdf-loader) evaluate it.
//!
//! For a pair (wi, wo) above the horizon, with the half vector m = (wi + wo)/|wi + wo|
//! and the angles θ, φ of each (θ by the stable 2·asin(|w − z|/2)):
//! 1. anisotropic files store a 1/2 or 1/4 of the φi range (`reduction` = 2π / span of
//!    φi): wi and wo are mirrored by wi's signs so wi lands in the stored range;
//! 2. the grid coordinates are u(θ) = √(2θ/π) and u(φ) = (φ + π)/2π, with φm taken
//!    relative to φi for isotropic files (wrapped to [0, 1));
//! 3. the half vector's coordinates go through the *inverse* of the VNDF warp at
//!    (φi, θi): that gives the sample position s in the unit square where the data were
//!    measured (the parameterisation of the paper, §4);
//! 4. the value is the `rgb` (or `spectra`) interpolant at s under (φi, θi[, λ]),
//!    multiplied, when the `jacobian` flag is set, by D(m) / (4 σ(wi)) (the `ndf` and
//!    `sigma` interpolants at u(m) and u(wi)): the Jacobian of the half-vector warp.
//!    That product is what Mitsuba's `eval` returns: f · cos θo, by Mitsuba's
//!    `BSDF::eval` contract (Mitsuba renders it as such; pbrt-v4's `MeasuredBxDF`
//!    divides it by |cos θo| for f);
//! 5. divided by cos θo: f_r.
//!
//! The result is f_r without the cosine (brdfkit's convention), with the file's θi being
//! brdfkit's wi; negative stored values are kept, as Mitsuba keeps them.
//!
//! Two paths compute it: this file's, one pair at a time in f64 ([`Brdf::eval`],
//! [`RglBsdf::eval_stored`], [`RglBsdf::eval_spectral`]), and the f32 batch kernel over
//! lanes of pairs (`batch.rs`: [`RglBsdf::eval_flat`], [`RglBsdf::eval_split`],
//! [`RglBsdf::eval_stored_flat`], [`RglBsdf::to_table`]), which is what `fit-brdf eval
//! --bsdf` and `resample --bsdf` run. Both agree with Mitsuba within the bound
//! (tests/mitsuba.rs) and with each other (tests/batch.rs).

use crate::batch::{Kernel, MAX_GRID, Packed};
use crate::cie;
use crate::fastmath::atan2_drjit;
use crate::tensor::TensorFile;
use crate::warp::{ParamPos, Warp2D};
use brdfkit_core::{Brdf, Rgb, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// What the file stores per sample: three colour channels or a spectrum.
#[derive(Clone, Debug)]
pub enum Values {
    /// `rgb`: (φi, θi, 3, n, n), linear RGB.
    Rgb(Warp2D),
    /// `spectra`: (φi, θi, λ, n, n) at `wavelengths` (nm); `to_srgb[c][k]` turns the
    /// values at the wavelengths into linear sRGB ([`cie`]).
    Spectral {
        warp: Warp2D,
        wavelengths: Vec<f32>,
        to_srgb: [Vec<f64>; 3],
    },
}

/// A `.bsdf` file, ready to evaluate.
#[derive(Clone, Debug)]
pub struct RglBsdf {
    name: String,
    description: String,
    phi_i: Vec<f32>,
    theta_i: Vec<f32>,
    ndf: Warp2D,
    sigma: Warp2D,
    vndf: Warp2D,
    values: Values,
    isotropic: bool,
    jacobian: bool,
    /// 2 or 4 (or 1, a full φ range): the fold of wi into the stored φi range.
    reduction: i32,
    /// What `info` reports.
    summary: Summary,
    /// The tables by cell for the batch kernel ([`crate::batch`]), built on first use.
    packed: OnceLock<Packed>,
}

/// The facts of a file that `info` reports.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The fields, as (name, dtype, shape).
    pub fields: Vec<(String, &'static str, Vec<u64>)>,
    /// Number of φi and θi slices.
    pub n_phi_i: usize,
    pub n_theta_i: usize,
    /// θi grid in radians.
    pub theta_i: Vec<f64>,
    /// VNDF grid (rows × columns) and value grid (n × n).
    pub vndf_grid: [usize; 2],
    pub value_grid: [usize; 2],
    /// Wavelengths (nm) of a spectral file.
    pub wavelengths: Option<Vec<f64>>,
    /// Stored values (rgb or spectra) and how many are negative.
    pub values: usize,
    pub negative: usize,
    /// Set bits of `valid` (the measured points) and its bit count, if the file has it.
    pub measured_points: Option<(usize, usize)>,
    pub jacobian: bool,
}

/// Pairs per parallel task of the batch evaluations.
const EVAL_BLOCK: usize = 2048;

/// What steps 1 to 3 of the evaluation find for a pair ([`RglBsdf::locate`]).
struct Located {
    /// (φi, θi) of the folded wi.
    params: [f64; 2],
    /// Their place on the φi and θi grids.
    at: ParamPos,
    /// The sample position of the value tables.
    sample: [f64; 2],
    /// D(m) / (4 σ(wi)), or 1 without the `jacobian` flag.
    jac: f64,
}

/// Elevation of a unit vector, stable near the pole (`measured.cpp`'s `elevation`).
#[inline]
fn elevation(d: &Vec3) -> f64 {
    let dist = (d.x * d.x + d.y * d.y + (d.z - 1.0) * (d.z - 1.0)).sqrt();
    2.0 * (0.5 * dist).clamp(-1.0, 1.0).asin()
}

#[inline]
pub(crate) fn theta2u(theta: f64) -> f64 {
    (theta * (2.0 / PI)).sqrt()
}

#[inline]
pub(crate) fn phi2u(phi: f64) -> f64 {
    (phi + PI) * (0.5 / PI)
}

/// θ of the format's u coordinate: θ = (π/2) u² (`measured.cpp`'s `u2theta`; the inverse
/// of [`theta2u`]).
#[inline]
pub(crate) fn u2theta(u: f64) -> f64 {
    u * u * (PI / 2.0)
}

/// The azimuth of u_φ = (φ + π)/2π: (2u − 1)π (`measured.cpp`'s `u2phi`, the inverse of
/// [`phi2u`]; relative to φi in an isotropic file, absolute in an anisotropic one).
#[inline]
pub(crate) fn u2phi(u: f64) -> f64 {
    (2.0 * u - 1.0) * PI
}

/// `x` with its sign flipped unless `s`'s sign bit is set (Dr.Jit's `mulsign_neg`).
#[inline]
fn mulsign_neg(x: f64, s: f64) -> f64 {
    if s.is_sign_negative() { x } else { -x }
}

/// (φi, θi) of a folded wi as the reader (and Mitsuba) computes them: the parameters
/// of every table lookup. φ by Dr.Jit's `atan2` conventions at signed zeros (wi at the
/// pole gives 0; y = ±0 with x < 0 gives +π), as Mitsuba computes it.
#[inline]
pub(crate) fn incident_params(wi: &Vec3) -> [f64; 2] {
    [atan2_drjit(wi.y, wi.x), elevation(wi)]
}

/// Step 1 for a file of `reduction` 4, 2 or 1 (see [`RglBsdf::fold`]); the writer folds
/// its slices' directions by it too.
#[inline]
pub(crate) fn fold_pair(reduction: i32, mut wi: Vec3, mut wo: Vec3) -> (Vec3, Vec3) {
    if reduction >= 2 {
        let sy = wi.y;
        let sx = if reduction == 4 { wi.x } else { sy };
        wi.x = mulsign_neg(wi.x, sx);
        wi.y = mulsign_neg(wi.y, sy);
        wo.x = mulsign_neg(wo.x, sx);
        wo.y = mulsign_neg(wo.y, sy);
    }
    (wi, wo)
}

impl RglBsdf {
    /// Step 1: wi and wo mirrored by wi's sign bits so that wi lies in the stored φi
    /// range (y ≤ 0, and x ≤ 0 for a 4-fold reduction), as `measured.cpp` folds them.
    #[inline]
    pub(crate) fn fold(&self, wi: Vec3, wo: Vec3) -> (Vec3, Vec3) {
        fold_pair(self.reduction, wi, wo)
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_parts(
        tf: &TensorFile,
        description: String,
        phi_i: Vec<f32>,
        theta_i: Vec<f32>,
        ndf: Warp2D,
        sigma: Warp2D,
        vndf: Warp2D,
        values: Values,
        jacobian: bool,
        summary: Summary,
    ) -> RglBsdf {
        let isotropic = phi_i.len() <= 2;
        // Isotropic files: Mitsuba 3.9.1 folds wi into y ≤ 0 as for a 2-fold reduction
        // (measured.cpp leaves `m_reduction` unset for them; measured against Mitsuba in
        // tests/mitsuba.rs). Everything but σ depends on φm − φi only, which a rotation
        // by π leaves alone; σ is looked up at the folded φi.
        let reduction = if isotropic {
            2
        } else {
            let span = f64::from(phi_i[phi_i.len() - 1]) - f64::from(phi_i[0]);
            (2.0 * PI / span).round() as i32
        };
        RglBsdf {
            name: tf.path().display().to_string(),
            description,
            phi_i,
            theta_i,
            ndf,
            sigma,
            vndf,
            values,
            isotropic,
            jacobian,
            reduction,
            summary,
            packed: OnceLock::new(),
        }
    }

    /// The file name it was read from.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The `description` field.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// Whether the file is spectral.
    pub fn is_spectral(&self) -> bool {
        matches!(self.values, Values::Spectral { .. })
    }

    /// Whether f depends on φi (more than two φi slices).
    pub fn is_anisotropic(&self) -> bool {
        !self.isotropic
    }

    /// The wavelengths (nm) of a spectral file.
    pub fn wavelengths(&self) -> Option<&[f32]> {
        match &self.values {
            Values::Spectral { wavelengths, .. } => Some(wavelengths),
            Values::Rgb(_) => None,
        }
    }

    /// What `info` reports.
    pub fn summary(&self) -> &Summary {
        &self.summary
    }

    /// The θi grid (radians) and the φi grid.
    pub fn grids(&self) -> (&[f32], &[f32]) {
        (&self.theta_i, &self.phi_i)
    }

    /// Steps 1 to 3: the parameters (φi, θi) and their place on the grids, the sample
    /// position of the value tables, and the Jacobian factor; `None` below the horizon.
    #[inline]
    fn locate(&self, wi: &Vec3, wo: &Vec3) -> Option<Located> {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return None;
        }
        let (wi, wo) = self.fold(*wi, *wo);
        let m = (wi + wo).normalize();
        let [phi_i, theta_i] = incident_params(&wi);
        let (theta_m, phi_m) = (elevation(&m), atan2_drjit(m.y, m.x));
        let u_wi = [theta2u(theta_i), phi2u(phi_i)];
        let mut u_m = [
            theta2u(theta_m),
            phi2u(if self.isotropic { phi_m - phi_i } else { phi_m }),
        ];
        u_m[1] -= u_m[1].floor();
        let params = [phi_i, theta_i];
        let at = ParamPos::new([&self.phi_i, &self.theta_i], params);
        let (sample, _) = self.vndf.invert_with(u_m, &self.vndf.weights_at(&at));
        // The stored value times the Jacobian is what Mitsuba's `eval` returns, f · cos θo
        // by its `BSDF::eval` contract (the database's values carry the cosine): f_r is
        // that over cos θo, which is > 0 here.
        let jac = if self.jacobian {
            self.ndf.eval_plain(u_m) / (4.0 * self.sigma.eval_plain(u_wi))
        } else {
            1.0
        } / wo.z;
        Some(Located {
            params,
            at,
            sample,
            jac,
        })
    }

    /// The spectral value at wavelength `lambda` (nm), f_r without the cosine; `None`
    /// for an RGB file. Below the horizon, 0.
    pub fn eval_spectral(&self, wi: &Vec3, wo: &Vec3, lambda: f64) -> Option<f64> {
        let Values::Spectral { warp, .. } = &self.values else {
            return None;
        };
        Some(match self.locate(wi, wo) {
            None => 0.0,
            Some(l) => warp.eval(l.sample, &[l.params[0], l.params[1], lambda]) * l.jac,
        })
    }

    /// The values at every stored wavelength (spectral) or channel (RGB) into `out`
    /// (its length: 3 or the number of wavelengths); all 0 below the horizon.
    #[inline]
    pub fn eval_stored(&self, wi: &Vec3, wo: &Vec3, out: &mut [f64]) {
        let Some(l) = self.locate(wi, wo) else {
            out.fill(0.0);
            return;
        };
        let warp = match &self.values {
            Values::Rgb(w) => w,
            Values::Spectral { warp, .. } => warp,
        };
        warp.eval_nodes_with(l.sample, warp.weights_at(&l.at), out);
        out.iter_mut().for_each(|o| *o *= l.jac);
    }

    /// f_r(wi, wo) in linear RGB into `out` ([`Brdf::eval`]'s value); `scratch` holds a
    /// spectral file's values at its wavelengths, so a caller evaluating many pairs
    /// allocates it once.
    #[inline]
    pub fn eval_rgb_into(&self, wi: &Vec3, wo: &Vec3, scratch: &mut Vec<f64>, out: &mut [f64]) {
        match &self.values {
            Values::Rgb(_) => self.eval_stored(wi, wo, &mut out[..3]),
            Values::Spectral { to_srgb, .. } => {
                scratch.resize(to_srgb[0].len(), 0.0);
                self.eval_stored(wi, wo, scratch);
                for (o, w) in out.iter_mut().zip(to_srgb) {
                    *o = cie::dot(w, scratch);
                }
            }
        }
    }

    /// The batch kernel's view of the file ([`crate::batch`]).
    fn kernel(&self) -> Kernel<'_> {
        let values = match &self.values {
            Values::Rgb(w) => w,
            Values::Spectral { warp, .. } => warp,
        };
        Kernel {
            vndf: &self.vndf,
            ndf: &self.ndf,
            sigma: &self.sigma,
            values,
            phi_i: &self.phi_i,
            theta_i: &self.theta_i,
            isotropic: self.isotropic,
            jacobian: self.jacobian,
            reduction: self.reduction,
            packed: self.packed.get_or_init(|| Packed::new(&self.vndf, values)),
        }
    }

    /// The stored values times the Jacobian over cos θo at `rows` into `scratch`
    /// ([`stored_len`](Self::stored_len) a row), by the batch kernel; by the f64 path
    /// (rounded to f32) for a file with a grid beyond the kernel's
    /// (`batch::MAX_GRID`, 2²⁴ columns).
    fn stored_rows(&self, rows: &[[f64; 6]], scratch: &mut Vec<f32>) {
        let k = self.stored_len();
        scratch.resize(rows.len() * k, 0.0);
        let values = match &self.values {
            Values::Rgb(w) => w,
            Values::Spectral { warp, .. } => warp,
        };
        // Checked before `kernel()`, which builds the kernel's tables.
        let fits = [&self.vndf, values, &self.ndf, &self.sigma]
            .iter()
            .all(|w| w.w <= MAX_GRID && w.h <= MAX_GRID);
        if fits {
            self.kernel().rows(rows, scratch);
            return;
        }
        let mut v = vec![0.0; k];
        for (r, o) in rows.iter().zip(scratch.chunks_exact_mut(k)) {
            let (wi, wo) = (Vec3::new(r[0], r[1], r[2]), Vec3::new(r[3], r[4], r[5]));
            self.eval_stored(&wi, &wo, &mut v);
            o.iter_mut().zip(&v).for_each(|(o, &x)| *o = x as f32);
        }
    }

    /// f_r in linear RGB at `rows` (wi, then wo) into `out`, by the f32 batch kernel
    /// ([`crate::batch`]), on this thread; 0 below the horizon. `scratch` holds the
    /// stored values, so a caller evaluating many blocks allocates it once.
    pub(crate) fn eval_rows(
        &self,
        rows: &[[f64; 6]],
        scratch: &mut Vec<f32>,
        out: &mut [[f64; 3]],
    ) {
        let k = self.stored_len();
        self.stored_rows(rows, scratch);
        match &self.values {
            Values::Rgb(_) => {
                for (o, v) in out.iter_mut().zip(scratch.chunks_exact(3)) {
                    *o = [v[0], v[1], v[2]].map(f64::from);
                }
            }
            Values::Spectral { to_srgb, .. } => {
                let mut spec = vec![0.0; k];
                for (o, v) in out.iter_mut().zip(scratch.chunks_exact(k)) {
                    spec.iter_mut().zip(v).for_each(|(s, &x)| *s = f64::from(x));
                    *o = [0, 1, 2].map(|c| cie::dot(&to_srgb[c], &spec));
                }
            }
        }
    }

    /// f_r in linear RGB at flat pairs (6 numbers a row: wi, then wo) into flat values
    /// (3 a row), by the f32 batch kernel (`batch.rs`, docs/rgl.md "Speed") in parallel over blocks of
    /// rows: what `fit-brdf eval --bsdf` runs. The pairs are taken as given (the callers
    /// check them); 0 below the horizon. Within the bound of the f64 path
    /// ([`Brdf::eval`]) and of Mitsuba (tests/batch.rs, tests/mitsuba.rs).
    pub fn eval_flat(&self, dirs: &[f64], out: &mut [f64]) {
        assert_eq!(dirs.len() / 6, out.len() / 3, "one row of values per pair");
        let (rows, out) = (dirs.as_chunks::<6>().0, out.as_chunks_mut::<3>().0);
        out.par_chunks_mut(EVAL_BLOCK)
            .zip(rows.par_chunks(EVAL_BLOCK))
            .for_each_init(Vec::new, |scratch, (out, rows)| {
                self.eval_rows(rows, scratch, out)
            });
    }

    /// [`eval_flat`](Self::eval_flat) with wi and wo in separate arrays (Python's
    /// `RglBsdf.eval`).
    pub fn eval_split(&self, wi: &[[f64; 3]], wo: &[[f64; 3]], out: &mut [[f64; 3]]) {
        assert!(
            wi.len() == wo.len() && wi.len() == out.len(),
            "one row per pair"
        );
        out.par_chunks_mut(EVAL_BLOCK)
            .zip(wi.par_chunks(EVAL_BLOCK).zip(wo.par_chunks(EVAL_BLOCK)))
            .for_each_init(Vec::new, |scratch, (out, (a, b))| {
                let rows: Vec<[f64; 6]> = a
                    .iter()
                    .zip(b)
                    .map(|(i, o)| [i[0], i[1], i[2], o[0], o[1], o[2]])
                    .collect();
                self.eval_rows(&rows, scratch, out);
            });
    }

    /// The stored values (3 channels, or one per wavelength of a spectral file:
    /// [`stored_len`](Self::stored_len) a pair) at flat pairs, times the Jacobian and
    /// over cos θo as [`eval_stored`](Self::eval_stored), by the f32 batch kernel in
    /// parallel; 0 below the horizon.
    pub fn eval_stored_flat(&self, dirs: &[f64], out: &mut [f64]) {
        let k = self.stored_len();
        assert_eq!(dirs.len() / 6, out.len() / k, "one row of values per pair");
        let rows = dirs.as_chunks::<6>().0;
        out.par_chunks_mut(EVAL_BLOCK * k)
            .zip(rows.par_chunks(EVAL_BLOCK))
            .for_each_init(Vec::new, |scratch: &mut Vec<f32>, (out, rows)| {
                self.stored_rows(rows, scratch);
                out.iter_mut()
                    .zip(scratch.iter())
                    .for_each(|(o, &v)| *o = f64::from(v));
            });
    }

    /// Number of values [`eval_stored`](Self::eval_stored) writes.
    pub fn stored_len(&self) -> usize {
        self.wavelengths().map_or(3, <[f32]>::len)
    }
}

impl Brdf for RglBsdf {
    /// f_r(wi, wo) in linear RGB: the stored channels of an RGB file, or a spectral
    /// file's spectrum converted to linear sRGB ([`cie`]).
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        let mut v = [0.0; 3];
        self.eval_rgb_into(wi, wo, &mut Vec::new(), &mut v);
        Rgb(v)
    }

    fn is_isotropic(&self) -> bool {
        self.isotropic
    }
}

/// The tables of a file, for the measured points ([`crate::MeasuredPoints`]): a view
/// that leaves the evaluation's fields private to this file.
pub(crate) struct Parts<'a> {
    pub phi_i: &'a [f32],
    pub theta_i: &'a [f32],
    pub ndf: &'a Warp2D,
    pub sigma: &'a Warp2D,
    pub vndf: &'a Warp2D,
    pub values: &'a Values,
    pub isotropic: bool,
    pub jacobian: bool,
}

impl RglBsdf {
    /// The tables of the file ([`Parts`]).
    pub(crate) fn parts(&self) -> Parts<'_> {
        Parts {
            phi_i: &self.phi_i,
            theta_i: &self.theta_i,
            ndf: &self.ndf,
            sigma: &self.sigma,
            vndf: &self.vndf,
            values: &self.values,
            isotropic: self.isotropic,
            jacobian: self.jacobian,
        }
    }
}
