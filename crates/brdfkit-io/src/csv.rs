//! The direction-pair CSV contract of `eval`.
//!
//! Input: a header line `wi_x,wi_y,wi_z,wo_x,wo_y,wo_z`, then one pair per line, six
//! finite numbers, each direction of unit length (within
//! [`UNIT_TOLERANCE`]; directions are not renormalised behind the user's back). Blank
//! lines are skipped. Output: a header `r,g,b`, then one row per input row; empty fields
//! where no valid sample exists. Numbers print in the shortest form that reads back to
//! the same f64.

use brdfkit_core::{Rgb, Vec3};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Tolerance on |w| − 1 for an input direction: the library's, so that the command
/// line and the Python bindings apply one rule.
pub use brdfkit_core::direction::UNIT_TOLERANCE;

/// The header of a direction-pair file.
pub const HEADER: [&str; 6] = ["wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"];

/// What is wrong with a direction-pair CSV file; lines count from 1, as editors do.
#[derive(Debug, Error)]
pub enum CsvError {
    /// The file could not be read, or is not UTF-8 text.
    #[error(transparent)]
    Text(#[from] brdfkit_core::text::TextFileError),
    /// No header line.
    #[error("{}: empty file, expected the header {}", path.display(), HEADER.join(","))]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// Another header than [`HEADER`].
    #[error("{}: line 1: header is `{found}`, expected `{}`", path.display(), HEADER.join(","))]
    Header {
        /// The file.
        path: PathBuf,
        /// The header line found.
        found: String,
    },
    /// A row without six fields.
    #[error("{}: line {line}: expected 6 fields, found {found}", path.display())]
    Fields {
        /// The file.
        path: PathBuf,
        /// The line.
        line: usize,
        /// Fields found.
        found: usize,
    },
    /// A field that is not a finite number.
    #[error("{}: line {line}: {column} = `{text}` is not a finite number", path.display())]
    Number {
        /// The file.
        path: PathBuf,
        /// The line.
        line: usize,
        /// The column's name.
        column: &'static str,
        /// The field as written.
        text: String,
    },
    /// A direction that is not of unit length.
    #[error("{}: line {line}: {name} has length {norm}, expected a unit vector", path.display())]
    NotUnit {
        /// The file.
        path: PathBuf,
        /// The line.
        line: usize,
        /// `wi` or `wo`.
        name: &'static str,
        /// Its length.
        norm: f64,
    },
}

/// Reads the direction pairs of a CSV file.
pub fn read_pairs(path: &Path) -> Result<Vec<(Vec3, Vec3)>, CsvError> {
    let text = brdfkit_core::text::read_utf8(path, "the directions file")?;
    parse_pairs(&text, path)
}

/// Parses the direction CSV; `path` names it in errors.
pub fn parse_pairs(text: &str, path: &Path) -> Result<Vec<(Vec3, Vec3)>, CsvError> {
    let path = || path.to_owned();
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or_else(|| CsvError::Empty { path: path() })?;
    let names: Vec<&str> = header
        .trim_start_matches('\u{feff}')
        .split(',')
        .map(str::trim)
        .collect();
    if names != HEADER {
        return Err(CsvError::Header {
            path: path(),
            found: header.trim().to_string(),
        });
    }
    let mut pairs = Vec::new();
    for (n, row) in lines {
        let line = n + 1;
        let v = parse_row(row, line, &path)?;
        let wi = Vec3::new(v[0], v[1], v[2]);
        let wo = Vec3::new(v[3], v[4], v[5]);
        for (name, w) in [("wi", wi), ("wo", wo)] {
            if (w.norm() - 1.0).abs() > UNIT_TOLERANCE {
                return Err(CsvError::NotUnit {
                    path: path(),
                    line,
                    name,
                    norm: w.norm(),
                });
            }
        }
        pairs.push((wi, wo));
    }
    Ok(pairs)
}

/// The six finite numbers of one data row.
fn parse_row(row: &str, line: usize, path: &impl Fn() -> PathBuf) -> Result<[f64; 6], CsvError> {
    let fields: Vec<&str> = row.split(',').map(str::trim).collect();
    if fields.len() != 6 {
        return Err(CsvError::Fields {
            path: path(),
            line,
            found: fields.len(),
        });
    }
    let mut v = [0.0f64; 6];
    for (c, f) in fields.iter().enumerate() {
        v[c] = f
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| CsvError::Number {
                path: path(),
                line,
                column: HEADER[c],
                text: f.to_string(),
            })?;
    }
    Ok(v)
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
            let m = parse_pairs(text, Path::new("d.csv"))
                .unwrap_err()
                .to_string();
            assert!(m.starts_with("d.csv: ") && m.contains(what), "{m}");
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
