//! Comparison of two representations of one material: tables, models and neural BRDFs.
//!
//! A is the reference, B is measured against it, on A's valid cells:
//! - every loss of the fitter, per channel and overall, with B in the place of the
//!   model and A in the place of the measurement (the cells, weights and cutoff of a
//!   fit: [`brdfkit_fit::CellFilter`]); for a model B these are
//!   [`brdfkit_fit::score()`]'s figures bit for bit;
//! - the largest relative differences |B − A| / A (A > 0) with the cell and its angles;
//! - the sphere renders of A and B under the report's two lightings, same seed and
//!   exposure, and their difference images ([`crate::html::renders`]).
//!
//! Files are told apart by their content, never their names
//! ([`brdfkit_rgl::InputKind`], the rule every reader shares): a model description, an
//! RGL-EPFL `.bsdf` or a MERL table; a path that is not a file is an NBRDF's stem.
//!
//! The grid: a table A is its own; a model, an NBRDF or a `.bsdf` A is tabulated at the cells'
//! angles on B's grid when B is a table, else on [`CompareOptions::dims`]. B is
//! brought onto A's grid: a model is evaluated at the cells' directions, an NBRDF
//! or a `.bsdf` tabulated (a `.bsdf` as the weighted mean of both orders of each pair, as
//! `RglBsdf::to_table` writes it: docs/rgl.md), a table of the same dims taken cell for cell; a table of other dims is
//! refused ([`CompareError::GridMismatch`]) unless [`CompareOptions::resample`] names
//! the lookup to resample it with ([`MerlTable::resample`]). Cells missing in B are
//! left out and counted.

use crate::html::error::ReportError;
use crate::html::renders::{Lighting, RenderOptions, RenderSet, Shown, render_set_of};
use brdfkit_core::{ModelError, Rgb};
use brdfkit_fit::data::PASS_CHUNK_CELLS;
use brdfkit_fit::{
    CellFilter, FitConfig, FitData, FitError, Fitted, LossReport, ScoreError, Weighting,
    losses_of_values,
};
use brdfkit_merl::{Dims, Lookup, MerlError, MerlTable, TableError, cell_directions};
use brdfkit_nbrdf::{Nbrdf, NbrdfError};
use brdfkit_rgl::{InputKind, RglBsdf, RglError};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;

/// Why two representations cannot be compared. Every variant names the file(s).
#[derive(Debug, Error)]
pub enum CompareError {
    /// A file that is none of the three kinds.
    #[error(
        "{}: not a MERL table, a model description (JSON), an RGL-EPFL .bsdf or an NBRDF (DIR/NAME, the stem of NAME_fc1.npy ...)",
        path.display()
    )]
    Unrecognised {
        /// The path given.
        path: PathBuf,
    },
    /// A table that cannot be read.
    #[error(transparent)]
    Table(#[from] MerlError),
    /// A model file that cannot be read, parsed or built.
    #[error("{}: {source}", path.display())]
    ModelFile {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: ModelFileError,
    },
    /// A model that cannot be compared with a table (anisotropic).
    #[error("{}: {source}", path.display())]
    Incompatible {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: ScoreError,
    },
    /// A file that cannot be opened or read to tell its kind.
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A `.bsdf` file that cannot be read (the error names the file and the field).
    #[error(transparent)]
    Rgl(#[from] RglError),
    /// An NBRDF that cannot be loaded or tabulated (the error names its files).
    #[error(transparent)]
    Nbrdf(#[from] NbrdfError),
    /// A model whose values cannot be stored in a table (negative or not finite).
    #[error("{}: tabulating on a {dims} grid: {source}", path.display())]
    Tabulate {
        /// The file.
        path: PathBuf,
        /// The grid.
        dims: Dims,
        /// The table's message.
        #[source]
        source: TableError,
    },
    /// Two tables on different grids, and no resampling asked for.
    #[error(
        "{} is a {a_dims} grid and {} a {b_dims} grid: the cells differ; resample B onto A's grid explicitly (the `resample` setting: nearest or linear)",
        a.display(), b.display()
    )]
    GridMismatch {
        /// A's file.
        a: PathBuf,
        /// A's dims.
        a_dims: Dims,
        /// B's file.
        b: PathBuf,
        /// B's dims.
        b_dims: Dims,
    },
    /// No cell left to compare (A has none, the cutoff removes all, or B misses all).
    #[error("{} against {}: {reason}", b.display(), a.display())]
    NoCells {
        /// A's file.
        a: PathBuf,
        /// B's file.
        b: PathBuf,
        /// Why.
        reason: String,
    },
    /// A render failed (a runtime failure, not the input's fault).
    #[error("render: {0}")]
    Render(#[from] ReportError),
}

/// Why a model file cannot be used.
#[derive(Debug, Error)]
pub enum ModelFileError {
    /// The file cannot be read.
    #[error("cannot read the model description: {0}")]
    Io(#[from] std::io::Error),
    /// Not JSON.
    #[error("not valid JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// Not a model the library knows, or a bad parameter.
    #[error(transparent)]
    Model(#[from] ModelError),
}

impl CompareError {
    /// True when the input is at fault (every variant but a failed render).
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, CompareError::Render(_))
    }
}

/// What a representation is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    /// A MERL table.
    Table,
    /// An analytic model (or one per channel).
    Model,
    /// A neural BRDF.
    Nbrdf,
    /// An RGL-EPFL `.bsdf` measurement.
    RglBsdf,
}

