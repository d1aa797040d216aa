//! Resampling a network onto a MERL table.

use crate::error::NbrdfError;
use crate::net::{INPUTS, Nbrdf, clamp, input_sc};
use brdfkit_core::{Columns, Rgb};
use brdfkit_merl::{CellDirections, Dims, MerlTable};
use rayon::prelude::*;

/// A cell is missing when either of its directions has z at or below this: the rule of
/// the proxies' README (`../shared/measured-proxies/README.md`), which puts 23.8 % of
/// the MERL grid's cells below the horizon.
///
/// [`cell_directions`](brdfkit_merl::cell_directions)' own flag is z > 0; the two differ only on cells exactly at
/// grazing (θh + θd = π/2 at φd = 0), whose z is round-off either side of 0: the
/// threshold makes them missing whatever the round-off. On the MERL grid these are
/// cells (30, 80, 0) and (60, 50, 0), both of which the z > 0 flag keeps.
pub const HORIZON_Z: f64 = 1e-12;

/// What [`Nbrdf::to_table`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResampleStats {
    /// Cells of the grid.
    pub cells: usize,
    /// Cells marked missing (a direction at or below the horizon, [`HORIZON_Z`]).
    pub missing: usize,
    /// Channel values the network returned negative and the table holds as 0.
    pub clamped_values: usize,
    /// Valid cells with at least one clamped channel.
    pub clamped_cells: usize,
    /// The most negative value clamped, in 1/sr (0 when none was): how far below zero
    /// the fit went.
    pub most_negative: f64,
}

impl ResampleStats {
    /// Fraction of the cells that are missing.
    pub fn missing_fraction(&self) -> f64 {
        self.missing as f64 / self.cells as f64
    }
}

impl std::ops::Add for ResampleStats {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        ResampleStats {
            cells: self.cells + o.cells,
            missing: self.missing + o.missing,
            clamped_values: self.clamped_values + o.clamped_values,
            clamped_cells: self.clamped_cells + o.clamped_cells,
            most_negative: self.most_negative.min(o.most_negative),
        }
    }
}

impl Nbrdf {
    /// The network sampled onto a MERL-format table of `dims`, in parallel over θh
    /// slabs, each in blocks of [`LANES`](crate::LANES) cells.
    ///
    /// Cell (i, j, k) gets the network at its grid angles θh = (i/nθh)² · π/2,
    /// θd = j/nθd · π/2, φd = k/nφd · π (the lower bin edges, assigned by index: the
    /// angles and directions come from [`cell_directions`](brdfkit_merl::cell_directions), the table crate's
    /// definition). It is missing (raw −1) when either direction at those angles has
    /// z ≤ [`HORIZON_Z`]. Negative channels are clamped to 0 ([`clamp`]) and counted
    /// in the returned [`ResampleStats`].
    ///
    /// Fails only if a value is beyond the format's range (exp overflow, impossible for
    /// weights of a sane fit), naming the network.
    pub fn to_table(&self, dims: Dims) -> Result<(MerlTable, ResampleStats), NbrdfError> {
        let slab = dims.theta_d() * dims.phi_d();
        // (sin, cos) of each grid angle, once per row; the same angles as the cells'.
        let sc = |n: usize, angle: &dyn Fn(usize) -> f64| -> Vec<(f64, f64)> {
            (0..n).map(|x| angle(x).sin_cos()).collect()
        };
        let th = sc(dims.theta_h(), &|i| dims.cell_angles(i, 0, 0).theta_h);
        let td = sc(dims.theta_d(), &|j| dims.cell_angles(0, j, 0).theta_d);
        let pd = sc(dims.phi_d(), &|k| dims.cell_angles(0, 0, k).phi_d);
        // The horizon test on `cell_directions`' bits, from per-axis sines and cosines
        // in a vectorised row pass rather than three `sin_cos` calls a cell (a quarter
        // of a proxy's resampling).
        let dirs = CellDirections::new(dims);
        const MISSING: usize = usize::MAX;
        let slabs: Vec<(Vec<Rgb>, Vec<usize>, ResampleStats)> = (0..dims.theta_h())
            .into_par_iter()
            .map_init(
                || crate::net::Scratch::new(self),
                |s, i| {
                    let mut xs: Vec<[f64; INPUTS]> = Vec::with_capacity(slab);
                    let mut at: Vec<usize> = Vec::with_capacity(slab);
                    // Only wi.z and wo.z (columns 2 and 5) are computed and stored:
                    // the loop for that set skips the half vector's root and division.
                    let (mut wi_z, mut wo_z) = (vec![0.0; pd.len()], vec![0.0; pd.len()]);
                    for (j, &tdj) in td.iter().enumerate() {
                        // The eight other columns are not written: empty slices.
                        let [a, b, c, e, f, g, h, l] = [(); 8].map(|_| &mut [][..]);
                        let into = [a, b, &mut wi_z[..], c, e, &mut wo_z[..], f, g, h, l];
                        dirs.row_columns_of(Columns::WI_Z | Columns::WO_Z, i, j, 0..pd.len(), into);
                        for (k, &pdk) in pd.iter().enumerate() {
                            if wi_z[k] > HORIZON_Z && wo_z[k] > HORIZON_Z {
                                xs.push(input_sc(th[i], tdj, pdk));
                                at.push(k + dims.phi_d() * j);
                            }
                        }
                    }
                    let mut raw = vec![Rgb::ZERO; xs.len()];
                    self.raw_block_into(&xs, &mut raw, s);
                    // Each cell's position in `raw` (`MISSING` for none): 8 bytes a cell
                    // where a slab of `Option<Rgb>` took 32, fresh pages on every table.
                    let mut slot = vec![MISSING; slab];
                    let mut st = ResampleStats {
                        cells: slab,
                        missing: slab - xs.len(),
                        ..Default::default()
                    };
                    for (n, (&c, v)) in at.iter().zip(raw.iter_mut()).enumerate() {
                        let neg = v.0.iter().filter(|&&x| x < 0.0).count();
                        st.most_negative = v.0.iter().fold(st.most_negative, |m, &x| m.min(x));
                        st.clamped_values += neg;
                        st.clamped_cells += usize::from(neg > 0);
                        *v = clamp(*v);
                        slot[c] = n;
                    }
                    (raw, slot, st)
                },
            )
            .collect();
        let stats = slabs
            .iter()
            .fold(ResampleStats::default(), |a, (_, _, s)| a + *s);
        let table = MerlTable::from_fn(dims, |i, j, k| {
            let (vals, slot, _) = &slabs[i];
            let n = slot[k + dims.phi_d() * j];
            (n != MISSING).then(|| vals[n])
        })
        .map_err(|source| NbrdfError::Table {
            name: self.name().to_owned(),
            source,
        })?;
        Ok((table, stats))
    }
}
