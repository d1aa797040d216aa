//! Checks of a measured table ([`MerlTable`]).
//!
//! Reciprocity and isotropy are built into the MERL grid (φd is stored modulo π, and φh
//! is dropped), so they are not measured. What is:
//!
//! - **Coverage**: missing cells, split by whether the cell's directions (at its corner
//!   angles, the rule that masks MERL files) are above the horizon. Missing cells below
//!   the horizon are expected; missing cells above it are holes in the measurement, and
//!   more than `missing_above` of the above-horizon cells fails.
//! - **Negative values**: a negative raw value marks a missing sample; a cell with
//!   some channels negative and others not is no marker but bad data (the table treats
//!   it as missing). Any such cell fails.
//! - **Finiteness**: every raw value finite (the reader already rejects NaN and
//!   infinity; the scan makes the report self-contained).
//! - **Energy**: the directional albedo a(θo) = ∫ f(wi, wo) cos θi dωi with wo at
//!   (θo, φo = 0), by [`brdfkit_core::quadrature::directional_albedo`] over the table's
//!   lookups, about the best-converged pole as in
//!   [`crate::physical::albedo_converged`]. Missing lookups
//!   are filled with the cosine-weighted mean of the valid ones (the policy of
//!   [`MerlTable::albedo`]): a = π ∫ f·v cos θi dωi / ∫ v cos θi dωi, v the validity
//!   indicator, each integral by the same rule. Fine rule versus default rule gives the
//!   convergence estimate; the verdict is as for a model.

use crate::physical::{PoleChoice, QuadPole, auto_pole, converged_with};
use crate::report::{Verdict, deg, num, rgb};
use brdfkit_core::direction::spherical;
use brdfkit_core::quadrature::AlbedoQuadrature;
use brdfkit_core::{Brdf, Rgb, Vec3};
use brdfkit_merl::{Lookup, MerlTable, cell_directions};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The limits of the table checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableThresholds {
    /// Largest fraction of above-horizon cells allowed to be missing.
    pub missing_above: f64,
    /// Largest albedo allowed is 1 + `energy`.
    pub energy: f64,
    /// Largest |fine − default| albedo difference for a converged estimate.
    pub convergence: f64,
}

impl Default for TableThresholds {
    /// 1 % holes; albedo ≤ 1 + 1e-3; convergence 1e-2. A table is piecewise
    /// multilinear, so its albedo converges only algebraically near a sharp peak: the
    /// convergence bound is looser than for a model, and so is the energy bound (a
    /// measured table carries noise and calibration error of this order).
    fn default() -> Self {
        TableThresholds {
            missing_above: 0.01,
            energy: 1e-3,
            convergence: 1e-2,
        }
    }
}

/// What the table checks run over.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableCheckOptions {
    /// The pass/fail thresholds.
    pub thresholds: TableThresholds,
    /// Polar angles (radians) of the albedo curve.
    pub albedo_thetas: Vec<f64>,
    /// How the table is read at the quadrature nodes.
    #[serde(with = "lookup_name")]
    pub lookup: Lookup,
}

impl Default for TableCheckOptions {
    /// Albedo at 0, 10, …, 80, 85, 88, 89° (the last θh bin of MERL reaches 89.0°;
    /// beyond it every lookup is extrapolated), interpolated lookups.
    fn default() -> Self {
        TableCheckOptions {
            thresholds: TableThresholds::default(),
            albedo_thetas: [
                0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0, 88.0, 89.0,
            ]
            .iter()
            .map(|d: &f64| d.to_radians())
            .collect(),
            lookup: Lookup::Interpolated,
        }
    }
}

mod lookup_name {
    use brdfkit_merl::Lookup;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(l: &Lookup, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match l {
            Lookup::Nearest => "nearest",
            Lookup::Interpolated => "interpolated",
        })
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Lookup, D::Error> {
        match String::deserialize(d)?.as_str() {
            "nearest" => Ok(Lookup::Nearest),
            "interpolated" => Ok(Lookup::Interpolated),
            other => Err(serde::de::Error::custom(format!(
                "unknown lookup `{other}` (known: nearest, interpolated)"
            ))),
        }
    }
}

