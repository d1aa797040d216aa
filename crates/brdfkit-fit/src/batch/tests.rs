//! The engine's logic on small tables: resume stamps, refits, failures, summary rows,
//! shards and cancellation (the token set by an observer, no signal involved).

use super::*;
use crate::families::{FitSettings, Structure, families};
use crate::{Loss, RobustKind};
use brdfkit_core::Rgb;
use brdfkit_merl::{Dims, MerlTable};

/// A Lambertian table of 8 × 8 × 16 cells with albedo `a` (fitted in milliseconds).
fn table_bytes(a: f64) -> Vec<u8> {
    let dims = Dims::new(8, 8, 16).unwrap();
    let v = a / std::f64::consts::PI;
    MerlTable::from_fn(dims, |_, _, _| Some(Rgb::new(v, 0.8 * v, 0.6 * v)))
        .unwrap()
        .to_bytes()
}

/// `n` tables `t0.binary`… in `dir/db`.
fn database(dir: &Path, n: usize) -> PathBuf {
    let db = dir.join("db");
    std::fs::create_dir_all(&db).unwrap();
    let bytes = table_bytes(0.5);
    for i in 0..n {
        std::fs::write(db.join(format!("t{i}.binary")), &bytes).unwrap();
    }
    db
}

fn job(db: &Path, out: &Path, shard: Option<Shard>, loss: Loss) -> BatchJob {
    let fams = families("lambert", &Structure::default()).unwrap();
    let cfg = FitSettings {
        loss,
        robust: RobustKind::None,
        ..FitSettings::default()
    }
    .config()
    .unwrap();
    BatchJob::new(&[db.display().to_string()], out, shard, fams, cfg).unwrap()
}

/// Records the events as short lines; optionally requests a stop after `stop_after`
/// finished tables.
#[derive(Default)]
struct Log {
    events: Mutex<Vec<String>>,
    stop_after: Option<(usize, &'static Cancel)>,
}

impl Log {
    fn events(&self) -> std::sync::MutexGuard<'_, Vec<String>> {
        self.events.lock().unwrap()
    }
}

impl Observe for Log {
    fn observe(&self, e: &Event) {
        let line = match e {
            Event::TableRefit { table, reason } => format!("refit {table}: {reason}"),
            Event::TableSkipped { table } => format!("skip {table}"),
            Event::BatchPlanned(p) => format!("plan {} {} {}", p.tables, p.resumed, p.to_fit),
            Event::TableStarted {
                index,
                count,
                table,
            } => format!("start {index}/{count} {table}"),
            Event::TableDone {
                index, table, end, ..
            } => {
                if let Some((after, cancel)) = self.stop_after
                    && index + 1 == after
                {
                    cancel.request();
                }
                let what = match end {
                    TableEnd::Fitted(_) => "fitted",
                    TableEnd::Failed(_) => "failed",
                };
                format!("done {index} {table} {what}")
            }
            // A batch reports nothing else (its fits are silent).
            other => panic!("a batch sent {other:?}"),
        };
        self.events().push(line);
    }
}

fn counts(r: &BatchOutcome) -> (usize, usize, usize, usize) {
    (r.fitted, r.resumed, r.failures.len(), r.pending)
}

fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect()
}

