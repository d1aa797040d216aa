//! Prints the worked examples and measured facts of `docs/merl-format.md`.
//!
//! `cargo run --release -p brdfkit-merl --example worked`

use brdfkit_core::direction::spherical;
use brdfkit_core::{Brdf, Rgb, Vec3, from_half_diff, to_half_diff};
use brdfkit_merl::*;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

/// A constant BRDF: only the horizon mask of the table matters here.
struct Constant;

impl Brdf for Constant {
    fn eval(&self, _: &Vec3, _: &Vec3) -> Rgb {
        Rgb::splat(0.1)
    }
}

fn main() {
    let d = Dims::MERL;
    let wi = spherical(30f64.to_radians(), 0.0);
    let wo = spherical(45f64.to_radians(), 150f64.to_radians());
    println!("wi {:?}\nwo {:?}", wi, wo);
    let c = to_half_diff(&wi, &wo);
    println!(
        "θh {:.7} ({:.4}°) φh {:.3}° θd {:.7} ({:.4}°) φd {:.7} ({:.4}°)",
        c.theta_h,
        c.theta_h.to_degrees(),
        c.phi_h.to_degrees(),
        c.theta_d,
        c.theta_d.to_degrees(),
        c.phi_d,
        c.phi_d.to_degrees()
    );
    println!("coordinates {:?}", d.coords(&c));
    let (i, j, k) = d.bins(&c);
    let idx = d.index(i, j, k);
    let n = d.cells();
    println!(
        "bins ({i}, {j}, {k}), flat {idx}, byte offsets R {} G {} B {}",
        12 + 8 * idx,
        12 + 8 * (n + idx),
        12 + 8 * (2 * n + idx)
    );
    let h = Dims::new(45, 45, 90).unwrap();
    println!(
        "45 x 45 x 90: coordinates {:?}, bins {:?}",
        h.coords(&c),
        h.bins(&c)
    );

    for (i, j, k) in [(10, 20, 30), (0, 0, 0), (45, 45, 90), (89, 89, 179)] {
        let a = d.cell_angles(i, j, k);
        let (wi, wo) = from_half_diff(&a);
        println!(
            "cell ({i}, {j}, {k}): θh {:.8} ({:.4}°) θd {:.8} ({:.4}°) φd {:.8} ({:.4}°)\n  wi {:?} wo {:?}\n  weight {:.4e}; bins of its angles {:?}, of its directions {:?}",
            a.theta_h,
            a.theta_h.to_degrees(),
            a.theta_d,
            a.theta_d.to_degrees(),
            a.phi_d,
            a.phi_d.to_degrees(),
            wi,
            wo,
            cell_weight(d, i, j),
            d.bins(&a),
            d.bins(&to_half_diff(&wi, &wo))
        );
    }

    let (mut valid, mut via_dirs, mut direct) = (0, 0, 0);
    for x in 0..n {
        let (i, j, k) = d.unflatten(x);
        let a = d.cell_angles(i, j, k);
        direct += (d.bin_index(&a) != x) as usize;
        let (wi, wo) = from_half_diff(&a);
        if wi.z > 0.0 && wo.z > 0.0 {
            valid += 1;
            via_dirs += (d.bin_index(&to_half_diff(&wi, &wo)) != x) as usize;
        }
    }
    println!(
        "cell angles straight into the bins: another bin for {direct} of {n} cells ({:.1} %)",
        100.0 * direct as f64 / n as f64
    );
    println!(
        "cell directions looked up: another bin for {via_dirs} of {valid} valid cells ({:.1} %)",
        100.0 * via_dirs as f64 / valid as f64
    );

    let t = MerlTable::from_brdf(&Constant, d).unwrap();
    println!(
        "valid cells of a model sampled onto the MERL grid: {} ({:.2} %)",
        t.valid_count(),
        100.0 * t.valid_fraction()
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut dir = || {
        let z: f64 = 1.0 - rng.random::<f64>();
        spherical(z.acos(), rng.random_range(-PI..PI))
    };
    let pairs: Vec<(Vec3, Vec3)> = (0..2_000_000).map(|_| (dir(), dir())).collect();
    let misses = t
        .nearest_batch(&pairs)
        .iter()
        .filter(|v| v.is_none())
        .count();
    println!(
        "uniform pairs above the horizon landing in a missing cell: {misses} of {} (1 in {:.0})",
        pairs.len(),
        pairs.len() as f64 / misses as f64
    );
    let s: f64 = (0..90)
        .flat_map(|i| (0..90).map(move |j| cell_weight(d, i, j)))
        .sum::<f64>()
        * 180.0;
    println!("Σ weights {s:.15}, 8π² {:.15}", 8.0 * PI * PI);
}
