//! The batch engine of `fit-brdf batch`: fit every table of a database, one table at a
//! time, resumably, shardable over a job array, and stoppable between tables.
//!
//! The inputs are MERL tables and RGL-EPFL `.bsdf` files (a `.bsdf` at its measured
//! points by default, as `fit` takes it: [`BatchJob::with_bsdf_input`]), or neural BRDF
//! proxies ([`Source::Nbrdf`], the six-file
//! NBRDF layout) each resampled onto the MERL grid in memory: a whole database of
//! proxies is fitted without writing a 35 MB table per material. A proxy's identity
//! (size, time, hash below) is that of its six files together.
//!
//! Per table `<stem>.binary` (or proxy `NAME`) the batch writes `OUTDIR/<stem>.json`:
//!
//! ```json
//! {"format": "fit-brdf-batch/1", "fit_brdf": "0.1.0",
//!  "table": {"path": "...", "name": "gold.binary", "size": 34992012,
//!            "mtime_ns": "1763760000000000000", "fnv1a64": "8c3f..."},
//!  "options_hash": "5e1b...", "options": {"models": [...], "config": {...}},
//!  "fits": [{"label": "cook-torrance", "params": {...}, "record": {...}}],
//!  "wall_time_s": 12.3, "finished_unix_s": 1763760123}
//! ```
//!
//! and after every table rewrites the summary CSV (`summary.csv`, or
//! `summary-I-of-N.csv` for a shard) with one row per table and model. A table's JSON and
//! the summary that lists it are written as one [`FileSet`] (each file atomically, the
//! pair rolled back together on failure).
//!
//! **Done** (skipped on a rerun) means: `<stem>.json` exists, parses, has this format,
//! the same options hash (models at their start values with their structural choices,
//! and every fit option: see [`options_value`]), the same number of fits, and was made
//! from the same table: same size and either the same modification time or, when the
//! time differs (a copy), the same FNV-1a 64 hash of its bytes. Anything else is refitted
//! (and said so through [`Event::TableRefit`]); `force` refits everything.
//!
//! **Shards** (`I/N`, 1 ≤ I ≤ N): a table belongs to shard
//! `FNV-1a-64(file name) mod N + 1`. The file name, not the path, so every machine of a
//! job array agrees however the database is mounted, and a table keeps its shard when
//! others are added or removed. The price: shards are balanced only statistically
//! (binomial spread, ±√(M/N) tables).
//!
//! **Cancellation**: the engine polls a [`Cancel`] token between tables and stops
//! before the next one; the current table finishes. Every write happens while the
//! token's write lock is held, so a caller that must end the process at once (a second
//! Ctrl-C) takes that lock first and never ends it between a temporary file's creation
//! and its rename.

mod inputs;
mod resume;
mod shard;
mod summary;

pub use inputs::{NBRDF_MARK, RGL_EXT, Source, TABLE_EXT, Table, tables, tables_of};
pub use resume::{Prior, Stamp, files, options_hash, options_value, prior, table_bytes};
pub use shard::{Shard, ShardError, fnv1a64, hex};
pub use summary::{CSV_HEADER, Row, Status, csv_field, summary_csv};

use crate::families::{FamilyError, check_free, fit_each};
use crate::input::{BsdfInput, Measured};
use crate::{FitConfig, FitData, FitError, families::Family};
use brdfkit_core::atomic::{FileSet, WriteError};
use brdfkit_core::progress::{BatchPlan, Event, Observe, TableEnd};
use brdfkit_rgl::InputKind;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, MutexGuard};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// The format tag of the per-table JSON; bump it when its meaning changes (old files are
/// then refitted, never misread).
pub const FORMAT: &str = "fit-brdf-batch/1";