/// A representation as loaded.
pub enum Representation {
    /// A MERL table.
    Table(Arc<MerlTable>),
    /// A model, or one per channel.
    Model(Fitted),
    /// A neural BRDF.
    Nbrdf(Box<Nbrdf>),
    /// An RGL-EPFL `.bsdf` measurement.
    RglBsdf(Box<RglBsdf>),
}

impl Representation {
    /// The representation as one [`brdfkit_core::Brdf`] (what the RGL-EPFL writer,
    /// `brdfkit_rgl::write`, tabulates for `export --to rgl`). A table
    /// is read with the interpolated lookup (missing cells 0), a per-channel fit takes
    /// channel c from model c, an NBRDF is its (clamped) `eval`, a `.bsdf` its own `eval`.
    pub fn as_brdf(&self) -> Box<dyn brdfkit_core::Brdf + '_> {
        use brdfkit_fit::Fitted;
        match self {
            Representation::Table(t) => Box::new(crate::table::table_brdf(
                t,
                brdfkit_merl::Lookup::Interpolated,
            )),
            Representation::Model(Fitted::Shared(m)) => Box::new(m.as_ref()),
            Representation::Model(f) => Box::new(PerChannel(f)),
            Representation::Nbrdf(n) => Box::new(n.as_ref()),
            // The file's own evaluation, one order of the pair (the writer refuses it).
            Representation::RglBsdf(b) => Box::new(b.as_ref()),
        }
    }

    /// Loads a file by its content ([`InputKind::of_file`]): a model description (a
    /// description, a per-channel fit or a fit record, [`Fitted::from_json`]), an
    /// RGL-EPFL `.bsdf`, or else a MERL table; a path that is not a file is the stem
    /// `DIR/NAME` of an NBRDF's six `.npy` files.
    pub fn load(path: &Path) -> Result<Representation, CompareError> {
        if path.is_file() {
            let kind = InputKind::of_file(path).map_err(|source| CompareError::Read {
                path: path.into(),
                source,
            })?;
            return match kind {
                InputKind::Table => Ok(Representation::Table(Arc::new(MerlTable::read(path)?))),
                InputKind::Rgl => Ok(Representation::RglBsdf(Box::new(RglBsdf::read(path)?))),
                InputKind::Json => {
                    let read = || -> Result<Fitted, ModelFileError> {
                        let v = serde_json::from_str(&std::fs::read_to_string(path)?)?;
                        Ok(Fitted::from_json(&v)?)
                    };
                    read()
                        .map(Representation::Model)
                        .map_err(|source| CompareError::ModelFile {
                            path: path.into(),
                            source,
                        })
                }
            };
        }
        if path.is_dir() {
            return Err(CompareError::Unrecognised { path: path.into() });
        }
        // Nothing of the NBRDF's at all: say what was expected, not which of the six
        // is missing.
        let any = Nbrdf::files(path).is_ok_and(|f| f.iter().any(|p| p.exists()));
        if !any {
            return Err(CompareError::Unrecognised { path: path.into() });
        }
        Ok(Representation::Nbrdf(Box::new(Nbrdf::load(path)?)))
    }

    /// The kind.
    pub fn kind(&self) -> Kind {
        match self {
            Representation::Table(_) => Kind::Table,
            Representation::Model(_) => Kind::Model,
            Representation::Nbrdf(_) => Kind::Nbrdf,
            Representation::RglBsdf(_) => Kind::RglBsdf,
        }
    }

    /// The table's dims, for a table.
    fn dims(&self) -> Option<Dims> {
        match self {
            Representation::Table(t) => Some(t.dims()),
            _ => None,
        }
    }

    /// The representation on a grid: a table as it is (its own dims), a model or an
    /// NBRDF sampled at the cells' angles.
    pub(crate) fn tabulate(&self, path: &Path, dims: Dims) -> Result<Arc<MerlTable>, CompareError> {
        let err = |source| CompareError::Tabulate {
            path: path.into(),
            dims,
            source,
        };
        match self {
            Representation::Table(t) => Ok(t.clone()),
            Representation::Model(Fitted::Shared(m)) => Ok(Arc::new(
                MerlTable::from_brdf(m.as_ref(), dims).map_err(err)?,
            )),
            Representation::Model(f) => Ok(Arc::new(
                MerlTable::from_fn(dims, |i, j, k| {
                    let (_, wi, wo, above) = cell_directions(dims, i, j, k);
                    above.then(|| {
                        let v = [0, 1, 2].map(|c| f.channel_model(c).eval(&wi, &wo)[c]);
                        Rgb::new(v[0], v[1], v[2])
                    })
                })
                .map_err(err)?,
            )),
            Representation::Nbrdf(n) => Ok(Arc::new(n.to_table(dims)?.0)),
            Representation::RglBsdf(b) => Ok(Arc::new(b.to_table(dims).map_err(err)?.0)),
        }
    }
}