#[test]
fn a_run_fits_reports_failures_and_a_rerun_resumes_only_what_is_unchanged() {
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 3);
    std::fs::write(db.join("t3.binary"), b"not a table at all").unwrap();
    let out = d.path().join("out");
    let j = job(&db, &out, None, Loss::Cbrt);
    let cancel = Cancel::new();

    let log = Log::default();
    let r = j.run(false, &cancel, &log).unwrap();
    assert_eq!(counts(&r), (3, 0, 1, 0));
    assert!(r.failures[0].0.ends_with("t3.binary"), "{:?}", r.failures);
    assert!(r.problem().unwrap().contains("1 of 4 tables failed"));
    // The plan, then every table started then finished (or failed) exactly once, in
    // order.
    assert_eq!(
        *log.events(),
        [
            "plan 4 0 4",
            "start 0/4 t0.binary",
            "done 0 t0.binary fitted",
            "start 1/4 t1.binary",
            "done 1 t1.binary fitted",
            "start 2/4 t2.binary",
            "done 2 t2.binary fitted",
            "start 3/4 t3.binary",
            "done 3 t3.binary failed",
        ]
    );
    // The summary: one row per model of a fitted table, a bare row for the failure.
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], CSV_HEADER);
    assert_eq!(lines.len(), 5, "{csv}");
    assert!(lines[1].starts_with("t0.binary,lambert,fitted,"), "{csv}");
    assert!(lines[4].starts_with("t3.binary,,failed,"), "{csv}");
    let doc: Value = serde_json::from_slice(&std::fs::read(out.join("t0.json")).unwrap()).unwrap();
    assert_eq!(doc["format"], FORMAT);
    assert_eq!(doc["options_hash"], r.options_hash.as_str());
    let rho = doc["fits"][0]["params"]["params"]["rho_d"][0]
        .as_f64()
        .unwrap();
    assert!((rho - 0.5).abs() < 1e-6, "rho_d {rho}");
    assert_eq!(r.to_json()["results"][3]["status"], "failed");
    assert!(leftovers(&out).is_empty(), "{:?}", leftovers(&out));

    // Rerun: the fitted tables are skipped, the failed one is tried again.
    let log = Log::default();
    let r = j.run(false, &cancel, &log).unwrap();
    assert_eq!(counts(&r), (0, 3, 1, 0));
    assert_eq!(log.events()[0], "skip t0.binary");
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(csv.matches(",resumed,").count(), 3, "{csv}");

    // Same bytes with a new time (a copy): still done. Other bytes of the same size:
    // refitted, and said why. A damaged output: refitted.
    std::thread::sleep(std::time::Duration::from_millis(20));
    std::fs::write(db.join("t0.binary"), table_bytes(0.5)).unwrap();
    std::fs::write(db.join("t1.binary"), table_bytes(0.25)).unwrap();
    std::fs::write(out.join("t2.json"), "{\"format\": ").unwrap();
    std::fs::write(db.join("t3.binary"), table_bytes(0.5)).unwrap();
    let log = Log::default();
    let r = j.run(false, &cancel, &log).unwrap();
    assert_eq!(counts(&r), (3, 1, 0, 0));
    assert!(r.problem().is_none());
    let ev = log.events();
    assert!(
        ev.contains(&"refit t1.binary: the table changed (contents)".to_string()),
        "{ev:?}"
    );
    assert!(
        ev.iter()
            .any(|e| e.starts_with("refit t2.binary:") && e.contains("does not parse")),
        "{ev:?}"
    );
    let doc: Value = serde_json::from_slice(&std::fs::read(out.join("t1.json")).unwrap()).unwrap();
    let rho = doc["fits"][0]["params"]["params"]["rho_d"][0]
        .as_f64()
        .unwrap();
    assert!(
        (rho - 0.25).abs() < 1e-6,
        "refitted on the new table: {rho}"
    );

    // Other options: everything refitted; the same again: nothing; force: everything.
    let l2 = job(&db, &out, None, Loss::L2);
    assert_eq!(counts(&l2.run(false, &cancel, &()).unwrap()), (4, 0, 0, 0));
    assert_eq!(counts(&l2.run(false, &cancel, &()).unwrap()), (0, 4, 0, 0));
    assert_eq!(counts(&l2.run(true, &cancel, &()).unwrap()), (4, 0, 0, 0));
}

