//! `fit-brdf demo`: the whole job on an embedded material, with no downloaded data and
//! no network.
//!
//! 1. tabulate the embedded material on the MERL grid: by default a measured one (the
//!    neural proxy of MERL's specular-red-phenolic, `data-measured/`), which no analytic
//!    model fits exactly, so the report shows what each model gets right and wrong;
//!    with `--synthetic` the synthetic red plastic with known parameters. Write the
//!    table, read it back and check it is bit-identical, print its statistics and
//!    compare table lookups with the material itself;
//! 2. fit the five model families of the report (lambert, plausible-phong, ward,
//!    lafortune, cook-torrance) with the demo's fit settings ([`demo_config`]);
//! 3. write the fit-quality report (OUT/report/index.html and report.json) and say
//!    where it is.

use super::demo_material::{Material, material};
use super::report::{make_report, model_fits};
use super::{read_table, write_table};
use crate::cli::DemoArgs;
use crate::error::{CliResult, bad_input, bad_msg, runtime};
use crate::output::write_failed;
use crate::progress;
use anyhow::Context;
use brdfkit::core::direction::spherical;
use brdfkit::fit::families::{REPORT_MODELS, Structure, comparison_text, families, fit_each};
use brdfkit::fit::{FitConfig, FitData};
use brdfkit_validate::html::ReportOptions;

/// The demo's fit settings: the `cbrt` loss with solid-angle weights and LM (the
/// defaults of `fit`), 2 starts, on a stratified quarter of the valid cells (every loss
/// is still reported on all of them): the whole demo stays well under a minute on two
/// cores in release. `fit-brdf report` with the defaults of `fit` (8 starts, every cell)
/// is the thorough version.
pub fn demo_config() -> CliResult<FitConfig> {
    FitConfig::default()
        .starts(2)
        .and_then(|c| c.subsample(0.25, 0))
        .map_err(runtime)
}

pub fn run(a: DemoArgs) -> CliResult<()> {
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("{}: cannot create the output directory", a.out.display()))
        .map_err(runtime)?;
    let t0 = std::time::Instant::now();
    let Material {
        name: mat,
        about,
        table,
        truth,
    } = material(a.synthetic)?;
    println!("brdfkit demo: {mat} — {about}");
    let path = a.out.join(format!("{mat}.binary"));
    write_table(&table, &path)?;
    println!(
        "tabulated and wrote {} in {:.2} s",
        path.display(),
        t0.elapsed().as_secs_f64()
    );
    let back = read_table(&path)?;
    if back.raw() != table.raw() {
        return Err(bad_msg(format!(
            "{}: read back differs from what was written",
            path.display()
        )));
    }
    println!("read it back: identical to what was written\n");
    print!(
        "{}",
        super::info::format_stats(&path.display().to_string(), &back.stats())
    );
    println!("\nlookups against the material itself (f_r in 1/sr, red channel):");
    println!("  θi     θo     Δφ      truth          nearest        interpolated");
    for &(ti, to, dphi) in &[
        (0.0, 0.0, 0.0),
        (30.0, 30.0, 180.0),
        (45.0, 45.0, 180.0),
        (60.0, 20.0, 90.0),
        (75.0, 75.0, 180.0),
    ] {
        let wi = spherical(f64::to_radians(ti), 0.0);
        let wo = spherical(f64::to_radians(to), f64::to_radians(dphi));
        let truth = truth(&wi, &wo).r();
        let fmt = |v: Option<brdfkit::core::Rgb>| {
            v.map_or("missing".to_string(), |c| format!("{:.6e}", c.r()))
        };
        println!(
            "  {ti:<5}  {to:<5}  {dphi:<6}  {truth:<13.6e}  {:<13}  {}",
            fmt(back.nearest(&wi, &wo)),
            fmt(back.interpolated(&wi, &wo))
        );
    }

    // 2. Fits.
    let t1 = std::time::Instant::now();
    let fams = families(REPORT_MODELS, &Structure::default()).map_err(bad_input)?;
    let cfg = demo_config()?;
    let data = FitData::from_table(&back).map_err(runtime)?;
    println!(
        "\nfitting {} model families to {} valid cells (cbrt loss, 2 starts, 25 % stratified subsample):",
        fams.len(),
        data.len()
    );
    let outcomes = fit_each(
        &data,
        &fams,
        &cfg,
        &progress::Progress::with_family_lines(false),
    )
    .map_err(runtime)?;
    print!("{}", comparison_text(&outcomes, cfg.get_loss()));
    println!("fits: {:.1} s", t1.elapsed().as_secs_f64());

    // 3. The report.
    let options = ReportOptions {
        title: format!("brdfkit demo: {mat}"),
        ..ReportOptions::default()
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // The report reuses the fits' cells and losses instead of rebuilding them.
    let fits = model_fits(&outcomes)?;
    let table = (std::sync::Arc::new(back), data);
    let report = make_report(table, &name, &fits, Some(&cfg), &options, false)?;
    let (html, json) = report
        .write_to(&a.out.join("report"))
        .map_err(write_failed)?;
    println!(
        "\nreport written in {:.1} s: {}\n  (data: {}); open it in a browser, no server needed",
        report.data.timings.total_s,
        html.display(),
        json.display()
    );
    println!(
        "\ndemo done in {:.1} s; outputs in {}",
        t0.elapsed().as_secs_f64(),
        a.out.display()
    );
    Ok(())
}
