//! How a `.bsdf` resamples onto the MERL grid of the table it was written from, cell by
//! cell (docs/rgl.md, "Near the horizon"; issue 24): for every cell above the horizon,
//! both orders f(wi, wo) and f(wo, wi) as the reader returns them (the stored f · cos θo
//! over the cosine of the outgoing direction), their plain mean and the weighted value
//! `to_table` stores ([`two_order_value`]), against the source table.
//!
//!   cargo run -p brdfkit-rgl --example grazing -- SOURCE.binary FILE.bsdf [WORST]
//!
//! Prints the WORST (default 8) cells of the plain mean and of `to_table`'s value by
//! |value − source| / source (red), then, for the plain mean, for the weights
//! cos² / (cos² + c²) with c = 0, 0.05, 0.2, 0.4 and for `to_table`'s (c =
//! [`brdfkit_rgl::ORDER_ERROR_COS`]), the median, 90th and 99th percentile and maximum of
//! that ratio over all cells and over the cells with both directions above 10°
//! elevation, and the number of cells above 10 × the source table's largest value.
use brdfkit_core::Rgb;
use brdfkit_merl::MerlTable;
use brdfkit_nbrdf::HORIZON_Z;
use brdfkit_rgl::{RglBsdf, two_order_value};

/// One cell: its index, its cosines, the source and the file's two orders (red channel).
struct Cell {
    ijk: (usize, usize, usize),
    cos_i: f64,
    cos_o: f64,
    source: f64,
    f_io: f64,
    f_oi: f64,
}

impl Cell {
    fn plain(&self) -> f64 {
        0.5 * (self.f_io + self.f_oi)
    }
    fn weighted(&self) -> f64 {
        let (a, b) = (Rgb::splat(self.f_io), Rgb::splat(self.f_oi));
        two_order_value(a, b, self.cos_i, self.cos_o).0[0]
    }
    /// The weights cos² / (cos² + c²) with another c (the choice of c, docs/rgl.md).
    fn with_c(&self, c: f64) -> f64 {
        // c = 0: the weights cos² themselves (the ratio would be 1).
        let w = |x: f64| {
            if c > 0.0 {
                x * x / (x * x + c * c)
            } else {
                x * x
            }
        };
        let (wa, wb) = (w(self.cos_o), w(self.cos_i));
        (wa * self.f_io + wb * self.f_oi) / (wa + wb)
    }
}

type Rule = fn(&Cell) -> f64;

/// The rules compared: (name, rule).
const RULES: [(&str, Rule); 6] = [
    ("plain mean", Cell::plain),
    ("c = 0 (cos²)", |c| c.with_c(0.0)),
    ("c = 0.05", |c| c.with_c(0.05)),
    ("to_table (c = 0.1)", Cell::weighted),
    ("c = 0.2", |c| c.with_c(0.2)),
    ("c = 0.4", |c| c.with_c(0.4)),
];

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let table = MerlTable::read(&args[1]).expect("a MERL table");
    let bsdf = RglBsdf::read(args[2].as_ref()).expect("a .bsdf file");
    let worst: usize = args.get(3).map_or(8, |w| w.parse().expect("a count"));
    let cells = cells(&table, &bsdf);
    let smax = cells.iter().map(|c| c.source).fold(0.0, f64::max);
    for (name, rule) in [RULES[0], RULES[3]] {
        print_worst(name, &cells, rule, worst);
    }
    println!();
    for (name, rule) in RULES {
        summary(name, &cells, rule, smax);
    }
}

/// Every cell above the horizon with a positive source, both orders by the batch kernel.
fn cells(table: &MerlTable, bsdf: &RglBsdf) -> Vec<Cell> {
    let mut cells = Vec::new();
    let mut rows = Vec::new();
    for c in table.present_cells() {
        let (wi, wo, src) = (c.wi, c.wo, c.value);
        if wi.z <= HORIZON_Z || wo.z <= HORIZON_Z || src.0[0] <= 0.0 {
            continue;
        }
        let (a, b) = ([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z]);
        rows.extend_from_slice(&[a[0], a[1], a[2], b[0], b[1], b[2]]);
        rows.extend_from_slice(&[b[0], b[1], b[2], a[0], a[1], a[2]]);
        let [i, j, k] = c.index;
        cells.push(Cell {
            ijk: (i, j, k),
            cos_i: wi.z,
            cos_o: wo.z,
            source: src.0[0],
            f_io: 0.0,
            f_oi: 0.0,
        });
    }
    let mut out = vec![0.0; rows.len() / 2];
    bsdf.eval_flat(&rows, &mut out);
    for (c, v) in cells.iter_mut().zip(out.chunks_exact(6)) {
        (c.f_io, c.f_oi) = (v[0], v[3]);
    }
    cells
}

fn ratio(c: &Cell, rule: Rule) -> f64 {
    (rule(c) - c.source).abs() / c.source
}

fn print_worst(name: &str, cells: &[Cell], rule: Rule, n: usize) {
    let mut idx: Vec<usize> = (0..cells.len()).collect();
    idx.sort_by(|&a, &b| ratio(&cells[b], rule).total_cmp(&ratio(&cells[a], rule)));
    println!("\nworst cells, {name} (red channel):");
    println!(
        "| cell | θh | θd | φd | source | cos θi | cos θo | g(wi,wo) | g(wo,wi) | f(wi,wo) | f(wo,wi) | plain mean | weighted |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let deg = |x: f64| x.to_degrees();
    for &k in idx.iter().take(n) {
        let c = &cells[k];
        let (i, j, l) = c.ijk;
        let dims = brdfkit_merl::Dims::MERL;
        let a = dims.cell_angles(i, j, l);
        println!(
            "| ({i}, {j}, {l}) | {:.2}° | {:.0}° | {:.0}° | {:.4} | {:.3e} | {:.3e} | {:.4} | {:.4} | {:.4e} | {:.4e} | {:.4e} | {:.4} |",
            deg(a.theta_h),
            deg(a.theta_d),
            deg(a.phi_d),
            c.source,
            c.cos_i,
            c.cos_o,
            c.f_io * c.cos_o,
            c.f_oi * c.cos_i,
            c.f_io,
            c.f_oi,
            c.plain(),
            c.weighted()
        );
    }
}

fn summary(name: &str, cells: &[Cell], rule: Rule, smax: f64) {
    let z10 = 10f64.to_radians().sin();
    for (what, high) in [("all cells", false), ("both above 10°", true)] {
        let mut r: Vec<f64> = cells
            .iter()
            .filter(|c| !high || (c.cos_i > z10 && c.cos_o > z10))
            .map(|c| ratio(c, rule))
            .collect();
        r.sort_by(f64::total_cmp);
        let q = |p: f64| r[((r.len() - 1) as f64 * p).round() as usize];
        let huge = cells
            .iter()
            .filter(|c| !high || (c.cos_i > z10 && c.cos_o > z10))
            .filter(|c| rule(c) > 10.0 * smax)
            .count();
        println!(
            "{name}, {what} ({} cells): |value - source| / source median {:.4}, p90 {:.4}, p99 {:.4}, max {:.4e}; {huge} cells > 10 x the source's max {smax:.4}",
            r.len(),
            q(0.5),
            q(0.9),
            q(0.99),
            r[r.len() - 1]
        );
    }
}
