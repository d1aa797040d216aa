//! The cells of a fit: the in-place builders (`from_table`, `from_owned_table`) give
//! exactly the cells of an independent construction (every valid cell's directions
//! pushed into a `GeometryBatch`, its value and measure), the lazy angle and
//! multiplicity views hold what the old stored arrays held, and the stratified
//! subsample draws the same cells as the straightforward per-bin algorithm.

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
    assert_eq!(
        before,
        data.len() * 14 * 8,
        "14 columns of f64, nothing else"
    );
    let g = data.geometry();
    for m in 0..data.len() {
        assert_eq!(data.theta_h()[m], g.h_z[m].clamp(-1.0, 1.0).acos());
        assert_eq!(data.theta_d()[m], g.cos_d[m].clamp(-1.0, 1.0).acos());
    }
    assert!(data.multiplicity().iter().all(|&x| x == 1.0));
    assert_eq!(data.heap_bytes(), before + 3 * data.len() * 8);
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
