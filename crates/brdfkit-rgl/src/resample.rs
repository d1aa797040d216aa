//! A `.bsdf` file as a MERL table, and how far its data are from reciprocal.
//!
//! The measurement is not reciprocal: its θi slices are light positions, and values
//! between them are interpolated, so f(wi, wo) ≠ f(wo, wi). A MERL cell stands for both
//! orders of its pair (φd + π is not stored), so it gets one value from the two: their
//! mean weighted by how well each is determined ([`two_order_value`]), which is the plain
//! mean when both directions are equally high. MERL has no negative values (a negative
//! marks a missing cell), so negative values are stored as 0 and counted.

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
    /// The most negative value clamped (0 when none was), 1/sr.
    pub most_negative: f64,
    /// Cells held (to more than 99 %) by one order alone: one direction is so near the
    /// horizon that its order, divided by that small cosine, gets under 1 % of the
    /// weight ([`two_order_value`]; cos θ below ~0.01 with the other direction high).
    pub one_order: usize,
}

/// The share of the weight below which an order counts as left out ([`TableStats::one_order`]).
const ONE_ORDER_SHARE: f64 = 0.01;

/// c of [`order_weight`]: the cosine at which the error of the file's stored f · cos θo
/// that does not shrink with its value (interpolation towards the horizon, extrapolation
/// in a database file) equals the part that does. Chosen by measurement (docs/rgl.md,
/// "Near the horizon"; `examples/grazing.rs`): on the tables of the Cook-Torrance surface
/// and of gold-paint, pink-fabric and specular-red-phenolic written as `.bsdf` files and
/// resampled back, c = 0.1 keeps the cells with both directions above 10° within 1.2 % of
/// the plain mean's median and 90th-percentile error and gives the lowest or near-lowest
/// 90th percentile over all cells; c = 0 (the pure cos² weights of an error that does not
/// shrink at all) raised the 90th percentile above 10° by 4–11 %, c = 0.4 by 2–6 %.
pub const ORDER_ERROR_COS: f64 = 0.1;

/// The weight of the order whose outgoing direction (the one the reader divides by) has
/// cosine `cos`: cos² / (cos² + c²), c = [`ORDER_ERROR_COS`].
///
/// The file holds g = f · cos θo (Mitsuba's `eval`, docs/rgl.md); the reader returns
/// g / cos θo. An error of g made of a part relative to g (ε_r g) and a part that does
/// not shrink with it (ε_a: near the horizon g is interpolated between nodes, or
/// extrapolated in a database file, and does not vanish with the cosine) has the
/// variance ε_r² f² + ε_a² / cos²θo in f; its inverse, up to a common factor, is this
/// weight with c = ε_a / (ε_r f). It is ~1 above c and falls as cos² below it.
pub fn order_weight(cos: f64) -> f64 {
    let c2 = cos * cos;
    c2 / (c2 + ORDER_ERROR_COS * ORDER_ERROR_COS)
}

/// One reciprocal value from the two orders of a pair, f_io = f(wi, wo) and
/// f_oi = f(wo, wi), as the reader returns them (f_io divided by cos θo, f_oi by cos θi):
/// their inverse-variance weighted mean,
///
///   f = (w(cos θo) f_io + w(cos θi) f_oi) / (w(cos θo) + w(cos θi)),  w = [`order_weight`].
///
/// Why: a MERL cell stands for both orders (φd + π is not stored), and the file's two
/// orders are not equally well determined near the horizon. At a MERL cell whose wo lies
/// 1.7e-7 above the horizon, a written Cook-Torrance file gave f_io = 1.7e5 for a source
/// of 0.81 (its stored f · cos θo there, interpolated, is 0.029 instead of ~1e-7) while
/// f_oi was 0.76 (issue 24); the plain mean was 8.4e4. With both directions at the same
/// elevation this is the plain mean, and with both well above c (θ below ~84°) nearly
/// so. An order of weight 0 (its direction on the horizon) is left out even if its value
/// is not finite; both 0 (no cell of a table has that) gives 0.
pub fn two_order_value(f_io: Rgb, f_oi: Rgb, cos_i: f64, cos_o: f64) -> Rgb {
    let (wa, wb) = (order_weight(cos_o), order_weight(cos_i));
    let sum = wa + wb;
    if sum <= 0.0 {
        return Rgb::ZERO;
    }
    let part = |w: f64, x: f64| if w > 0.0 { w * x } else { 0.0 };
    f_io.zip(f_oi, |a, b| (part(wa, a) + part(wb, b)) / sum)
}

/// Whether one order carries less than [`ONE_ORDER_SHARE`] of the weight.
fn one_order(cos_i: f64, cos_o: f64) -> bool {
    let (wa, wb) = (order_weight(cos_o), order_weight(cos_i));
    wa.min(wb) < ONE_ORDER_SHARE * (wa + wb)
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
    /// The two orders' value ([`two_order_value`]) sampled onto a MERL table of `dims`:
    /// cell (i, j, k) at its grid angles ([`cell_directions`], the table crate's
    /// definition), in parallel, by the f32 batch kernel (as [`RglBsdf::eval_flat`]).
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
                        above.push(ok.then_some((wi.z, wo.z)));
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
                for cosines in above {
                    let Some(((ci, co), p)) = cosines.and_then(|c| Some((c, pairs.next()?))) else {
                        st.missing += 1;
                        vals.push(None);
                        continue;
                    };
                    st.one_order += usize::from(one_order(ci, co));
                    let m = two_order_value(Rgb(p[0]), Rgb(p[1]), ci, co);
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
                one_order: a.one_order + s.one_order,
            });
        let table = MerlTable::from_fn(dims, |i, j, k| slabs[i].0[k + dims.phi_d() * j])?;
        Ok((table, stats))
    }

    /// The reciprocal value of the pair from both orders, [`two_order_value`] (what
    /// [`RglBsdf::to_table`] stores, by the f64 path; the directions above the horizon).
    pub fn symmetric(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        let (a, b) = (self.eval(wi, wo), self.eval(wo, wi));
        two_order_value(a, b, wi.z.max(0.0), wo.z.max(0.0))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal elevations give the plain mean; an order on the horizon is left out even
    /// when the reader's division made it infinite; both on it give 0.
    #[test]
    fn two_order_value_limits() {
        let (a, b) = (Rgb([1.0, 2.0, 3.0]), Rgb([3.0, 2.0, 1.0]));
        assert_eq!(two_order_value(a, b, 0.3, 0.3), Rgb([2.0, 2.0, 2.0]));
        let inf = Rgb::splat(f64::INFINITY);
        let close = |x: Rgb, y: Rgb| (0..3).all(|c| (x.0[c] - y.0[c]).abs() < 1e-12);
        assert!(close(two_order_value(inf, b, 0.5, 0.0), b));
        assert!(close(two_order_value(a, inf, 0.0, 0.5), a));
        assert_eq!(two_order_value(a, b, 0.0, 0.0), Rgb::ZERO);
        // Well above c the weights are within 4 % of each other: nearly the plain mean.
        let v = two_order_value(a, b, 0.5, 1.0).0[0];
        assert!((v - 2.0).abs() < 0.04, "{v}");
        // f_io divided by cos θo = 1e-6, against f_oi divided by 0.5: one order holds it.
        assert!(one_order(0.5, 1e-6) && !one_order(0.5, 0.2));
    }
}
