//! `fit-brdf info F.bsdf`: what an RGL-EPFL `.bsdf` file holds.

use brdfkit::rgl::{Asymmetry, RglBsdf};
use serde_json::json;
use std::fmt::Write as _;

/// Random pairs of the asymmetry statistics (above 5°, as the figures).
pub const ASYMMETRY_PAIRS: usize = 200_000;

/// The facts as JSON: the library's ([`RglBsdf::info_json`], which Python's
/// `RglBsdf.info` returns too), under the name given on the command line.
pub fn to_json(name: &str, b: &RglBsdf, asym: &Asymmetry) -> serde_json::Value {
    let mut v = b.info_json(asym);
    v["file"] = json!(name);
    v
}

/// The facts as text for a person.
pub fn to_text(name: &str, b: &RglBsdf, asym: &Asymmetry) -> String {
    let s = b.summary();
    let mut o = String::new();
    let _ = writeln!(
        o,
        "file:           {name} (RGL-EPFL .bsdf, Mitsuba tensor file)"
    );
    let _ = writeln!(o, "description:    {}", b.description().trim_end());
    let kind = match (b.is_spectral(), b.is_anisotropic()) {
        (false, false) => "RGB, isotropic",
        (false, true) => "RGB, anisotropic",
        (true, false) => "spectral, isotropic",
        (true, true) => "spectral, anisotropic",
    };
    let _ = writeln!(
        o,
        "kind:           {kind}; jacobian flag {}",
        u8::from(s.jacobian)
    );
    let deg: Vec<String> = s
        .theta_i
        .iter()
        .map(|t| format!("{:.1}", t.to_degrees()))
        .collect();
    let _ = writeln!(
        o,
        "grids:          {} φi x {} θi slices; θi = {} °",
        s.n_phi_i,
        s.n_theta_i,
        deg.join(", ")
    );
    let _ = writeln!(
        o,
        "                VNDF {} x {}, values {} x {}",
        s.vndf_grid[0], s.vndf_grid[1], s.value_grid[0], s.value_grid[1]
    );
    if let Some(w) = &s.wavelengths {
        let _ = writeln!(
            o,
            "wavelengths:    {} from {:.0} to {:.0} nm",
            w.len(),
            w[0],
            w[w.len() - 1]
        );
    }
    let _ = writeln!(
        o,
        "negative:       {} of {} stored values ({:.2} %)",
        s.negative,
        s.values,
        100.0 * s.negative as f64 / s.values as f64
    );
    match s.measured_points {
        Some((set, bits)) => {
            let _ = writeln!(
                o,
                "measured:       {set} of {bits} grid points (the `valid` bits)"
            );
        }
        None => {
            let _ = writeln!(o, "measured:       no `valid` field");
        }
    }
    let _ = writeln!(
        o,
        "asymmetry:      |f(wi,wo) - f(wo,wi)| / mean, {} random pairs above {:.0}°: median {:.1} %, 90th percentile {:.1} %, max {:.1} %",
        asym.pairs,
        asym.min_elevation_deg,
        100.0 * asym.median,
        100.0 * asym.p90,
        100.0 * asym.max
    );
    if asym.skipped > 0 {
        let _ = writeln!(
            o,
            "                ({} pairs with a mean ≤ 0 left out)",
            asym.skipped
        );
    }
    o
}