/// Missing cells.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoverageCheck {
    /// Pass when the holes above the horizon are within the threshold.
    pub verdict: Verdict,
    /// Cells of the table.
    pub cells: usize,
    /// Missing cells (every channel negative).
    pub missing: usize,
    /// missing / cells.
    pub missing_fraction: f64,
    /// Cells whose directions are above the horizon.
    pub above_horizon: usize,
    /// Of those, missing ones (holes in the measurement).
    pub missing_above: usize,
    /// missing_above / above_horizon.
    pub missing_above_fraction: f64,
    /// Cells below the horizon that hold a value anyway (not an error; MERL files have
    /// none).
    pub valid_below: usize,
}

/// Negative values that are not missing-sample markers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NegativeCheck {
    /// Pass when no cell is partially negative.
    pub verdict: Verdict,
    /// Cells with every channel negative: missing-sample markers.
    pub markers: usize,
    /// Cells with some channels negative and some not.
    pub partially_negative: usize,
    /// The first such cell (i, j, k) and its raw values.
    pub first: Option<([usize; 3], [f64; 3])>,
}

/// No NaN or infinity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableFinitenessCheck {
    /// Pass when every value is finite.
    pub verdict: Verdict,
    /// Raw values scanned (3 × cells).
    pub values: usize,
    /// Raw values that are NaN or infinite.
    pub nonfinite: usize,
}

/// The albedo at one outgoing angle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableAlbedoPoint {
    /// θo (radians), φo = 0.
    pub theta: f64,
    /// Fine rule; `None` when no node found a sample.
    pub albedo: Option<Rgb>,
    /// Fraction of the cosine-weighted hemisphere whose lookups were missing.
    pub missing_weight: f64,
    /// The quadrature pole used.
    pub pole: QuadPole,
    /// max over channels of |fine − default|.
    pub convergence: f64,
}

/// Albedo ≤ 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableEnergyCheck {
    /// Pass when the largest albedo is within the threshold.
    pub verdict: Verdict,
    /// Largest albedo over the curve and channels.
    pub max_albedo: f64,
    /// θo of the maximum (radians).
    pub max_theta: f64,
    /// Largest convergence estimate over the curve (max over channels of |fine − default|).
    pub convergence: f64,
    /// The albedo curve.
    pub curve: Vec<TableAlbedoPoint>,
}

/// Every check of one table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableReport {
    /// (nθh, nθd, nφd).
    pub dims: [usize; 3],
    /// Cells holding a sample.
    pub valid: usize,
    /// The thresholds the verdicts used.
    pub thresholds: TableThresholds,
    /// `"nearest"` or `"interpolated"`.
    pub lookup: String,
    /// Missing cells.
    pub coverage: CoverageCheck,
    /// Negative values that are not missing-sample markers.
    pub negative: NegativeCheck,
    /// No NaN or infinity.
    pub finiteness: TableFinitenessCheck,
    /// Albedo ≤ 1.
    pub energy: TableEnergyCheck,
    /// All checks passed.
    pub passed: bool,
}

/// A table read as a BRDF: missing lookups give 0 (`valid = false`), or the validity
/// indicator itself (`indicator = true`).
struct TableBrdf<'a> {
    t: &'a MerlTable,
    mode: Lookup,
    indicator: bool,
}

impl Brdf for TableBrdf<'_> {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        match self.t.lookup(self.mode, wi, wo) {
            Some(_) if self.indicator => Rgb::splat(1.0 / PI),
            Some(f) => f,
            None => Rgb::ZERO,
        }
    }
}

