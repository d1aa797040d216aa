//! `fit-brdf info TABLE|F.bsdf`: what a table (or a `.bsdf` file, [`super::info_rgl`])
//! holds.

use super::{InputKind, info_rgl, input_kind, read_bsdf, read_table};
use crate::cli::InfoArgs;
use crate::error::CliResult;
use crate::output::write_text;
use brdfkit::merl::TableStats;
use serde_json::json;
use std::fmt::Write as _;

pub fn run(a: InfoArgs) -> CliResult<()> {
    if input_kind(&a.table)? == InputKind::Rgl {
        let (name, b) = (a.table.display().to_string(), read_bsdf(&a.table)?);
        let asym = b.asymmetry(info_rgl::ASYMMETRY_PAIRS, 5.0, 1);
        let text = if a.json {
            serde_json::to_string_pretty(&info_rgl::to_json(&name, &b, &asym))
                .expect("JSON of numbers")
                + "\n"
        } else {
            info_rgl::to_text(&name, &b, &asym)
        };
        return write_text(None, &text);
    }
    let table = read_table(&a.table)?;
    let stats = table.stats();
    let text = if a.json {
        serde_json::to_string_pretty(&stats_json(&a.table.display().to_string(), &stats))
            .expect("JSON of numbers")
            + "\n"
    } else {
        format_stats(&a.table.display().to_string(), &stats)
    };
    write_text(None, &text)
}

/// The statistics as JSON (null where no value exists).
pub fn stats_json(name: &str, s: &TableStats) -> serde_json::Value {
    let channels = s.channels.map(|ch| {
        let names = ["r", "g", "b"];
        let m: serde_json::Map<String, serde_json::Value> = ch
            .iter()
            .zip(names)
            .map(|(c, n)| {
                (
                    n.to_string(),
                    json!({"min": c.min, "median": c.median, "max": c.max}),
                )
            })
            .collect();
        serde_json::Value::Object(m)
    });
    let albedo: Vec<serde_json::Value> = s
        .albedo
        .iter()
        .map(|a| {
            json!({
                "theta_o_deg": a.theta_o.to_degrees(),
                "albedo": a.albedo.map(|v| vec![v.r(), v.g(), v.b()]),
                "missing_weight": a.missing_weight,
            })
        })
        .collect();
    json!({
        "table": name,
        "dims": [s.dims.theta_h(), s.dims.theta_d(), s.dims.phi_d()],
        "cells": s.cells,
        "valid": s.valid,
        "valid_fraction": s.valid_fraction,
        "channels": channels,
        "albedo": albedo,
    })
}

/// The statistics as text for a person.
pub fn format_stats(name: &str, s: &TableStats) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "table:          {name}");
    let _ = writeln!(
        o,
        "dims:           {} x {} x {} (θh, θd, φd), {} cells",
        s.dims.theta_h(),
        s.dims.theta_d(),
        s.dims.phi_d(),
        s.cells
    );
    let _ = writeln!(
        o,
        "valid:          {} cells ({:.2} %), {} missing",
        s.valid,
        100.0 * s.valid_fraction,
        s.cells - s.valid
    );
    match &s.channels {
        None => {
            let _ = writeln!(o, "channels:       no valid cell");
        }
        Some(ch) => {
            let _ = writeln!(
                o,
                "channel         min            median         max            (1/sr)"
            );
            for (c, n) in ch.iter().zip(["R", "G", "B"]) {
                let _ = writeln!(
                    o,
                    "  {n}             {:<14.6e} {:<14.6e} {:<14.6e}",
                    c.min, c.median, c.max
                );
            }
        }
    }
    let _ = writeln!(
        o,
        "directional albedo a(θo) = ∫ f cosθi dωi (interpolated lookups, 32x64 Gauss-Legendre x midpoint nodes):"
    );
    for a in &s.albedo {
        match a.albedo {
            Some(v) => {
                let _ = write!(
                    o,
                    "  θo = {:>4.1}°    R {:.4}  G {:.4}  B {:.4}",
                    a.theta_o.to_degrees(),
                    v.r(),
                    v.g(),
                    v.b()
                );
                if a.missing_weight > 0.0 {
                    let _ = write!(
                        o,
                        "   ({:.1} % of the weight on missing cells, filled with the mean)",
                        100.0 * a.missing_weight
                    );
                }
                o.push('\n');
            }
            None => {
                let _ = writeln!(
                    o,
                    "  θo = {:>4.1}°    no valid sample",
                    a.theta_o.to_degrees()
                );
            }
        }
    }
    o
}
