//! Writing RGL-EPFL `.bsdf` files from anything brdfkit evaluates (a MERL table, a
//! model, an NBRDF, a `.bsdf` file: any [`Brdf`]), built the way Dupuy & Jakob 2018 ("An
//! Adaptive Parameterization for Efficient Material Acquisition and Rendering",
//! SIGGRAPH Asia) build the database's files, so Mitsuba 3's and pbrt-v4's `measured`
//! materials render them with importance sampling and no plugin:
//!
//! 1. the NDF from the source's retro-reflection by power iteration (Dupuy et al. 2015;
//!    `write/ndf.rs`) — for every source, models included: brdfkit has no typed accessor for a
//!    whole model's D (a model is often a sum of lobes), and the power iteration gives
//!    the D that the *whole* BRDF's retro-reflection implies, diffuse part included;
//! 2. σ(ω) = ∫ D(m) ⟨ω, m⟩₊ dm from that D (the `sigma` table);
//! 3. per (φi, θi) slice, the VNDF table and the values on its warped grid
//!    (`write/tables.rs`): `rgb` (f · cos θo · 4σ/D, the `jacobian` flag set: Mitsuba's
//!    `eval`, which returns the stored value times D/(4σ), is f · cos θo by its
//!    contract), `luminance`, `valid`;
//! 4. `description`, `version` = 1.0, `phi_i`, `theta_i`.
//!
//! **Isotropic sources** ([`Brdf::is_isotropic`]) give one φi slice (`phi_i` = \[0\]), a
//! 1-D NDF (two identical u_φ rows) and u_φ relative to φi, as the database's isotropic
//! files. **Anisotropic sources** give [`WriteOptions::phi_i`] slices over the smallest
//! φi range their symmetry allows (`write/symmetry.rs`: a quarter, a half or the whole
//! turn, the reader's fold `reduction` 4, 2 or 1), a 2-D NDF and σ over the half
//! vector's absolute azimuth (rows) and u_θ (columns) by the 2-D power iteration
//! (`ndf::power_iteration_2d`), and per slice the VNDF and values with u_φ absolute;
//! both go through the same code, an isotropic file being the case of one φi slice.
//!
//! **Reciprocity.** The file stores f(wi, ·) per incident slice, wi being the light
//! (Mitsuba's `si.wi`): the value at (wi, wo) is the source's f(wi, wo) in that order. A
//! reciprocal source gives a file that is reciprocal up to the interpolation.
//!
//! **Negatives.** The file holds no negative value: a source value below 0 (an NBRDF
//! dips slightly below 0 near grazing) is stored as 0 and counted
//! ([`WriteReport::clamped`]).

pub(crate) mod ndf;
pub mod symmetry;
pub(crate) mod tables;

pub use ndf::PowerIteration;
pub use symmetry::{Symmetry, symmetry};

