//! Published parameters against a brdfkit fit of the same model structure, each scored
//! under the metric the paper fitted with (docs/fitting.md, "Published metrics").
//!
//! ```text
//! cargo run --example published_proof -- FITS.json PROXY_DIR LOSS [MATERIAL ...]
//! ```
//!
//! FITS.json is one of `data-measured/published/`; PROXY_DIR holds the NBRDF proxies
//! (`<name>_fc1.npy` ...); LOSS is the paper's metric (`ngan`, `low-e1`, `low-e2`).
//! For every material of FITS.json with a proxy (or the ones named), the proxy is
//! resampled to a 90 × 90 × 180 MERL table, the published model is scored on it, and
//! the brdfkit family of the same structure is fitted under LOSS (8 starts); when that
//! fit scores above the published parameters, it is fitted once more with the
//! published parameters as its first start. One markdown row per material.

use brdfkit::fit::{FitConfig, FitData, Loss, Weighting, evaluate_losses, fit};
use brdfkit::merl::Dims;
use brdfkit::models::from_json;
use serde_json::Value;
use std::error::Error;
use std::time::Instant;

/// The brdfkit family of a published parameterisation, and the parameters a fit frees
/// beyond the family's defaults.
fn family(name: &str) -> Option<(&'static str, &'static [&'static str])> {
    match name {
        "ngan-cook-torrance" => Some((
            r#"{"model":"cook-torrance","params":{"distribution":"beckmann","masking":"v-cavity","fresnel":"schlick"}}"#,
            &[],
        )),
        "ngan-ward" => Some((r#"{"model":"ward","params":{"normalization":"ward"}}"#, &[])),
        "low-cook-torrance" => Some((
            r#"{"model":"cook-torrance","params":{"distribution":"beckmann","masking":"v-cavity","fresnel":"dielectric"}}"#,
            &["eta"],
        )),
        _ => None,
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        return Err("usage: published_proof FITS.json PROXY_DIR LOSS [MATERIAL ...]".into());
    }
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&args[0])?)?;
    let fits = doc["fits"]
        .as_object()
        .ok_or("FITS.json has no `fits` object")?;
    let dir = std::path::Path::new(&args[1]);
    let loss: Loss = args[2].parse()?;
    let only = &args[3..];
    println!("| material | published | brdfkit fit | fit / published | seconds |");
    println!("|---|---:|---:|---:|---:|");
    let (mut checked, mut below) = (0, 0);
    for (name, desc) in fits {
        if !only.is_empty() && !only.contains(name) {
            continue;
        }
        if !dir.join(format!("{name}_fc1.npy")).exists() {
            continue;
        }
        let t0 = Instant::now();
        let published = from_json(desc)?;
        let (fam_json, free) = family(desc["model"].as_str().unwrap_or("")).ok_or("unknown")?;
        let net = brdfkit::nbrdf::Nbrdf::load(&dir.join(name))?;
        let (table, _) = net.to_table(Dims::new(90, 90, 180)?)?;
        let data = FitData::from_owned_table(table)?;
        let score = |m: &dyn brdfkit::core::Model| {
            evaluate_losses([m; 3], &data, Weighting::SolidAngle)
                .get(loss)
                .overall
        };
        let p = score(published.as_ref());
        let cfg = FitConfig::default()
            .loss(loss)
            .starts(8)?
            .free_params(free.iter().copied());
        let fam = brdfkit::models::from_json_str(fam_json)?;
        let mut f = fit(fam.as_ref(), &data, &cfg, None)?
            .record
            .losses_full
            .get(loss)
            .overall;
        let mut note = "";
        if f > p {
            // Start 0 at the published parameters (the model passed is start 0).
            let again = fit(published.as_ref(), &data, &cfg, None)?;
            f = f.min(again.record.losses_full.get(loss).overall);
            note = " (from the published start)";
        }
        checked += 1;
        if f <= p {
            below += 1;
        }
        println!(
            "| {name} | {p:.6e} | {f:.6e}{note} | {:.3} | {:.0} |",
            f / p,
            t0.elapsed().as_secs_f64()
        );
    }
    println!(
        "\n{below} of {checked} materials: brdfkit's fit ≤ the published parameters under `{loss}`."
    );
    Ok(())
}
