//! Resampling to a MERL table: the horizon mask, the clamp and its counts.

mod common;

use brdfkit_merl::{Dims, cell_directions};
use brdfkit_nbrdf::{HORIZON_Z, Nbrdf, clamp};

/// A grid with no cell exactly at grazing: (i/10)² + j/9 = 1 has no solution with
/// i < 10, j < 9, so the horizon test below cannot disagree by round-off.
fn small() -> Dims {
    Dims::new(10, 9, 12).unwrap()
}

#[test]
fn small_grid_mask_and_clamps() {
    // The RGL felt has negative values near grazing, so there are clamps to count.
    let net = Nbrdf::load(&common::material("rgl-isotropic", "acrylic_felt_green_rgb")).unwrap();
    let dims = small();
    let (table, st) = net.to_table(dims).unwrap();
    assert_eq!(st.cells, dims.cells());
    let (mut missing, mut clamped_values, mut clamped_cells) = (0, 0, 0);
    let mut most_negative = 0.0f64;
    for i in 0..dims.theta_h() {
        for j in 0..dims.theta_d() {
            for k in 0..dims.phi_d() {
                let c = dims.cell_angles(i, j, k);
                // The horizon from the angles directly (not through the directions):
                // wi.z = cos θh cos θd − sin θh sin θd cos φd, wo.z the same with +.
                let (a, b) = (
                    c.theta_h.cos() * c.theta_d.cos(),
                    c.theta_h.sin() * c.theta_d.sin() * c.phi_d.cos(),
                );
                let below = a - b <= HORIZON_Z || a + b <= HORIZON_Z;
                let got = table.get(i, j, k);
                if below {
                    missing += 1;
                    assert_eq!(got, None, "({i}, {j}, {k}) must be missing");
                    continue;
                }
                let raw = net.raw(c.theta_h, c.theta_d, c.phi_d);
                let neg = raw.0.iter().filter(|&&x| x < 0.0).count();
                clamped_values += neg;
                clamped_cells += usize::from(neg > 0);
                most_negative = raw.0.iter().fold(most_negative, |m, &x| m.min(x));
                let want = clamp(raw);
                let got = got.unwrap_or_else(|| panic!("({i}, {j}, {k}) must be valid"));
                for ch in 0..3 {
                    // Stored as value / scale, read back as raw × scale: within an ulp.
                    let (g, w) = (got.0[ch], want.0[ch]);
                    assert!(g >= 0.0);
                    assert!((g - w).abs() <= 2.0 * f64::EPSILON * w, "{g} vs {w}");
                }
            }
        }
    }
    assert_eq!(st.missing, missing);
    assert_eq!(st.clamped_values, clamped_values);
    assert_eq!(st.clamped_cells, clamped_cells);
    assert_eq!(st.most_negative, most_negative);
    assert_eq!(table.valid_count(), dims.cells() - missing);
    // Pinned, so a change of mask or clamp shows: 1,080 cells, 178 below the horizon,
    // one cell with one negative channel.
    assert_eq!(
        (st.cells, st.missing, st.clamped_cells, st.clamped_values),
        (1080, 178, 1, 1)
    );
}

/// The MERL grid: the README's 23.8 % missing, and the difference between its z ≤ 1e-12
/// rule and `cell_directions`' z > 0 flag.
#[test]
fn merl_grid_missing_fraction() {
    let net = Nbrdf::load(&common::material("merl", "gold-paint")).unwrap();
    let (table, st) = net.to_table(Dims::MERL).unwrap();
    assert_eq!(st.cells, 1_458_000);
    assert_eq!(table.valid_count(), st.cells - st.missing);
    assert_eq!(
        (1000.0 * st.missing_fraction()).round() / 10.0,
        23.8,
        "{st:?}"
    );
    // Cells the z > 0 flag keeps and the threshold drops: the exact-grazing ones.
    let d = Dims::MERL;
    let mut differ = Vec::new();
    for i in 0..d.theta_h() {
        for j in 0..d.theta_d() {
            for k in 0..d.phi_d() {
                let (_, wi, wo, above) = cell_directions(d, i, j, k);
                if above != (wi.z > HORIZON_Z && wo.z > HORIZON_Z) {
                    differ.push((i, j, k));
                }
            }
        }
    }
    assert_eq!(differ, [(30, 80, 0), (60, 50, 0)]);
    // 23.77 %; `MerlTable::from_brdf`'s mask (z > 0) would miss 346,568.
    assert_eq!(st.missing, 346_570, "{st:?}");
    eprintln!("gold-paint on the MERL grid: {st:?}");
}

/// A network that is −0.632 in red everywhere (zero weights, b3 = (−1, 0, 0.5)): every
/// valid cell clamps exactly one value.
#[test]
fn every_valid_cell_clamped() {
    use npyz::{WriteOptions, WriterBuilder};
    let d = tempfile::tempdir().unwrap();
    let stem = d.path().join("negative");
    let files = Nbrdf::files(&stem).unwrap();
    let parts: [(&[u64], Vec<f32>); 6] = [
        (&[6, 2], vec![0.0; 12]),
        (&[2], vec![0.0; 2]),
        (&[2, 2], vec![0.0; 4]),
        (&[2], vec![0.0; 2]),
        (&[2, 3], vec![0.0; 6]),
        (&[3], vec![-1.0, 0.0, 0.5]),
    ];
    for (f, (shape, data)) in files.iter().zip(parts) {
        let mut buf = Vec::new();
        let mut w = WriteOptions::new()
            .default_dtype()
            .shape(shape)
            .writer(&mut buf)
            .begin_nd()
            .unwrap();
        w.extend(data).unwrap();
        w.finish().unwrap();
        std::fs::write(f, buf).unwrap();
    }
    let net = Nbrdf::load(&stem).unwrap();
    let (table, st) = net.to_table(small()).unwrap();
    let valid = st.cells - st.missing;
    assert_eq!((st.clamped_cells, st.clamped_values), (valid, valid));
    assert_eq!(st.most_negative, (-1.0f64).exp_m1());
    let v = table.valid_cells().next().unwrap().value;
    assert_eq!(v.0[0], 0.0);
    assert!((v.0[2] - 0.5f64.exp_m1()).abs() < 1e-15);
}