use crate::bsdf::{fold_pair, incident_params, phi2u, theta2u, u2theta};
use crate::error::RglError;
use crate::tensor::{self, Tensor, TensorData};
use crate::warp::Warp2D;
use brdfkit_core::direction::spherical;
use brdfkit_core::{Brdf, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::path::Path;
use tables::{SliceSpec, SliceValues};

/// The highest elevation the source is evaluated at: a θi = 90° slice (the database
/// grids end there) is filled with the source at 89.5°, where a table or a model is
/// still defined (at exactly grazing incidence most return 0).
pub const MAX_EVAL_THETA_DEG: f64 = 89.5;

/// Resolution of the `ndf` and `sigma` tables (u_θ nodes) and of the VNDF grid, as in
/// the database's files.
pub const NDF_RES: usize = 128;
pub const VNDF_RES: usize = 128;

/// u_φ rows of an anisotropic file's `ndf` and `sigma` tables: 64 intervals of 5.6°
/// over the full turn (the NDF is not folded: m takes every azimuth), a row on each
/// tangent-frame axis (multiples of 90°).
pub const NDF_PHI_RES: usize = 65;

/// The φi spacing of the default slice count of an anisotropic file (degrees): 5, 9 or
/// 17 slices over a quarter, half or whole turn (docs/rgl.md, "Anisotropic files", for
/// the measurement behind it).
pub const DEFAULT_PHI_STEP_DEG: f64 = 22.5;

/// The fewest and the most φi slices of an anisotropic file: readers take a file of one
/// or two for isotropic (`measured.cpp`: `m_isotropic = phi_i.shape[0] <= 2`).
pub const MIN_PHI_I: usize = 3;
pub const MAX_PHI_I: usize = 64;

/// Floors relative to the maximum: of D (so the stored values f · 4σ/D stay finite)
/// and of each VNDF slice (so each of its rows can be inverted).
const NDF_FLOOR: f64 = 1e-6;
const VNDF_FLOOR: f64 = 1e-5;

/// How to write a file.
#[derive(Clone, Debug, PartialEq)]
pub struct WriteOptions {
    /// Number of θi slices, at θ_k = (π/2)(k/(N − 1))² (uniform in the format's
    /// u = √(2θ/π), from 0 to 90° as the database's 8); at least 2.
    pub theta_i: usize,
    /// Number of φi slices of an anisotropic source, uniform over the stored range (both
    /// ends included; 3 to [`MAX_PHI_I`]: Mitsuba and brdfkit's reader take a file of one
    /// or two φi slices for isotropic); `None`: one per [`DEFAULT_PHI_STEP_DEG`].
    /// Refused for an isotropic source (its file has `phi_i` = \[0\]).
    pub phi_i: Option<usize>,
    /// The value grid, n × n (the database has 32 and 64); at least 2.
    pub grid: usize,
    /// What the file is of (the `description` field starts with it).
    pub description: String,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            theta_i: 8,
            phi_i: None,
            grid: 32,
            description: String::new(),
        }
    }
}

/// What the writer did.
#[derive(Clone, Debug, PartialEq)]
pub struct WriteReport {
    /// The NDF's power iteration.
    pub power_iteration: PowerIteration,
    /// The source's symmetry, which sets the stored φi range (the reader's fold).
    pub symmetry: Symmetry,
    /// The φi grid (radians; \[0\] for an isotropic source).
    pub phi_i: Vec<f64>,
    /// The θi grid (radians).
    pub theta_i: Vec<f64>,
    /// Value nodes whose wo is above the horizon (`valid` bits set).
    pub valid: usize,
    /// All value nodes: slices × grid².
    pub nodes: usize,
    /// Negative source values stored as 0.
    pub clamped: usize,
}

/// Why a file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// An option out of range, or one that does not apply to the source.
    #[error("{0}")]
    Options(String),
    /// The source returned NaN or infinity.
    #[error(
        "the source is not finite at wi = ({:.4}, {:.4}, {:.4}), wo = ({:.4}, {:.4}, {:.4})",
        wi.x, wi.y, wi.z, wo.x, wo.y, wo.z
    )]
    NonFinite { wi: Vec3, wo: Vec3 },
    /// Writing the file failed.
    #[error(transparent)]
    Write(#[from] RglError),
}

/// The θi grid of `n` slices: uniform in u = √(2θ/π) from 0 to π/2.
pub fn theta_grid(n: usize) -> Vec<f32> {
    (0..n)
        .map(|k| u2theta(k as f64 / (n - 1) as f64) as f32)
        .collect()
}

/// The φi grid of a source of symmetry `sym`: \[0\] if isotropic, else `n` slices
/// uniform over [`Symmetry::phi_range`] (`None`: the default count).
pub fn phi_grid(sym: Symmetry, n: Option<usize>) -> Vec<f32> {
    if sym == Symmetry::Isotropic {
        return vec![0.0];
    }
    let (lo, hi) = sym.phi_range();
    let n = n.unwrap_or_else(|| default_phi_i(sym));
    (0..n)
        .map(|k| (lo + (hi - lo) * k as f64 / (n - 1) as f64) as f32)
        .collect()
}

/// The default φi slice count of an anisotropic source: one per
/// [`DEFAULT_PHI_STEP_DEG`] over its stored range, both ends included.
pub fn default_phi_i(sym: Symmetry) -> usize {
    let (lo, hi) = sym.phi_range();
    1 + ((hi - lo).to_degrees() / DEFAULT_PHI_STEP_DEG).round() as usize
}

/// The `ndf` and `sigma` tables (rows u_φ × [`NDF_RES`] columns u_θ, f32, the same
/// shape) and the power iteration that made them.
struct NdfTables {
    ndf: Vec<f32>,
    sigma: Vec<f32>,
    rows: usize,
    power_iteration: PowerIteration,
}

