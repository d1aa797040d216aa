//! The facts of a `.bsdf` file as JSON: one definition for `fit-brdf info --json` and
//! the Python package's `RglBsdf.info`.

use crate::bsdf::RglBsdf;
use crate::resample::Asymmetry;
use serde_json::json;

impl RglBsdf {
    /// What `fit-brdf info --json` reports of the file (and Python's `RglBsdf.info`):
    /// the description, the kind, the grids, the negative stored values, the measured
    /// points, the fields, and `asym` (from [`RglBsdf::asymmetry`]).
    pub fn info_json(&self, asym: &Asymmetry) -> serde_json::Value {
        let b = self;
        let s = b.summary();
        json!({
            "file": b.name(),
            "format": "rgl-epfl-bsdf",
            "description": b.description(),
            "spectral": b.is_spectral(),
            "anisotropic": b.is_anisotropic(),
            "phi_i_count": s.n_phi_i,
            "theta_i_deg": s.theta_i.iter().map(|t| t.to_degrees()).collect::<Vec<_>>(),
            "vndf_grid": s.vndf_grid,
            "value_grid": s.value_grid,
            "wavelengths_nm": s.wavelengths,
            "values": s.values,
            "negative_values": s.negative,
            "negative_fraction": s.negative as f64 / s.values as f64,
            "measured_points": s.measured_points.map(|(set, _)| set),
            "grid_points": s.measured_points.map(|(_, bits)| bits),
            "jacobian": s.jacobian,
            "asymmetry": {
                "pairs": asym.pairs,
                "min_elevation_deg": asym.min_elevation_deg,
                "skipped_not_positive": asym.skipped,
                "median": asym.median,
                "p90": asym.p90,
                "max": asym.max,
            },
            "fields": s.fields.iter().map(|(n, d, sh)| json!({"name": n, "dtype": d, "shape": sh})).collect::<Vec<_>>(),
        })
    }
}
