//! `fit-brdf batch INPUT... --models ... --out OUTDIR [--shard I/N]`: fit every table of
//! a database, one table at a time, resumably.
//!
//! Per table `<stem>.binary` the batch writes `OUTDIR/<stem>.json`:
//!
//! ```json
//! {"format": "fit-brdf-batch/1", "fit_brdf": "0.1.0",
//!  "table": {"path": "...", "name": "gold.binary", "size": 34992012,
//!            "mtime_ns": 1763760000000000000, "fnv1a64": "8c3f..."},
//!  "options_hash": "5e1b...", "options": {"models": [...], "config": {...}},
//!  "fits": [{"label": "cook-torrance", "params": {...}, "record": {...}}],
//!  "wall_time_s": 12.3, "finished_unix_s": 1763760123}
//! ```
//!
//! and after every table rewrites the summary CSV (`summary.csv`, or
//! `summary-I-of-N.csv` for a shard) with one row per table and model. Every file is
//! written to a temporary file in OUTDIR and renamed into place.
//!
//! **Done** (skipped on a rerun) means: `<stem>.json` exists, parses, has this format,
//! the same options hash (models at their start values with their structural choices,
//! and every fit option: see [`options_value`]), the same number of fits, and was made
//! from the same table: same size and either the same modification time or, when the
//! time differs (a copy), the same FNV-1a 64 hash of its bytes. Anything else is refitted
//! (and said so on stderr); `--force` refits everything.
//!
//! **Shards** (`--shard I/N`, 1 ≤ I ≤ N): a table belongs to shard
//! `FNV-1a-64(file name) mod N + 1`. The file name, not the path, so every machine of a
//! job array agrees however the database is mounted, and a table keeps its shard when
//! others are added or removed. The price: shards are balanced only statistically
//! (binomial spread, ±√(M/N) tables).
//!
//! **Interrupts**: the first SIGINT or SIGTERM lets the current table finish and stops
//! before the next one; a second stops at once, but never inside a file write (the
//! handler waits for the write lock). Either way every output present is complete and
//! no temporary file is left.

use super::fit::{Family, Outcome, check_free, config, families, fit_all, structure};
use crate::cli::BatchArgs;
use crate::error::{CliResult, bad_input, bad_msg, runtime};
use crate::output::write_text;
use anyhow::{Context, anyhow};
use brdfkit::merl::MerlTable;
use brdfkit_fit::{FitConfig, FitData};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::{Value, json};
use std::collections::{BTreeMap, HashSet};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// The format tag of the per-table JSON; bump it when its meaning changes (old files are
/// then refitted, never misread).
pub const FORMAT: &str = "fit-brdf-batch/1";

/// Extension of the tables a directory input contributes.
pub const TABLE_EXT: &str = "binary";

/// Interrupts received (SIGINT, SIGTERM, SIGHUP).
static INTERRUPTS: AtomicUsize = AtomicUsize::new(0);

/// Held while an output file is written: the second interrupt takes it before exiting,
/// so the process never ends between creating a temporary file and renaming it.
static WRITE_LOCK: Mutex<()> = Mutex::new(());

/// FNV-1a, 64 bits (Fowler, Noll, Vo; offset basis 0xcbf29ce484222325, prime
/// 0x100000001b3): h ← (h ⊕ byte) · prime for every byte. Stable across platforms and
/// Rust versions (std's `DefaultHasher` is not), which is all the shard assignment and
/// the change checks need; it is not meant to resist deliberate collisions.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn hex(h: u64) -> String {
    format!("{h:016x}")
}

