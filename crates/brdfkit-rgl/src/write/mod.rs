//! Writing RGL-EPFL `.bsdf` files from anything brdfkit evaluates (a MERL table, a
//! model, an NBRDF: any [`Brdf`]), built the way Dupuy & Jakob 2018 ("An Adaptive
//! Parameterization for Efficient Material Acquisition and Rendering", SIGGRAPH Asia)
//! build the database's files, so Mitsuba 3's and pbrt-v4's `measured` materials render
//! them with importance sampling and no plugin:
//!
//! 1. the NDF from the source's retro-reflection by power iteration (Dupuy et al. 2015;
//!    `write/ndf.rs`) — for every source, models included: brdfkit has no typed accessor for a
//!    whole model's D (a model is often a sum of lobes), and the power iteration gives
//!    the D that the *whole* BRDF's retro-reflection implies, diffuse part included;
//! 2. σ(θ) = ∫ D(m) ⟨ω, m⟩₊ dm from that D (the `sigma` table);
//! 3. per θi slice, the VNDF table and the values on its warped grid (`write/tables.rs`):
//!    `rgb` (f · cos θo · 4σ/D, the `jacobian` flag set: Mitsuba's `eval`, which
//!    returns the stored value times D/(4σ), is f · cos θo by its contract), `luminance`,
//!    `valid`;
//! 4. `description`, `version` = 1.0, `phi_i` = \[0\] (isotropic), `theta_i`.
//!
//! Only isotropic sources are written (one φi slice), as the database's isotropic
//! files; an anisotropic source is refused ([`WriteError::Anisotropic`]).
//!
//! **Reciprocity.** The file stores f(wi, ·) per θi slice, wi being the light (Mitsuba's
//! `si.wi`): the value at (wi, wo) is the source's f(wi, wo) in that order. A
//! reciprocal source gives a file that is reciprocal up to the interpolation.
//!
//! **Negatives.** The file holds no negative value: a source value below 0 (an NBRDF
//! dips slightly below 0 near grazing) is stored as 0 and counted
//! ([`WriteReport::clamped`]).

pub(crate) mod ndf;
pub(crate) mod tables;

pub use ndf::PowerIteration;

use crate::error::RglError;
use crate::tensor::{self, Tensor, TensorData};
use crate::warp::Warp2D;
use brdfkit_core::{Brdf, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::path::Path;
use tables::{SliceSpec, SliceValues, spherical};

/// The highest elevation the source is evaluated at: a θi = 90° slice (the database
/// grids end there) is filled with the source at 89.5°, where a table or a model is
/// still defined (at exactly grazing incidence most return 0).
pub const MAX_EVAL_THETA_DEG: f64 = 89.5;

/// Resolution of the `ndf` and `sigma` tables (u_θ nodes) and of the VNDF grid, as in
/// the database's files.
pub const NDF_RES: usize = 128;
pub const VNDF_RES: usize = 128;

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
    /// The value grid, n × n (the database has 32 and 64); at least 2.
    pub grid: usize,
    /// What the file is of (the `description` field starts with it).
    pub description: String,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            theta_i: 8,
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
    /// The θi grid (radians).
    pub theta_i: Vec<f64>,
    /// Value nodes whose wo is above the horizon (`valid` bits set), and all nodes.
    pub valid: usize,
    pub nodes: usize,
    /// Negative source values stored as 0.
    pub clamped: usize,
}

/// Why a file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The source depends on the azimuth of wi; only isotropic files are written.
    #[error(
        "the source is anisotropic; the RGL writer builds isotropic files only (one phi_i slice)"
    )]
    Anisotropic,
    /// An option out of range.
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
        .map(|k| ndf::u2theta(k as f64 / (n - 1) as f64) as f32)
        .collect()
}

