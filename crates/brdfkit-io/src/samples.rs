//! Scattered measured samples, the input of `fit-brdf fit --samples`: N rows of
//! `wi_x wi_y wi_z wo_x wo_y wo_z r g b` and optionally `weight`, as
//! - a `.npy` array of shape (N, 9) or (N, 10), float32 or float64, C or Fortran order;
//! - a CSV file with the header `wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,r,g,b` or the same with
//!   `,weight`, then one sample per line. Blank lines are skipped; an empty `r`, `g` or
//!   `b` field (or `nan`) is a missing value.
//!
//! Directions point away from the surface in the local frame (z = normal); values are
//! f_r in linear RGB (1/sr, without the cosine); the weight is the measure of (wi, wo)
//! pairs the sample stands for (sr²). This module reads the numbers and checks the
//! file's structure (columns, numbers); the rules on the samples themselves (unit
//! directions above the horizon, missing values, negatives, weights) are the fitter's
//! (`brdfkit_fit::samples`), which names the row.

use crate::npy::{self, NpyError};
use npyz::Order;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The CSV header of a file with weights; without, the first nine names.
pub const HEADER: [&str; 10] = [
    "wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z", "r", "g", "b", "weight",
];

/// The numbers of a samples file, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleRows {
    /// 9 or 10 (with weights).
    pub cols: usize,
    /// `cols` numbers a row.
    pub data: Vec<f64>,
    /// The line of each row in a CSV file (1-based), `None` for `.npy`.
    pub lines: Option<Vec<usize>>,
}

impl SampleRows {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.data.len() / self.cols
    }

    /// True without rows.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Row `k`.
    pub fn row(&self, k: usize) -> &[f64] {
        &self.data[k * self.cols..(k + 1) * self.cols]
    }

    /// Where row `k` is in the file, as a person looks for it: `row k` (0-based, as
    /// numpy counts) or `line L` of a CSV file.
    pub fn locate(&self, k: usize) -> String {
        match &self.lines {
            Some(l) => format!("line {}", l[k]),
            None => format!("row {k}"),
        }
    }
}