/// The fields of a `.bsdf` file of `source`, in the database's order, and what was
/// done.
pub fn build(
    source: &dyn Brdf,
    opts: &WriteOptions,
) -> Result<(Vec<Tensor>, WriteReport), WriteError> {
    let sym = check_options(source, opts)?;
    let tables = if sym == Symmetry::Isotropic {
        ndf_and_sigma(source)?
    } else {
        ndf_and_sigma_2d(source)?
    };
    let phi_i = phi_grid(sym, opts.phi_i);
    let theta_i = theta_grid(opts.theta_i);
    let slices = slices(source, opts, &tables, &phi_i, &theta_i, sym)?;
    let (vndf, values): (Vec<_>, Vec<_>) = slices.into_iter().unzip();
    let report = WriteReport {
        power_iteration: tables.power_iteration,
        symmetry: sym,
        phi_i: phi_i.iter().map(|&p| f64::from(p)).collect(),
        theta_i: theta_i.iter().map(|&t| f64::from(t)).collect(),
        valid: values.iter().flat_map(|v| &v.valid).filter(|&&b| b).count(),
        nodes: values.len() * opts.grid * opts.grid,
        clamped: values.iter().map(|v| v.clamped).sum(),
    };
    let description = description(opts, &report);
    let fields = fields(
        description,
        phi_i,
        theta_i,
        tables,
        &vndf,
        &values,
        opts.grid,
    );
    Ok((fields, report))
}

/// The fields in the database's order; `vndf` and `values` per slice, (φi, θi) order.
fn fields(
    description: String,
    phi_i: Vec<f32>,
    theta_i: Vec<f32>,
    t: NdfTables,
    vndf: &[Vec<f32>],
    values: &[SliceValues],
    grid: usize,
) -> Vec<Tensor> {
    let (np, nt, n) = (phi_i.len() as u64, theta_i.len() as u64, grid as u64);
    let (r, rows) = (NDF_RES as u64, t.rows as u64);
    vec![
        Tensor::new("version", &[2], TensorData::U32(vec![1, 0])),
        Tensor::new(
            "description",
            &[description.len() as u64],
            TensorData::U8(description.into_bytes()),
        ),
        Tensor::new("phi_i", &[np], TensorData::F32(phi_i)),
        Tensor::new("theta_i", &[nt], TensorData::F32(theta_i)),
        Tensor::new("sigma", &[rows, r], TensorData::F32(t.sigma)),
        Tensor::new("ndf", &[rows, r], TensorData::F32(t.ndf)),
        Tensor::new(
            "vndf",
            &[np, nt, VNDF_RES as u64, VNDF_RES as u64],
            TensorData::F32(vndf.concat()),
        ),
        Tensor::new(
            "luminance",
            &[np, nt, n, n],
            TensorData::F32(values.iter().flat_map(|v| v.luminance.clone()).collect()),
        ),
        Tensor::new(
            "rgb",
            &[np, nt, 3, n, n],
            TensorData::F32(values.iter().flat_map(|v| v.rgb.clone()).collect()),
        ),
        Tensor::new("jacobian", &[1], TensorData::U8(vec![1])),
        valid_field(values),
    ]
}

/// Builds the file of `source` and writes it to `path` atomically.
pub fn write(
    source: &dyn Brdf,
    opts: &WriteOptions,
    path: &Path,
) -> Result<WriteReport, WriteError> {
    let (fields, report) = build(source, opts)?;
    tensor::write(&fields, path)?;
    Ok(report)
}

/// Checks the options against each other and the source; the source's symmetry.
fn check_options(source: &dyn Brdf, opts: &WriteOptions) -> Result<Symmetry, WriteError> {
    if opts.theta_i < 2 || opts.theta_i > 1024 {
        return Err(WriteError::Options(format!(
            "{} theta_i slices: need 2 to 1024",
            opts.theta_i
        )));
    }
    if opts.grid < 2 || opts.grid > 1024 {
        return Err(WriteError::Options(format!(
            "a {0} x {0} value grid: need 2 to 1024",
            opts.grid
        )));
    }
    if let Some(n) = opts.phi_i {
        if source.is_isotropic() {
            return Err(WriteError::Options(format!(
                "{n} phi_i slices for an isotropic source: its file has one (phi_i = [0]); \
                 phi_i slices apply to anisotropic sources only"
            )));
        }
        if !(MIN_PHI_I..=MAX_PHI_I).contains(&n) {
            return Err(WriteError::Options(format!(
                "{n} phi_i slices: need {MIN_PHI_I} to {MAX_PHI_I} (both ends of the stored \
                 range; a file of one or two is read as isotropic)"
            )));
        }
    }
    symmetry(source)
}

