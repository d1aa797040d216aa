//! The cells of a fit: the in-place builders (`from_table`, `from_owned_table`) give
//! exactly the cells of an independent construction (every valid cell's directions
//! pushed into a `GeometryBatch`, its value and measure), the lazy angle and
//! multiplicity views hold what the old stored arrays held, and the stratified
//! subsample draws the same cells as the straightforward per-bin algorithm; a table
//! file read straight into cells (`FitData::from_table_cells`) gives `from_table`'s
//! cells of the table read from it.

mod common;
use brdfkit_core::{GeometryBatch, Rgb};
use brdfkit_fit::data::STRATA;
use brdfkit_fit::{FitData, Weighting};
use brdfkit_merl::MerlTable;
use common::*;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::FRAC_PI_2;

const CT: &str = r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.15}}"#;

/// A table with the MERL horizon pattern and, on top, every 7th valid cell missing
/// (runs of valid cells of uneven length in every slab).
fn table() -> MerlTable {
    let d = dims(18, 15, 32);
    let mut t = MerlTable::from_brdf(model(CT).as_ref(), d).unwrap();
    for x in (0..d.cells()).step_by(7) {
        let (i, j, k) = d.unflatten(x);
        t.set(i, j, k, None).unwrap();
    }
    t
}

fn columns(g: &GeometryBatch) -> [&Vec<f64>; 10] {
    [
        &g.wi_x, &g.wi_y, &g.wi_z, &g.wo_x, &g.wo_y, &g.wo_z, &g.h_x, &g.h_y, &g.h_z, &g.cos_d,
    ]
}

/// Bitwise equality of two cell sets (columns, values, measures, multiplicities).
fn assert_same(a: &FitData, b: &FitData, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: cell count");
    for (c, (x, y)) in columns(a.geometry())
        .iter()
        .zip(columns(b.geometry()))
        .enumerate()
    {
        let same = x
            .iter()
            .zip(y.iter())
            .all(|(p, q)| p.to_bits() == q.to_bits());
        assert!(same && x.len() == y.len(), "{what}: geometry column {c}");
    }
    for c in 0..3 {
        assert_eq!(a.values()[c], b.values()[c], "{what}: channel {c}");
    }
    assert_eq!(a.measure(), b.measure(), "{what}: measures");
    assert_eq!(a.multiplicity(), b.multiplicity(), "{what}: multiplicities");
}

#[test]
fn table_builders_agree_with_an_independent_construction() {
    let t = table();
    assert!(
        t.valid_count() < t.cells() * 3 / 4,
        "the pattern leaves gaps"
    );
    // Reference: the valid cells one by one, as `GeometryBatch::push` stores them.
    let mut g = GeometryBatch::default();
    let (mut v, mut w): ([Vec<f64>; 3], Vec<f64>) = Default::default();
    for c in t.valid_cells() {
        g.push(&c.wi, &c.wo);
        for (ch, plane) in v.iter_mut().enumerate() {
            plane.push(c.value[ch]);
        }
        w.push(c.weight);
    }
    let reference = FitData::from_parts(g, v, w).unwrap();
    assert_eq!(reference.len(), t.valid_count());
    assert_same(&FitData::from_table(&t).unwrap(), &reference, "from_table");
    assert_same(
        &FitData::from_cell_batch(t.cell_batch()).unwrap(),
        &reference,
        "cell_batch",
    );
    let b = t.cell_batch();
    let idx: Vec<usize> = t.valid_cells().map(|c| c.index).collect();
    assert_eq!(b.indices, idx, "cell_batch indices");
    assert_same(
        &FitData::from_owned_table(t.clone()).unwrap(),
        &reference,
        "from_owned_table",
    );
    // No valid cell: a typed error, not a panic.
    let empty = MerlTable::all_missing(t.dims());
    assert!(FitData::from_table(&empty).is_err());
    assert!(FitData::from_owned_table(empty).is_err());
}

