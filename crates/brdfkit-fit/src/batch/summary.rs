//! The summary of a batch: one row per table and model (or per failed or pending table),
//! written as CSV after every table.

use super::Table;
use serde_json::{Value, json};
use std::fmt::Write as _;

/// Where a table stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Fitted by this run.
    Fitted,
    /// Done by an earlier run with the same options (skipped).
    Resumed,
    /// Could not be fitted (its error is in the row).
    Failed,
    /// Not reached (the batch was interrupted before it).
    Pending,
}

impl Status {
    /// The name in the CSV and the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Status::Fitted => "fitted",
            Status::Resumed => "resumed",
            Status::Failed => "failed",
            Status::Pending => "pending",
        }
    }
}

/// One row of the summary: one model of one table, or a failed / pending table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The table's file name.
    pub table: String,
    /// The family's label (empty for a failed or pending table).
    pub model: String,
    /// Where the table stands.
    pub status: Status,
    /// Loss `cbrt` over all valid cells.
    pub cbrt: Option<f64>,
    /// Loss `l2` over all valid cells.
    pub l2: Option<f64>,
    /// Loss `cosine` over all valid cells.
    pub cosine: Option<f64>,
    /// Loss `log` over all valid cells.
    pub log: Option<f64>,
    /// Valid cells.
    pub cells: Option<u64>,
    /// Iterations of the fit.
    pub iterations: Option<u64>,
    /// Whether the fit converged.
    pub converged: Option<bool>,
    /// Wall time of the fit.
    pub fit_time_s: Option<f64>,
    /// The per-table JSON (empty for a failed or pending table).
    pub json: String,
    /// Why the table failed.
    pub error: String,
}

impl Row {
    /// The row of a table without fits (failed or pending).
    pub fn bare(t: &Table, status: Status, error: String) -> Row {
        Row {
            table: t.name.clone(),
            model: String::new(),
            status,
            cbrt: None,
            l2: None,
            cosine: None,
            log: None,
            cells: None,
            iterations: None,
            converged: None,
            fit_time_s: None,
            json: String::new(),
            error,
        }
    }

    /// Rows from the `fits` of a per-table JSON; None when a fit has no label.
    pub fn from_fits(t: &Table, fits: &[Value], status: Status) -> Option<Vec<Row>> {
        let mut rows = Vec::new();
        for f in fits {
            let r = &f["record"];
            let loss = |k: &str| r["losses_full"][k]["overall"].as_f64();
            rows.push(Row {
                table: t.name.clone(),
                model: f["label"].as_str()?.to_string(),
                status,
                cbrt: loss("cbrt"),
                l2: loss("l2"),
                cosine: loss("cosine"),
                log: loss("log"),
                cells: r["cells_full"].as_u64(),
                iterations: r["iterations"].as_u64(),
                converged: r["converged"].as_bool(),
                fit_time_s: r["wall_time_s"].as_f64(),
                json: t.out.display().to_string(),
                error: String::new(),
            });
        }
        Some(rows)
    }

    /// The row's figures as JSON (the `fits` of `batch --json`).
    pub fn to_json(&self) -> Value {
        json!({"model": self.model, "cbrt": self.cbrt, "l2": self.l2, "cosine": self.cosine,
               "log": self.log, "cells": self.cells, "iterations": self.iterations,
               "converged": self.converged, "fit_time_s": self.fit_time_s})
    }
}

/// The header of the summary CSV.
pub const CSV_HEADER: &str =
    "table,model,status,cbrt,l2,cosine,log,cells,iterations,converged,fit_time_s,json,error";

/// A CSV field (RFC 4180): quoted when it holds a comma, a quote or a line break.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn opt<T: ToString>(v: Option<T>) -> String {
    v.map_or(String::new(), |x| x.to_string())
}

/// The summary CSV of `rows`, header first.
pub fn summary_csv<'a>(rows: impl IntoIterator<Item = &'a Row>) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in rows {
        let fields = [
            csv_field(&r.table),
            csv_field(&r.model),
            r.status.name().to_string(),
            opt(r.cbrt),
            opt(r.l2),
            opt(r.cosine),
            opt(r.log),
            opt(r.cells),
            opt(r.iterations),
            opt(r.converged),
            opt(r.fit_time_s),
            csv_field(&r.json),
            csv_field(&r.error),
        ];
        let _ = writeln!(s, "{}", fields.join(","));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn csv_fields_are_quoted_when_needed() {
        assert_eq!(csv_field("plain"), "plain");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"x\""), "\"say \"\"x\"\"\"");
        assert_eq!(csv_field("two\nlines"), "\"two\nlines\"");
    }

    #[test]
    fn rows_come_from_the_fits_of_a_table_json() {
        let t = Table {
            path: PathBuf::from("db/gold.binary"),
            name: "gold.binary".into(),
            out: PathBuf::from("out/gold.json"),
            source: crate::batch::Source::Binary,
        };
        let fits = [json!({"label": "lambert", "record": {
            "losses_full": {"cbrt": {"overall": 0.5}, "l2": {"overall": 2.0}},
            "cells_full": 10, "iterations": 3, "converged": true, "wall_time_s": 0.25}})];
        let rows = Row::from_fits(&t, &fits, Status::Resumed).unwrap();
        let failed = Row::bare(&t, Status::Failed, "gold.binary: bad, really".into());
        let csv = summary_csv(rows.iter().chain([&failed]));
        assert_eq!(
            csv,
            format!(
                "{CSV_HEADER}\n\
                 gold.binary,lambert,resumed,0.5,2,,,10,3,true,0.25,out/gold.json,\n\
                 gold.binary,,failed,,,,,,,,,,\"gold.binary: bad, really\"\n"
            )
        );
        assert_eq!(rows[0].to_json()["cbrt"], 0.5);
        assert!(Row::from_fits(&t, &[json!({"record": {}})], Status::Fitted).is_none());
    }
}
