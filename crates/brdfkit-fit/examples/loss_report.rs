//! Times the loss report of fitted families on one measured table, the way a batch
//! runs it (cells and cube-root targets prepared once per table): each family is fitted
//! with the user's defaults, then its report ([`evaluate_losses_of`] over every valid
//! cell, the default loss set) is repeated, families interleaved, and the median and
//! minimum printed with the report's bits (a hash of every loss), so two builds can be
//! compared for time and for identical results.
//!
//! `cargo run --release -p brdfkit-fit --example loss_report -- T.binary [REPS] [FAMILY,...] [own|all]`
//! (the loss set: the user's default, brdfkit's own four, unless `all`).

use brdfkit_fit::families::{FitSettings, Structure, families};
use brdfkit_fit::{FitData, evaluate_losses_of, fit, prepare};
use std::hash::{DefaultHasher, Hash, Hasher};
use std::time::Instant;

const FAMILIES: &str = "lambert,oren-nayar,plausible-phong,blinn-phong,ward,lafortune,\
                        lafortune-2,ashikhmin-shirley,cook-torrance,cook-torrance-beckmann,\
                        cook-torrance-2";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .ok_or("usage: loss_report T.binary [REPS] [FAMILY,...] [own|all]")?;
    let reps: usize = args.get(2).map_or(Ok(21), |s| s.parse())?;
    let names = args.get(3).map_or(FAMILIES, |s| s.as_str());
    let table = brdfkit_merl::MerlTable::read(path)?;
    let data = FitData::from_owned_table(table)?;
    let mut config = FitSettings::default().config()?;
    if let Some(set) = args.get(4) {
        config = config.report_losses(set.parse()?);
    }
    prepare(&data, &config)?;
    let mut fitted = Vec::new();
    for f in families(names, &Structure::default())? {
        let r = fit(f.model.as_ref(), &data, &config, None)?;
        fitted.push((f.label, r.fitted));
    }
    let (w, set) = (config.get_weighting(), config.reported_losses());
    let mut times = vec![Vec::with_capacity(reps); fitted.len()];
    let mut bits = DefaultHasher::new();
    for rep in 0..reps {
        for ((_, f), t) in fitted.iter().zip(&mut times) {
            let t0 = Instant::now();
            let r = evaluate_losses_of(f.channel_models(), &data, w, set);
            t.push(t0.elapsed().as_secs_f64() * 1e3);
            if rep == 0 {
                for l in brdfkit_fit::Loss::ALL
                    .into_iter()
                    .chain(brdfkit_fit::Loss::PUBLISHED)
                {
                    let c = r.get(l);
                    c.overall.to_bits().hash(&mut bits);
                    c.channels.map(f64::to_bits).hash(&mut bits);
                }
            }
        }
    }
    println!(
        "family\tmedian ms\tmin ms\t({reps} reports, {} cells)",
        data.len()
    );
    for ((name, _), t) in fitted.iter().zip(&mut times) {
        t.sort_by(f64::total_cmp);
        println!("{name}\t{:.2}\t{:.2}", t[t.len() / 2], t[0]);
    }
    println!("report bits: {:016x}", bits.finish());
    Ok(())
}