/// The table read as a BRDF (missing lookups 0), for the pole's first guess.
pub(crate) fn table_brdf(t: &MerlTable, mode: Lookup) -> impl Brdf + '_ {
    TableBrdf {
        t,
        mode,
        indicator: false,
    }
}

/// Albedo of the table at θo with the given rule: (filled albedo, missing weight).
///
/// Two integrals over the same nodes: the table's values, and the validity indicator
/// (the valid fraction of the cosine-weighted hemisphere), both from one lookup per
/// node, a ring of nodes at a time ([`crate::rings::table_albedo_sums`]: the bits of
/// [`directional_albedo`] over [`TableBrdf`] with and without `indicator`).
pub(crate) fn table_albedo(
    t: &MerlTable,
    mode: Lookup,
    wo: &Vec3,
    q: &AlbedoQuadrature,
) -> (Option<Rgb>, f64) {
    let s = crate::rings::table_albedo_sums(t, mode, wo, q);
    // ∫ (v/π) cos θi dωi: the valid fraction of the cosine-weighted hemisphere.
    let v = s.valid;
    if v > 0.0 {
        (Some(s.f / v), (1.0 - v).max(0.0))
    } else {
        (None, 1.0)
    }
}

/// Runs every table check with the default options.
pub fn check_table(t: &MerlTable) -> TableReport {
    check_table_with(t, &TableCheckOptions::default())
}

/// The counts of one pass over the cells: coverage, negatives, finiteness.
#[derive(Default, Clone)]
struct CellCounts {
    missing: usize,
    above: usize,
    missing_above: usize,
    valid_below: usize,
    markers: usize,
    partial: usize,
    /// The first partially negative cell (index, values): the smallest index, whatever
    /// the order the threads met them in.
    first: Option<(usize, [f64; 3])>,
    nonfinite: usize,
}

impl CellCounts {
    fn add_cell(mut self, t: &MerlTable, idx: usize) -> Self {
        let (n, raw, dims) = (t.cells(), t.raw(), t.dims());
        let r = [raw[idx], raw[n + idx], raw[2 * n + idx]];
        self.nonfinite += r.iter().filter(|x| !x.is_finite()).count();
        let negs = r.iter().filter(|x| **x < 0.0).count();
        let (i, j, k) = dims.unflatten(idx);
        let (_, _, _, above) = cell_directions(dims, i, j, k);
        self.above += above as usize;
        if !t.is_valid(idx) {
            self.missing += 1;
            self.missing_above += above as usize;
        } else if !above {
            self.valid_below += 1;
        }
        if negs == 3 {
            self.markers += 1;
        } else if negs > 0 {
            self.partial += 1;
            if self.first.is_none_or(|(f, _)| idx < f) {
                self.first = Some((idx, r));
            }
        }
        self
    }

    fn merge(mut self, b: Self) -> Self {
        self.missing += b.missing;
        self.above += b.above;
        self.missing_above += b.missing_above;
        self.valid_below += b.valid_below;
        self.markers += b.markers;
        self.partial += b.partial;
        self.nonfinite += b.nonfinite;
        self.first = match (self.first, b.first) {
            (Some(x), Some(y)) => Some(if x.0 <= y.0 { x } else { y }),
            (x, y) => x.or(y),
        };
        self
    }

    /// One parallel pass over the cells.
    fn of(t: &MerlTable) -> Self {
        (0..t.cells())
            .into_par_iter()
            .with_min_len(4096)
            .fold(CellCounts::default, |a, idx| a.add_cell(t, idx))
            .reduce(CellCounts::default, CellCounts::merge)
    }
}

