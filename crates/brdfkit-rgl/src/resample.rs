//! A `.bsdf` file as a MERL table, and how far its data are from reciprocal.
//!
//! The measurement is not reciprocal: its θi slices are light positions, and values
//! between them are interpolated, so f(wi, wo) ≠ f(wo, wi). A MERL cell stands for both
//! orders of its pair (φd + π is not stored), so it gets the mean of the two. MERL has no
//! negative values (a negative marks a missing cell), so negative means are stored as 0
//! and counted.

use crate::bsdf::RglBsdf;
use brdfkit_core::{Brdf, Rgb, Vec3};
use brdfkit_merl::{Dims, MerlTable, TableError, cell_directions};
use brdfkit_nbrdf::HORIZON_Z;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// What [`RglBsdf::to_table`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TableStats {
    /// Cells of the grid.
    pub cells: usize,
    /// Cells with a direction at or below the horizon ([`HORIZON_Z`]): missing.
    pub missing: usize,
    /// Channel values whose two-order mean was negative and is stored as 0.
    pub clamped_values: usize,
    /// The most negative mean clamped (0 when none was), 1/sr.
    pub most_negative: f64,
}

/// The relative asymmetry |f(wi, wo) − f(wo, wi)| / (½ (f(wi, wo) + f(wo, wi))) of the
/// channel mean, over random pairs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Asymmetry {
    /// Pairs drawn (uniform on the hemisphere, both above `min_elevation_deg`).
    pub pairs: usize,
    /// Pairs whose mean was not positive (left out).
    pub skipped: usize,
    pub median: f64,
    pub p90: f64,
    pub max: f64,
    pub min_elevation_deg: f64,
}

impl RglBsdf {
    /// The two-order mean sampled onto a MERL table of `dims`: cell (i, j, k) at its grid
    /// angles ([`cell_directions`], the table crate's definition), in parallel, by the
    /// f32 batch kernel (as [`RglBsdf::eval_flat`]).
    pub fn to_table(&self, dims: Dims) -> Result<(MerlTable, TableStats), TableError> {
        let slab = dims.theta_d() * dims.phi_d();
        let slabs: Vec<(Vec<Option<Rgb>>, TableStats)> = (0..dims.theta_h())
            .into_par_iter()
            .map(|i| {
                let mut st = TableStats {
                    cells: slab,
                    ..Default::default()
                };
                // Both orders of every cell above the horizon, evaluated as one batch.
                let mut rows = Vec::with_capacity(2 * slab);
                let mut above = Vec::with_capacity(slab);
                for j in 0..dims.theta_d() {
                    for k in 0..dims.phi_d() {
                        let (_, wi, wo, _) = cell_directions(dims, i, j, k);
                        let ok = wi.z > HORIZON_Z && wo.z > HORIZON_Z;
                        above.push(ok);
                        if ok {
                            let (a, b) = ([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z]);
                            rows.push([a[0], a[1], a[2], b[0], b[1], b[2]]);
                            rows.push([b[0], b[1], b[2], a[0], a[1], a[2]]);
                        }
                    }
                }
                let mut f = vec![[0.0; 3]; rows.len()];
                self.eval_rows(&rows, &mut Vec::new(), &mut f);
                let mut pairs = f.chunks_exact(2);
                let mut vals = Vec::with_capacity(slab);
                for ok in above {
                    let Some(p) = ok.then(|| pairs.next()).flatten() else {
                        st.missing += 1;
                        vals.push(None);
                        continue;
                    };
                    let m = Rgb(p[0]).zip(Rgb(p[1]), |x, y| 0.5 * (x + y));
                    for x in m.0 {
                        if x < 0.0 {
                            st.clamped_values += 1;
                            st.most_negative = st.most_negative.min(x);
                        }
                    }
                    vals.push(Some(m.map(|x| x.max(0.0))));
                }
                (vals, st)
            })
            .collect();
        let stats = slabs
            .iter()
            .fold(TableStats::default(), |a, (_, s)| TableStats {
                cells: a.cells + s.cells,
                missing: a.missing + s.missing,
                clamped_values: a.clamped_values + s.clamped_values,
                most_negative: a.most_negative.min(s.most_negative),
            });
        let table = MerlTable::from_fn(dims, |i, j, k| slabs[i].0[k + dims.phi_d() * j])?;
        Ok((table, stats))
    }

    /// ½ (f(wi, wo) + f(wo, wi)).
    pub fn symmetric(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        let (a, b) = (self.eval(wi, wo), self.eval(wo, wi));
        a.zip(b, |x, y| 0.5 * (x + y))
    }

    /// The asymmetry over `pairs` random pairs (seeded: the same figures every run),
    /// both directions above `min_elevation_deg`.
    pub fn asymmetry(&self, pairs: usize, min_elevation_deg: f64, seed: u64) -> Asymmetry {
        let zmin = min_elevation_deg.to_radians().sin();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut dir = || loop {
            // Uniform on the hemisphere: z uniform in [0, 1).
            let (z, phi): (f64, f64) = (rng.random(), rng.random::<f64>() * std::f64::consts::TAU);
            if z > zmin {
                let r = (1.0 - z * z).sqrt();
                return Vec3::new(r * phi.cos(), r * phi.sin(), z);
            }
        };
        let dirs: Vec<(Vec3, Vec3)> = (0..pairs).map(|_| (dir(), dir())).collect();
        let rel: Vec<Option<f64>> = dirs
            .par_iter()
            .map(|(wi, wo)| {
                let (a, b) = (self.eval(wi, wo).mean(), self.eval(wo, wi).mean());
                let m = 0.5 * (a + b);
                (m > 0.0).then(|| (a - b).abs() / m)
            })
            .collect();
        let mut r: Vec<f64> = rel.iter().flatten().copied().collect();
        r.sort_by(f64::total_cmp);
        let q = |p: f64| {
            if r.is_empty() {
                f64::NAN
            } else {
                r[((r.len() - 1) as f64 * p).round() as usize]
            }
        };
        Asymmetry {
            pairs,
            skipped: pairs - r.len(),
            median: q(0.5),
            p90: q(0.9),
            max: r.last().copied().unwrap_or(f64::NAN),
            min_elevation_deg,
        }
    }
}
