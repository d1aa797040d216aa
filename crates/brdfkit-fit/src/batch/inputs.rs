//! The tables of a batch: inputs (directories, files, glob patterns) expanded into a
//! fixed, duplicate-free list, each with its output file.

use super::BatchError;
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

/// Extension of the tables a directory input contributes.
pub const TABLE_EXT: &str = "binary";

/// One table of the batch.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Table {
    /// The table file as given (or as the directory listing or glob gave it).
    pub path: PathBuf,
    /// File name (`gold.binary`): the shard key and the summary's `table` column.
    pub name: String,
    /// `OUTDIR/<stem>.json`.
    pub out: PathBuf,
}

fn has_glob_chars(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

fn is_table_file(p: &Path) -> bool {
    p.is_file()
        && p.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case(TABLE_EXT))
}

/// Expands the inputs: a directory gives its `*.binary` files (not recursive), an
/// existing file itself, anything else is a glob pattern. An input that gives nothing
/// is an error (a typo must not make an empty batch).
fn expand(inputs: &[String]) -> Result<Vec<PathBuf>, BatchError> {
    let mut out = Vec::new();
    for input in inputs {
        let p = Path::new(input);
        let before = out.len();
        let list = |source| BatchError::List {
            input: input.clone(),
            source,
        };
        if p.is_dir() {
            for e in std::fs::read_dir(p).map_err(list)? {
                let e = e.map_err(list)?;
                if is_table_file(&e.path()) {
                    out.push(e.path());
                }
            }
            if out.len() == before {
                return Err(BatchError::EmptyDir {
                    input: input.clone(),
                });
            }
        } else if p.exists() {
            out.push(p.to_path_buf());
        } else if has_glob_chars(input) {
            let paths = glob::glob(input).map_err(|source| BatchError::Pattern {
                input: input.clone(),
                source,
            })?;
            for entry in paths {
                let path = entry.map_err(|source| BatchError::Match {
                    input: input.clone(),
                    source,
                })?;
                if path.is_file() {
                    out.push(path);
                }
            }
            if out.len() == before {
                return Err(BatchError::NoMatch {
                    input: input.clone(),
                });
            }
        } else {
            return Err(BatchError::NoSuchInput {
                input: input.clone(),
            });
        }
    }
    Ok(out)
}

/// The tables in a fixed order (by file name, then path), duplicates removed; two
/// different tables with the same stem would share an output file: an error.
pub fn tables(inputs: &[String], outdir: &Path) -> Result<Vec<Table>, BatchError> {
    let mut seen = HashSet::new();
    let mut v: Vec<Table> = Vec::new();
    for path in expand(inputs)? {
        let key = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        if !seen.insert(key) {
            continue;
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .ok_or_else(|| BatchError::NotAFileName { path: path.clone() })?;
        let stem = path
            .file_stem()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| name.clone());
        v.push(Table {
            out: outdir.join(format!("{stem}.json")),
            path,
            name,
        });
    }
    v.sort_by(|a, b| a.name.cmp(&b.name).then_with(|| a.path.cmp(&b.path)));
    let mut by_out: BTreeMap<&Path, &Path> = BTreeMap::new();
    for t in &v {
        if let Some(other) = by_out.insert(&t.out, &t.path) {
            return Err(BatchError::SameName {
                first: other.to_path_buf(),
                second: t.path.clone(),
                out: t.out.clone(),
            });
        }
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(p: &Path) -> String {
        p.to_str().unwrap().to_string()
    }

    #[test]
    fn directories_files_and_globs_expand_in_a_fixed_order_without_duplicates() {
        let d = tempfile::tempdir().unwrap();
        let db = d.path().join("db");
        std::fs::create_dir(&db).unwrap();
        for n in ["b.binary", "a.binary", "c.BINARY", "notes.txt"] {
            std::fs::write(db.join(n), "x").unwrap();
        }
        let out = d.path().join("out");
        let t = tables(&[s(&db), s(&db.join("a.binary"))], &out).unwrap();
        let names: Vec<&str> = t.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names, ["a.binary", "b.binary", "c.BINARY"]);
        assert_eq!(t[1].out, out.join("b.json"));
        let t = tables(&[format!("{}/[ab].binary", db.display())], &out).unwrap();
        assert_eq!(t.len(), 2);
        // An explicit file needs no table extension.
        assert_eq!(tables(&[s(&db.join("notes.txt"))], &out).unwrap().len(), 1);
    }

    #[test]
    fn inputs_that_give_nothing_or_collide_are_errors() {
        let d = tempfile::tempdir().unwrap();
        let (a, b) = (d.path().join("a"), d.path().join("b"));
        for dir in [&a, &b] {
            std::fs::create_dir(dir).unwrap();
            std::fs::write(dir.join("t.binary"), "x").unwrap();
        }
        let empty = d.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        let out = d.path().join("out");
        let err = |inputs: &[String]| tables(inputs, &out).unwrap_err();
        assert!(matches!(
            err(&[s(&d.path().join("missing"))]),
            BatchError::NoSuchInput { .. }
        ));
        assert!(matches!(err(&[s(&empty)]), BatchError::EmptyDir { .. }));
        assert!(matches!(
            err(&[format!("{}/*.nope", a.display())]),
            BatchError::NoMatch { .. }
        ));
        let e = err(&[s(&a), s(&b)]);
        assert!(matches!(e, BatchError::SameName { .. }), "{e}");
        assert!(e.to_string().contains("same name"), "{e}");
        assert!(e.is_bad_input());
    }
}