#[test]
fn lazy_views_hold_the_angles_and_unit_multiplicities() {
    let data = FitData::from_table(&table()).unwrap();
    let before = data.heap_bytes();
    // Values and measures, and the cells' grid runs (a few kB), not their geometry.
    let stored = data.len() * 4 * 8;
    assert!(
        before > stored && before < stored + 64 * 1024,
        "{before} bytes for {} cells",
        data.len()
    );
    // The angles are built without the whole-set geometry.
    let (th, td) = (data.theta_h().to_vec(), data.theta_d().to_vec());
    assert!(data.geometry_if_built().is_none());
    let with_angles = data.heap_bytes();
    assert_eq!(with_angles, before + 2 * data.len() * 8);
    let g = data.geometry();
    assert_eq!(data.heap_bytes(), with_angles + data.len() * 10 * 8);
    for m in 0..data.len() {
        assert_eq!(th[m], g.h_z[m].clamp(-1.0, 1.0).acos());
        assert_eq!(td[m], g.cos_d[m].clamp(-1.0, 1.0).acos());
    }
    let built = data.heap_bytes();
    assert!(data.multiplicity().iter().all(|&x| x == 1.0));
    assert_eq!(data.heap_bytes(), built + data.len() * 8);
    let w = data.weights(Weighting::SolidAngle);
    assert_eq!(w, data.measure());
    assert_eq!(data.weights(Weighting::Uniform), vec![1.0; data.len()]);
    // A subsample stores its multiplicities; a filter of a full set keeps them at 1.
    let s = data.stratified_subsample(0.2, 3);
    assert!(s.multiplicity().iter().any(|&x| x > 1.0));
    let f = data.filter(|m| m % 2 == 0);
    assert!(f.multiplicity().iter().all(|&x| x == 1.0));
    let fs = s.filter(|m| m % 2 == 0);
    let expect: Vec<f64> = s.multiplicity().iter().step_by(2).copied().collect();
    assert_eq!(fs.multiplicity(), &expect[..]);
}

