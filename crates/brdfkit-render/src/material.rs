//! Materials: an analytic model (any `brdfkit_models` JSON description), a MERL table
//! or an RGL-EPFL `.bsdf` measurement, behind one evaluation that also reports missing
//! table samples.

use brdfkit_core::{Brdf, Model, Rgb, Vec3};
use brdfkit_merl::{Lookup, MerlTable};
use brdfkit_rgl::RglBsdf;
use std::sync::Arc;

/// A MERL table as a [`Brdf`].
///
/// A lookup that lands in a missing cell (or a direction at or below the horizon)
/// returns zero through [`Brdf::eval`]; [`TableBrdf::try_eval`] tells the two apart so
/// a renderer can count the misses.
#[derive(Clone, Debug)]
pub struct TableBrdf {
    table: Arc<MerlTable>,
    lookup: Lookup,
}

impl TableBrdf {
    /// Wraps `table`, read between cells by `lookup`.
    pub fn new(table: Arc<MerlTable>, lookup: Lookup) -> Self {
        TableBrdf { table, lookup }
    }

    /// The table.
    pub fn table(&self) -> &MerlTable {
        &self.table
    }

    /// The lookup mode.
    pub fn lookup(&self) -> Lookup {
        self.lookup
    }

    /// f_r, or `None` where the table has no sample (missing cell, or a direction at
    /// or below the horizon).
    #[inline]
    pub fn try_eval(&self, wi: &Vec3, wo: &Vec3) -> Option<Rgb> {
        self.table.lookup(self.lookup, wi, wo)
    }
}

impl Brdf for TableBrdf {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        // Missing means "not measured"; in an image the only honest value is no light
        // (the renderer counts these lookups, see `RenderStats::table_misses`).
        self.try_eval(wi, wo).unwrap_or(Rgb::ZERO)
    }
}

/// An RGL-EPFL `.bsdf` measurement as the renderer sees it: evaluated as Mitsuba 3
/// renders it, with the file's θi (Mitsuba's `si.wi`) on the camera side.
///
/// The data are not reciprocal (docs/rgl.md), so the order matters: the renderer's
/// `eval(wi, wo)` has wi toward the light and wo toward the camera, and Mitsuba's
/// `measured` plugin evaluates `eval(si.wi = toward the camera, wo = toward the light)`.
/// This wrapper swaps the pair, so a render here is one of the same material as
/// Mitsuba's render of the file.
#[derive(Clone, Debug)]
pub struct MeasuredBrdf(pub Arc<RglBsdf>);

impl Brdf for MeasuredBrdf {
    #[inline]
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        self.0.eval(wo, wi)
    }

    fn is_isotropic(&self) -> bool {
        self.0.is_isotropic()
    }
}

/// Where a material came from (for reports).
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialSource {
    /// An inline model description in the scene file.
    Inline,
    /// A model JSON file.
    ModelFile(std::path::PathBuf),
    /// A MERL table file.
    TableFile(std::path::PathBuf),
    /// An RGL-EPFL `.bsdf` file.
    MeasuredFile(std::path::PathBuf),
}

/// The material of a scene object: what the renderer evaluates at a hit point.
#[derive(Debug, Clone)]
pub enum SceneMaterial {
    /// An analytic model.
    Model {
        /// The model.
        model: Arc<dyn Model>,
        /// Where it came from.
        source: MaterialSource,
    },
    /// A measured table.
    Table {
        /// The table and its lookup.
        brdf: TableBrdf,
        /// Where it came from.
        source: MaterialSource,
    },
    /// An RGL-EPFL `.bsdf` measurement, evaluated directly (not resampled).
    Measured {
        /// The file's model.
        brdf: MeasuredBrdf,
        /// Where it came from.
        source: MaterialSource,
    },
}

impl SceneMaterial {
    /// f_r(wi, wo) in the local frame, and whether a table lookup found no sample
    /// (the value is then zero).
    #[inline]
    pub fn eval(&self, wi: &Vec3, wo: &Vec3) -> (Rgb, bool) {
        match self {
            SceneMaterial::Model { model, .. } => (model.eval(wi, wo), false),
            SceneMaterial::Table { brdf, .. } => match brdf.try_eval(wi, wo) {
                Some(v) => (v, false),
                // Below the horizon is not a miss: the renderer never asks there.
                None => (Rgb::ZERO, wi.z > 0.0 && wo.z > 0.0),
            },
            SceneMaterial::Measured { brdf, .. } => (brdf.eval(wi, wo), false),
        }
    }

    /// The material as a plain [`Brdf`].
    pub fn as_brdf(&self) -> &dyn Brdf {
        match self {
            SceneMaterial::Model { model, .. } => model.as_ref(),
            SceneMaterial::Table { brdf, .. } => brdf,
            SceneMaterial::Measured { brdf, .. } => brdf,
        }
    }

    /// Where it came from.
    pub fn source(&self) -> &MaterialSource {
        match self {
            SceneMaterial::Model { source, .. }
            | SceneMaterial::Table { source, .. }
            | SceneMaterial::Measured { source, .. } => source,
        }
    }

    /// A short description: the model name or "MERL table".
    pub fn describe(&self) -> String {
        match self {
            SceneMaterial::Model { model, .. } => format!("model `{}`", model.name()),
            SceneMaterial::Table { brdf, .. } => format!("MERL table {}", brdf.table().dims()),
            SceneMaterial::Measured { brdf, .. } => format!(
                "RGL-EPFL .bsdf ({})",
                if brdf.0.is_spectral() {
                    "spectral"
                } else {
                    "RGB"
                }
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The renderer's (light, camera) pair is the file's (camera, light): the order
    /// Mitsuba's `measured` plugin evaluates, whose `si.wi` points to the camera. The
    /// vendored synthetic file is not reciprocal, so the swap shows.
    #[test]
    fn a_measured_material_puts_the_files_theta_i_on_the_camera_side() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../data-synthetic/felt-synthetic.bsdf");
        let bsdf = Arc::new(RglBsdf::read(&path).unwrap());
        let m = SceneMaterial::Measured {
            brdf: MeasuredBrdf(bsdf.clone()),
            source: MaterialSource::MeasuredFile(path),
        };
        let light = Vec3::new(0.7, 0.1, 0.5).normalize();
        let camera = Vec3::new(-0.2, 0.3, 0.9).normalize();
        let (f, miss) = m.eval(&light, &camera);
        assert!(!miss);
        assert_eq!(f, bsdf.eval(&camera, &light));
        assert_ne!(f, bsdf.eval(&light, &camera), "the file is not reciprocal");
        assert_eq!(m.as_brdf().eval(&light, &camera), f);
        assert!(m.describe().contains(".bsdf"));
    }
}
