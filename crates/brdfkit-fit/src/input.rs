//! The one rule for what a measured input is, shared by every command that fits,
//! scores or reports (`fit`, `score`, `report`, `batch`): a MERL table, an RGL-EPFL
//! `.bsdf` file (told apart by their first bytes, [`InputKind::of_head`]) or a file of
//! scattered samples ([`FitData::read_samples`]).
//!
//! A `.bsdf` becomes its measured points at their own directions
//! ([`BsdfInput::Points`], the default: docs/rgl.md "The sample-set fit" has the
//! measurement that chose it) or its resampling to a 90 × 90 × 180 MERL table
//! ([`BsdfInput::Table`], each cell the weighted mean of both orders of its pair, as `fit-brdf
//! resample --bsdf` writes it). Isotropic and anisotropic files alike
//! (`brdfkit_rgl::MeasuredPoints::of`).

use crate::data::FitData;
use crate::error::FitError;
use crate::samples::SamplesFileError;
use brdfkit_merl::{Dims, MerlError, MerlTable, TableCells, TablePlanes};
use brdfkit_rgl::{InputKind, MeasuredPoints, RglBsdf, RglError, TensorFile};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What a `.bsdf` input is fitted, scored and reported on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BsdfInput {
    /// The measured points (the `valid` bits) at their own directions.
    #[default]
    Points,
    /// The file resampled to a 90 × 90 × 180 MERL table.
    Table,
}

brdfkit_core::named_choice!(BsdfInput, "bsdf input", {
    Points => "points",
    Table => "table",
});

