//! Materials: an analytic model (any `brdfkit_models` JSON description) or a MERL
//! table, behind one evaluation that also reports missing table samples.

use brdfkit_core::{Brdf, Model, Rgb, Vec3};
use brdfkit_merl::{Lookup, MerlTable};
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

/// Where a material came from (for reports).
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialSource {
    /// An inline model description in the scene file.
    Inline,
    /// A model JSON file.
    ModelFile(std::path::PathBuf),
    /// A MERL table file.
    TableFile(std::path::PathBuf),
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
        }
    }

    /// The material as a plain [`Brdf`].
    pub fn as_brdf(&self) -> &dyn Brdf {
        match self {
            SceneMaterial::Model { model, .. } => model.as_ref(),
            SceneMaterial::Table { brdf, .. } => brdf,
        }
    }

    /// Where it came from.
    pub fn source(&self) -> &MaterialSource {
        match self {
            SceneMaterial::Model { source, .. } | SceneMaterial::Table { source, .. } => source,
        }
    }

    /// A short description: the model name or "MERL table".
    pub fn describe(&self) -> String {
        match self {
            SceneMaterial::Model { model, .. } => format!("model `{}`", model.name()),
            SceneMaterial::Table { brdf, .. } => format!("MERL table {}", brdf.table().dims()),
        }
    }
}
