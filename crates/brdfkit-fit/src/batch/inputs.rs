//! The tables of a batch: inputs (directories, files, glob patterns) expanded into a
//! fixed, duplicate-free list, each with its output file. The inputs are MERL binary
//! tables and RGL-EPFL `.bsdf` files (told apart by their content; a `.bsdf` is fitted
//! as `fit` fits it, [`crate::input`]), or neural BRDF proxies ([`Source::Nbrdf`])
//! that the engine resamples onto the MERL grid in memory.

use super::BatchError;
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

/// Extension of the tables a directory input contributes.
pub const TABLE_EXT: &str = "binary";

/// Extension of the RGL-EPFL files a directory input also contributes (a file is read
/// by its content, this only picks directory entries).
pub const RGL_EXT: &str = "bsdf";

/// Suffix of the file that names a neural BRDF proxy in a directory listing (one of
/// its six `.npy` files, `brdfkit_nbrdf::PARTS`).
pub const NBRDF_MARK: &str = "_fc1.npy";

/// What the inputs of a batch are.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Source {
    /// MERL binary tables (`*.binary`).
    #[default]
    Binary,
    /// Neural BRDF proxies in the six-file NBRDF layout, each named by its stem
    /// `DIR/NAME` (a directory input gives every `NAME` with a `NAME_fc1.npy`). Each is
    /// resampled onto the MERL grid in memory (`Nbrdf::to_table(Dims::MERL)`), never
    /// written to disk.
    Nbrdf,
}

/// One table of the batch.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Table {
    /// The table file as given (or as the directory listing or glob gave it); for a
    /// proxy its stem `DIR/NAME`.
    pub path: PathBuf,
    /// File name (`gold.binary`), or a proxy's `NAME`: the shard key and the summary's
    /// `table` column.
    pub name: String,
    /// `OUTDIR/<stem>.json`.
    pub out: PathBuf,
    /// What the path holds.
    pub source: Source,
}

fn has_glob_chars(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

fn is_table_file(p: &Path) -> bool {
    p.is_file()
        && p.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case(TABLE_EXT) || e.eq_ignore_ascii_case(RGL_EXT))
}

/// The stem `DIR/NAME` of a proxy file `DIR/NAME_fc1.npy`.
fn nbrdf_stem(p: &Path) -> Option<PathBuf> {
    let name = p.file_name()?.to_str()?;
    let stem = name.strip_suffix(NBRDF_MARK).filter(|s| !s.is_empty())?;
    Some(p.with_file_name(stem))
}

/// The file that stands for input `p` in a listing: itself for a table, its
/// `NAME_fc1.npy` for a proxy stem.
fn marker(p: &Path, source: Source) -> PathBuf {
    match source {
        Source::Binary => p.to_path_buf(),
        Source::Nbrdf => {
            let mut name = p.file_name().unwrap_or_default().to_os_string();
            name.push(NBRDF_MARK);
            p.with_file_name(name)
        }
    }
}

/// Expands the inputs: a directory gives its `*.binary` files (not recursive), an
/// existing file itself, anything else is a glob pattern. An input that gives nothing
/// is an error (a typo must not make an empty batch). For proxies
/// ([`Source::Nbrdf`]), a directory gives the stems of its `*_fc1.npy` files, a stem
/// `DIR/NAME` or any `DIR/NAME_fc1.npy` itself, and a pattern the stems of the
/// `*_fc1.npy` files it matches.
fn expand(inputs: &[String], source: Source) -> Result<Vec<PathBuf>, BatchError> {
    let take = |p: &Path| -> Option<PathBuf> {
        match source {
            Source::Binary => Some(p.to_path_buf()),
            Source::Nbrdf => nbrdf_stem(p),
        }
    };
    let listed = |p: &Path| match source {
        Source::Binary => is_table_file(p),
        Source::Nbrdf => p.is_file() && nbrdf_stem(p).is_some(),
    };
    let mut out: Vec<PathBuf> = Vec::new();
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
                if listed(&e.path()) {
                    out.extend(take(&e.path()));
                }
            }
            if out.len() == before {
                return Err(BatchError::EmptyDir {
                    input: input.clone(),
                    looked_for: source,
                });
            }
        } else if match source {
            Source::Binary => p.exists(),
            Source::Nbrdf => listed(&marker(p, source)),
        } {
            out.push(p.to_path_buf());
        } else if source == Source::Nbrdf && listed(p) {
            out.extend(take(p));
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
                if path.is_file() && (source == Source::Binary || listed(&path)) {
                    out.extend(take(&path));
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
    tables_of(inputs, Source::Binary, outdir)
}

/// [`tables`] of inputs holding `source`.
pub fn tables_of(
    inputs: &[String],
    source: Source,
    outdir: &Path,
) -> Result<Vec<Table>, BatchError> {
    let mut seen = HashSet::new();
    let mut v: Vec<Table> = Vec::new();
    for path in expand(inputs, source)? {
        let key = std::fs::canonicalize(marker(&path, source)).unwrap_or_else(|_| path.clone());
        if !seen.insert(key) {
            continue;
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .ok_or_else(|| BatchError::NotAFileName { path: path.clone() })?;
        let stem = match source {
            // A proxy's name is its stem already (it may hold dots).
            Source::Nbrdf => name.clone(),
            Source::Binary => path
                .file_stem()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| name.clone()),
        };
        v.push(Table {
            out: outdir.join(format!("{stem}.json")),
            path,
            name,
            source,
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

    #[test]
    fn proxy_inputs_expand_to_their_stems() {
        let d = tempfile::tempdir().unwrap();
        let db = d.path().join("db");
        std::fs::create_dir(&db).unwrap();
        // Two proxies (one with a dot in its name), a table, and a nameless file.
        let files = "b.2_fc1.npy b.2_b1.npy a_fc1.npy t.binary _fc1.npy";
        files
            .split(' ')
            .for_each(|n| std::fs::write(db.join(n), "x").unwrap());
        let out = d.path().join("out");
        let nb = |inputs: &[String]| tables_of(inputs, Source::Nbrdf, &out);
        // The directory, a stem and a file of the same proxy: two proxies.
        let t = nb(&[s(&db), s(&db.join("a")), s(&db.join("b.2_fc1.npy"))]).unwrap();
        let names: Vec<&str> = t.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names, ["a", "b.2"]);
        assert_eq!(t[1].path, db.join("b.2"));
        assert_eq!(t[1].out, out.join("b.2.json"));
        assert!(t.iter().all(|t| t.source == Source::Nbrdf));
        assert_eq!(nb(&[format!("{}/b*", db.display())]).unwrap().len(), 1);
        // A table is not a proxy, and a directory without proxies is an error.
        assert!(matches!(
            nb(&[s(&db.join("t.binary"))]).unwrap_err(),
            BatchError::NoSuchInput { .. }
        ));
        let empty = d.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        let e = nb(&[s(&empty)]).unwrap_err();
        assert!(e.to_string().contains("_fc1.npy"), "{e}");
    }
}
