//! Geometry and shared types of brdfkit.
//!
//! Conventions (see `docs/conventions.md` and `../shared/conventions.md`):
//! - a local shading frame with z the surface normal, x the tangent (the direction of
//!   `alpha_x` / `n_u`), y = z × x;
//! - `wi` and `wo` are unit vectors pointing **away** from the surface;
//! - [`Brdf::eval`] returns f_r in 1/sr **without** the cosine factor;
//! - angles are radians.
//!
//! Modules:
//! - [`direction`]: vector helpers and spherical coordinates;
//! - [`rusinkiewicz`]: (wi, wo) <-> (θh, φh, θd, φd) exactly as the MERL reference code;
//! - [`rgb`]: the [`Rgb`] triple;
//! - [`brdf`]: the [`Brdf`] trait;
//! - [`model`]: the parametric [`Model`] trait the fitter drives (parameters, gradients,
//!   the fast path over precomputed geometry);
//! - [`quadrature`]: Gauss-Legendre rules and the directional albedo of any BRDF;
//! - [`geometry`]: [`GeometryBatch`], per-pair geometry precomputed once as a structure
//!   of arrays.
//! - [`atomic`]: the one way every output file is written (whole, or not at all).
//! - [`choice`]: structural choices parsed from their names.
//! - [`scattering`]: Fresnel, microfacet distributions and masking, with derivatives.
//! - [`progress`]: the one progress channel: [`progress::Event`] and [`progress::Observe`].
//! - [`text`]: the one way a text input file is read (whole, as UTF-8, errors naming
//!   the file and the first bad byte).

#![warn(missing_docs)]

pub mod atomic;
pub mod brdf;
pub mod choice;
pub mod direction;
pub mod geometry;
pub mod lanes;
pub mod model;
pub mod par;
pub mod progress;
pub mod quadrature;
pub mod rgb;
pub mod rusinkiewicz;
pub mod scattering;
pub mod text;

pub use brdf::Brdf;
pub use choice::UnknownName;
pub use direction::Vec3;
pub use geometry::{
    Columns, DirPairs, GeomSlice, GeomSliceF32, GeomSliceOf, Geometry, GeometryBatch,
    GeometryBatchF32,
};
pub use model::{AsAny, CloneModel, Model, ModelError, ParamRole, ParamSpec, downcast};
pub use rgb::Rgb;
pub use rusinkiewicz::{HalfDiff, from_half_diff, to_half_diff};