#[test]
fn a_stop_request_ends_the_run_between_tables_and_a_rerun_finishes_it() {
    static CANCEL: Cancel = Cancel::new();
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 4);
    let out = d.path().join("out");
    let j = job(&db, &out, None, Loss::Cbrt);
    let log = Log {
        stop_after: Some((2, &CANCEL)),
        ..Log::default()
    };
    let r = j.run(false, &CANCEL, &log).unwrap();
    assert_eq!(counts(&r), (2, 0, 0, 2));
    assert!(r.interrupted);
    assert!(
        r.problem()
            .unwrap()
            .starts_with("interrupted after 2 of 4 tables")
    );
    assert!(r.text().contains("2 not started"), "{}", r.text());
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(csv.matches(",pending,").count(), 2, "{csv}");
    assert_eq!(csv.matches(",fitted,").count(), 2, "{csv}");
    assert!(!out.join("t2.json").exists() && out.join("t1.json").exists());

    // A token already set: nothing is fitted, the summary lists every table pending.
    let d2 = tempfile::tempdir().unwrap();
    let r = job(&db, d2.path(), None, Loss::Cbrt)
        .run(false, &CANCEL, &())
        .unwrap();
    assert_eq!(counts(&r), (0, 0, 0, 4));

    let r = j.run(false, &Cancel::new(), &()).unwrap();
    assert_eq!(counts(&r), (2, 2, 0, 0));
    assert!(!r.interrupted);
}

#[test]
fn shards_split_the_tables_and_name_their_summary() {
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 9);
    let out = d.path().join("out");
    let mut all = Vec::new();
    for i in 1..=3 {
        let shard = Shard { index: i, count: 3 };
        let j = job(&db, &out, Some(shard), Loss::Cbrt);
        assert_eq!(j.tables_matched, 9);
        assert!(j.tables.iter().all(|t| shard.contains(&t.name)));
        assert_eq!(j.summary_path(), out.join(format!("summary-{i}-of-3.csv")));
        all.extend(j.tables.iter().map(|t| t.name.clone()));
    }
    all.sort();
    let want: Vec<String> = (0..9).map(|i| format!("t{i}.binary")).collect();
    assert_eq!(all, want);
}

#[test]
fn an_empty_shard_says_why_it_has_nothing_to_do() {
    // 3 tables over 4 shards: at least one shard is empty (pigeonhole).
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 3);
    let out = d.path().join("out");
    let mut empty = 0;
    for i in 1..=4 {
        let j = job(&db, &out, Some(Shard { index: i, count: 4 }), Loss::Cbrt);
        let r = j.run(false, &Cancel::new(), &()).unwrap();
        let want = format!(
            "shard {i}/4 holds none of the 3 tables (tables are assigned by file-name hash); \
             nothing to do"
        );
        if j.tables.is_empty() {
            empty += 1;
            assert_eq!(r.note().as_deref(), Some(want.as_str()));
            assert!(r.text().starts_with(&(want.clone() + "\n")), "{}", r.text());
            assert_eq!(r.to_json()["note"], serde_json::json!(want));
            assert_eq!(r.problem(), None, "an empty shard is not a failure");
            // The shard's summary exists (a merge step finds every shard's file).
            assert!(j.summary_path().is_file());
        } else {
            assert_eq!(r.note(), None);
            assert!(r.to_json()["note"].is_null());
            assert!(!r.text().contains("holds none"), "{}", r.text());
        }
    }
    assert!(empty >= 1);
    // Without shards a run over tables has no note either.
    let r = job(&db, &out, None, Loss::Cbrt)
        .run(false, &Cancel::new(), &())
        .unwrap();
    assert_eq!(r.note(), None);
}

#[test]
fn options_that_cannot_work_are_refused_before_anything_is_written() {
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 1);
    let out = d.path().join("out");
    let fams = families("lambert", &Structure::default()).unwrap();
    let cfg = FitSettings {
        fix: Some(vec!["rho_d".into()]),
        ..FitSettings::default()
    }
    .config()
    .unwrap();
    let e = BatchJob::new(&[db.display().to_string()], &out, None, fams, cfg)
        .err()
        .unwrap();
    assert!(e.is_bad_input(), "{e}");
    assert!(e.to_string().contains("nothing is left to fit"), "{e}");
    assert!(!out.exists());
}