/// The stratified draw written the plain way (one Vec of indices per bin), as it was
/// before the counting-sort version.
fn reference_subsample(data: &FitData, fraction: f64, seed: u64) -> (Vec<usize>, Vec<f64>) {
    let (th, td) = (data.theta_h(), data.theta_d());
    let mut bins: Vec<Vec<usize>> = vec![Vec::new(); STRATA * STRATA];
    for m in 0..data.len() {
        let a = ((th[m].max(0.0) / FRAC_PI_2).sqrt() * STRATA as f64) as usize;
        let b = ((td[m].max(0.0) / FRAC_PI_2) * STRATA as f64) as usize;
        bins[a.min(STRATA - 1) * STRATA + b.min(STRATA - 1)].push(m);
    }
    let mut picked: Vec<(usize, f64)> = Vec::new();
    for (b, cells) in bins.iter_mut().enumerate() {
        if cells.is_empty() {
            continue;
        }
        let n = cells.len();
        let take = ((fraction * n as f64).round() as usize).clamp(1, n);
        let mut rng =
            ChaCha8Rng::seed_from_u64(seed ^ (b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        cells.shuffle(&mut rng);
        for &m in &cells[..take] {
            picked.push((m, n as f64 / take as f64));
        }
    }
    picked.sort_by_key(|p| p.0);
    picked.into_iter().unzip()
}

#[test]
fn stratified_subsample_draws_the_reference_cells() {
    let data = FitData::from_table(&table()).unwrap();
    for (fraction, seed) in [(0.05, 1), (0.3, 77), (0.9, 5)] {
        let (idx, mult) = reference_subsample(&data, fraction, seed);
        let s = data.stratified_subsample(fraction, seed);
        assert_eq!(s.len(), idx.len(), "fraction {fraction}");
        assert_eq!(s.multiplicity(), &mult[..]);
        let g = data.geometry();
        let picked: Vec<f64> = idx.iter().map(|&m| g.h_z[m]).collect();
        assert_eq!(s.geometry().h_z, picked);
        let vals: Vec<f64> = idx.iter().map(|&m| data.values()[1][m]).collect();
        assert_eq!(s.values()[1], vals);
    }
    // Values of a model: the subsample's are the model's at its cells.
    let m = model(CT);
    let s = data.stratified_subsample(0.1, 2);
    let mut out = vec![Rgb::ZERO; s.len()];
    m.eval_batch(&s.geometry().as_slice(), &mut out);
    let mv = s.with_model_values(m.as_ref());
    assert!((0..s.len()).all(|k| mv.values()[0][k] == out[k][0]));
}

/// A table's cells hold their geometry as grid runs and compute it where read; every
/// way of reading it gives the bits of the whole-set columns, and those are the
/// independent construction's (each valid cell's directions from `cell_directions`,
/// pushed into a `GeometryBatch`) on a whole MERL grid: `geometry()` itself, chunks
/// (`geometry_of`) before anything is built, the strata and the subsample drawn from
/// them, a filtered set, the cube-root targets, model values and the loss report.
#[test]
fn a_tables_geometry_computed_where_read_is_the_materialised_one() {
    let mut t = MerlTable::from_brdf(model(CT).as_ref(), dims(90, 90, 180)).unwrap();
    // Some extra holes, so runs end mid-row.
    for x in (0..t.cells()).step_by(13) {
        let (i, j, k) = t.dims().unflatten(x);
        t.set(i, j, k, None).unwrap();
    }
    let lazy = FitData::from_table(&t).unwrap();
    let mut g = GeometryBatch::with_capacity(t.valid_count());
    for c in t.valid_cells() {
        g.push(&c.wi, &c.wo);
    }
    let given = FitData::from_parts(g, lazy.values().clone(), lazy.measure().to_vec()).unwrap();
    let bits = |s: brdfkit_core::GeomSlice<'_>| -> Vec<u64> {
        s.columns()
            .iter()
            .flat_map(|c| c.iter().map(|x| x.to_bits()))
            .collect()
    };
    let n = lazy.len();
    let whole = given.geometry();
    // Chunks of the pass size and an odd size, computed without building the columns.
    for size in [brdfkit_fit::data::PASS_CHUNK_CELLS, 1000] {
        let mut scratch = GeometryBatch::default();
        for s in (0..n).step_by(size) {
            let r = s..(s + size).min(n);
            let got = bits(lazy.geometry_of(r.clone(), &mut scratch));
            assert_eq!(got, bits(whole.slice(r.clone())), "cells {r:?}");
        }
    }
    let ct = model(CT);
    let ms = [ct.as_ref(); 3];
    let report = |d: &FitData| {
        format!(
            "{:?}",
            brdfkit_fit::evaluate_losses(ms, d, Weighting::SolidAngle)
        )
    };
    assert_eq!(report(&lazy), report(&given), "the loss report");
    assert_eq!(lazy.cbrt_targets(), given.cbrt_targets());
    assert_eq!(lazy.theta_d(), given.theta_d());
    assert_eq!(lazy.theta_h(), given.theta_h());
    let s_lazy = lazy.stratified_subsample(0.05, 11);
    assert_same(&s_lazy, &given.stratified_subsample(0.05, 11), "subsample");
    assert!(s_lazy.len() > 1000);
    assert_same(
        &lazy.with_model_values(ct.as_ref()),
        &given.with_model_values(ct.as_ref()),
        "model values",
    );
    assert_eq!(
        (0..n)
            .step_by(97)
            .map(|m| lazy.stratum_at(m))
            .collect::<Vec<_>>(),
        (0..n)
            .step_by(97)
            .map(|m| given.stratum_at(m))
            .collect::<Vec<_>>()
    );
    assert!(
        lazy.geometry_if_built().is_none(),
        "none of these passes builds the whole set"
    );
    // A filtered set (its geometry gathered cell by cell), then the whole set.
    let keep = |m: usize| m % 3 != 1 && !m.is_multiple_of(101);
    assert_same(&lazy.filter(keep), &given.filter(keep), "a filtered set");
    assert!(lazy.geometry_if_built().is_none());
    assert_same(&lazy, &given, "the whole table");
    assert!(lazy.geometry_if_built().is_some());
}

/// The ten columns of the cells `r`, computed ([`FitData::geometry_of`]) and copied.
fn chunk_copy(d: &FitData, r: std::ops::Range<usize>) -> GeometryBatch {
    let mut scratch = GeometryBatch::default();
    let g = d.geometry_of(r, &mut scratch);
    let mut cols = g.columns().into_iter();
    GeometryBatch::from_column_fn(|| cols.next().unwrap().to_vec())
}

/// The loss report's bits under every reading of a table's geometry: computed where
/// read with only the columns the losses and the models declare
/// (`Model::geometry_columns`: Lambert's two cosines, Oren-Nayar's directions), and
/// sliced from the whole columns; each loss set, with the cube-root targets built
/// and not, for one model and per-channel models; and the ten-column chunk of a
/// column set holds that set's bits, NaN in the others.
#[test]
fn a_report_from_the_columns_it_reads_is_the_whole_columns_report() {
    let lazy = FitData::from_table(&table()).unwrap();
    let whole = chunk_copy(&lazy, 0..lazy.len());
    let given = FitData::from_parts(whole, lazy.values().clone(), lazy.measure().to_vec()).unwrap();
    let fresh = || FitData::from_table(&table()).unwrap();
    let names = ["lambert", "oren-nayar", "cook-torrance", "ward"];
    let models: Vec<_> = names
        .iter()
        .map(|n| brdfkit_models::default_model(n).unwrap())
        .collect();
    let on = |a: &dyn brdfkit_core::Model, b: &dyn brdfkit_core::Model, d: &FitData, set| {
        let r = brdfkit_fit::evaluate_losses_of([a, b, a], d, Weighting::SolidAngle, set);
        format!("{r:?}")
    };
    for set in brdfkit_fit::LossSet::ALL {
        for (a, b) in [(0, 0), (1, 1), (0, 1), (2, 3), (3, 0)] {
            let (a, b) = (models[a].as_ref(), models[b].as_ref());
            let want = on(a, b, &given, set);
            let lazy_now = fresh();
            assert_eq!(
                on(a, b, &lazy_now, set),
                want,
                "{} {} {set:?}",
                a.name(),
                b.name()
            );
            lazy_now.cbrt_targets();
            assert_eq!(on(a, b, &lazy_now, set), want, "with the cube roots built");
            assert!(lazy_now.geometry_if_built().is_none());
        }
    }
    // A subsample's report (multiplicities, given columns) from either.
    let (sl, sg) = (
        lazy.stratified_subsample(0.1, 5),
        given.stratified_subsample(0.1, 5),
    );
    assert_eq!(
        on(
            models[0].as_ref(),
            models[0].as_ref(),
            &sl,
            brdfkit_fit::LossSet::All
        ),
        on(
            models[0].as_ref(),
            models[0].as_ref(),
            &sg,
            brdfkit_fit::LossSet::All
        )
    );
    // The chunks of a column set: what the report reads with each model, the strata's
    // cosines, and each column alone.
    use brdfkit_core::Columns;
    let mut sets: Vec<Columns> = brdfkit_models::MODEL_NAMES
        .iter()
        .map(|n| {
            let m = brdfkit_models::default_model(n).unwrap();
            m.geometry_columns() | Columns::WI_Z | Columns::WO_Z
        })
        .collect();
    sets.push(Columns::H_Z | Columns::COS_D);
    sets.extend((0..10).map(|c| Columns::from_bits(1 << c)));
    let mut scratch = brdfkit_fit::data::ChunkGeometry::default();
    for set in sets {
        for r in [0..2048, 2048..2100, 5..6, 1000..3048] {
            let got = lazy.columns_of(r.clone(), set, &mut scratch);
            let want = given.geometry().slice(r.clone());
            for (c, (x, y)) in got.columns().iter().zip(want.columns()).enumerate() {
                assert_eq!(x.len(), r.len());
                for (p, q) in x.iter().zip(y) {
                    if set.has(c) {
                        assert_eq!(p.to_bits(), q.to_bits(), "{set:?} column {c} cells {r:?}");
                    } else {
                        assert!(p.is_nan(), "{set:?}: column {c} not read is NaN");
                    }
                }
            }
        }
    }
}

/// Every model that declares the geometry columns it reads
/// (`Model::geometry_columns`) gives the same bits, value and gradient, from those
/// columns alone (the others NaN) as from all ten.
#[test]
fn a_model_reads_only_the_columns_it_declares() {
    let lazy = FitData::from_table(&table()).unwrap();
    let n = lazy.len().min(4096);
    let full = chunk_copy(&lazy, 0..n);
    let mut declaring = 0;
    for name in brdfkit_models::MODEL_NAMES {
        let m = brdfkit_models::default_model(name).unwrap();
        let set = m.geometry_columns();
        if set == brdfkit_core::Columns::ALL {
            continue;
        }
        declaring += 1;
        let mut scratch = brdfkit_fit::data::ChunkGeometry::default();
        let part = lazy.columns_of(0..n, set, &mut scratch);
        let np = m.num_params();
        let run = |g: &brdfkit_core::GeomSlice<'_>| {
            let (mut out, mut out2) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
            let mut grad = vec![Rgb::ZERO; np * n];
            m.eval_batch(g, &mut out);
            m.eval_grad_batch(g, &mut out2, &mut grad);
            let bits = |v: &[Rgb]| -> Vec<u64> {
                v.iter()
                    .flat_map(|x| [x[0], x[1], x[2]])
                    .map(f64::to_bits)
                    .collect()
            };
            (bits(&out), bits(&out2), bits(&grad))
        };
        assert_eq!(
            run(&part),
            run(&full.as_slice()),
            "{name} reads a column it does not declare"
        );
    }
    assert!(declaring >= 2, "lambert and oren-nayar declare theirs");
}