/// What a comparison computes.
#[derive(Debug, Clone)]
pub struct CompareOptions {
    /// The cell filter and the weighting (those of a fit: [`CellFilter::of`],
    /// [`FitConfig::get_weighting`]).
    pub config: FitConfig,
    /// How a table B of other dims is brought onto A's grid; `None`: refused.
    pub resample: Option<Lookup>,
    /// The grid of a model or NBRDF A when B is not a table.
    pub dims: Dims,
    /// How many of the largest relative differences to list.
    pub top: usize,
    /// The renders; `None`: none.
    pub render: Option<RenderOptions>,
}

impl Default for CompareOptions {
    /// A fit's defaults, no resampling, the MERL grid, the ten largest differences,
    /// the report's default renders.
    fn default() -> Self {
        CompareOptions {
            config: FitConfig::default(),
            resample: None,
            dims: Dims::MERL,
            top: 10,
            render: Some(RenderOptions::default()),
        }
    }
}

/// One side of a comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Side {
    /// The file (or NBRDF stem).
    pub path: PathBuf,
    /// Its kind.
    pub kind: Kind,
    /// Its own grid, for a table.
    pub dims: Option<[usize; 3]>,
}

/// One cell channel where B differs most from A, relative to A.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Difference {
    /// The cell (θh, θd, φd bins) on A's grid.
    pub cell: [usize; 3],
    /// Its angles (the lower bin edges), degrees: θh, θd, φd.
    pub angles_deg: [f64; 3],
    /// The channel (0 R, 1 G, 2 B).
    pub channel: usize,
    /// A's value (1/sr).
    pub a: f64,
    /// B's value (1/sr).
    pub b: f64,
    /// |B − A| / A.
    pub relative: f64,
}

/// The comparison of B against A.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// The reference.
    pub a: Side,
    /// The representation compared.
    pub b: Side,
    /// The grid of the comparison (A's).
    pub grid: [usize; 3],
    /// How B's values on A's cells were obtained.
    pub b_on_grid: String,
    /// Every loss of B against A, per channel and overall; `losses.cells` cells.
    pub losses: LossReport,
    /// The cell weights.
    pub weighting: Weighting,
    /// The θd cutoff (degrees), if any; written `theta_d_max`, the setting's name
    /// (older: `theta_d_max_deg`).
    #[serde(rename = "theta_d_max", alias = "theta_d_max_deg")]
    pub theta_d_max_deg: Option<f64>,
    /// A's valid cells after the cutoff.
    pub cells_a: usize,
    /// Of those, the cells B has no value in (left out).
    pub cells_missing_in_b: usize,
    /// Cell channels where A is 0 and B is not (no relative difference).
    pub zero_in_a: usize,
    /// The largest relative differences, largest first.
    pub largest: Vec<Difference>,
    /// The renders of A (`table_png`) and B, one set per lighting.
    pub renders: Vec<RenderSet>,
}

