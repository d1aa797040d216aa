//! `fit-brdf demo`: the whole job on an embedded material, with no downloaded data.
//!
//! For now: synthesise the embedded spec, write the table, read it back (bit for bit),
//! print its statistics and compare table lookups with the analytic truth.

use super::{read_table, write_table};
use crate::cli::DemoArgs;
use crate::error::{CliResult, bad_msg, runtime};
use anyhow::Context;
use brdfkit::core::direction::spherical;
use brdfkit::synth::SynthSpec;

/// The embedded default material.
pub const DEMO_SPEC: &str = include_str!("../../../../data-synthetic/demo-plastic.toml");

pub fn run(a: DemoArgs) -> CliResult<()> {
    let spec =
        SynthSpec::from_toml_str(DEMO_SPEC, "embedded demo-plastic.toml").map_err(runtime)?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("{}: cannot create the output directory", a.out.display()))
        .map_err(runtime)?;
    println!("brdfkit demo: {} — {}", spec.name, spec.description);
    let t0 = std::time::Instant::now();
    let table = spec.synthesize().map_err(runtime)?;
    let path = a.out.join(format!("{}.binary", spec.name));
    write_table(&table, &path)?;
    println!(
        "synthesised and wrote {} in {:.2} s",
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
    println!("\nlookups against the analytic truth (f_r in 1/sr, red channel):");
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
        let truth = spec.truth(&wi, &wo).r();
        let fmt = |v: Option<brdfkit::core::Rgb>| {
            v.map_or("missing".to_string(), |c| format!("{:.6e}", c.r()))
        };
        println!(
            "  {ti:<5}  {to:<5}  {dphi:<6}  {truth:<13.6e}  {:<13}  {}",
            fmt(back.nearest(&wi, &wo)),
            fmt(back.interpolated(&wi, &wo))
        );
    }
    println!("\noutputs in {}", a.out.display());
    Ok(())
}