/// A default fit of a table's cells (the command line's settings: the warm-up
/// optimum evaluated on all cells, no iteration there) never builds their whole-set
/// geometry: the subsamples, the targets' RMS and the loss report compute it chunk by
/// chunk.
#[test]
fn a_default_fit_does_not_build_the_tables_geometry() {
    let t = MerlTable::from_brdf(model(CT).as_ref(), dims(90, 90, 180)).unwrap();
    let data = FitData::from_table(&t).unwrap();
    let start = brdfkit_models::default_model("cook-torrance").unwrap();
    let config = brdfkit_fit::families::FitSettings::default()
        .config()
        .unwrap();
    let r = brdfkit_fit::fit(start.as_ref(), &data, &config, None).unwrap();
    assert!(r.record.losses_full.get(brdfkit_fit::Loss::Cbrt).overall < 1e-3);
    assert!(data.geometry_if_built().is_none());
}

/// The stratum by the formula, through `acos` (what `stratum_at` computed per cell
/// before it compared cosines with the bins' edges).
fn stratum_by_acos(h_z: f64, cos_d: f64) -> usize {
    let (th, td) = (h_z.clamp(-1.0, 1.0).acos(), cos_d.clamp(-1.0, 1.0).acos());
    let a = ((th.max(0.0) / FRAC_PI_2).sqrt() * STRATA as f64) as usize;
    let b = ((td.max(0.0) / FRAC_PI_2) * STRATA as f64) as usize;
    a.min(STRATA - 1) * STRATA + b.min(STRATA - 1)
}