/// Each channel's model at every cell (chunks in parallel).
fn model_values(f: &Fitted, cells: &FitData) -> [Vec<f64>; 3] {
    let n = cells.len();
    let mut out = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let g = cells.geometry();
    let rows: Vec<(usize, Vec<Rgb>)> = (0..n.div_ceil(PASS_CHUNK_CELLS))
        .into_par_iter()
        .map(|ci| {
            let s = ci * PASS_CHUNK_CELLS;
            let e = (s + PASS_CHUNK_CELLS).min(n);
            let gs = g.slice(s..e);
            let mut v = vec![Rgb::ZERO; e - s];
            let mut w = vec![Rgb::ZERO; e - s];
            for c in 0..3 {
                f.channel_model(c).eval_batch(&gs, &mut w);
                for (x, y) in v.iter_mut().zip(&w) {
                    x[c] = y[c];
                }
            }
            (s, v)
        })
        .collect();
    for (s, v) in rows {
        for (k, x) in v.iter().enumerate() {
            for c in 0..3 {
                out[c][s + k] = x[c];
            }
        }
    }
    out
}

/// The `top` largest |b − a| / a over cells and channels (a > 0), largest first, and
/// the count of channels with a = 0 ≠ b.
fn largest(
    a: &[Vec<f64>; 3],
    b: &[Vec<f64>; 3],
    flat: &[usize],
    dims: Dims,
    top: usize,
) -> (Vec<Difference>, usize) {
    let mut best: Vec<(f64, usize, usize)> = Vec::with_capacity(top + 1);
    let mut zero = 0;
    for m in 0..flat.len() {
        for c in 0..3 {
            let (x, y) = (a[c][m], b[c][m]);
            if x <= 0.0 {
                zero += usize::from(y != 0.0);
                continue;
            }
            let r = (y - x).abs() / x;
            if best.len() < top || best.last().is_some_and(|l| r > l.0) {
                let at = best.partition_point(|e| e.0 >= r);
                best.insert(at, (r, m, c));
                best.truncate(top);
            }
        }
    }
    let out = best
        .into_iter()
        .map(|(r, m, c)| {
            let (i, j, k) = dims.unflatten(flat[m]);
            let h = dims.cell_angles(i, j, k);
            Difference {
                cell: [i, j, k],
                angles_deg: [h.theta_h, h.theta_d, h.phi_d].map(f64::to_degrees),
                channel: c,
                a: a[c][m],
                b: b[c][m],
                relative: r,
            }
        })
        .collect();
    (out, zero)
}

fn side(path: &Path, r: &Representation) -> Side {
    Side {
        path: path.into(),
        kind: r.kind(),
        dims: r.dims().map(|d| [d.theta_h(), d.theta_d(), d.phi_d()]),
    }
}

