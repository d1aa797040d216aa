//! The directions of a grid's cells from per-axis sines and cosines.
//!
//! [`cell_directions`](crate::cell_directions) converts a cell's angles with
//! [`from_half_diff`](brdfkit_core::from_half_diff): six sines and cosines per cell.
//! Every cell of a row shares θh and θd, and every row the same φd angles, so
//! [`CellDirections`] computes each axis's sines and cosines once and repeats the rest
//! of `from_half_diff`'s arithmetic, operation for operation: the same directions, bit
//! for bit, for the price of a few multiplications (building the cells of a 1.46 M-cell
//! table for a fit spent about a fifth of its CPU in `sin`/`cos` before).

use crate::grid::{Dims, phi_d_angle, theta_d_angle, theta_h_angle};
use brdfkit_core::Vec3;
use brdfkit_core::geometry::pair_columns_of;
use brdfkit_core::lanes::{Run, dispatch};

/// (cos, sin) of an angle.
type CosSin = [f64; 2];

/// The sines and cosines of a grid's cell angles, per axis; see the module doc.
#[derive(Clone, Debug)]
pub struct CellDirections {
    theta_h: Vec<CosSin>,
    theta_d: Vec<CosSin>,
    phi_d: Vec<CosSin>,
}

fn cos_sin(a: f64) -> CosSin {
    [a.cos(), a.sin()]
}

/// `brdfkit_core::rotate(v, axis, angle)` with cos and sin of the angle given: the same
/// operations in the same order (Rodrigues' formula, v cos + a (a·v)(1 − cos) + (a × v)
/// sin), hence the same bits.
fn rotate_cs(v: [f64; 3], a: [f64; 3], [c, s]: CosSin) -> [f64; 3] {
    let along = (a[0] * v[0] + a[1] * v[1] + a[2] * v[2]) * (1.0 - c);
    let cross = [
        a[1] * v[2] - a[2] * v[1],
        a[2] * v[0] - a[0] * v[2],
        a[0] * v[1] - a[1] * v[0],
    ];
    std::array::from_fn(|m| v[m] * c + a[m] * along + cross[m] * s)
}

impl CellDirections {
    /// The tables of `dims`.
    pub fn new(dims: Dims) -> Self {
        let (nh, nd, np) = (dims.theta_h(), dims.theta_d(), dims.phi_d());
        CellDirections {
            theta_h: (0..nh)
                .map(|i| cos_sin(theta_h_angle(i as f64, nh)))
                .collect(),
            theta_d: (0..nd)
                .map(|j| cos_sin(theta_d_angle(j as f64, nd)))
                .collect(),
            phi_d: (0..np)
                .map(|k| cos_sin(phi_d_angle(k as f64, np)))
                .collect(),
        }
    }

    /// (wi, wo) of cell (i, j, k): [`cell_directions`](crate::cell_directions)'s, bit
    /// for bit. Panics when the cell is out of range.
    #[inline(always)]
    pub fn get(&self, i: usize, j: usize, k: usize) -> (Vec3, Vec3) {
        let [ch, sh] = self.theta_h[i];
        let [cd, sd] = self.theta_d[j];
        let [cp, sp] = self.phi_d[k];
        // from_half_diff with φh = 0: d = spherical(θd, φd), rotated by θh about the
        // binormal, then by φh = 0 about the normal (cos 0 = 1, sin 0 = 0 exactly).
        let d = [sd * cp, sd * sp, cd];
        let t = rotate_cs(d, [0.0, 1.0, 0.0], [ch, sh]);
        let wi = Vec3::from(rotate_cs(t, [0.0, 0.0, 1.0], [1.0, 0.0]));
        let h = Vec3::new(sh * 1.0, sh * 0.0, ch);
        let wo = 2.0 * wi.dot(&h) * h - wi;
        (wi, wo)
    }

    /// The ten geometry columns ([`pair_columns_of`]: wi, wo, h, cos θd) of every cell
    /// (i, j, k) of row (i, j), into `cols[c][k]` (each column at least φd-count long):
    /// [`get`](Self::get) and the columns cell by cell, the same bits, in one loop
    /// compiled for the widest vector instructions the processor has
    /// ([`brdfkit_core::lanes`]; every operation is branch-free IEEE arithmetic).
    pub fn row_columns(&self, i: usize, j: usize, cols: [&mut [f64]; 10]) {
        struct Row<'a> {
            cells: &'a CellDirections,
            i: usize,
            j: usize,
            cols: [&'a mut [f64]; 10],
        }
        impl Run for Row<'_> {
            #[inline(always)]
            fn run(&mut self) {
                let n = self.cells.phi_d.len();
                let mut cols = self.cols.each_mut().map(|c| &mut c[..n]);
                for k in 0..n {
                    let (wi, wo) = self.cells.get(self.i, self.j, k);
                    let v = pair_columns_of([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z]);
                    for (c, x) in cols.iter_mut().zip(v) {
                        c[k] = x;
                    }
                }
            }
        }
        dispatch(&mut Row {
            cells: self,
            i,
            j,
            cols,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell_directions;

    /// A row's columns are `get`'s directions and `pair_columns`' numbers, bit for bit.
    #[test]
    fn row_columns_are_the_cells_columns() {
        for (a, b, c) in [(90, 90, 180), (13, 17, 11), (1, 1, 1)] {
            let dims = Dims::new(a, b, c).unwrap();
            let fast = CellDirections::new(dims);
            let np = dims.phi_d();
            let mut cols = vec![vec![0.0; np + 3]; 10];
            for i in 0..dims.theta_h() {
                for j in 0..dims.theta_d() {
                    let [c0, c1, c2, c3, c4, c5, c6, c7, c8, c9] = &mut cols[..] else {
                        unreachable!()
                    };
                    fast.row_columns(i, j, [c0, c1, c2, c3, c4, c5, c6, c7, c8, c9]);
                    let want: Vec<[u64; 10]> = (0..np)
                        .map(|k| {
                            let (wi, wo) = fast.get(i, j, k);
                            brdfkit_core::geometry::pair_columns(&wi, &wo).map(f64::to_bits)
                        })
                        .collect();
                    let got: Vec<[u64; 10]> = (0..np)
                        .map(|k| std::array::from_fn(|m| cols[m][k].to_bits()))
                        .collect();
                    assert_eq!(got, want, "row {i} {j}");
                }
            }
        }
    }

    #[test]
    fn same_bits_as_cell_directions_on_every_cell() {
        let grids = [(90, 90, 180), (13, 17, 11), (1, 1, 1)];
        for dims in grids.map(|(a, b, c)| Dims::new(a, b, c).unwrap()) {
            let fast = CellDirections::new(dims);
            for x in 0..dims.cells() {
                let (i, j, k) = dims.unflatten(x);
                let (_, wi, wo, _) = cell_directions(dims, i, j, k);
                let (a, b) = fast.get(i, j, k);
                let bits = |v: Vec3| v.map(f64::to_bits);
                assert_eq!((bits(a), bits(b)), (bits(wi), bits(wo)), "cell {i} {j} {k}");
            }
        }
    }
}