/// The strata from the edges' cosines are the formula's bins on every cell of a full
/// MERL grid (90 × 90 × 180, the measured tables' cells), beside every edge (the
/// cosines one ulp either side of each θ bin edge's), and outside [−1, 1] and NaN.
#[test]
fn strata_from_edges_are_the_formula_s_bins() {
    let lambert = model(r#"{"model":"lambert","params":{"rho_d":[0.5,0.5,0.5]}}"#);
    let t = MerlTable::from_brdf(lambert.as_ref(), dims(90, 90, 180)).unwrap();
    let data = FitData::from_table(&t).unwrap();
    let g = data.geometry();
    for m in 0..data.len() {
        assert_eq!(
            data.stratum_at(m),
            stratum_by_acos(g.h_z[m], g.cos_d[m]),
            "cell {m}"
        );
    }
    // Cells at and beside each edge: cosines of the θ edges, stepped by ulps.
    let mut zs = vec![-1.5, -1.0, 1.0, 1.5, f64::NAN, 0.0, -0.0];
    for e in 1..STRATA {
        let f = e as f64 / STRATA as f64;
        for theta in [f * f * FRAC_PI_2, f * FRAC_PI_2] {
            let mut z = theta.cos();
            for _ in 0..4 {
                z = z.next_down();
            }
            for _ in 0..9 {
                zs.push(z);
                z = z.next_up();
            }
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    zs.extend((0..5_000).map(|_| rand::Rng::random_range(&mut rng, -1.0..=1.0)));
    let n = zs.len();
    let mut gb = GeometryBatch::zeroed(n * n.min(64));
    let mut cells = Vec::new();
    for (p, &hz) in zs.iter().enumerate() {
        for q in 0..n.min(64) {
            let dz = zs[(p * 31 + q * 17) % n];
            cells.push((hz, dz));
        }
    }
    gb.h_z = cells.iter().map(|c| c.0).collect();
    gb.cos_d = cells.iter().map(|c| c.1).collect();
    let len = cells.len();
    let ones = vec![1.0; len];
    let d = FitData::from_parts(gb, [ones.clone(), ones.clone(), ones.clone()], ones).unwrap();
    for (m, &(hz, dz)) in cells.iter().enumerate() {
        assert_eq!(
            d.stratum_at(m),
            stratum_by_acos(hz, dz),
            "h_z {hz:e}, cos_d {dz:e}"
        );
    }
}

/// `Measured::read` reads a MERL table file straight into the table (positional reads,
/// no copy of the whole file): the same cells, bit for bit, as parsing the file's
/// bytes, the same table when it is kept, and for a damaged file the same error,
/// naming the file.
#[test]
fn reading_a_table_file_gives_the_cells_of_its_bytes() {
    use brdfkit_fit::{BsdfInput, Measured, MeasuredSide};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.binary");
    let t = table();
    t.write(&path).unwrap();
    let how = BsdfInput::Points;
    let bytes = std::fs::read(&path).unwrap();
    let read = Measured::read(&path, how, false).unwrap();
    let parsed = Measured::from_bytes(bytes.clone(), &path, how, false).unwrap();
    assert_same(&read.data, &parsed.data, "read against from_bytes");
    assert_same(
        &read.data,
        &FitData::from_table(&t).unwrap(),
        "read against the table",
    );
    assert_eq!(read.kind(), "table");
    match Measured::read(&path, how, true).unwrap().side {
        MeasuredSide::Table {
            table: Some(kept),
            resampled_from_bsdf: None,
        } => assert_eq!(kept, t),
        _ => panic!("the table is kept"),
    }
    // One value short, and one value bad: the table reader's errors either way.
    let short = &bytes[..bytes.len() - 8];
    let mut nan = bytes.clone();
    nan[12 + 8 * 40..12 + 8 * 41].copy_from_slice(&f64::NAN.to_le_bytes());
    for damaged in [short, &nan[..]] {
        std::fs::write(&path, damaged).unwrap();
        let e = Measured::read(&path, how, false).err().expect("an error");
        let e2 = Measured::from_bytes(damaged.to_vec(), &path, how, false)
            .err()
            .expect("an error");
        assert_eq!(e.to_string(), e2.to_string());
        assert!(e.to_string().contains("t.binary"), "{e}");
    }
}

/// A table file's cells read without a table (`TableCells`, the planes turned in place
/// into the cells' arrays) are `from_table`'s cells of the table read from the file,
/// bit for bit, on the test table and on a MERL-sized one of a measured-like model; a
/// file without a valid cell is a typed error naming the file, through `Measured` as
/// through `from_table`.
#[test]
fn table_cells_read_from_a_file_are_the_tables_cells() {
    use brdfkit_fit::{BsdfInput, Measured};
    use brdfkit_merl::{Dims, TableCells};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.binary");
    let merl = MerlTable::from_brdf(model(CT).as_ref(), Dims::MERL).unwrap();
    for t in [table(), merl] {
        t.write(&path).unwrap();
        let direct = FitData::from_table_cells(TableCells::read(&path).unwrap()).unwrap();
        let through = FitData::from_table(&MerlTable::read(&path).unwrap()).unwrap();
        assert!(
            direct.geometry_if_built().is_none(),
            "the geometry stays lazy"
        );
        assert_same(&direct, &through, "from_table_cells against from_table");
        assert!(
            direct.heap_bytes() <= through.heap_bytes(),
            "{} bytes against {}",
            direct.heap_bytes(),
            through.heap_bytes()
        );
    }
    MerlTable::all_missing(dims(6, 5, 8)).write(&path).unwrap();
    assert!(FitData::from_table_cells(TableCells::read(&path).unwrap()).is_err());
    let e = Measured::read(&path, BsdfInput::Points, false)
        .err()
        .expect("no valid cell");
    assert!(
        e.to_string().contains("t.binary") && e.to_string().contains("no valid cell"),
        "{e}"
    );
}

/// A table's strata found row by row (`FitData::strata` on a table's cells) are every
/// cell's own (`stratum_at`, from its computed cosines), on a whole MERL grid with
/// every cell valid and on the gapped test table, and equal to the strata of the same
/// cells with their geometry given as columns (the chunk-by-chunk path); the subsample
/// drawn from them is the reference draw.
#[test]
fn row_by_row_strata_are_every_cells_own() {
    use brdfkit_merl::Dims;
    let all = MerlTable::from_fn(Dims::MERL, |_, _, _| Some(Rgb::new(0.1, 0.2, 0.3))).unwrap();
    for t in [all, table()] {
        let d = FitData::from_table(&t).unwrap();
        let ids = d.strata();
        assert!(
            d.geometry_if_built().is_none(),
            "row by row, not from the columns"
        );
        let own: Vec<u8> = (0..d.len()).map(|m| d.stratum_at(m) as u8).collect();
        assert_eq!(ids, own);
        let given = FitData::from_parts(
            d.geometry().clone(),
            d.values().clone(),
            d.measure().to_vec(),
        )
        .unwrap();
        assert_eq!(given.strata(), own);
        let (idx, mult) = reference_subsample(&d, 0.05, 11);
        let s = d.stratified_subsample(0.05, 11);
        assert_eq!(s.multiplicity(), &mult[..]);
        assert_eq!(
            s.values()[0],
            idx.iter().map(|&m| d.values()[0][m]).collect::<Vec<f64>>()
        );
    }
}