/// Compares B (at `b_path`) against A (at `a_path`); see the module doc.
pub fn compare(
    a_path: &Path,
    a: &Representation,
    b_path: &Path,
    b: &Representation,
    o: &CompareOptions,
) -> Result<Comparison, CompareError> {
    let no_cells = |reason: String| CompareError::NoCells {
        a: a_path.into(),
        b: b_path.into(),
        reason,
    };
    if let Representation::Model(f) = a {
        brdfkit_fit::score::check_isotropic(f).map_err(|source| CompareError::Incompatible {
            path: a_path.into(),
            source,
        })?;
    }
    let dims = a.dims().or(b.dims()).unwrap_or(o.dims);
    let a_table = a.tabulate(a_path, dims)?;
    // B on A's grid: a table (`None` for a model, evaluated at the cells instead).
    let (b_table, how): (Option<Arc<MerlTable>>, String) = match b {
        Representation::Model(_) => (None, "model evaluated at the cells' directions".into()),
        Representation::Nbrdf(_) => (
            Some(b.tabulate(b_path, dims)?),
            "NBRDF evaluated at the cells' angles".into(),
        ),
        Representation::RglBsdf(_) => (
            Some(b.tabulate(b_path, dims)?),
            ".bsdf evaluated at the cells' angles (weighted mean of both orders of each pair)"
                .into(),
        ),
        Representation::Table(t) if t.dims() == dims => (Some(t.clone()), "the same cells".into()),
        Representation::Table(t) => match o.resample {
            Some(l) => (
                Some(Arc::new(t.resample(dims, l))),
                format!("resampled from {} ({l:?} lookup)", t.dims()).to_lowercase(),
            ),
            None => {
                return Err(CompareError::GridMismatch {
                    a: a_path.into(),
                    a_dims: dims,
                    b: b_path.into(),
                    b_dims: t.dims(),
                });
            }
        },
    };
    let data = FitData::from_table(&a_table).map_err(|e| no_cells(e.to_string()))?;
    // File-order flat index of each of A's valid cells (FitData's order).
    let valid: Vec<usize> = (0..a_table.cells())
        .filter(|&x| a_table.is_valid(x))
        .collect();
    let filter = CellFilter::of(&o.config);
    let kept = filter.indices(&data);
    let weighting = o.config.get_weighting();
    let (cells, flat, b_vals, losses) = match (b, &b_table) {
        (Representation::Model(f), _) => {
            // The losses of `score`: the same call a fit's final report makes.
            let s = brdfkit_fit::score(f, &data, &o.config).map_err(|source| match source {
                ScoreError::Fit(e) => no_cells(e.to_string()),
                source => CompareError::Incompatible {
                    path: b_path.into(),
                    source,
                },
            })?;
            let cells = filter.apply(&data).map_err(|e| no_cells(e.to_string()))?;
            let vals = model_values(f, &cells);
            let flat: Vec<usize> = kept.iter().map(|&m| valid[m]).collect();
            (cells, flat, vals, s.losses)
        }
        (_, Some(bt)) => {
            let both: Vec<usize> = kept
                .iter()
                .copied()
                .filter(|&m| bt.is_valid(valid[m]))
                .collect();
            let cells = if both.len() == data.len() {
                Cow::Borrowed(&data)
            } else {
                let mut keep = vec![false; data.len()];
                for &m in &both {
                    keep[m] = true;
                }
                Cow::Owned(data.filter(|m| keep[m]))
            };
            if cells.is_empty() {
                return Err(no_cells(format!(
                    "no cell of A's {} (after the cutoff) has a value in B",
                    kept.len()
                )));
            }
            let flat: Vec<usize> = both.iter().map(|&m| valid[m]).collect();
            let get = |x: usize, c: usize| bt.get_flat(x).map_or(0.0, |v| v[c]);
            let vals = [0, 1, 2].map(|c| flat.iter().map(|&x| get(x, c)).collect::<Vec<f64>>());
            let losses = losses_of_values(&cells, &vals, weighting)
                .map_err(|e: FitError| no_cells(e.to_string()))?;
            (cells, flat, vals, losses)
        }
        (_, None) => unreachable!("only a model B has no table"),
    };
    let (top, zero_in_a) = largest(cells.values(), &b_vals, &flat, dims, o.top);
    let cells_missing_in_b = kept.len() - cells.len();
    drop(cells);

    let mut renders = Vec::new();
    if let Some(ro) = &o.render {
        let reference = match a {
            Representation::Model(f) => Shown::Fitted(f),
            _ => Shown::Table(&a_table),
        };
        let other = match (b, &b_table) {
            (Representation::Model(f), _) => Shown::Fitted(f),
            // A table B as it is (its own grid), an NBRDF as tabulated.
            (Representation::Table(t), _) => Shown::Table(t),
            (_, Some(t)) => Shown::Table(t),
            (_, None) => unreachable!("only a model B has no table"),
        };
        for l in Lighting::ALL {
            renders.push(render_set_of(l, ro, reference, &[other])?);
        }
    }
    Ok(Comparison {
        a: side(a_path, a),
        b: side(b_path, b),
        grid: [dims.theta_h(), dims.theta_d(), dims.phi_d()],
        b_on_grid: how,
        losses,
        weighting,
        theta_d_max_deg: filter.theta_d_max.map(f64::to_degrees),
        cells_a: kept.len(),
        cells_missing_in_b,
        zero_in_a,
        largest: top,
        renders,
    })
}

/// A per-channel fit as one BRDF: channel c of model c.
struct PerChannel<'a>(&'a brdfkit_fit::Fitted);