/// The fields of a `.bsdf` file of `source`, in the database's order, and what was
/// done.
pub fn build(
    source: &dyn Brdf,
    opts: &WriteOptions,
) -> Result<(Vec<Tensor>, WriteReport), WriteError> {
    check_options(source, opts)?;
    let (ndf_t, sigma_t, pi) = ndf_and_sigma(source)?;
    let theta_i = theta_grid(opts.theta_i);
    let slices = slices(source, opts, &ndf_t, &sigma_t, &theta_i)?;
    let n = opts.grid as u64;
    let nt = theta_i.len() as u64;
    let (vndf, values): (Vec<_>, Vec<_>) = slices.into_iter().unzip();
    let report = WriteReport {
        power_iteration: pi,
        theta_i: theta_i.iter().map(|&t| f64::from(t)).collect(),
        valid: values.iter().flat_map(|v| &v.valid).filter(|&&b| b).count(),
        nodes: values.len() * opts.grid * opts.grid,
        clamped: values.iter().map(|v| v.clamped).sum(),
    };
    let description = description(opts, &report);
    let r = NDF_RES as u64;
    let fields = vec![
        Tensor::new("version", &[2], TensorData::U32(vec![1, 0])),
        Tensor::new(
            "description",
            &[description.len() as u64],
            TensorData::U8(description.into_bytes()),
        ),
        Tensor::new("phi_i", &[1], TensorData::F32(vec![0.0])),
        Tensor::new("theta_i", &[nt], TensorData::F32(theta_i)),
        Tensor::new("sigma", &[2, r], TensorData::F32(sigma_t)),
        Tensor::new("ndf", &[2, r], TensorData::F32(ndf_t)),
        Tensor::new(
            "vndf",
            &[1, nt, VNDF_RES as u64, VNDF_RES as u64],
            TensorData::F32(vndf.concat()),
        ),
        Tensor::new(
            "luminance",
            &[1, nt, n, n],
            TensorData::F32(values.iter().flat_map(|v| v.luminance.clone()).collect()),
        ),
        Tensor::new(
            "rgb",
            &[1, nt, 3, n, n],
            TensorData::F32(values.iter().flat_map(|v| v.rgb.clone()).collect()),
        ),
        Tensor::new("jacobian", &[1], TensorData::U8(vec![1])),
        valid_field(&values),
    ];
    Ok((fields, report))
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

fn check_options(source: &dyn Brdf, opts: &WriteOptions) -> Result<(), WriteError> {
    if !source.is_isotropic() {
        return Err(WriteError::Anisotropic);
    }
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
    Ok(())
}

/// The direction at elevation θ (clamped to [`MAX_EVAL_THETA_DEG`]) in the xz plane.
fn eval_dir(theta: f64) -> (f64, Vec3) {
    let th = theta.min(MAX_EVAL_THETA_DEG.to_radians());
    (th, spherical(th, 0.0))
}

/// The `ndf` and `sigma` tables (2 identical φ rows × [`NDF_RES`] u_θ nodes, f32).
fn ndf_and_sigma(source: &dyn Brdf) -> Result<(Vec<f32>, Vec<f32>, PowerIteration), WriteError> {
    let us: Vec<f64> = (0..NDF_RES)
        .map(|k| k as f64 / (NDF_RES - 1) as f64)
        .collect();
    let mut retro = Vec::with_capacity(NDF_RES);
    for &u in &us {
        let (_, w) = eval_dir(ndf::u2theta(u));
        let f = source.eval(&w, &w);
        if !f.is_finite() {
            return Err(WriteError::NonFinite { wi: w, wo: w });
        }
        retro.push(tables::luminance(&f.map(|c| c.max(0.0))));
    }
    let (d, pi) = ndf::power_iteration(&retro, NDF_FLOOR);
    let sigma: Vec<f64> = us.par_iter().map(|&u| d.sigma(ndf::u2theta(u))).collect();
    let row = |v: &[f64]| -> Vec<f32> { v.iter().chain(v).map(|&x| x as f32).collect() };
    Ok((row(&d.values), row(&sigma), pi))
}

/// Each θi slice's VNDF table and value tables.
fn slices(
    source: &dyn Brdf,
    opts: &WriteOptions,
    ndf_t: &[f32],
    sigma_t: &[f32],
    theta_i: &[f32],
) -> Result<Vec<(Vec<f32>, SliceValues)>, WriteError> {
    // The reader's own interpolants of the written tables: the stored values divide by
    // exactly what it will multiply by.
    let ndf_w = Warp2D::new(ndf_t, NDF_RES, 2, vec![], false, false);
    let sigma_w = Warp2D::new(sigma_t, NDF_RES, 2, vec![], false, false);
    let d_u = |u: f64| ndf_w.eval([u, 0.0], &[]);
    let out: Vec<(Vec<f32>, SliceValues)> = theta_i
        .par_iter()
        .map(|&t| {
            let theta = f64::from(t);
            let (th_eval, _) = eval_dir(theta);
            // Reader: wi is folded to φi = −π, so u_φ(wi) = 0.
            let u_wi = [(theta * 2.0 / PI).sqrt(), 0.0];
            let sigma = sigma_w.eval(u_wi, &[]);
            let vndf = tables::vndf_slice(&d_u, sigma, th_eval, VNDF_RES, VNDF_FLOOR);
            let warp = Warp2D::new(
                &vndf,
                VNDF_RES,
                VNDF_RES,
                vec![vec![0.0], vec![t]],
                true,
                true,
            );
            let jacobian = |um: [f64; 2]| ndf_w.eval(um, &[]) / (4.0 * sigma);
            let values = tables::values_slice(&SliceSpec {
                source,
                vndf: &warp,
                params: [-PI, theta],
                theta_eval: th_eval,
                jacobian: &jacobian,
                n: opts.grid,
            });
            (vndf, values)
        })
        .collect();
    if let Some((wi, wo)) = out.iter().find_map(|(_, v)| v.non_finite) {
        return Err(WriteError::NonFinite { wi, wo });
    }
    Ok(out)
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
        "a brdfkit source".to_string()
    } else {
        opts.description.clone()
    };
    format!(
        "{what}; written by brdfkit {} (brdfkit-rgl): NDF from the retro-reflection by power \
         iteration (Dupuy et al. 2015, {} steps), {} theta_i slices, {} x {} values, \
         {} of {} nodes above the horizon, {} negative source values stored as 0",
        env!("CARGO_PKG_VERSION"),
        r.power_iteration.iterations,
        opts.theta_i,
        opts.grid,
        opts.grid,
        r.valid,
        r.nodes,
        r.clamped
    )
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
                    let m = spherical(ndf::u2theta(um[0]), (2.0 * um[1] - 1.0) * PI);
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

    /// An anisotropic source, bad options and a NaN source are typed errors.
    #[test]
    fn refusals() {
        let o = WriteOptions::default();
        assert!(matches!(build(&Tilted, &o), Err(WriteError::Anisotropic)));
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
