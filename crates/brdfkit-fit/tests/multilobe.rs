//! Multi-lobe families on measured data (issue 12, item 3): on every vendored proxy of
//! `data-measured/`, the two-lobe fit of a family must reach a loss no higher than its
//! one-lobe fit with the command line's default settings. A second lobe can always
//! be switched off (ρs = 0), so a higher loss means the fit did not converge to the
//! better optimum that exists.

use brdfkit_fit::batch::{Source, tables_of};
use brdfkit_fit::families::{FitSettings, Structure, families, fit_each};
use brdfkit_fit::{FitData, config};
use std::path::PathBuf;

/// (one lobe, several lobes) pairs compared.
const PAIRS: [(&str, &str); 2] = [
    ("lafortune", "lafortune-2"),
    ("cook-torrance", "cook-torrance-2"),
];

#[test]
fn two_lobes_fit_measured_proxies_at_least_as_well_as_one() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-measured");
    let dirs: Vec<String> = ["merl", "rgl-isotropic", "nielsen"]
        .iter()
        .map(|d| root.join(d).display().to_string())
        .collect();
    let proxies = tables_of(&dirs, Source::Nbrdf, &root).expect("the vendored proxies");
    assert!(proxies.len() >= 7, "{} proxies", proxies.len());
    let list: Vec<&str> = PAIRS.iter().flat_map(|(a, b)| [*a, *b]).collect();
    let fams = families(&list.join(","), &Structure::default()).expect("families");
    // The command line's defaults (`fit-brdf fit`).
    let cfg = FitSettings {
        starts: 8,
        full_iters: config::DEFAULT_FULL_ITERS,
        explore_cells: Some(config::DEFAULT_EXPLORE_CELLS),
        ..FitSettings::default()
    }
    .config()
    .expect("config");
    let mut worse = Vec::new();
    for p in &proxies {
        let net = brdfkit_nbrdf::Nbrdf::load(&p.path).expect("a vendored proxy loads");
        let table = net.to_table(brdfkit_merl::Dims::MERL).expect("tabulates").0;
        let data = FitData::from_owned_table(table).expect("cells");
        let out = fit_each(&data, &fams, &cfg, &()).expect("fits");
        for (k, (one, two)) in PAIRS.iter().enumerate() {
            let (a, b) = (&out[2 * k].record, &out[2 * k + 1].record);
            let (la, lb) = (a.losses_full.cbrt.overall, b.losses_full.cbrt.overall);
            eprintln!(
                "{}: {one} {la:.5e} ({:.2} s), {two} {lb:.5e} ({:.2} s), {:+.1} %",
                p.name,
                a.wall_time_s,
                b.wall_time_s,
                100.0 * (lb / la - 1.0)
            );
            // Round-off of two fits that end at the same optimum is allowed.
            if lb > la * (1.0 + 1e-9) {
                worse.push(format!("{}: {two} {lb:e} > {one} {la:e}", p.name));
            }
        }
    }
    assert!(worse.is_empty(), "{}", worse.join("\n"));
}