impl brdfkit_core::Brdf for PerChannel<'_> {
    fn eval(&self, wi: &brdfkit_core::Vec3, wo: &brdfkit_core::Vec3) -> Rgb {
        Rgb([0, 1, 2].map(|c| self.0.channel_model(c).eval(wi, wo).0[c]))
    }
    fn is_isotropic(&self) -> bool {
        (0..3).all(|c| self.0.channel_model(c).is_isotropic())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_fit::Loss;

    fn lambert(rho: [f64; 3]) -> Fitted {
        Fitted::Shared(
            brdfkit_models::from_json(
                &serde_json::json!({"model": "lambert", "params": {"rho_d": rho}}),
            )
            .unwrap(),
        )
    }

    fn no_renders() -> CompareOptions {
        CompareOptions {
            render: None,
            ..CompareOptions::default()
        }
    }

    fn table(f: &Fitted, dims: Dims) -> Arc<MerlTable> {
        Representation::Model(f.clone())
            .tabulate(Path::new("t"), dims)
            .unwrap()
    }

    #[test]
    fn one_changed_cell_is_the_largest_difference_where_it_is() {
        let dims = Dims::new(12, 12, 24).unwrap();
        let a = table(&lambert([0.2, 0.4, 0.6]), dims);
        let mut b = (*a).clone();
        let (i, j, k) = (5, 3, 7);
        let v = a.get(i, j, k).unwrap();
        b.set(i, j, k, Some(Rgb::new(v[0], 3.0 * v[1], v[2])))
            .unwrap();
        let (pa, pb) = (Path::new("a.binary"), Path::new("b.binary"));
        let c = compare(
            pa,
            &Representation::Table(a.clone()),
            pb,
            &Representation::Table(Arc::new(b)),
            &no_renders(),
        )
        .unwrap();
        let d = c.largest[0];
        assert_eq!(d.cell, [i, j, k]);
        assert_eq!(d.channel, 1);
        assert!((d.relative - 2.0).abs() < 1e-12, "{}", d.relative);
        let h = dims.cell_angles(i, j, k);
        assert_eq!(
            d.angles_deg,
            [h.theta_h, h.theta_d, h.phi_d].map(f64::to_degrees)
        );
        // Every other cell is equal.
        assert_eq!(c.largest[1].relative, 0.0);
        // l2 of one cell: sqrt(w (2v)² / Σw) in G, 0 in R and B.
        let data = FitData::from_table(&a).unwrap();
        let w = brdfkit_merl::cell_weight(dims, i, j);
        let sum: f64 = data.measure().iter().sum();
        let want = (w * (2.0 * v[1]).powi(2) / sum).sqrt();
        let got = c.losses.get(Loss::L2).channels;
        assert!((got[1] - want).abs() < 1e-12 * want, "{} vs {want}", got[1]);
        assert_eq!((got[0], got[2]), (0.0, 0.0));
        assert_eq!(c.cells_missing_in_b, 0);
    }

    #[test]
    fn grids_must_match_unless_resampled() {
        let f = lambert([0.3; 3]);
        let a = Representation::Table(table(&f, Dims::new(12, 12, 24).unwrap()));
        let b = Representation::Table(table(&f, Dims::new(6, 6, 12).unwrap()));
        let (pa, pb) = (Path::new("a.binary"), Path::new("b.binary"));
        let e = compare(pa, &a, pb, &b, &no_renders()).unwrap_err();
        assert!(matches!(e, CompareError::GridMismatch { .. }) && e.is_bad_input());
        let msg = e.to_string();
        assert!(
            msg.contains("a.binary") && msg.contains("6 x 6 x 12"),
            "{msg}"
        );
        // A constant resamples to itself.
        let o = CompareOptions {
            resample: Some(Lookup::Interpolated),
            ..no_renders()
        };
        let c = compare(pa, &a, pb, &b, &o).unwrap();
        assert!(c.losses.get(Loss::Cbrt).overall < 1e-12);
    }

    #[test]
    fn a_model_b_has_the_losses_of_its_score() {
        let dims = Dims::new(12, 12, 24).unwrap();
        let a = table(&lambert([0.2, 0.4, 0.6]), dims);
        let f = lambert([0.25, 0.35, 0.5]);
        let cfg = FitConfig::default().theta_d_max_deg(70.0).unwrap();
        let o = CompareOptions {
            config: cfg.clone(),
            ..no_renders()
        };
        let c = compare(
            Path::new("a"),
            &Representation::Table(a.clone()),
            Path::new("b"),
            &Representation::Model(f.clone()),
            &o,
        )
        .unwrap();
        let s = brdfkit_fit::score(&f, &FitData::from_table(&a).unwrap(), &cfg).unwrap();
        assert_eq!(c.losses, s.losses);
        // The largest relative difference of two Lambertians is their constant ratio.
        let want = [0.05 / 0.2, 0.05 / 0.4, 0.1 / 0.6]
            .into_iter()
            .fold(0.0, f64::max);
        assert!((c.largest[0].relative - want).abs() < 1e-12);
    }
}