/// What is wrong with a samples file.
#[derive(Debug, Error)]
pub enum SamplesError {
    /// A `.npy` problem (unreadable, damaged, wrong dtype or shape).
    #[error(transparent)]
    Npy(#[from] NpyError),
    /// The file could not be read.
    #[error("{}: cannot read the samples file: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A CSV file that is not UTF-8 text.
    #[error(transparent)]
    Text(#[from] brdfkit_core::text::TextFileError),
    /// A CSV problem at a line (1-based).
    #[error("{}: line {line}: {what}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// The line.
        line: usize,
        /// What is wrong.
        what: String,
    },
}

/// Reads a samples file: `.npy` by extension, CSV otherwise.
pub fn read_samples(path: &Path) -> Result<SampleRows, SamplesError> {
    let bytes = std::fs::read(path).map_err(|source| SamplesError::Read {
        path: path.to_owned(),
        source,
    })?;
    if crate::npy::is_npy(path) {
        return Ok(parse_npy(&bytes, path)?);
    }
    let text = brdfkit_core::text::utf8(bytes, path, "the samples file")?;
    parse_csv(&text, path)
}

/// The rows of a (N, 9) or (N, 10) float32 or float64 `.npy` array; `path` names it.
pub fn parse_npy(bytes: &[u8], path: &Path) -> Result<SampleRows, NpyError> {
    let format = |source| npy::format_error(path, source);
    let npy = npy::open_bytes(bytes, path)?;
    let dtype = npy.dtype();
    let size = npy::float_size(&npy);
    let shape = npy.shape().to_vec();
    if shape.len() != 2 || !(shape[1] == 9 || shape[1] == 10) {
        return Err(NpyError::Shape {
            path: path.to_owned(),
            found: shape,
            expected: "(N, 9) or (N, 10): wi_x wi_y wi_z wo_x wo_y wo_z r g b [weight] per sample"
                .into(),
        });
    }
    let fortran = npy.order() == Order::Fortran;
    let data: Vec<f64> = match size {
        Some(4) => npy
            .into_vec::<f32>()
            .map_err(format)?
            .into_iter()
            .map(f64::from)
            .collect(),
        Some(8) => npy.into_vec::<f64>().map_err(format)?,
        _ => {
            return Err(NpyError::Dtype {
                path: path.to_owned(),
                found: dtype.descr(),
                expected: "float32 or float64",
            });
        }
    };
    let (rows, cols) = (shape[0] as usize, shape[1] as usize);
    let data = if fortran {
        npy::fortran_to_c(&data, rows, cols)
    } else {
        data
    };
    Ok(SampleRows {
        cols,
        data,
        lines: None,
    })
}

/// The rows of a samples CSV (module doc); `path` names it in errors.
pub fn parse_csv(text: &str, path: &Path) -> Result<SampleRows, SamplesError> {
    let err = |line: usize, what: String| SamplesError::Csv {
        path: path.to_owned(),
        line,
        what,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let expected = format!("`{}` (`,weight` optional)", HEADER[..9].join(","));
    let (_, header) = lines
        .next()
        .ok_or_else(|| err(1, format!("empty file, expected the header {expected}")))?;
    let names: Vec<&str> = header
        .trim_start_matches('\u{feff}')
        .split(',')
        .map(str::trim)
        .collect();
    let cols = names.len();
    if !(cols == 9 || cols == 10) || names != HEADER[..cols] {
        return Err(err(
            1,
            format!("header is `{}`, expected {expected}", header.trim()),
        ));
    }
    let mut out = SampleRows {
        cols,
        data: Vec::new(),
        lines: Some(Vec::new()),
    };
    for (n, row) in lines {
        let line = n + 1;
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != cols {
            return Err(err(
                line,
                format!("expected {cols} fields, found {}", fields.len()),
            ));
        }
        for (c, f) in fields.iter().enumerate() {
            out.data.push(
                field(f, c)
                    .ok_or_else(|| err(line, format!("{} = `{f}` is not a number", HEADER[c])))?,
            );
        }
        if let Some(l) = &mut out.lines {
            l.push(line);
        }
    }
    Ok(out)
}

/// One field of column `c`: a number; an empty or NaN value field (r, g, b) is missing
/// (NaN), any other column must hold a number.
fn field(f: &str, c: usize) -> Option<f64> {
    let value_col = (6..9).contains(&c);
    if f.is_empty() {
        return value_col.then_some(f64::NAN);
    }
    f.parse::<f64>().ok().filter(|x| !x.is_nan() || value_col)
}

/// A (N, 9|10) `.npy` of `rows` in float64 (tests and tools): header by npyz.
pub fn write_npy(w: &mut impl std::io::Write, data: &[f64], cols: usize) -> std::io::Result<()> {
    use npyz::WriterBuilder;
    let mut out = npyz::WriteOptions::new()
        .default_dtype()
        .shape(&[(data.len() / cols) as u64, cols as u64])
        .writer(w)
        .begin_nd()?;
    out.extend(data.iter().copied())?;
    out.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    const H9: &str = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,r,g,b";

    #[test]
    fn csv_rows_missing_values_and_weights() {
        let text = format!("{H9}\n0,0,1,0.6,0,0.8,0.1,0.2,0.3\n\n0,0,1,0,0,1,,nan,0.5\n");
        let r = parse_csv(&text, Path::new("s.csv")).unwrap();
        assert_eq!((r.cols, r.len()), (9, 2));
        assert_eq!(r.row(0), [0.0, 0.0, 1.0, 0.6, 0.0, 0.8, 0.1, 0.2, 0.3]);
        assert!(r.row(1)[6].is_nan() && r.row(1)[7].is_nan() && r.row(1)[8] == 0.5);
        assert_eq!(r.locate(1), "line 4");
        let w = parse_csv(
            &format!("{H9},weight\n0,0,1,0,0,1,1,1,1,0.25\n"),
            Path::new("w.csv"),
        )
        .unwrap();
        assert_eq!((w.cols, w.row(0)[9]), (10, 0.25));
    }

    #[test]
    fn csv_bad_files_name_file_line_and_problem() {
        let bad = [
            ("".to_string(), "line 1: empty file"),
            ("a,b\n".to_string(), "line 1: header is `a,b`"),
            (
                format!("{H9}\n0,0,1,0,0,1,1,1\n"),
                "line 2: expected 9 fields, found 8",
            ),
            (
                format!("{H9}\n0,0,x,0,0,1,1,1,1\n"),
                "line 2: wi_z = `x` is not a number",
            ),
            (
                format!("{H9}\n\n0,0,,0,0,1,1,1,1\n"),
                "line 3: wi_z = `` is not a number",
            ),
            (
                format!("{H9}\n0,0,nan,0,0,1,1,1,1\n"),
                "line 2: wi_z = `nan`",
            ),
            (
                format!("{H9},weight\n0,0,1,0,0,1,1,1,1,\n"),
                "line 2: weight = ``",
            ),
        ];
        for (text, what) in bad {
            let m = parse_csv(&text, Path::new("s.csv"))
                .unwrap_err()
                .to_string();
            assert!(m.starts_with("s.csv: ") && m.contains(what), "{m}");
        }
    }

    #[test]
    fn npy_f32_f64_and_bad_shapes() {
        let rows = [0.0, 0.0, 1.0, 0.6, 0.0, 0.8, 0.1, 0.2, 0.3];
        let mut b = Vec::new();
        write_npy(&mut b, &rows, 9).unwrap();
        let r = parse_npy(&b, Path::new("s.npy")).unwrap();
        assert_eq!((r.cols, r.row(0)), (9, &rows[..]));
        assert_eq!(r.locate(0), "row 0");
        // float32, 10 columns.
        let mut b = Vec::new();
        {
            use npyz::WriterBuilder;
            let mut w = npyz::WriteOptions::new()
                .default_dtype()
                .shape(&[1, 10])
                .writer(&mut b)
                .begin_nd()
                .unwrap();
            w.extend([0.0f32, 0.0, 1.0, 0.0, 0.0, 1.0, 0.5, 0.5, 0.5, 2.0])
                .unwrap();
            w.finish().unwrap();
        }
        let r = parse_npy(&b, Path::new("s.npy")).unwrap();
        assert_eq!((r.cols, r.row(0)[9]), (10, 2.0));
        let mut b = Vec::new();
        write_npy(&mut b, &rows[..6], 6).unwrap();
        let m = parse_npy(&b, Path::new("s.npy")).unwrap_err().to_string();
        assert!(
            m.contains("s.npy: shape (1, 6), expected (N, 9) or (N, 10)"),
            "{m}"
        );
        let m = parse_npy(b"not npy", Path::new("s.npy"))
            .unwrap_err()
            .to_string();
        assert!(m.starts_with("s.npy: not a valid .npy file"), "{m}");
    }
}