/// Why an input cannot be read; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The file cannot be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A bad samples file (names the file and the row or line).
    #[error(transparent)]
    Samples(#[from] SamplesFileError),
    /// A bad `.bsdf` file (names the file and the field).
    #[error(transparent)]
    Rgl(#[from] RglError),
    /// A bad MERL table.
    #[error(transparent)]
    Merl(#[from] MerlError),
    /// The input holds nothing to fit, or its resampling failed.
    #[error("{}: {message}", path.display())]
    Data {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// What the cells of a [`Measured`] input stand for beside themselves.
pub enum MeasuredSide {
    /// A MERL table (kept when the caller asked for it: a report draws from it);
    /// `resampled_from_bsdf` is set when it is a `.bsdf`'s resampling.
    Table {
        /// The table, if kept.
        table: Option<MerlTable>,
        /// A `.bsdf`'s negative values stored as 0 by the resampling, when it is one.
        resampled_from_bsdf: Option<usize>,
    },
    /// A `.bsdf`'s measured points; the file itself evaluates anywhere.
    BsdfPoints(Box<RglBsdf>),
    /// A user's scattered samples: nothing evaluates between them.
    Samples,
}

/// A measured input: the cells every loss, solver and report works on, and what they
/// stand for.
pub struct Measured {
    /// The cells.
    pub data: FitData,
    /// The measurement beside the cells.
    pub side: MeasuredSide,
    /// The input's path.
    pub path: PathBuf,
    /// What a command tells its user about how the input was read (stderr), if
    /// anything.
    pub note: Option<String>,
    /// Seconds spent reading and parsing the file (a table's bytes into a table, a
    /// `.bsdf` into its fields), before its cells are built: `fit --stage-times`'s
    /// `read` (the rest is `cells`).
    pub read_s: f64,
}

/// An input as a score or a report names it: its file, its kind and its counts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputInfo {
    /// The file.
    pub path: String,
    /// `table`, `bsdf-table` (a `.bsdf` resampled to a MERL table), `bsdf-points` or
    /// `samples`.
    pub kind: String,
    /// Cells (table cells or samples) the input gives.
    pub cells: usize,
    /// Rows, dropped rows and the weights of a sample set.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<crate::data::SampleInput>,
}

impl Measured {
    /// Reads a table or a `.bsdf` file (`how` for the latter); `keep_table` keeps a
    /// table beside its cells (else it is freed before their geometry is built).
    ///
    /// A MERL table in a regular file is read by [`MerlTable::read`] straight into the
    /// table (positional reads into a buffer on huge pages), not through a copy of the
    /// whole file: that copy cost 35 MB of fresh 4 KiB pages and a second pass over
    /// the bytes, about 30 ms of a default fit's 0.2 s (docs/performance.md, "Issue
    /// 28, session 11"). Without `keep_table` its planes become the cells' arrays in
    /// place ([`TableCells`]; "Issue 28, session 14"). Anything else (a `.bsdf`, a
    /// pipe) is read whole, as before.
    pub fn read(path: &Path, how: BsdfInput, keep_table: bool) -> Result<Measured, InputError> {
        let t = std::time::Instant::now();
        if std::fs::metadata(path).is_ok_and(|m| m.is_file())
            && InputKind::of_file(path).is_ok_and(|k| k != InputKind::Rgl)
        {
            if !keep_table {
                return Measured::read_cells(path);
            }
            let table = MerlTable::read(path)?;
            let read_s = t.elapsed().as_secs_f64();
            let m = Measured::of_table(table, path, None, keep_table, None)?;
            return Ok(Measured { read_s, ..m });
        }
        let bytes = std::fs::read(path).map_err(|source| InputError::Io {
            path: path.to_owned(),
            source,
        })?;
        let read_s = t.elapsed().as_secs_f64();
        let m = Measured::from_bytes(bytes, path, how, keep_table)?;
        Ok(Measured {
            read_s: read_s + m.read_s,
            ..m
        })
    }

    /// A MERL table file's valid cells, its values read straight into the cells'
    /// arrays ([`FitData::from_table_cells`]): no table in memory, and the values copied
    /// from the file into fresh memory once. `read_s` is the file's reading and
    /// checking ([`TablePlanes::read`]); the cells are built in its planes' buffers.
    fn read_cells(path: &Path) -> Result<Measured, InputError> {
        let t = std::time::Instant::now();
        let planes = TablePlanes::read(path)?;
        let read_s = t.elapsed().as_secs_f64();
        let data = FitData::from_table_cells(TableCells::from_planes(planes)).map_err(|e| {
            InputError::Data {
                path: path.to_owned(),
                message: e.to_string(),
            }
        })?;
        Ok(Measured {
            data,
            side: MeasuredSide::Table {
                table: None,
                resampled_from_bsdf: None,
            },
            path: path.to_owned(),
            note: None,
            read_s,
        })
    }

    /// A file of scattered samples ([`FitData::read_samples`]).
    pub fn read_samples(path: &Path) -> Result<Measured, InputError> {
        Ok(Measured {
            data: FitData::read_samples(path)?,
            side: MeasuredSide::Samples,
            path: path.to_owned(),
            note: None,
            read_s: 0.0,
        })
    }

    /// [`Measured::read`] of a file's bytes (`path` names it in errors).
    pub fn from_bytes(
        bytes: Vec<u8>,
        path: &Path,
        how: BsdfInput,
        keep_table: bool,
    ) -> Result<Measured, InputError> {
        let data_err = |e: &dyn std::fmt::Display| InputError::Data {
            path: path.to_owned(),
            message: e.to_string(),
        };
        let t = std::time::Instant::now();
        if InputKind::of_head(&bytes) != InputKind::Rgl {
            let table = MerlTable::from_bytes(&bytes, path)?;
            drop(bytes);
            let parse_s = t.elapsed().as_secs_f64();
            let m = Measured::of_table(table, path, None, keep_table, None)?;
            return Ok(Measured {
                read_s: parse_s,
                ..m
            });
        }
        let tf = TensorFile::from_bytes(bytes, path)?;
        let bsdf = RglBsdf::from_tensor(&tf)?;
        let parse_s = t.elapsed().as_secs_f64();
        if how == BsdfInput::Points {
            // from_tensor has checked `valid`'s dtype and length.
            let valid = tf.get("valid").map(|f| tf.data(f));
            let pts = MeasuredPoints::of(&bsdf, valid);
            let data = FitData::from_bsdf_points(&pts).map_err(|e: FitError| data_err(&e))?;
            let note = format!(
                "{}: an RGL-EPFL .bsdf file, taken at its {} measured points ({} skipped, {} \
                 sharing a direction merged; negative values stored as 0: {}); docs/rgl.md",
                path.display(),
                pts.points.len(),
                pts.skipped,
                pts.merged,
                data.input().map_or(0, |i| i.negative_zeroed),
            );
            return Ok(Measured {
                data,
                side: MeasuredSide::BsdfPoints(Box::new(bsdf)),
                path: path.to_owned(),
                note: Some(note),
                read_s: parse_s,
            });
        }
        drop(tf);
        let (table, clamped, note) = resampled(&bsdf, path)?;
        // The resampling is part of reading the file as a table.
        let read_s = t.elapsed().as_secs_f64();
        let m = Measured::of_table(table, path, Some(clamped), keep_table, Some(note))?;
        Ok(Measured { read_s, ..m })
    }

    fn of_table(
        table: MerlTable,
        path: &Path,
        resampled_from_bsdf: Option<usize>,
        keep_table: bool,
        note: Option<String>,
    ) -> Result<Measured, InputError> {
        let err = |e: FitError| InputError::Data {
            path: path.to_owned(),
            message: e.to_string(),
        };
        let (data, table) = if keep_table {
            (FitData::from_table(&table).map_err(err)?, Some(table))
        } else {
            // The table (35 MB) is freed while the cells are built, before their
            // geometry is allocated.
            (FitData::from_owned_table(table).map_err(err)?, None)
        };
        Ok(Measured {
            data,
            side: MeasuredSide::Table {
                table,
                resampled_from_bsdf,
            },
            path: path.to_owned(),
            note,
            read_s: 0.0,
        })
    }

    /// The input's kind: `table`, `bsdf-table`, `bsdf-points` or `samples`.
    pub fn kind(&self) -> &'static str {
        match &self.side {
            MeasuredSide::Table {
                resampled_from_bsdf: None,
                ..
            } => "table",
            MeasuredSide::Table { .. } => "bsdf-table",
            MeasuredSide::BsdfPoints(_) => "bsdf-points",
            MeasuredSide::Samples => "samples",
        }
    }

    /// The input's file, kind and counts.
    pub fn info(&self) -> InputInfo {
        InputInfo {
            path: self.path.display().to_string(),
            kind: self.kind().into(),
            cells: self.data.len(),
            samples: self.data.input().cloned(),
        }
    }
}

/// A `.bsdf` resampled to a 90 × 90 × 180 MERL table (each cell the weighted mean of both
/// orders of its pair, as `fit-brdf resample --bsdf` writes it), its negative values stored as
/// 0, and the note that says so.
fn resampled(bsdf: &RglBsdf, path: &Path) -> Result<(MerlTable, usize, String), InputError> {
    let (table, stats) = bsdf.to_table(Dims::MERL).map_err(|e| InputError::Data {
        path: path.to_owned(),
        message: e.to_string(),
    })?;
    let note = format!(
        "{}: an RGL-EPFL .bsdf file, resampled to a 90x90x180 MERL table (weighted mean of \
         both orders of each pair; {} negative values stored as 0); docs/rgl.md",
        path.display(),
        stats.clamped_values
    );
    Ok((table, stats.clamped_values, note))
}

/// A table for the commands that need a full grid (`info`, `check`, `eval --table`, …):
/// a MERL table, or a `.bsdf` (by its first bytes) resampled to one with the note that
/// says so.
pub fn read_table(path: &Path) -> Result<(MerlTable, Option<String>), InputError> {
    let io = |source| InputError::Io {
        path: path.to_owned(),
        source,
    };
    if InputKind::of_file(path).map_err(io)? != InputKind::Rgl {
        return Ok((MerlTable::read(path)?, None));
    }
    let (table, _, note) = resampled(&RglBsdf::read(path)?, path)?;
    Ok((table, Some(note)))
}

impl InputInfo {
    /// One line: the file, its kind and its counts.
    pub fn text(&self) -> String {
        let what = match self.kind.as_str() {
            "table" => "a MERL table".to_string(),
            "bsdf-table" => "a .bsdf file resampled to a 90x90x180 MERL table".to_string(),
            "bsdf-points" => "a .bsdf file's measured points at their own directions".into(),
            _ => "scattered samples".into(),
        };
        let counts = match &self.samples {
            Some(s) => format!(
                "{} samples of {} rows ({} missing, {} dropped by the reader, {} negative \
                 values stored as 0; {} weights)",
                s.samples, s.rows, s.dropped_missing, s.dropped_other, s.negative_zeroed, s.weights
            ),
            None => format!("{} valid cells", self.cells),
        };
        format!("{} ({what}): {counts}", self.path)
    }
}
