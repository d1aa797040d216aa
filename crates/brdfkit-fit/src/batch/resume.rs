//! Resuming: what makes a finished table's JSON reusable (see the module doc of
//! [`crate::batch`]).

use super::summary::{Row, Status};
use super::{FORMAT, Source, Table, fnv1a64, hex};
use crate::FitConfig;
use crate::families::Family;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::UNIX_EPOCH;

/// What decides whether a finished table can be reused: the models at their start
/// values (with their structural choices) and the whole fit configuration, plus the
/// format tag. Where the outputs go, the shard and how progress is shown are not part
/// of it.
pub fn options_value(fams: &[Family], cfg: &FitConfig) -> Result<Value, serde_json::Error> {
    Ok(json!({
        "format": FORMAT,
        "models": fams.iter().map(|f| f.model.to_json()).collect::<Vec<_>>(),
        "config": serde_json::to_value(cfg)?,
    }))
}

/// The hash of [`options_value`] stored as `options_hash`.
pub fn options_hash(options: &Value) -> String {
    hex(fnv1a64(options.to_string().as_bytes()))
}

/// Identity of a table file: size and modification time (the hash of its bytes is
/// computed only when the time differs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stamp {
    /// Size in bytes.
    pub size: u64,
    /// Modification time, nanoseconds since 1970, when the file system has one.
    pub mtime_ns: Option<u128>,
}

impl Stamp {
    /// The stamp of the file at `path`.
    pub fn of(path: &Path) -> std::io::Result<Stamp> {
        let m = std::fs::metadata(path)?;
        let mtime_ns = m
            .modified()
            .ok()
            .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
            .map(|d| d.as_nanos());
        Ok(Stamp {
            size: m.len(),
            mtime_ns,
        })
    }
}

/// The files a table is read from: the table file, or a proxy's six `.npy` files.
pub fn files(t: &Table) -> Vec<PathBuf> {
    match t.source {
        Source::Binary => vec![t.path.clone()],
        Source::Nbrdf => brdfkit_nbrdf::PARTS
            .iter()
            .map(|p| {
                let mut name = t.path.file_name().unwrap_or_default().to_os_string();
                name.push(format!("_{p}.npy"));
                t.path.with_file_name(name)
            })
            .collect(),
    }
}

/// The bytes of a table's files, in [`files`] order, one after the other (what its
/// FNV-1a hash is taken of).
pub fn table_bytes(t: &Table) -> std::io::Result<Vec<u8>> {
    let mut all = Vec::new();
    for f in files(t) {
        let b = std::fs::read(&f)
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", f.display())))?;
        all.extend_from_slice(&b);
    }
    Ok(all)
}

impl Stamp {
    /// The stamp of a table: of its file, or for a proxy the total size and latest
    /// modification time of its six files.
    pub fn of_table(t: &Table) -> std::io::Result<Stamp> {
        let mut total = Stamp {
            size: 0,
            mtime_ns: Some(0),
        };
        for f in files(t) {
            let s = Stamp::of(&f)
                .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", f.display())))?;
            total.size += s.size;
            total.mtime_ns = total.mtime_ns.zip(s.mtime_ns).map(|(a, b)| a.max(b));
        }
        Ok(total)
    }
}

/// Whether a table is done: its summary rows, or why it is not (None: no output yet,
/// nothing worth saying).
#[derive(Debug, Clone, PartialEq)]
pub enum Prior {
    /// Done with these options from this table.
    Done(Vec<Row>),
    /// To fit.
    Todo(Option<String>),
}

/// Checks whether `t` is done with these options.
pub fn prior(t: &Table, options_hash: &str, n_fits: usize) -> Prior {
    let text = match std::fs::read(&t.out) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Prior::Todo(None),
        Err(e) => return Prior::Todo(Some(format!("cannot read {}: {e}", t.out.display()))),
    };
    let v: Value = match serde_json::from_slice(&text) {
        Ok(v) => v,
        Err(e) => {
            return Prior::Todo(Some(format!("{} does not parse ({e})", t.out.display())));
        }
    };
    if v["format"] != FORMAT {
        return Prior::Todo(Some(format!("{} has another format", t.out.display())));
    }
    if v["options_hash"] != options_hash {
        return Prior::Todo(Some("made with other options".into()));
    }
    let Ok(now) = Stamp::of_table(t) else {
        return Prior::Todo(None);
    };
    let rec = &v["table"];
    if rec["size"].as_u64() != Some(now.size) {
        return Prior::Todo(Some("the table changed (size)".into()));
    }
    let same_time = now.mtime_ns.is_some()
        && rec["mtime_ns"]
            .as_str()
            .and_then(|s| s.parse::<u128>().ok())
            == now.mtime_ns;
    if !same_time {
        // A copy or a touch: the bytes decide.
        let same_bytes = table_bytes(t)
            .map(|b| hex(fnv1a64(&b)))
            .is_ok_and(|h| rec["fnv1a64"] == h.as_str());
        if !same_bytes {
            return Prior::Todo(Some("the table changed (contents)".into()));
        }
    }
    match v["fits"].as_array() {
        Some(fits) if fits.len() == n_fits => match Row::from_fits(t, fits, Status::Resumed) {
            Some(rows) => Prior::Done(rows),
            None => Prior::Todo(Some(format!("{} lacks fit labels", t.out.display()))),
        },
        _ => Prior::Todo(Some(format!(
            "{} does not hold {n_fits} fits",
            t.out.display()
        ))),
    }
}