/// Runs every table check.
pub fn check_table_with(t: &MerlTable, o: &TableCheckOptions) -> TableReport {
    let dims = t.dims();
    let n = t.cells();
    let acc = CellCounts::of(t);
    let th = &o.thresholds;
    let frac = |a: usize, b: usize| if b > 0 { a as f64 / b as f64 } else { 0.0 };
    let missing_above_fraction = frac(acc.missing_above, acc.above);
    let coverage = CoverageCheck {
        verdict: Verdict::from_bool(acc.above > 0 && missing_above_fraction <= th.missing_above),
        cells: n,
        missing: acc.missing,
        missing_fraction: frac(acc.missing, n),
        above_horizon: acc.above,
        missing_above: acc.missing_above,
        missing_above_fraction,
        valid_below: acc.valid_below,
    };
    let negative = NegativeCheck {
        verdict: Verdict::from_bool(acc.partial == 0),
        markers: acc.markers,
        partially_negative: acc.partial,
        first: acc.first.map(|(idx, r)| {
            let (i, j, k) = dims.unflatten(idx);
            ([i, j, k], r)
        }),
    };
    let finiteness = TableFinitenessCheck {
        verdict: Verdict::from_bool(acc.nonfinite == 0),
        values: 3 * n,
        nonfinite: acc.nonfinite,
    };
    let energy = energy_check(t, o);
    let passed = coverage.verdict.passed()
        && negative.verdict.passed()
        && finiteness.verdict.passed()
        && energy.verdict.passed();
    TableReport {
        dims: [dims.theta_h(), dims.theta_d(), dims.phi_d()],
        valid: t.valid_count(),
        thresholds: th.clone(),
        lookup: match o.lookup {
            Lookup::Nearest => "nearest",
            Lookup::Interpolated => "interpolated",
        }
        .into(),
        coverage,
        negative,
        finiteness,
        energy,
        passed,
    }
}

/// The table's directional albedo at each of `o.albedo_thetas`, converged, against the
/// energy bound: inconclusive when the quadrature did not converge enough to decide.
fn energy_check(t: &MerlTable, o: &TableCheckOptions) -> TableEnergyCheck {
    let th = &o.thresholds;
    let curve: Vec<TableAlbedoPoint> = o
        .albedo_thetas
        .par_iter()
        .map(|&theta| {
            let wo = spherical(theta, 0.0);
            let guess = auto_pole(
                &TableBrdf {
                    t,
                    mode: o.lookup,
                    indicator: false,
                },
                &wo,
            );
            let good_enough = 1e-2 * th.convergence;
            let (_, pole, convergence, (albedo, missing_weight)) =
                converged_with(&wo, PoleChoice::Auto, good_enough, guess, |q| {
                    let (a, m) = table_albedo(t, o.lookup, &wo, q);
                    // No sample at all: an unbounded convergence estimate.
                    (a.unwrap_or(Rgb::splat(f64::NAN)), (a, m))
                });
            TableAlbedoPoint {
                theta,
                albedo,
                missing_weight,
                pole,
                convergence,
            }
        })
        .collect();
    let mut max = (f64::NEG_INFINITY, 0.0);
    let mut conv: f64 = 0.0;
    for p in &curve {
        if let Some(a) = p.albedo
            && a.max_channel() > max.0
        {
            max = (a.max_channel(), p.theta);
        }
        conv = conv.max(p.convergence);
    }
    let found = (max.0 != f64::NEG_INFINITY).then_some(max.0);
    let verdict = Verdict::of_energy(found, conv, th.energy, th.convergence);
    TableEnergyCheck {
        verdict,
        max_albedo: max.0,
        max_theta: max.1,
        convergence: conv,
        curve,
    }
}