/// The direction at elevation θ (clamped to [`MAX_EVAL_THETA_DEG`]) in the xz plane.
fn eval_dir(theta: f64) -> (f64, Vec3) {
    let th = theta.min(MAX_EVAL_THETA_DEG.to_radians());
    (th, spherical(th, 0.0))
}

/// The luminance of the source's retro-reflection f(ω, ω) at ω (negatives as 0).
fn retro(source: &dyn Brdf, w: Vec3) -> Result<f64, WriteError> {
    let f = source.eval(&w, &w);
    if !f.is_finite() {
        return Err(WriteError::NonFinite { wi: w, wo: w });
    }
    Ok(tables::luminance(&f.map(|c| c.max(0.0))))
}

/// The tables of an isotropic source: 2 identical φ rows × [`NDF_RES`] u_θ nodes.
fn ndf_and_sigma(source: &dyn Brdf) -> Result<NdfTables, WriteError> {
    let us: Vec<f64> = (0..NDF_RES)
        .map(|k| k as f64 / (NDF_RES - 1) as f64)
        .collect();
    let retro = us
        .iter()
        .map(|&u| retro(source, eval_dir(u2theta(u)).1))
        .collect::<Result<Vec<f64>, _>>()?;
    let (d, pi) = ndf::power_iteration(&retro, NDF_FLOOR);
    let sigma: Vec<f64> = us.par_iter().map(|&u| d.sigma(u2theta(u))).collect();
    let row = |v: &[f64]| -> Vec<f32> { v.iter().chain(v).map(|&x| x as f32).collect() };
    Ok(NdfTables {
        ndf: row(&d.values),
        sigma: row(&sigma),
        rows: 2,
        power_iteration: pi,
    })
}

/// The tables of an anisotropic source: [`NDF_PHI_RES`] rows over the absolute u_φ ×
/// [`NDF_RES`] u_θ columns, by the 2-D power iteration.
fn ndf_and_sigma_2d(source: &dyn Brdf) -> Result<NdfTables, WriteError> {
    let (rows, cols) = (NDF_PHI_RES, NDF_RES);
    let mut retro_v = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        // The last row is φ = π, the first again: the same directions.
        let phi = (2.0 * (r % (rows - 1)) as f64 / (rows - 1) as f64 - 1.0) * PI;
        for c in 0..cols {
            let th = u2theta(c as f64 / (cols - 1) as f64);
            let (th, _) = eval_dir(th);
            retro_v.push(retro(source, spherical(th, phi))?);
        }
    }
    let (d, sigma, pi) = ndf::power_iteration_2d(&retro_v, rows, cols, NDF_FLOOR);
    let f32s = |v: &[f64]| -> Vec<f32> { v.iter().map(|&x| x as f32).collect() };
    Ok(NdfTables {
        ndf: f32s(&d.values),
        sigma: f32s(&sigma.values),
        rows,
        power_iteration: pi,
    })
}

/// One (φi, θi) slice's incident geometry: the direction the source is evaluated at,
/// the reader's parameters (φi, θi) of the slice's own direction and σ's lookup
/// coordinates u(wi).
struct Incidence {
    wi: Vec3,
    params: [f64; 2],
    u_wi: [f64; 2],
}

