//! The RGL-EPFL measured BSDF format (Dupuy & Jakob 2018, "An Adaptive Parameterization
//! for Efficient Material Acquisition and Rendering", SIGGRAPH Asia): the `.bsdf` files
//! of the RGL material database, which Mitsuba 3's and pbrt-v4's `measured` materials
//! render.
//!
//! - [`tensor`]: Mitsuba tensor files, the container: a reader for every dtype that
//!   trusts no count or offset, and a writer (through brdfkit-core's atomic writer).
//! - [`RglBsdf`]: a `.bsdf` file evaluated exactly as Mitsuba 3's `measured` plugin does
//!   (isotropic and anisotropic, RGB and spectral), f_r without the cosine; it is a
//!   [`brdfkit_core::Brdf`], so everything that takes a BRDF takes it.
//! - [`mod@write`]: `.bsdf` files written from any isotropic [`brdfkit_core::Brdf`] (a table,
//!   a model, an NBRDF), built as Dupuy & Jakob 2018 build the database's.
//! - [`fastmath`]: the f32 `atan2`/`asin` polynomials of the batch evaluation, with
//!   their error bounds.
//! - [`cie`]: the conversion of spectral files to linear sRGB.
//! - [`RglBsdf::to_table`]: the file as a MERL table (both orders of a pair in one value,
//!   [`two_order_value`]),
//!   and [`RglBsdf::asymmetry`], how far the data are from reciprocal.
//!
//! - [`MeasuredPoints`]: the file's measured points at their own directions, with the
//!   solid angle each stands for (the native input of a fit).
//!
//! - [`InputKind`]: the one rule that tells a `.bsdf`, a model description and a MERL
//!   table apart by their first bytes.
//!
//! docs/rgl.md describes the format, the evaluation and its sources.

mod batch;
mod bsdf;
mod check;
pub mod cie;
pub mod cie_table;
mod error;
pub mod fastmath;
mod info;
pub mod kind;
mod points;
mod resample;
pub mod tensor;
mod warp;
pub mod write;

pub use bsdf::{RglBsdf, Summary, Values};
pub use error::RglError;
pub use kind::InputKind;
pub use points::{MIN_COS_I, MeasuredPoints, Point};
pub use resample::{Asymmetry, ORDER_ERROR_COS, TableStats, order_weight, two_order_value};
pub use tensor::{Dtype, Tensor, TensorData, TensorFile, is_tensor_file};
pub use warp::Warp2D;
