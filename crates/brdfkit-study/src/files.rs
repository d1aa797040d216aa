//! The study's data files (CSV, JSON, PNG, the Markdown report), all written through
//! brdfkit's one writer, [`brdfkit_core::atomic`]: whole or not at all, and with the
//! permissions of a plainly created file (0666 & ~umask) or of the file replaced.

use crate::StudyError;
use serde::Serialize;
use std::path::Path;

/// Writes `bytes` to `path` atomically.
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), StudyError> {
    Ok(brdfkit_core::atomic::write_bytes(path, bytes)?)
}

/// Pretty JSON of `v`.
pub fn write_json<T: Serialize>(path: &Path, v: &T) -> Result<(), StudyError> {
    let s = serde_json::to_string_pretty(v).map_err(|e| StudyError::io(path, e.into()))?;
    write(path, s.as_bytes())
}

fn csv_field(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) if s.contains([',', '"', '\n']) => {
            format!("\"{}\"", s.replace('"', "\"\""))
        }
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Null => String::new(),
        x => x.to_string(),
    }
}

/// CSV of flat serialisable rows (header from the first row's fields; NaN is empty).
pub fn write_csv<T: Serialize>(path: &Path, rows: &[T]) -> Result<(), StudyError> {
    let mut out = String::new();
    let vals: Vec<serde_json::Map<String, serde_json::Value>> = rows
        .iter()
        .filter_map(|r| match serde_json::to_value(r) {
            Ok(serde_json::Value::Object(m)) => Some(m),
            _ => None,
        })
        .collect();
    if let Some(first) = vals.first() {
        let keys: Vec<&String> = first.keys().collect();
        out.push_str(
            &keys
                .iter()
                .map(|k| k.as_str())
                .collect::<Vec<_>>()
                .join(","),
        );
        out.push('\n');
        for m in &vals {
            let line: Vec<String> = keys
                .iter()
                .map(|k| csv_field(m.get(*k).unwrap_or(&serde_json::Value::Null)))
                .collect();
            out.push_str(&line.join(","));
            out.push('\n');
        }
    }
    write(path, out.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quotes_fields_with_commas() {
        #[derive(Serialize)]
        struct R {
            a: String,
            b: f64,
        }
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.csv");
        write_csv(
            &p,
            &[
                R {
                    a: "x, \"y\"".into(),
                    b: 1.5,
                },
                R {
                    a: "z".into(),
                    b: f64::NAN,
                },
            ],
        )
        .unwrap();
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            "a,b\n\"x, \"\"y\"\"\",1.5\nz,\n"
        );
    }
}