/// A shard `I/N`, 1-based.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Shard {
    /// Parses `I/N` with 1 ≤ I ≤ N.
    pub fn parse(s: &str) -> CliResult<Shard> {
        let bad = |why: &str| bad_msg(format!("--shard `{s}`: {why}"));
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| bad("expected I/N, e.g. 3/8 (shard 3 of 8, counted from 1)"))?;
        let i: u64 = i.trim().parse().map_err(|_| bad("I is not a number"))?;
        let n: u64 = n.trim().parse().map_err(|_| bad("N is not a number"))?;
        if n == 0 {
            return Err(bad("N must be at least 1"));
        }
        if i == 0 || i > n {
            return Err(bad("I must lie in 1..=N (shards are counted from 1)"));
        }
        Ok(Shard { index: i, count: n })
    }

    /// The shard (1-based) a table of this file name belongs to among `count`.
    pub fn of(name: &str, count: u64) -> u64 {
        fnv1a64(name.as_bytes()) % count + 1
    }

    fn contains(&self, name: &str) -> bool {
        Shard::of(name, self.count) == self.index
    }
}

/// One table of the batch.
#[derive(Debug, Clone)]
struct Table {
    path: PathBuf,
    /// File name (`gold.binary`): the shard key and the summary's `table` column.
    name: String,
    /// `OUTDIR/<stem>.json`.
    out: PathBuf,
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
/// is bad input (a typo must not make an empty batch).
fn expand_inputs(inputs: &[String]) -> CliResult<Vec<PathBuf>> {
    let mut out = Vec::new();
    for input in inputs {
        let p = Path::new(input);
        let before = out.len();
        if p.is_dir() {
            let rd = std::fs::read_dir(p)
                .with_context(|| format!("{input}: cannot list the directory"))
                .map_err(bad_input)?;
            for e in rd {
                let e = e
                    .with_context(|| format!("{input}: cannot list the directory"))
                    .map_err(bad_input)?;
                if is_table_file(&e.path()) {
                    out.push(e.path());
                }
            }
            if out.len() == before {
                return Err(bad_msg(format!(
                    "{input}: the directory holds no *.{TABLE_EXT} table"
                )));
            }
        } else if p.exists() {
            out.push(p.to_path_buf());
        } else if has_glob_chars(input) {
            let paths = glob::glob(input)
                .map_err(|e| bad_msg(format!("{input}: not a valid glob pattern: {e}")))?;
            for entry in paths {
                let path = entry
                    .with_context(|| format!("{input}: cannot read a match"))
                    .map_err(bad_input)?;
                if path.is_file() {
                    out.push(path);
                }
            }
            if out.len() == before {
                return Err(bad_msg(format!("{input}: the pattern matches no file")));
            }
        } else {
            return Err(bad_msg(format!("{input}: no such file or directory")));
        }
    }
    Ok(out)
}

/// The tables in a fixed order (by file name, then path), duplicates removed; two
/// different tables with the same stem would share an output file: bad input.
fn tables(inputs: &[String], outdir: &Path) -> CliResult<Vec<Table>> {
    let mut seen = HashSet::new();
    let mut v: Vec<Table> = Vec::new();
    for path in expand_inputs(inputs)? {
        let key = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        if !seen.insert(key) {
            continue;
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .ok_or_else(|| bad_msg(format!("{}: not a file name", path.display())))?;
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
            return Err(bad_msg(format!(
                "{} and {}: two tables with the same name would share the output {}; \
                 run them as separate batches (different --out)",
                other.display(),
                t.path.display(),
                t.out.display()
            )));
        }
    }
    Ok(v)
}

/// What decides whether a finished table can be reused: the models at their start
/// values (with their structural choices) and the whole fit configuration, plus the
/// format tag. `--quiet`, `--json`, `--shard` and `--out` are not part of it.
pub fn options_value(fams: &[Family], cfg: &FitConfig) -> CliResult<Value> {
    Ok(json!({
        "format": FORMAT,
        "models": fams.iter().map(|f| f.model.to_json()).collect::<Vec<_>>(),
        "config": serde_json::to_value(cfg).map_err(runtime)?,
    }))
}

/// Identity of a table file: size, modification time and (computed only when needed)
/// the hash of its bytes.
#[derive(Debug, Clone, Copy)]
struct Stamp {
    size: u64,
    mtime_ns: Option<u128>,
}

fn stamp(path: &Path) -> std::io::Result<Stamp> {
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

/// Why a table is not done (for the log), or its summary rows when it is.
enum Prior {
    Done(Vec<Row>),
    Todo(Option<String>),
}

/// One row of the summary: one model of one table, or a failed / pending table.
#[derive(Debug, Clone)]
struct Row {
    table: String,
    model: String,
    status: &'static str,
    cbrt: Option<f64>,
    l2: Option<f64>,
    cosine: Option<f64>,
    log: Option<f64>,
    cells: Option<u64>,
    iterations: Option<u64>,
    converged: Option<bool>,
    fit_time_s: Option<f64>,
    json: String,
    error: String,
}

impl Row {
    fn bare(t: &Table, status: &'static str, error: String) -> Row {
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

    /// Rows from the `fits` of a per-table JSON.
    fn from_fits(t: &Table, fits: &[Value], status: &'static str) -> Option<Vec<Row>> {
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

    fn to_json(&self) -> Value {
        json!({"model": self.model, "cbrt": self.cbrt, "l2": self.l2, "cosine": self.cosine,
               "log": self.log, "cells": self.cells, "iterations": self.iterations,
               "converged": self.converged, "fit_time_s": self.fit_time_s})
    }
}

const CSV_HEADER: &str =
    "table,model,status,cbrt,l2,cosine,log,cells,iterations,converged,fit_time_s,json,error";

/// A CSV field (RFC 4180): quoted when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn opt<T: ToString>(v: Option<T>) -> String {
    v.map_or(String::new(), |x| x.to_string())
}

fn summary_csv(rows: &[Row]) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in rows {
        let fields = [
            csv_field(&r.table),
            csv_field(&r.model),
            r.status.to_string(),
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

/// Checks whether `t` is done with these options (see the module doc).
fn prior(t: &Table, options_hash: &str, n_fits: usize) -> Prior {
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
    let Ok(now) = stamp(&t.path) else {
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
        let same_bytes = std::fs::read(&t.path)
            .map(|b| hex(fnv1a64(&b)))
            .is_ok_and(|h| rec["fnv1a64"] == h.as_str());
        if !same_bytes {
            return Prior::Todo(Some("the table changed (contents)".into()));
        }
    }
    match v["fits"].as_array() {
        Some(fits) if fits.len() == n_fits => match Row::from_fits(t, fits, "resumed") {
            Some(rows) => Prior::Done(rows),
            None => Prior::Todo(Some(format!("{} lacks fit labels", t.out.display()))),
        },
        _ => Prior::Todo(Some(format!(
            "{} does not hold {n_fits} fits",
            t.out.display()
        ))),
    }
}

/// Prefix of the temporary files of a batch (`OUTDIR/.fit-brdf-batch-XXXXXX.tmp`).
pub const TEMP_PREFIX: &str = ".fit-brdf-batch-";

/// Writes each `bytes` to its `path` atomically (a temporary file in the same directory,
/// synced, then renamed), all under one hold of the write lock (see [`WRITE_LOCK`]), so
/// a table's JSON and the summary that lists it are never separated by an abort. The file is created with
/// mode 0o644 less the umask, as a plain `create` would: batch outputs are shared on
/// cluster file systems (tempfile's default, 0o600, would hide them from the group).
fn write_locked(files: &[(&Path, &[u8])]) -> CliResult<()> {
    let _g = WRITE_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    for (path, bytes) in files {
        write_one(path, bytes)?;
    }
    Ok(())
}

fn write_one(path: &Path, bytes: &[u8]) -> CliResult<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let fail = |what: &str| format!("{}: {what}", path.display());
    let mut b = tempfile::Builder::new();
    b.prefix(TEMP_PREFIX).suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut tmp = b
        .tempfile_in(dir)
        .with_context(|| fail("cannot create a temporary file beside it"))
        .map_err(runtime)?;
    tmp.write_all(bytes)
        .and_then(|_| tmp.as_file().sync_all())
        .with_context(|| fail("write failed"))
        .map_err(runtime)?;
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| fail("cannot move the finished file into place"))
        .map_err(runtime)?;
    Ok(())
}

/// Installs the interrupt handler (once per process).
fn install_handler() -> CliResult<()> {
    ctrlc::set_handler(|| {
        let n = INTERRUPTS.fetch_add(1, Ordering::SeqCst) + 1;
        if n == 1 {
            eprintln!(
                "\nfit-brdf batch: interrupted; finishing the current table, then stopping \
                 (interrupt again to stop now)"
            );
        } else {
            // Never between a temporary file's creation and its rename.
            let _g = WRITE_LOCK.lock().unwrap_or_else(|e| e.into_inner());
            eprintln!("fit-brdf batch: stopped; rerun the same command to resume");
            std::process::exit(1);
        }
    })
    .context("cannot install the interrupt handler")
    .map_err(runtime)
}

fn interrupted() -> bool {
    INTERRUPTS.load(Ordering::SeqCst) > 0
}

/// Fits one table: read (its bytes hashed on the way), fit every family. Returns the
/// rows and the text of its JSON, or the error message of a table that cannot be
/// fitted.
fn fit_one(
    t: &Table,
    fams: &[Family],
    cfg: &FitConfig,
    options: &Value,
    options_hash: &str,
) -> CliResult<Result<(Vec<Row>, String), String>> {
    let t0 = Instant::now();
    let st = match stamp(&t.path) {
        Ok(s) => s,
        Err(e) => return Ok(Err(format!("{}: {e}", t.path.display()))),
    };
    let (data, hash) = {
        let bytes = match std::fs::read(&t.path) {
            Ok(b) => b,
            Err(e) => return Ok(Err(format!("{}: cannot read: {e}", t.path.display()))),
        };
        let hash = hex(fnv1a64(&bytes));
        let table = match MerlTable::from_bytes(&bytes, &t.path) {
            Ok(t) => t,
            Err(e) => return Ok(Err(e.to_string())),
        };
        drop(bytes);
        // The table is not needed after its cells: freeing it before the geometry is
        // built keeps the table and the cells out of memory together.
        match FitData::from_owned_table(table) {
            Ok(d) => (d, hash),
            Err(e) => return Ok(Err(format!("{}: {e}", t.path.display()))),
        }
    };
    let outcomes: Vec<Outcome> = match fit_all(&data, fams, cfg, true) {
        Ok(o) => o,
        Err(e) => return Ok(Err(format!("{}: {:#}", t.path.display(), e.error))),
    };
    drop(data);
    let fits: Vec<Value> = outcomes
        .iter()
        .map(|o| json!({"label": o.label, "params": o.params, "record": o.record}))
        .collect();
    let doc = json!({
        "format": FORMAT,
        "fit_brdf": env!("CARGO_PKG_VERSION"),
        "table": {
            "path": t.path.display().to_string(),
            "name": t.name,
            "size": st.size,
            // A string: nanoseconds since 1970 overflow JSON's exact integer range.
            "mtime_ns": st.mtime_ns.map(|n| n.to_string()),
            "fnv1a64": hash,
        },
        "options_hash": options_hash,
        "options": options,
        "fits": fits,
        "wall_time_s": t0.elapsed().as_secs_f64(),
        "finished_unix_s": SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()),
    });
    let text = serde_json::to_string_pretty(&doc).map_err(runtime)? + "\n";
    let rows = Row::from_fits(t, &fits, "fitted").expect("labels were just written");
    Ok(Ok((rows, text)))
}

/// The progress bar of a batch: hidden, and shown on stderr by a timer once the batch
/// has run for a second (so a first table that takes minutes gets its bar too);
/// indicatif draws nothing when stderr is not a terminal.
struct BatchBar {
    bar: ProgressBar,
    quiet: bool,
}

impl BatchBar {
    fn new(len: usize, quiet: bool) -> BatchBar {
        let bar = ProgressBar::with_draw_target(Some(len as u64), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{bar:24}] {pos}/{len} tables, {elapsed}, eta {eta}: {msg}",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        if !quiet {
            let b = bar.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_secs(1));
                if !b.is_finished() {
                    b.set_draw_target(ProgressDrawTarget::stderr());
                    b.enable_steady_tick(Duration::from_millis(200));
                }
            });
        }
        BatchBar { bar, quiet }
    }

    fn line(&self, s: &str) {
        if !self.quiet {
            self.bar.suspend(|| eprintln!("{s}"));
        }
    }
}

