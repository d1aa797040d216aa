//! `brdfkit-render`: a scene-driven preview renderer for measured and analytic BRDFs.
//!
//! A scene file (TOML, `docs/rendering.md`) declares a camera, a sphere and/or a plane,
//! materials (a model JSON, inline or by path, or a MERL table), lights (point,
//! directional, and an environment: constant or a lat-long EXR/PNG) and the **effects**
//! to simulate: `direct`, `environment`, `shadows`. The renderer computes exactly those
//! (no global illumination), reports what each cost, and writes a linear EXR and a
//! tone-mapped sRGB PNG.
//!
//! ```no_run
//! use brdfkit_render::{Scene, render};
//! let scene = Scene::read("examples/scenes/sphere-point.toml")?;
//! let out = render(&scene)?;
//! println!("{}", out.stats);
//! out.write_exr("sphere.exr")?;
//! out.write_png("sphere.png")?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Modules: [`scene`] (format, validation, loading), [`mod@render`] (estimators, cost
//! accounting), [`mod@env`] (environment lookup and sampling), [`sampling`] (BRDF lobe
//! sampling), [`geometry`] (camera, sphere, plane), [`material`] (models and tables),
//! [`output`] (image files, tone mapping), [`stats`] (what a render cost), [`rng`]
//! (per-pixel random streams).

#![warn(missing_docs)]

pub mod env;
pub mod error;
pub mod geometry;
pub mod material;
pub mod output;
pub mod render;
pub mod rng;
pub mod sampling;
pub mod scene;
pub mod stats;

pub use error::{OutputError, RenderError, SceneError};
pub use material::{MeasuredBrdf, SceneMaterial, TableBrdf};
pub use output::RenderOutput;
pub use render::{render, render_observed};
pub use scene::{Effect, Effects, Film, Light, Mis, PixelFilter, Scene};
pub use stats::{EffectCost, RenderStats};