impl TableReport {
    /// The report as indented text.
    pub fn to_text(&self) -> String {
        let th = &self.thresholds;
        let mut s = format!(
            "table checks ({} x {} x {}, {} valid cells): {}\n",
            self.dims[0],
            self.dims[1],
            self.dims[2],
            self.valid,
            if self.passed { "PASS" } else { "FAIL" }
        );
        s += "  reciprocity     built into the grid (φd stored modulo π); isotropy likewise (no φh)\n";
        let c = &self.coverage;
        s += &format!(
            "  coverage        {:<12} {} of {} cells missing ({:.2} %); above the horizon {} of {} missing ({:.4} %, threshold {:.2} %); {} valid cells below the horizon\n",
            c.verdict.label(),
            c.missing,
            c.cells,
            100.0 * c.missing_fraction,
            c.missing_above,
            c.above_horizon,
            100.0 * c.missing_above_fraction,
            100.0 * th.missing_above,
            c.valid_below
        );
        let n = &self.negative;
        s += &format!(
            "  negative values {:<12} {} partially negative cells (threshold 0); {} missing-sample markers\n",
            n.verdict.label(),
            n.partially_negative,
            n.markers
        );
        if let Some((ijk, r)) = &n.first {
            s += &format!(
                "                  first at cell {:?}: raw [{}, {}, {}]\n",
                ijk,
                num(r[0]),
                num(r[1]),
                num(r[2])
            );
        }
        let f = &self.finiteness;
        s += &format!(
            "  finiteness      {:<12} {} non-finite of {} raw values\n",
            f.verdict.label(),
            f.nonfinite,
            f.values
        );
        let e = &self.energy;
        s += &format!(
            "  energy          {:<12} max albedo {} at θo = {}, convergence {} (threshold ≤ 1 + {}, convergence ≤ {}; {} lookups)\n",
            e.verdict.label(),
            num(e.max_albedo),
            deg(e.max_theta.to_degrees()),
            num(e.convergence),
            num(th.energy),
            num(th.convergence),
            self.lookup
        );
        s += "  albedo curve a(θo) = ∫f cosθi dωi (fine rule, missing lookups filled with the mean):\n";
        s += "      θo     albedo [R, G, B]                missing weight  pole    convergence\n";
        for p in &e.curve {
            s += &format!(
                "    {:>7}  {:<31} {:<15} {:<7} {}\n",
                deg(p.theta.to_degrees()),
                p.albedo.as_ref().map(rgb).unwrap_or_else(|| "none".into()),
                num(p.missing_weight),
                match p.pole {
                    QuadPole::Mirror => "mirror",
                    QuadPole::Retro => "retro",
                    QuadPole::Normal => "normal",
                },
                num(p.convergence)
            );
        }
        s
    }
}

crate::report::display_as_text!(TableReport);

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_core::quadrature::directional_albedo;
    use brdfkit_merl::Dims;

    /// The one-pass value and indicator integrals are the two looked-up ones to the
    /// bit.
    #[test]
    fn table_albedo_matches_two_lookup_passes() {
        let dims = Dims::new(16, 16, 32).unwrap();
        // Holes in the table, so the indicator is not 1 wherever a direction is up.
        let t = MerlTable::from_fn(dims, |i, j, k| {
            let (_, _, _, up) = cell_directions(dims, i, j, k);
            (up && (i + j + k) % 7 != 0).then_some(Rgb([0.1 + i as f64 * 0.01, 0.2, 0.3]))
        })
        .unwrap();
        let mut holes = false;
        for mode in [Lookup::Nearest, Lookup::Interpolated] {
            for theta in [0.0f64, 0.7, 1.4] {
                let wo = spherical(theta, 0.3);
                let q = AlbedoQuadrature::default();
                let (a, m) = table_albedo(&t, mode, &wo, &q);
                let f = directional_albedo(
                    &TableBrdf {
                        t: &t,
                        mode,
                        indicator: false,
                    },
                    &wo,
                    &q,
                );
                let v = directional_albedo(
                    &TableBrdf {
                        t: &t,
                        mode,
                        indicator: true,
                    },
                    &wo,
                    &q,
                )
                .r();
                assert!(v > 0.0, "{v}");
                holes |= v < 1.0 - 1e-6;
                assert_eq!(a, Some(f / v));
                assert_eq!(m, (1.0 - v).max(0.0));
            }
        }
        assert!(holes, "some integral must cross the holes");
    }
}