/// The geometry of slice (φ, θ). Isotropic: wi at φ = 0 (u_φ is relative; the reader
/// folds wi to φi = −π, where σ is read at u_φ = 0). Anisotropic: wi at the slice's φi
/// (the f64 −π at the range's start: the f32 grid's −3.14159274 has sin > 0 and would
/// be folded onto the other side), exact zeros on the stored side (−0) and folded as
/// the reader folds, so the parameters are those the reader computes for it
/// (`points.rs`, `slice`, builds the measured points the same way).
fn incidence(sym: Symmetry, phi: f32, theta: f32) -> Incidence {
    let theta = f64::from(theta);
    let (th_eval, wi_iso) = eval_dir(theta);
    if sym == Symmetry::Isotropic {
        return Incidence {
            wi: wi_iso,
            params: [-PI, theta],
            u_wi: [(theta * 2.0 / PI).sqrt(), 0.0],
        };
    }
    let phi = f64::from(phi).max(-PI);
    let stored = |th: f64| {
        let mut w = spherical(th, phi);
        let side = |c: f64| if c == 0.0 { -0.0 } else { c };
        (w.x, w.y) = (side(w.x), side(w.y));
        fold_pair(sym.reduction(), w, w).0
    };
    let params = incident_params(&stored(theta));
    Incidence {
        wi: stored(th_eval),
        params,
        u_wi: [theta2u(params[1]), phi2u(params[0])],
    }
}

/// Each (φi, θi) slice's VNDF table and value tables, φi-major.
///
/// The VNDF tables come first, and the values are placed through the warp of all of
/// them at the reader's own parameters of each slice's direction, exactly as the reader
/// interpolates it: the reader's (φi, θi), computed from a direction, differ from the
/// f32 grid by ~1e-8 rad and mix in a sliver of the neighbouring slices, which a
/// slice's own warp alone would miss (a shift of wo by ~1e-8, 1e-4 of f · cos θo / cos θo
/// where wo is 1e-4 above the horizon).
fn slices(
    source: &dyn Brdf,
    opts: &WriteOptions,
    t: &NdfTables,
    phi_i: &[f32],
    theta_i: &[f32],
    sym: Symmetry,
) -> Result<Vec<(Vec<f32>, SliceValues)>, WriteError> {
    // The reader's own interpolants of the written tables: the stored values divide by
    // exactly what it will multiply by.
    let ndf_w = Warp2D::new(&t.ndf, NDF_RES, t.rows, vec![], false, false);
    let sigma_w = Warp2D::new(&t.sigma, NDF_RES, t.rows, vec![], false, false);
    let iso = sym == Symmetry::Isotropic;
    let d_u = |u: [f64; 2]| ndf_w.eval(if iso { [u[0], 0.0] } else { u }, &[]);
    let grid: Vec<(Incidence, f64)> = phi_i
        .iter()
        .flat_map(|&p| theta_i.iter().map(move |&t| incidence(sym, p, t)))
        .map(|inc| {
            let sigma = sigma_w.eval(inc.u_wi, &[]);
            (inc, sigma)
        })
        .collect();
    let vndf: Vec<Vec<f32>> = grid
        .par_iter()
        .map(|(inc, sigma)| tables::vndf_slice(&d_u, *sigma, inc.wi, VNDF_RES, VNDF_FLOOR))
        .collect();
    let warp = Warp2D::new(
        &vndf.concat(),
        VNDF_RES,
        VNDF_RES,
        vec![phi_i.to_vec(), theta_i.to_vec()],
        true,
        true,
    );
    let values: Vec<SliceValues> = grid
        .par_iter()
        .map(|(inc, sigma)| {
            let jacobian = |um: [f64; 2]| ndf_w.eval(um, &[]) / (4.0 * sigma);
            tables::values_slice(&SliceSpec {
                source,
                vndf: &warp,
                params: inc.params,
                wi: inc.wi,
                jacobian: &jacobian,
                n: opts.grid,
            })
        })
        .collect();
    if let Some((wi, wo)) = values.iter().find_map(|v| v.non_finite) {
        return Err(WriteError::NonFinite { wi, wo });
    }
    Ok(vndf.into_iter().zip(values).collect())
}

/// `valid`: one bit per value node over (φi, θi, y, x), packed most significant bit
/// first (as `numpy.packbits`).
fn valid_field(values: &[SliceValues]) -> Tensor {
    let bits: Vec<bool> = values
        .iter()
        .flat_map(|v| v.valid.iter().copied())
        .collect();
    let bytes: Vec<u8> = bits
        .chunks(8)
        .map(|c| {
            c.iter()
                .enumerate()
                .fold(0u8, |b, (i, &set)| b | (u8::from(set) << (7 - i)))
        })
        .collect();
    Tensor::new("valid", &[bytes.len() as u64], TensorData::U8(bytes))
}

