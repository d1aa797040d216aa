//! The array file formats brdfkit reads and writes besides its measured sources: NumPy
//! `.npy` arrays ([`npy`]: the NBRDF weights, `eval`'s direction pairs and values) and
//! the direction-pair CSV ([`csv`]), and the scattered samples of `fit --samples`
//! ([`samples`], `.npy` or CSV). One implementation of each, shared by the CLI and the
//! NBRDF reader (and through it the Python package), so that one file is read by one rule
//! everywhere.
//!
//! Every error names the file and what is wrong with it; nothing is renormalised,
//! clamped or converted behind the user's back.
//!
//! # Why `npyz`
//! `.npy` files are read with [`npyz`] (0.9, MIT), not a hand-written parser. It reads
//! a file's header (dtype, shape, order) before its data, so a wrong dtype or shape is
//! reported from the header, and it reads into a plain `Vec<f32>` / `Vec<f64>` and
//! writes n-dimensional arrays of any plain dtype (`WriteOptions::new().default_dtype()
//! .shape(&[n, 3])`), which is what `fit-brdf eval` needs (read N×6 f64, write
//! N×3 f64; writing into a `Vec<u8>` leaves the file to the project's atomic writer).
//! Its dependencies are small (byteorder, num-bigint, py_literal). The alternative,
//! `ndarray-npy`, does the same through `ndarray` arrays, a dependency nothing else in
//! the workspace uses, for what here are six small matrices.

pub mod csv;
pub mod npy;
pub mod samples;
