//! Neural BRDFs (NBRDF) as a source: read the six-file `.npy` layout, evaluate it as a
//! [`Brdf`](brdfkit_core::Brdf) in f64, resample it onto a MERL table.
//!
//! The networks are those of A. Sztrajman, G. Rainer, T. Ritschel, T. Weyrich, "Neural
//! BRDF Representation and Importance Sampling", Computer Graphics Forum 40(6), 2021
//! (doi:10.1111/cgf.14335; weights from the authors' repository asztr/Neural-BRDF, MIT
//! licence): a 6 → 21 → 21 → 3 perceptron per material, trained on a measured BRDF
//! (MERL, RGL, Nielsen et al.). `docs/measured.md` describes the proxies shipped in
//! `data-measured/` and their attribution.
//!
//! - [`Nbrdf::load`]: `DIR/NAME` → the six files `NAME_{fc1,b1,fc2,b2,fc3,b3}.npy`,
//!   shapes, dtype (float32) and finiteness checked, typed errors naming the file
//!   ([`NbrdfError`]);
//! - [`Nbrdf::raw`], [`Nbrdf::raw_angles`]: the network's output at (θh, θd, φd), not
//!   clamped; [`Brdf::eval`](brdfkit_core::Brdf::eval) and [`Nbrdf::eval_pairs`]: f_r of
//!   direction pairs, zero below the horizon, negatives clamped ([`clamp`]);
//! - [`Nbrdf::to_table`]: a MERL-format table, with [`ResampleStats`] (missing cells,
//!   clamped values).
//!
//! # Wiring into `fit-brdf`
//! `resample --nbrdf P`: `let (t, st) = Nbrdf::load(P)?.to_table(dims)?;` then write `t`
//! and report `st`. `eval --nbrdf P --dirs F`: `Nbrdf::load(P)?.eval_pairs(&pairs)`.
//! [`NbrdfError`] is always bad input (exit 2) except an I/O failure
//! ([`NbrdfError::Npy`] of [`NpyError::Read`]) and [`NbrdfError::Table`].
//!
//! # Reading the files
//! The six `.npy` files are read by the workspace's one `.npy` reader,
//! [`brdfkit_io::npy::read_f32`] (through `npyz`: see that crate for why).

pub mod error;
mod net;
pub mod npy;
pub use brdfkit_io::npy::NpyError;
mod table;

pub use error::NbrdfError;
pub use net::{INPUTS, LANES, Nbrdf, PARTS, clamp, input};
pub use table::{HORIZON_Z, ResampleStats};