/// The `description`: what the file is of, what wrote it and how.
fn description(opts: &WriteOptions, r: &WriteReport) -> String {
    let what = if opts.description.is_empty() {
        "a brdfkit source"
    } else {
        &opts.description
    };
    format!(
        "{what}; written by brdfkit {} (brdfkit-rgl): {}",
        env!("CARGO_PKG_VERSION"),
        r.how(opts)
    )
}

impl WriteReport {
    /// How the file was built from its source, in words: what the `description` field
    /// says after "written by", and what `fit-brdf export` tells the user.
    pub fn how(&self, opts: &WriteOptions) -> String {
        let phi = if self.symmetry == Symmetry::Isotropic {
            String::new()
        } else {
            format!(
                "anisotropic ({}, {} slices), 2-D ",
                self.symmetry.describe(),
                self.phi_i.len()
            )
        };
        format!(
            "{phi}NDF from the retro-reflection by power iteration (Dupuy et al. 2015, {} \
             steps), {} theta_i slices, {} x {} values, {} of {} nodes above the horizon, {} \
             negative source values stored as 0",
            self.power_iteration.iterations,
            opts.theta_i,
            opts.grid,
            opts.grid,
            self.valid,
            self.nodes,
            self.clamped
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RglBsdf;
    use crate::tensor::{TensorFile, encode};
    use brdfkit_core::Rgb;

    /// A diffuse base plus a Blinn-Phong lobe: smooth, reciprocal, isotropic.
    struct Lobe {
        exponent: f64,
        shift: f64,
    }

    impl Brdf for Lobe {
        fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                return Rgb::ZERO;
            }
            let h = (wi + wo).normalize();
            let spec = (self.exponent + 2.0) / (8.0 * PI) * h.z.powf(self.exponent);
            Rgb([0.2, 0.1, 0.05].map(|k| k / PI + spec * (1.0 + self.shift * k)))
        }
    }

    impl Lobe {
        /// The lobe the writer's tests write.
        const SHARP: Lobe = Lobe {
            exponent: 40.0,
            shift: 0.5,
        };
    }

    /// The fields and report of [`Lobe::SHARP`] written with `theta_i` slices on a
    /// `grid`² value grid.
    fn lobe_file(theta_i: usize, grid: usize, description: &str) -> (Vec<Tensor>, WriteReport) {
        let opts = WriteOptions {
            theta_i,
            grid,
            description: description.into(),
            ..WriteOptions::default()
        };
        build(&Lobe::SHARP, &opts).unwrap()
    }

    struct Tilted;
    impl Brdf for Tilted {
        fn eval(&self, _: &Vec3, _: &Vec3) -> Rgb {
            Rgb::splat(0.1)
        }
        fn is_isotropic(&self) -> bool {
            false
        }
    }

    struct Nan;
    impl Brdf for Nan {
        fn eval(&self, wi: &Vec3, _: &Vec3) -> Rgb {
            Rgb::splat(if wi.z < 0.5 { f64::NAN } else { 0.1 })
        }
    }

    fn read_back(fields: &[Tensor]) -> RglBsdf {
        let bytes = encode(fields, Path::new("mem.bsdf")).unwrap();
        RglBsdf::from_tensor(&TensorFile::from_bytes(bytes, "mem.bsdf").unwrap()).unwrap()
    }

