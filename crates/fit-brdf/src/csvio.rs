//! The direction-pair CSV contract of `eval`.
//!
//! Input: a header line `wi_x,wi_y,wi_z,wo_x,wo_y,wo_z`, then one pair per line, six
//! finite numbers, each direction of unit length (within 1e-6; directions are not
//! renormalised behind the user's back). Blank lines are skipped.
//! Output: a header `r,g,b`, then one row per input row; empty fields where no valid
//! sample exists. Numbers print in the shortest form that reads back to the same f64.

use crate::error::{CliResult, bad_input, bad_msg};
use anyhow::Context;
use brdfkit::core::{Rgb, Vec3};
use std::fmt::Write as _;
use std::path::Path;

const HEADER: [&str; 6] = ["wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"];

/// Tolerance on |w| − 1 for an input direction: the library's, so that the command
/// line and the Python bindings apply one rule.
pub use brdfkit::core::direction::UNIT_TOLERANCE;

/// Reads the direction pairs of a CSV file.
pub fn read_pairs(path: &Path) -> CliResult<Vec<(Vec3, Vec3)>> {
    let bytes = std::fs::read(path)
        .with_context(|| format!("{}: cannot read the directions file", path.display()))
        .map_err(bad_input)?;
    let text = String::from_utf8(bytes)
        .map_err(|_| bad_msg(format!("{}: not valid UTF-8", path.display())))?;
    parse_pairs(&text, path)
}

/// Parses the direction CSV; `path` names it in errors.
pub fn parse_pairs(text: &str, path: &Path) -> CliResult<Vec<(Vec3, Vec3)>> {
    let p = path.display();
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| {
        bad_msg(format!(
            "{p}: empty file, expected the header {}",
            HEADER.join(",")
        ))
    })?;
    let names: Vec<&str> = header
        .trim_start_matches('\u{feff}')
        .split(',')
        .map(str::trim)
        .collect();
    if names != HEADER {
        return Err(bad_msg(format!(
            "{p}: line 1: header is `{}`, expected `{}`",
            header.trim(),
            HEADER.join(",")
        )));
    }
    let mut pairs = Vec::new();
    for (n, line) in lines {
        let line_no = n + 1;
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != 6 {
            return Err(bad_msg(format!(
                "{p}: line {line_no}: expected 6 fields, found {}",
                fields.len()
            )));
        }
        let mut v = [0.0f64; 6];
        for (c, f) in fields.iter().enumerate() {
            v[c] = f
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    bad_msg(format!(
                        "{p}: line {line_no}: {} = `{f}` is not a finite number",
                        HEADER[c]
                    ))
                })?;
        }
        let wi = Vec3::new(v[0], v[1], v[2]);
        let wo = Vec3::new(v[3], v[4], v[5]);
        for (name, w) in [("wi", wi), ("wo", wo)] {
            if (w.norm() - 1.0).abs() > UNIT_TOLERANCE {
                return Err(bad_msg(format!(
                    "{p}: line {line_no}: {name} has length {}, expected a unit vector",
                    w.norm()
                )));
            }
        }
        pairs.push((wi, wo));
    }
    Ok(pairs)
}

/// Formats values as the `r,g,b` CSV (None: empty fields).
pub fn format_rgb(values: &[Option<Rgb>]) -> String {
    let mut s = String::with_capacity(values.len() * 48 + 8);
    s.push_str("r,g,b\n");
    for v in values {
        match v {
            Some(c) => {
                let _ = writeln!(s, "{},{},{}", c.r(), c.g(), c.b());
            }
            None => s.push_str(",,\n"),
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_pairs_and_reports_bad_lines() {
        let ok = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n\n0.6, 0, 0.8, 0,0.6,0.8\n";
        let p = parse_pairs(ok, Path::new("d.csv")).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[1].0, Vec3::new(0.6, 0.0, 0.8));
        let bad = [
            ("", "empty file"),
            ("a,b\n", "header"),
            (
                "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0\n",
                "line 2: expected 6 fields",
            ),
            ("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,x,0,0,1\n", "wi_z = `x`"),
            (
                "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,NaN\n",
                "not a finite number",
            ),
            (
                "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,2,0,0,1\n",
                "wi has length 2",
            ),
        ];
        for (text, what) in bad {
            let e = parse_pairs(text, Path::new("d.csv")).unwrap_err();
            let m = e.error.to_string();
            assert!(m.starts_with("d.csv: ") && m.contains(what), "{m}");
            assert_eq!(e.exit_code(), 2);
        }
    }

    #[test]
    fn rgb_rows_round_trip_and_leave_missing_empty() {
        let s = format_rgb(&[Some(Rgb::new(0.1, 1.0 / 3.0, 2e-300)), None]);
        let lines: Vec<&str> = s.lines().collect();
        assert_eq!(lines[0], "r,g,b");
        let back: Vec<f64> = lines[1].split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(back, vec![0.1, 1.0 / 3.0, 2e-300]);
        assert_eq!(lines[2], ",,");
    }
}