pub fn run(a: BatchArgs) -> CliResult<()> {
    let fams = families(&a.opts.model, &structure(&a.opts))?;
    let cfg = config(&a.opts)?;
    cfg.validate()
        .map_err(|e| bad_msg(format!("fit options: {e}")))?;
    check_free(&fams, &cfg)?;
    let shard = a.shard.as_deref().map(Shard::parse).transpose()?;
    let all = tables(&a.inputs, &a.out)?;
    let total = all.len();
    let list: Vec<Table> = match shard {
        Some(s) => all.into_iter().filter(|t| s.contains(&t.name)).collect(),
        None => all,
    };
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("{}: cannot create the output directory", a.out.display()))
        .map_err(runtime)?;
    let summary_path = a.out.join(match shard {
        Some(s) => format!("summary-{}-of-{}.csv", s.index, s.count),
        None => "summary.csv".to_string(),
    });
    let options = options_value(&fams, &cfg)?;
    let options_hash = hex(fnv1a64(
        serde_json::to_string(&options).map_err(runtime)?.as_bytes(),
    ));
    install_handler()?;

    let t0 = Instant::now();
    // Phase 1: what is done already (cheap: small JSON files and file metadata).
    let mut rows: Vec<Vec<Row>> = Vec::with_capacity(list.len());
    let mut todo: Vec<usize> = Vec::new();
    let mut notes = Vec::new();
    for (k, t) in list.iter().enumerate() {
        match (a.force, prior(t, &options_hash, fams.len())) {
            (false, Prior::Done(r)) => rows.push(r),
            (_, p) => {
                if let (false, Prior::Todo(Some(why))) = (a.force, p) {
                    notes.push(format!("{}: refitting: {why}", t.name));
                }
                rows.push(vec![Row::bare(t, "pending", String::new())]);
                todo.push(k);
            }
        }
    }
    let resumed = list.len() - todo.len();
    let summary = |rows: &[Vec<Row>]| {
        let flat: Vec<Row> = rows.iter().flatten().cloned().collect();
        summary_csv(&flat)
    };
    write_locked(&[(&summary_path, summary(&rows).as_bytes())])?;

    let bar = BatchBar::new(todo.len(), a.quiet);
    for n in &notes {
        bar.line(n);
    }
    if resumed > 0 {
        bar.line(&format!(
            "{resumed} of {} tables already done with these options: skipped",
            list.len()
        ));
    }
    let (mut fitted, mut failures) = (0usize, Vec::<(String, String)>::new());
    let mut fit_time = 0.0;
    for (done, &k) in todo.iter().enumerate() {
        if interrupted() {
            break;
        }
        let t = &list[k];
        bar.bar.set_message(t.name.clone());
        let ts = Instant::now();
        let outcome = fit_one(t, &fams, &cfg, &options, &options_hash)?;
        let dt = ts.elapsed().as_secs_f64();
        let mut table_json = None;
        match outcome {
            Ok((r, text)) => {
                table_json = Some(text);
                fitted += 1;
                fit_time += dt;
                bar.line(&format!(
                    "[{}/{}] {}: fitted in {dt:.2} s",
                    done + 1,
                    todo.len(),
                    t.name
                ));
                rows[k] = r;
            }
            Err(e) => {
                bar.line(&format!(
                    "[{}/{}] {}: FAILED: {e}",
                    done + 1,
                    todo.len(),
                    t.name
                ));
                rows[k] = vec![Row::bare(t, "failed", e.clone())];
                failures.push((t.path.display().to_string(), e));
            }
        }
        // Output write failures are fatal: the next table would fail the same way.
        let csv = summary(&rows);
        match &table_json {
            Some(text) => {
                write_locked(&[(&t.out, text.as_bytes()), (&summary_path, csv.as_bytes())])?
            }
            None => write_locked(&[(&summary_path, csv.as_bytes())])?,
        }
        bar.bar.inc(1);
    }
    bar.bar.finish_and_clear();
    let pending = list.len() - resumed - fitted - failures.len();
    let wall = t0.elapsed().as_secs_f64();

    if a.json {
        let results: Vec<Value> = list
            .iter()
            .zip(&rows)
            .map(|(t, r)| {
                json!({"table": t.name, "path": t.path.display().to_string(),
                       "status": r[0].status, "json": t.out.display().to_string(),
                       "error": (r[0].status == "failed").then(|| r[0].error.clone()),
                       "fits": r.iter().filter(|x| !x.model.is_empty()).map(Row::to_json).collect::<Vec<_>>()})
            })
            .collect();
        let v = json!({
            "out": a.out.display().to_string(),
            "summary_csv": summary_path.display().to_string(),
            "shard": shard.map(|s| json!({"index": s.index, "count": s.count})),
            "options_hash": options_hash,
            "tables_matched": total,
            "tables": list.len(),
            "fitted": fitted,
            "resumed": resumed,
            "failed": failures.len(),
            "pending": pending,
            "interrupted": interrupted(),
            "wall_time_s": wall,
            "failures": failures.iter().map(|(t, e)| json!({"table": t, "error": e})).collect::<Vec<_>>(),
            "results": results,
        });
        write_text(
            None,
            &(serde_json::to_string_pretty(&v).map_err(runtime)? + "\n"),
        )?;
    } else {
        let mut s = format!(
            "batch: {} tables{}: {fitted} fitted, {resumed} already done, {} failed{}; {wall:.2} s",
            list.len(),
            shard.map_or(String::new(), |sh| format!(
                " (shard {}/{} of {total})",
                sh.index, sh.count
            )),
            failures.len(),
            if pending > 0 {
                format!(", {pending} not started")
            } else {
                String::new()
            }
        );
        if fitted > 0 {
            let _ = write!(s, " ({:.3} s per fitted table)", fit_time / fitted as f64);
        }
        let _ = writeln!(s, "\nsummary: {}", summary_path.display());
        for (_, e) in &failures {
            // Every message names its file.
            let _ = writeln!(s, "failed: {e}");
        }
        write_text(None, &s)?;
    }

    if interrupted() {
        return Err(runtime(anyhow!(
            "interrupted after {} of {} tables ({pending} not started); every output written is \
             complete: rerun the same command to resume",
            resumed + fitted + failures.len(),
            list.len()
        )));
    }
    if !failures.is_empty() {
        return Err(runtime(anyhow!(
            "{} of {} tables failed: {}",
            failures.len(),
            list.len(),
            failures
                .iter()
                .map(|(t, _)| t.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a64_matches_the_reference_vectors() {
        // From the FNV reference test suite (Noll): "", "a", "foobar".
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn shards_parse_and_partition() {
        assert_eq!(Shard::parse("2/3").unwrap(), Shard { index: 2, count: 3 });
        for bad in ["0/3", "4/3", "1/0", "a/2", "3", "1/2/3", ""] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        // Every name lands in exactly one shard, and the spread is binomial.
        let names: Vec<String> = (0..1000).map(|i| format!("material-{i}.binary")).collect();
        let mut counts = [0usize; 4];
        for n in &names {
            let s = Shard::of(n, 4);
            assert!((1..=4).contains(&s));
            counts[(s - 1) as usize] += 1;
            let hits = (1..=4)
                .filter(|&i| Shard { index: i, count: 4 }.contains(n))
                .count();
            assert_eq!(hits, 1);
        }
        // 250 ± 3σ (σ = √(1000·¼·¾) ≈ 13.7).
        assert!(
            counts.iter().all(|&c| (209..=291).contains(&c)),
            "{counts:?}"
        );
    }

    #[test]
    fn csv_fields_are_quoted_when_needed() {
        assert_eq!(csv_field("plain"), "plain");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"x\""), "\"say \"\"x\"\"\"");
        assert_eq!(csv_field("two\nlines"), "\"two\nlines\"");
    }
}