    fn field<'a>(fields: &'a [Tensor], name: &str) -> &'a [f32] {
        match &fields.iter().find(|f| f.name == name).unwrap().data {
            TensorData::F32(v) => v,
            _ => panic!("{name} is not f32"),
        }
    }

    /// At the measurement positions (every value node of every slice but the 90° one,
    /// wo above 1°), the file read back by the reader is the source's f (the file holds
    /// f · cos θo, the reader divides by cos θo): the writer inverts exactly the warp the
    /// reader applies.
    #[test]
    fn nodes_read_back_exactly() {
        let src = Lobe::SHARP;
        let (fields, report) = lobe_file(6, 16, "test lobe");
        assert_eq!(report.nodes, 6 * 16 * 16);
        assert_eq!(report.clamped, 0);
        let bsdf = read_back(&fields);
        assert!(
            bsdf.description()
                .starts_with("test lobe; written by brdfkit")
        );
        let theta = field(&fields, "theta_i").to_vec();
        let vndf = field(&fields, "vndf");
        let (mut checked, mut worst) = (0, 0.0f64);
        for (k, &t) in theta.iter().enumerate().take(theta.len() - 1) {
            let slice = &vndf[k * VNDF_RES * VNDF_RES..(k + 1) * VNDF_RES * VNDF_RES];
            let warp = Warp2D::new(slice, VNDF_RES, VNDF_RES, vec![], true, true);
            let wi = spherical(f64::from(t), 0.0);
            for y in 0..16 {
                for x in 0..16 {
                    let s = [x as f64 / 15.0, y as f64 / 15.0];
                    let um = tables::forward(&warp, s, &[]);
                    let m = spherical(u2theta(um[0]), (2.0 * um[1] - 1.0) * PI);
                    let wo = m * (2.0 * wi.dot(&m)) - wi;
                    if wo.z < 1f64.to_radians().sin() {
                        continue;
                    }
                    let (got, want) = (bsdf.eval(&wi, &wo), src.eval(&wi, &wo));
                    for c in 0..3 {
                        let w = want.0[c];
                        let rel = (got.0[c] - w).abs() / w;
                        worst = worst.max(rel);
                    }
                    checked += 1;
                }
            }
        }
        assert!(checked > 600, "{checked} nodes checked");
        assert!(worst < 1e-5, "worst relative error at the nodes {worst:e}");
    }

    /// Every node whose `valid` bit is clear (wo on or below the horizon) stores 0 in
    /// every channel, and every set one a positive value: f · cos θo at the horizon is 0,
    /// and anything else there, divided by the D of the grid's last column (~1e-6 of its
    /// maximum), leaks into the valid part of the last cell (docs/rgl.md, "Near the
    /// horizon").
    #[test]
    fn nodes_below_the_horizon_store_zero() {
        let (fields, report) = lobe_file(5, 12, "");
        let rgb = field(&fields, "rgb");
        let TensorData::U8(bits) = &fields.iter().find(|f| f.name == "valid").unwrap().data else {
            panic!("valid is not u8");
        };
        let nn = 12 * 12;
        let (mut zero, mut valid) = (0, 0);
        for node in 0..5 * nn {
            let (slice, k) = (node / nn, node % nn);
            let set = bits[node / 8] & (0x80 >> (node % 8)) != 0;
            for c in 0..3 {
                let v = rgb[(slice * 3 + c) * nn + k];
                if set {
                    assert!(v > 0.0, "valid node {node} channel {c}: {v}");
                } else {
                    assert_eq!(v, 0.0, "node {node} below the horizon, channel {c}");
                }
            }
            valid += usize::from(set);
            zero += usize::from(!set);
        }
        assert_eq!(valid, report.valid);
        assert!(zero > 5 * 12, "{zero} nodes below the horizon");
    }

    /// φi slices for an isotropic source or out of range, bad options and a NaN source
    /// are typed errors.
    #[test]
    fn refusals() {
        let o = WriteOptions::default();
        for n in [1, 2, MAX_PHI_I + 1] {
            let bad = WriteOptions {
                phi_i: Some(n),
                ..o.clone()
            };
            assert!(matches!(build(&Tilted, &bad), Err(WriteError::Options(_))));
        }
        let iso = WriteOptions {
            phi_i: Some(5),
            ..o.clone()
        };
        let e = build(&Lobe::SHARP, &iso).unwrap_err();
        assert!(e.to_string().contains("isotropic"), "{e}");
        let bad = WriteOptions {
            grid: 1,
            ..o.clone()
        };
        let src = Lobe {
            exponent: 10.0,
            shift: 0.0,
        };
        assert!(matches!(build(&src, &bad), Err(WriteError::Options(_))));
        let bad = WriteOptions {
            theta_i: 1,
            ..o.clone()
        };
        assert!(matches!(build(&src, &bad), Err(WriteError::Options(_))));
        assert!(matches!(build(&Nan, &o), Err(WriteError::NonFinite { .. })));
    }

    /// `valid` is packed most significant bit first, one bit per node.
    #[test]
    fn valid_bits_are_packed_msb_first() {
        let v = SliceValues {
            rgb: vec![],
            luminance: vec![],
            valid: vec![true, false, false, false, false, false, false, true, true],
            clamped: 0,
            non_finite: None,
        };
        let t = valid_field(&[v]);
        assert_eq!(t.shape, vec![2]);
        assert_eq!(t.data, TensorData::U8(vec![0b1000_0001, 0b1000_0000]));
    }
}