/// Why a batch cannot start or had to stop. [`BatchError::is_bad_input`] tells the
/// user's mistakes from failures at run time. A table that cannot be fitted is not an
/// error of the batch: it is reported in [`BatchOutcome::failures`].
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// An input is neither a file, a directory nor a glob pattern.
    #[error("{input}: no such file or directory")]
    NoSuchInput {
        /// The input.
        input: String,
    },
    /// A directory input holds no table (or no proxy).
    #[error("{input}: the directory holds no {}", match looked_for {
        Source::Binary => format!("*.{TABLE_EXT} table or *.{RGL_EXT} file"),
        Source::Nbrdf => format!("neural BRDF proxy (*{NBRDF_MARK})"),
    })]
    EmptyDir {
        /// The input.
        input: String,
        /// What was looked for.
        looked_for: Source,
    },
    /// A glob pattern matches no file.
    #[error("{input}: the pattern matches no file")]
    NoMatch {
        /// The input.
        input: String,
    },
    /// A glob pattern does not parse.
    #[error("{input}: not a valid glob pattern: {source}")]
    Pattern {
        /// The input.
        input: String,
        /// The parser's message.
        #[source]
        source: glob::PatternError,
    },
    /// A directory input cannot be listed.
    #[error("{input}: cannot list the directory")]
    List {
        /// The input.
        input: String,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A glob match cannot be read.
    #[error("{input}: cannot read a match")]
    Match {
        /// The input.
        input: String,
        /// Why.
        #[source]
        source: glob::GlobError,
    },
    /// An input path has no file name.
    #[error("{}: not a file name", path.display())]
    NotAFileName {
        /// The path.
        path: PathBuf,
    },
    /// Two tables would write the same output file.
    #[error(
        "{} and {}: two tables with the same name would share the output {}; \
         run them as separate batches (different --out)",
        first.display(), second.display(), out.display()
    )]
    SameName {
        /// The first table.
        first: PathBuf,
        /// The second.
        second: PathBuf,
        /// The output both would write.
        out: PathBuf,
    },
    /// The fit configuration is invalid.
    #[error("fit options: {0}")]
    Config(#[source] FitError),
    /// The model families do not fit the configuration (e.g. `--fix`).
    #[error(transparent)]
    Family(#[from] FamilyError),
    /// The output directory cannot be created.
    #[error("{}: cannot create the output directory", path.display())]
    CreateDir {
        /// The directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// An output could not be written (fatal: the next table would fail the same way).
    #[error(transparent)]
    Write(#[from] WriteError),
    /// A result could not be serialised.
    #[error("cannot serialise a batch result: {0}")]
    Serialize(#[from] serde_json::Error),
}

impl BatchError {
    /// Whether the error is in the user's input (the inputs, the options), as opposed to
    /// a failure at run time (a write, the output directory).
    pub fn is_bad_input(&self) -> bool {
        !matches!(
            self,
            BatchError::CreateDir { .. } | BatchError::Write(_) | BatchError::Serialize(_)
        )
    }
}

/// A request to stop, shared between the engine and whoever asks it to stop (a signal
/// handler). The engine polls it between tables and holds its write lock during every
/// write.
#[derive(Debug, Default)]
pub struct Cancel {
    requests: AtomicUsize,
    writing: Mutex<()>,
}

impl Cancel {
    /// No request yet. `const`, so a signal handler can reach a `static` token.
    pub const fn new() -> Cancel {
        Cancel {
            requests: AtomicUsize::new(0),
            writing: Mutex::new(()),
        }
    }

    /// Asks the batch to stop after the current table; returns how many requests there
    /// have been, this one included.
    pub fn request(&self) -> usize {
        self.requests.fetch_add(1, Ordering::SeqCst) + 1
    }

    /// Whether a stop was requested.
    pub fn is_requested(&self) -> bool {
        self.requests.load(Ordering::SeqCst) > 0
    }

    /// Blocks until no output is being written and keeps it so while the guard lives.
    pub fn hold_writes(&self) -> MutexGuard<'_, ()> {
        self.writing.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A batch ready to run: its tables found and its options validated; nothing written
/// yet.
pub struct BatchJob {
    /// The tables of this shard, in order.
    pub tables: Vec<Table>,
    /// Tables the inputs matched, before sharding.
    pub tables_matched: usize,
    /// The output directory.
    pub out: PathBuf,
    /// The shard, if any.
    pub shard: Option<Shard>,
    /// The model families fitted to every table.
    pub families: Vec<Family>,
    /// The fit configuration.
    pub config: FitConfig,
    /// What a `.bsdf` input is fitted on (the rule of `fit`: [`crate::input`]).
    pub bsdf_input: BsdfInput,
}

/// The result of a run.
#[derive(Debug, Clone)]
pub struct BatchOutcome {
    /// The output directory.
    pub out: PathBuf,
    /// The summary CSV.
    pub summary_csv: PathBuf,
    /// The shard, if any.
    pub shard: Option<Shard>,
    /// The hash of the options (see [`options_value`]); a `.bsdf` file's JSON adds
    /// `bsdf_input` to them, and has its own.
    pub options_hash: String,
    /// Tables the inputs matched, before sharding.
    pub tables_matched: usize,
    /// Every table of the run with its summary rows (one per model, or one bare row).
    pub tables: Vec<(Table, Vec<Row>)>,
    /// Tables fitted by this run.
    pub fitted: usize,
    /// Tables done before (skipped).
    pub resumed: usize,
    /// Tables not reached.
    pub pending: usize,
    /// Failed tables: path and message.
    pub failures: Vec<(String, String)>,
    /// Whether a stop was requested.
    pub interrupted: bool,
    /// Wall time of the run.
    pub wall_time_s: f64,
    /// Time spent fitting the tables fitted by this run.
    pub fit_time_s: f64,
}

impl BatchJob {
    /// Finds the tables of `inputs` (the shard's only, if any) and checks the options
    /// against the families. Writes nothing.
    pub fn new(
        inputs: &[String],
        out: &Path,
        shard: Option<Shard>,
        families: Vec<Family>,
        config: FitConfig,
    ) -> Result<BatchJob, BatchError> {
        BatchJob::new_from(inputs, Source::Binary, out, shard, families, config)
    }

    /// [`BatchJob::new`] for inputs holding `source` (tables or neural BRDF proxies).
    pub fn new_from(
        inputs: &[String],
        source: Source,
        out: &Path,
        shard: Option<Shard>,
        families: Vec<Family>,
        config: FitConfig,
    ) -> Result<BatchJob, BatchError> {
        config.validate().map_err(BatchError::Config)?;
        check_free(&families, &config)?;
        let all = tables_of(inputs, source, out)?;
        let tables_matched = all.len();
        let tables = match shard {
            Some(s) => all.into_iter().filter(|t| s.contains(&t.name)).collect(),
            None => all,
        };
        Ok(BatchJob {
            tables,
            tables_matched,
            out: out.to_path_buf(),
            shard,
            families,
            config,
            bsdf_input: BsdfInput::default(),
        })
    }

    /// The job with `.bsdf` inputs fitted on `how` (default: their measured points).
    pub fn with_bsdf_input(self, how: BsdfInput) -> BatchJob {
        BatchJob {
            bsdf_input: how,
            ..self
        }
    }

    /// The options of one table's JSON and their hash: the job's [`options_value`]
    /// (`base`), and `bsdf_input` for a `.bsdf` file, so that a change of it refits the
    /// `.bsdf` files and not the tables beside them (whose hash stays what it always was).
    fn options_of(&self, base: &Value, t: &Table) -> (Value, String) {
        let mut options = base.clone();
        if t.source == Source::Binary
            && InputKind::of_file(&t.path).is_ok_and(|k| k == InputKind::Rgl)
        {
            options["bsdf_input"] = json!(self.bsdf_input.name());
        }
        let hash = options_hash(&options);
        (options, hash)
    }

    /// `OUTDIR/summary.csv`, or `OUTDIR/summary-I-of-N.csv` for a shard.
    pub fn summary_path(&self) -> PathBuf {
        self.out.join(match self.shard {
            Some(s) => format!("summary-{}-of-{}.csv", s.index, s.count),
            None => "summary.csv".to_string(),
        })
    }

    /// Runs the batch: skips the tables already done (unless `force`), fits the others
    /// one by one, and stops before the next table once `cancel` is requested. Returns
    /// an error only for what stops the whole batch (an output that cannot be written);
    /// a table that cannot be fitted is in the report's failures.
    pub fn run(
        &self,
        force: bool,
        cancel: &Cancel,
        obs: &dyn Observe,
    ) -> Result<BatchOutcome, BatchError> {
        let t0 = Instant::now();
        std::fs::create_dir_all(&self.out).map_err(|source| BatchError::CreateDir {
            path: self.out.clone(),
            source,
        })?;
        let summary_path = self.summary_path();
        let base = options_value(&self.families, &self.config)?;
        let hash = options_hash(&base);

        // Phase 1: what is done already (cheap: small JSON files and file metadata).
        let mut rows: Vec<Vec<Row>> = Vec::with_capacity(self.tables.len());
        let mut todo: Vec<usize> = Vec::new();
        for (k, t) in self.tables.iter().enumerate() {
            let (_, table_hash) = self.options_of(&base, t);
            match (force, prior(t, &table_hash, self.families.len())) {
                (false, Prior::Done(r)) => {
                    obs.observe(&Event::TableSkipped {
                        table: t.name.clone(),
                    });
                    rows.push(r);
                }
                (_, p) => {
                    if let (false, Prior::Todo(Some(reason))) = (force, p) {
                        obs.observe(&Event::TableRefit {
                            table: t.name.clone(),
                            reason,
                        });
                    }
                    rows.push(vec![Row::bare(t, Status::Pending, String::new())]);
                    todo.push(k);
                }
            }
        }
        let resumed = self.tables.len() - todo.len();
        let csv = |rows: &[Vec<Row>]| summary_csv(rows.iter().flatten());
        {
            let _g = cancel.hold_writes();
            let mut set = FileSet::new();
            set.stage_bytes(&summary_path, csv(&rows).as_bytes())?;
            set.commit()?;
        }
        obs.observe(&Event::BatchPlanned(BatchPlan {
            tables: self.tables.len(),
            resumed,
            to_fit: todo.len(),
        }));

        // Phase 2: fit.
        let (mut fitted, mut failures, mut fit_time) = (0usize, Vec::new(), 0.0);
        for (done, &k) in todo.iter().enumerate() {
            if cancel.is_requested() {
                break;
            }
            let t = &self.tables[k];
            obs.observe(&Event::TableStarted {
                index: done,
                count: todo.len(),
                table: t.name.clone(),
            });
            let ts = Instant::now();
            let (options, table_hash) = self.options_of(&base, t);
            let outcome = self.fit_one(t, &options, &table_hash)?;
            let dt = ts.elapsed().as_secs_f64();
            let mut set = FileSet::new();
            let how = match &outcome {
                Ok((r, text)) => {
                    fitted += 1;
                    fit_time += dt;
                    rows[k] = r.clone();
                    set.stage_bytes(&t.out, text.as_bytes())?;
                    TableEnd::Fitted(dt)
                }
                Err(e) => {
                    rows[k] = vec![Row::bare(t, Status::Failed, e.clone())];
                    failures.push((t.path.display().to_string(), e.clone()));
                    TableEnd::Failed(e.clone())
                }
            };
            {
                let _g = cancel.hold_writes();
                set.stage_bytes(&summary_path, csv(&rows).as_bytes())?;
                set.commit()?;
            }
            obs.observe(&Event::TableDone {
                index: done,
                count: todo.len(),
                table: t.name.clone(),
                end: how,
            });
        }
        let pending = self.tables.len() - resumed - fitted - failures.len();
        Ok(BatchOutcome {
            out: self.out.clone(),
            summary_csv: summary_path,
            shard: self.shard,
            options_hash: hash,
            tables_matched: self.tables_matched,
            tables: self.tables.iter().cloned().zip(rows).collect(),
            fitted,
            resumed,
            pending,
            failures,
            interrupted: cancel.is_requested(),
            wall_time_s: t0.elapsed().as_secs_f64(),
            fit_time_s: fit_time,
        })
    }

    /// Fits one table: read (its bytes hashed on the way), fit every family. Returns the
    /// rows and the text of its JSON, or the message of a table that cannot be fitted.
    #[allow(clippy::type_complexity)]
    fn fit_one(
        &self,
        t: &Table,
        options: &Value,
        options_hash: &str,
    ) -> Result<Result<(Vec<Row>, String), String>, BatchError> {
        let t0 = Instant::now();
        let st = match Stamp::of_table(t) {
            Ok(s) => s,
            Err(e) => return Ok(Err(format!("{}: {e}", t.path.display()))),
        };
        let (data, hash) = match read_data(t, self.bsdf_input) {
            Ok(d) => d,
            Err(e) => return Ok(Err(e)),
        };
        let outcomes = match fit_each(&data, &self.families, &self.config, &()) {
            Ok(o) => o,
            Err(e) => return Ok(Err(format!("{}: {e}", t.path.display()))),
        };
        drop(data);
        let fits: Vec<Value> = outcomes.iter().map(|o| o.to_json()).collect();
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
        let text = serde_json::to_string_pretty(&doc)? + "\n";
        let rows = Row::from_fits(t, &fits, Status::Fitted).expect("labels were just written");
        Ok(Ok((rows, text)))
    }
}

/// The fitted cells of a table and the hash of its bytes, or the message of a table
/// that cannot be read (naming its file). A table or a `.bsdf` is read by the rule of
/// `fit` ([`Measured::from_bytes`]: a `.bsdf` at its measured points or resampled, as
/// `how` says); a proxy is resampled onto the MERL grid in memory.
fn read_data(t: &Table, how: BsdfInput) -> Result<(FitData, String), String> {
    let bytes = table_bytes(t).map_err(|e| format!("{}: cannot read: {e}", t.path.display()))?;
    let hash = hex(fnv1a64(&bytes));
    let data = match t.source {
        Source::Binary => {
            Measured::from_bytes(bytes, &t.path, how, false)
                .map_err(|e| e.to_string())?
                .data
        }
        Source::Nbrdf => {
            drop(bytes);
            // Resampled in memory: a proxy is a few KB, its table 35 MB.
            let net = brdfkit_nbrdf::Nbrdf::load(&t.path).map_err(|e| e.to_string())?;
            let table = net
                .to_table(brdfkit_merl::Dims::MERL)
                .map_err(|e| e.to_string())?
                .0;
            // The table is not needed after its cells: freeing it before the geometry
            // is built keeps the table and the cells out of memory together.
            FitData::from_owned_table(table).map_err(|e| format!("{}: {e}", t.path.display()))?
        }
    };
    Ok((data, hash))
}

impl BatchOutcome {
    /// The report as `fit-brdf batch --json` prints it.
    pub fn to_json(&self) -> Value {
        let results: Vec<Value> = self
            .tables
            .iter()
            .map(|(t, r)| {
                let failed = r[0].status == Status::Failed;
                json!({"table": t.name, "path": t.path.display().to_string(),
                       "status": r[0].status.name(), "json": t.out.display().to_string(),
                       "error": failed.then(|| r[0].error.clone()),
                       "fits": r.iter().filter(|x| !x.model.is_empty()).map(Row::to_json).collect::<Vec<_>>()})
            })
            .collect();
        json!({
            "out": self.out.display().to_string(),
            "summary_csv": self.summary_csv.display().to_string(),
            "shard": self.shard.map(|s| json!({"index": s.index, "count": s.count})),
            "options_hash": self.options_hash,
            "tables_matched": self.tables_matched,
            "tables": self.tables.len(),
            "fitted": self.fitted,
            "resumed": self.resumed,
            "failed": self.failures.len(),
            "pending": self.pending,
            "interrupted": self.interrupted,
            "note": self.note(),
            "wall_time_s": self.wall_time_s,
            "failures": self.failures.iter().map(|(t, e)| json!({"table": t, "error": e})).collect::<Vec<_>>(),
            "results": results,
        })
    }

    /// Why the run had nothing to do, when a shard holds none of the tables (legitimate:
    /// a job array may have more tasks than a database has tables), or None.
    pub fn note(&self) -> Option<String> {
        let sh = self.shard.filter(|_| self.tables.is_empty())?;
        Some(format!(
            "shard {}/{} holds none of the {} tables (tables are assigned by file-name hash); \
             nothing to do",
            sh.index, sh.count, self.tables_matched
        ))
    }

    /// The report as text: the note of an empty shard, counts, the summary's path,
    /// every failure.
    pub fn text(&self) -> String {
        let n = self.tables.len();
        let mut s = self.note().map_or(String::new(), |m| m + "\n");
        let _ = write!(
            s,
            "batch: {n} tables{}: {} fitted, {} already done, {} failed{}; {:.2} s",
            self.shard.map_or(String::new(), |sh| format!(
                " (shard {}/{} of {})",
                sh.index, sh.count, self.tables_matched
            )),
            self.fitted,
            self.resumed,
            self.failures.len(),
            if self.pending > 0 {
                format!(", {} not started", self.pending)
            } else {
                String::new()
            },
            self.wall_time_s
        );
        if self.fitted > 0 {
            let _ = write!(
                s,
                " ({:.3} s per fitted table)",
                self.fit_time_s / self.fitted as f64
            );
        }
        let _ = writeln!(s, "\nsummary: {}", self.summary_csv.display());
        for (_, e) in &self.failures {
            // Every message names its file.
            let _ = writeln!(s, "failed: {e}");
        }
        s
    }

    /// Why the run is not a success (interrupted, or tables failed), or None.
    pub fn problem(&self) -> Option<String> {
        let n = self.tables.len();
        if self.interrupted {
            return Some(format!(
                "interrupted after {} of {n} tables ({} not started); every output written is \
                 complete: rerun the same command to resume",
                self.resumed + self.fitted + self.failures.len(),
                self.pending
            ));
        }
        if !self.failures.is_empty() {
            let names: Vec<&str> = self.failures.iter().map(|(t, _)| t.as_str()).collect();
            return Some(format!(
                "{} of {n} tables failed: {}",
                self.failures.len(),
                names.join(", ")
            ));
        }
        None
    }
}

#[cfg(test)]
mod tests;
