//! Multi-start with ranking against finishing every start, on a synthetic Cook-Torrance
//! table (the default distribution, Schlick; 24 x 24 x 48 grid above the horizon,
//! 21,821 cells, a 1000-cell warm-up) from starts whose roughness is far from the
//! truth (α = 0.15): the loss reached, solver iterations on the fitted cells (+ on the
//! warm-up subsample) and wall time for n starts / k finished.
//! `cargo run --release -p brdfkit-fit --example starts`.

use brdfkit_fit::synth::{Coverage, synth_data};
use brdfkit_fit::{FitConfig, fit};
use brdfkit_merl::Dims;
use std::time::Instant;

const TRUTH: &str = r#"{"model":"cook-torrance","params":{"fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.15}}"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let truth = brdfkit_models::from_json_str(TRUTH)?;
    let data = synth_data(
        truth.as_ref(),
        Dims::new(24, 24, 48)?,
        Coverage::AboveHorizon,
    )?;
    println!(
        "{} cells; columns: starts/finished: cbrt loss (iterations on the fitted cells + on the warm-up subsample, wall)",
        data.len()
    );
    for a in [
        "0.001", "0.01", "0.05", "0.3", "1", "3", "8", "20", "50", "90",
    ] {
        let start = brdfkit_models::from_json_str(&format!(
            r#"{{"model":"cook-torrance","params":{{"fresnel":"schlick","alpha":{a}}}}}"#
        ))?;
        let mut line = format!("alpha0 {a:>6}:");
        for (n, f) in [(1, 1), (4, 1), (4, 4), (8, 1), (8, 8)] {
            let cfg = FitConfig::default()
                .warm_up(Some(1000))?
                .starts(n)?
                .finish(f)?;
            let t = Instant::now();
            let r = fit(start.as_ref(), &data, &cfg, None)?;
            let it: u64 = r.record.starts.iter().map(|s| s.iterations).sum();
            let wit: u64 = r
                .record
                .starts
                .iter()
                .map(|s| s.warm_up.as_ref().map_or(0, |w| w.iterations))
                .sum();
            line += &format!(
                "  {n}/{f}: {:.1e} ({it}+{wit}, {:.2} s)",
                r.record.losses_full.cbrt.overall,
                t.elapsed().as_secs_f64()
            );
        }
        println!("{line}");
    }
    Ok(())
}
