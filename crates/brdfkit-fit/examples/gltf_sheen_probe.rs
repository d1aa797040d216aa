//! Where a measured table holds (or lacks) the grazing sheen `KHR_materials_sheen` can
//! add: the table's value against a fitted glTF material's at Rusinkiewicz angles, and
//! what the Charlie lobe (sheenColor 1) adds there and takes from the base (E).
//!
//! `cargo run --release -p brdfkit-fit --example gltf_sheen_probe -- PROXY MODEL.json`
//! (PROXY: an NBRDF stem, e.g. ../shared/measured-proxies/merl/red-fabric; MODEL.json:
//! the `params` file `fit --for gltf --out` or `fit --model gltf-pbr --out` wrote).
//! Values are the mean of the three channels, in 1/sr, without the cosine.

use brdfkit_core::Brdf;
use brdfkit_core::rusinkiewicz::{HalfDiff, from_half_diff};
use brdfkit_models::sheen::{SheenLobe, SheenVisibility, sheen_albedo};
use brdfkit_nbrdf::Nbrdf;
use std::path::Path;

fn mean(c: brdfkit_core::Rgb) -> f64 {
    (c[0] + c[1] + c[2]) / 3.0
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let [_, proxy, model] = &args[..] else {
        return Err("usage: gltf_sheen_probe PROXY MODEL.json".into());
    };
    let net = Nbrdf::load(Path::new(proxy))?;
    let fitted = brdfkit_models::from_json_str(&std::fs::read_to_string(model)?)?;
    let rough = [0.3, 0.5, 1.0];
    println!(
        "θh θd φd | cosθi cosθo | table   fitted  table/fitted | Charlie D·V (r 0.3 0.5 1) | E(cosθi) (r 0.3 0.5 1)"
    );
    let deg = std::f64::consts::PI / 180.0;
    let rows: [(f64, f64, f64); 16] = [
        (0.0, 0.0, 90.0),
        (30.0, 0.0, 90.0),
        (60.0, 0.0, 90.0),
        (75.0, 0.0, 90.0),
        (85.0, 0.0, 90.0),
        (88.0, 0.0, 90.0),
        (60.0, 30.0, 90.0),
        (75.0, 30.0, 90.0),
        (85.0, 30.0, 90.0),
        (75.0, 60.0, 90.0),
        (85.0, 60.0, 90.0),
        (0.0, 60.0, 0.0),
        (0.0, 75.0, 0.0),
        (0.0, 85.0, 0.0),
        (30.0, 30.0, 0.0),
        (30.0, 55.0, 0.0),
    ];
    for (th, td, pd) in rows {
        let (wi, wo) = from_half_diff(&HalfDiff::new(th * deg, 0.0, td * deg, pd * deg));
        let (t, f) = (mean(net.eval(&wi, &wo)), mean(fitted.eval(&wi, &wo)));
        let dv: Vec<String> = rough
            .iter()
            .map(|&r| {
                let lobe = SheenLobe {
                    vis: SheenVisibility::Charlie,
                    roughness: r,
                };
                format!("{:.3}", lobe.eval(&wi, &wo)[0])
            })
            .collect();
        let e: Vec<String> = rough
            .iter()
            .map(|&r| format!("{:.3}", sheen_albedo(SheenVisibility::Charlie, r, wi.z).0))
            .collect();
        println!(
            "{th:>2} {td:>2} {pd:>2} | {:.3} {:.3} | {t:.4} {f:.4} {:.2} | {} | {}",
            wi.z,
            wo.z,
            t / f,
            dv.join(" "),
            e.join(" ")
        );
    }
    Ok(())
}
