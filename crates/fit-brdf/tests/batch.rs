//! `fit-brdf batch` end to end: every table fitted, corrupt ones reported (exit 1),
//! reruns resume without refitting, shards partition the database, and SIGINT leaves
//! only complete files. The engine's logic has its unit tests in `brdfkit_fit::batch`.

#[macro_use]
mod common;

use common::{assert_bad_input, bin, names, stderr, synth_to};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// A spec of a small table (16 x 16 x 32 cells, or 24 x 24 x 48 with `big`).
fn spec(alpha: f64, big: bool) -> String {
    format!(
        r#"name = "t"
dims = {}
[material]
model = "cook-torrance"
[material.params]
rho_d = [0.3, 0.2, 0.1]
rho_s = 0.6
alpha = {alpha}
fresnel = {{ schlick = {{ f0 = 0.04 }} }}
"#,
        if big { "[24, 24, 48]" } else { "[16, 16, 32]" }
    )
}

/// Synthesises a table at `out`.
fn synth(dir: &Path, alpha: f64, big: bool, out: &Path) {
    let s = dir.join(format!("spec-{alpha}-{big}.toml"));
    std::fs::write(&s, spec(alpha, big)).unwrap();
    synth_to(&s, out);
}

/// `n` tables `t00.binary`… in `db` (copies of one synthesis: fitting cost is what the
/// tests need, not variety).
fn database(dir: &Path, n: usize, big: bool) -> PathBuf {
    let db = dir.join("db");
    std::fs::create_dir_all(&db).unwrap();
    let first = db.join("t00.binary");
    synth(dir, 0.2, big, &first);
    for i in 1..n {
        std::fs::copy(&first, db.join(format!("t{i:02}.binary"))).unwrap();
    }
    db
}

fn json_of(o: &std::process::Output) -> Value {
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not JSON ({e}): {}",
            String::from_utf8_lossy(&o.stdout)
        )
    })
}

fn batch(db: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    bin()
        .arg("batch")
        .arg(db)
        .args([
            "--models",
            "lambert,cook-torrance",
            "--starts",
            "1",
            "--json",
            "--quiet",
            "--out",
        ])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

fn mtime(p: &Path) -> SystemTime {
    std::fs::metadata(p).unwrap().modified().unwrap()
}

/// Every output present is complete: each JSON parses with its fits, no temporary file,
/// and the summary lists exactly the tables whose JSON exists as fitted or resumed.
fn assert_outputs_complete(out: &Path) -> usize {
    let all = names(out);
    assert!(
        all.iter()
            .all(|n| !n.starts_with('.') && !n.ends_with(".tmp")),
        "temporary files left: {all:?}"
    );
    let jsons: Vec<&String> = all.iter().filter(|n| n.ends_with(".json")).collect();
    #[cfg(unix)]
    {
        // Readable like a plainly created file (shared file systems), not owner-only.
        use std::os::unix::fs::PermissionsExt;
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o444;
        let probe = out.with_extension("probe");
        std::fs::write(&probe, "x").unwrap();
        let want = mode(&probe);
        std::fs::remove_file(&probe).unwrap();
        for n in jsons.iter().map(|s| s.as_str()).chain(["summary.csv"]) {
            assert_eq!(mode(&out.join(n)), want, "{n}");
        }
    }
    for n in &jsons {
        let v: Value = serde_json::from_slice(&std::fs::read(out.join(n)).unwrap())
            .unwrap_or_else(|e| panic!("{n} does not parse: {e}"));
        assert_eq!(v["format"], "fit-brdf-batch/1");
        assert!(!v["fits"].as_array().unwrap().is_empty(), "{n}");
    }
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(lines.next().unwrap().starts_with("table,model,status,"));
    let mut done = std::collections::BTreeSet::new();
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        if f[2] == "fitted" || f[2] == "resumed" {
            done.insert(f[0].trim_end_matches(".binary").to_string() + ".json");
        }
    }
    let have: std::collections::BTreeSet<String> = jsons.iter().map(|s| s.to_string()).collect();
    assert_eq!(done, have, "the summary lists exactly the finished tables");
    jsons.len()
}

#[test]
fn batch_fits_good_tables_reports_corrupt_ones_and_resumes() {
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 3, false);
    let good = std::fs::read(db.join("t00.binary")).unwrap();
    std::fs::write(db.join("t03.binary"), &good[..1000]).unwrap(); // truncated
    std::fs::write(db.join("t04.binary"), b"not a table at all").unwrap();
    let out = d.path().join("out");

    let o = batch(&db, &out, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    common::assert_mentions(&e, &["2 of 5 tables failed", "t03.binary", "t04.binary"]);
    let v = json_of(&o);
    assert_eq!(
        (v["fitted"].as_u64(), v["failed"].as_u64()),
        (Some(3), Some(2)),
        "{v}"
    );
    assert_eq!(
        v["failures"][0]["table"].as_str().unwrap(),
        db.join("t03.binary").to_str().unwrap()
    );
    assert!(
        v["failures"][0]["error"]
            .as_str()
            .unwrap()
            .contains("truncated"),
        "{v}"
    );
    for r in v["results"].as_array().unwrap() {
        let ok = r["status"] == "fitted";
        assert_eq!(ok, r["table"].as_str().unwrap() < "t03", "{r}");
    }
    assert_eq!(assert_outputs_complete(&out), 3);
    // The per-table JSON holds each model's parameters (a model the other commands read)
    // and its record.
    let t0: Value = serde_json::from_slice(&std::fs::read(out.join("t00.json")).unwrap()).unwrap();
    let fits = t0["fits"].as_array().unwrap();
    assert_eq!(fits.len(), 2);
    assert_eq!(fits[1]["params"]["model"], "cook-torrance");
    brdfkit::models::from_json(&fits[1]["params"]).unwrap();
    let alpha = fits[1]["params"]["params"]["alpha"].as_f64().unwrap();
    assert!((alpha - 0.2).abs() < 1e-6, "alpha {alpha}");
    assert!(
        fits[1]["record"]["losses_full"]["cbrt"]["overall"]
            .as_f64()
            .unwrap()
            < 1e-8
    );
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3 * 2 + 2, "{csv}");
    common::assert_mentions(&csv, &["t04.binary,,failed,"]);

    // Rerun: nothing refitted (the outputs keep their times), failures reported again.
    let before: Vec<SystemTime> = (0..3)
        .map(|i| mtime(&out.join(format!("t0{i}.json"))))
        .collect();
    std::thread::sleep(Duration::from_millis(20));
    let o = batch(&db, &out, &[]);
    assert_eq!(o.status.code(), Some(1));
    let v = json_of(&o);
    assert_eq!(
        (
            v["fitted"].as_u64(),
            v["resumed"].as_u64(),
            v["failed"].as_u64()
        ),
        (Some(0), Some(3), Some(2))
    );
    let after: Vec<SystemTime> = (0..3)
        .map(|i| mtime(&out.join(format!("t0{i}.json"))))
        .collect();
    assert_eq!(before, after, "finished tables are not rewritten");

    // Repair the corrupt tables: only they are fitted; exit 0.
    std::fs::write(db.join("t03.binary"), &good).unwrap();
    std::fs::write(db.join("t04.binary"), &good).unwrap();
    let o = batch(&db, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_of(&o);
    assert_eq!(
        (v["fitted"].as_u64(), v["resumed"].as_u64()),
        (Some(2), Some(3))
    );
    assert_eq!(assert_outputs_complete(&out), 5);

    // Same bytes, new modification time (a copy): still done. New bytes of the same size:
    // refitted.
    std::fs::write(db.join("t00.binary"), &good).unwrap();
    synth(d.path(), 0.35, false, &db.join("t01.binary"));
    let o = batch(&db, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_of(&o);
    assert_eq!(
        (v["fitted"].as_u64(), v["resumed"].as_u64()),
        (Some(1), Some(4)),
        "{v}"
    );
    let t1: Value = serde_json::from_slice(&std::fs::read(out.join("t01.json")).unwrap()).unwrap();
    let alpha = t1["fits"][1]["params"]["params"]["alpha"].as_f64().unwrap();
    assert!(
        (alpha - 0.35).abs() < 1e-6,
        "refitted on the new table: alpha {alpha}"
    );

    // Other options: everything is refitted; --force too.
    let o = batch(&db, &out, &["--loss", "l2"]);
    assert!(o.status.success());
    assert_eq!(json_of(&o)["fitted"].as_u64(), Some(5));
    let o = batch(&db, &out, &["--loss", "l2"]);
    assert_eq!(json_of(&o)["fitted"].as_u64(), Some(0));
    let o = batch(&db, &out, &["--loss", "l2", "--force"]);
    assert_eq!(json_of(&o)["fitted"].as_u64(), Some(5));
    // A damaged output is refitted, not trusted.
    std::fs::write(out.join("t02.json"), "{\"format\": ").unwrap();
    let o = batch(&db, &out, &["--loss", "l2"]);
    assert_eq!(json_of(&o)["fitted"].as_u64(), Some(1));
    assert_outputs_complete(&out);
}

#[test]
fn shards_partition_the_tables_and_their_summaries_merge() {
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 9, false);
    let out = d.path().join("out");
    let mut seen = Vec::new();
    let mut merged = String::new();
    for i in 1..=3 {
        let o = fit_brdf_ok!(
            "batch",
            &db,
            "--models",
            "lambert",
            "--json",
            "--quiet",
            "--shard",
            &format!("{i}/3"),
            "--out",
            &out
        );
        let v = json_of(&o);
        assert_eq!(v["tables_matched"].as_u64(), Some(9));
        for r in v["results"].as_array().unwrap() {
            seen.push(r["table"].as_str().unwrap().to_string());
        }
        // The merge recipe of docs/batch.md: one header, then every shard's rows.
        let csv = std::fs::read_to_string(out.join(format!("summary-{i}-of-3.csv"))).unwrap();
        let mut lines = csv.lines();
        let header = lines.next().unwrap();
        if merged.is_empty() {
            merged = format!("{header}\n");
        }
        for l in lines {
            merged += &format!("{l}\n");
        }
    }
    seen.sort();
    let all: Vec<String> = (0..9).map(|i| format!("t{i:02}.binary")).collect();
    assert_eq!(seen, all, "every table in exactly one shard");
    assert_eq!(merged.lines().count(), 1 + 9);
    assert_eq!(
        names(&out).iter().filter(|n| n.ends_with(".json")).count(),
        9
    );

    // The assignment depends on the file name only, not on where the database lives.
    let moved = d.path().join("elsewhere").join("db");
    std::fs::create_dir_all(&moved).unwrap();
    for t in &all {
        std::fs::copy(db.join(t), moved.join(t)).unwrap();
    }
    let shard_of = |dir: &Path| -> Vec<String> {
        let o = fit_brdf!(
            "batch",
            dir,
            "--models",
            "lambert",
            "--json",
            "--quiet",
            "--shard",
            "2/3",
            "--out",
            d.path().join(format!("o-{}", dir.components().count()))
        );
        json_of(&o)["results"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["table"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(shard_of(&db), shard_of(&moved));

    for bad in ["0/3", "4/3", "1/0", "x/2", "2"] {
        let o = fit_brdf!("batch", &db, "--shard", bad, "--out", &out);
        assert_bad_input(&o, &["--shard"]);
    }
}

#[test]
fn inputs_globs_and_bad_usage() {
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 4, false);
    let out = d.path().join("out");
    // A quoted glob (expanded by the batch) and explicit files (expanded by a shell).
    let pattern = format!("{}/t0[12].binary", db.display());
    let o = fit_brdf_ok!(
        "batch", &pattern, "--models", "lambert", "--json", "--quiet", "--out", &out
    );
    assert_eq!(json_of(&o)["tables"].as_u64(), Some(2));
    let o = fit_brdf_ok!(
        "batch",
        db.join("t00.binary"),
        db.join("t03.binary"),
        db.join("t03.binary"),
        "--models",
        "lambert",
        "--json",
        "--quiet",
        "--out",
        &out
    );
    assert_eq!(
        json_of(&o)["tables"].as_u64(),
        Some(2),
        "duplicates count once"
    );
    // Not quiet: the summary on stdout, per-table lines on stderr; quiet: nothing on stderr.
    let o = fit_brdf!(
        "batch",
        &db,
        "--models",
        "lambert",
        "--out",
        d.path().join("loud")
    );
    assert!(o.status.success());
    let s = String::from_utf8_lossy(&o.stdout);
    common::assert_mentions(&s, &["batch: 4 tables: 4 fitted", "summary.csv"]);
    common::assert_mentions(&stderr(&o), &["[4/4] t03.binary: fitted"]);
    let o = fit_brdf!(
        "batch",
        &db,
        "--models",
        "lambert",
        "--quiet",
        "--out",
        d.path().join("loud")
    );
    assert!(o.status.success() && o.stderr.is_empty(), "{}", stderr(&o));

    let empty = d.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let other = d.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::copy(db.join("t00.binary"), other.join("t00.binary")).unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let no_match = format!("{}/*.nope", db.display());
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec![s(&d.path().join("missing"))], "no such file"),
        (vec![s(&empty)], "no *.binary"),
        (vec![no_match], "matches no file"),
        (vec![s(&db), s(&other)], "same name"),
        (vec![s(&db), "--loss".into(), "l3".into()], "--loss"),
        (vec![s(&db), "--model".into(), "nope".into()], "nope"),
        (vec![s(&db), "--record".into(), "x.json".into()], "--record"),
        (vec![], "required"),
    ];
    for (args, what) in cases {
        let o = bin()
            .arg("batch")
            .args(&args)
            .arg("--out")
            .arg(d.path().join("never"))
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(what), "{args:?}: {}", stderr(&o));
    }
    assert!(!d.path().join("never").exists(), "bad input writes nothing");
}

#[cfg(unix)]
/// Spawns a batch over `db`, waits for its first newly finished table and 50 ms more (the
/// second table is then being fitted: each takes a few hundred ms), sends `signals`
/// SIGINTs 30 ms apart, and returns its output.
fn interrupt(db: &Path, out: &Path, signals: usize) -> std::process::Output {
    let child = std::process::Command::new(assert_cmd::cargo::cargo_bin("fit-brdf"))
        .arg("batch")
        .arg(db)
        .args([
            "--models",
            "cook-torrance",
            "--starts",
            "8",
            "--json",
            "--quiet",
            "--out",
        ])
        .arg(out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let jsons = |out: &Path| {
        if out.exists() {
            names(out).iter().filter(|n| n.ends_with(".json")).count()
        } else {
            0
        }
    };
    // Outputs of an earlier run do not count: the handler is surely installed once
    // this run has finished a table.
    let before = jsons(out);
    while jsons(out) <= before {
        assert!(t0.elapsed() < Duration::from_secs(120), "no table finished");
        std::thread::sleep(Duration::from_millis(2));
    }
    std::thread::sleep(Duration::from_millis(50));
    for _ in 0..signals {
        // SAFETY: kill(2) on our own child's pid.
        let r = unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
        assert_eq!(r, 0);
        std::thread::sleep(Duration::from_millis(30));
    }
    child.wait_with_output().unwrap()
}

/// The interrupt glue of the command line, end to end: a first SIGINT makes the batch
/// stop after the current table (exit 1, every output complete), and on a rerun a second
/// SIGINT stops it at once, still leaving no partial file. What the engine does with a
/// stop request (pending rows, the rerun's counts) is tested in
/// `brdfkit_fit::batch` without signals.
#[cfg(unix)]
#[test]
fn sigint_stops_the_batch_and_a_second_stops_it_at_once() {
    let d = tempfile::tempdir().unwrap();
    let n = 6;
    let db = database(d.path(), n, true);
    let out = d.path().join("out");
    let o = interrupt(&db, &out, 1);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    common::assert_mentions(&stderr(&o), &["interrupted"]);
    let v = json_of(&o);
    assert_eq!(v["interrupted"], true);
    let done = assert_outputs_complete(&out);
    assert!(done >= 1 && done < n, "stopped early: {done} of {n}");
    assert_eq!(v["fitted"].as_u64(), Some(done as u64));
    assert_eq!(v["pending"].as_u64(), Some((n - done) as u64));

    let t0 = Instant::now();
    let o = interrupt(&db, &out, 2);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    common::assert_mentions(&stderr(&o), &["stopped"]);
    let again = assert_outputs_complete(&out);
    assert!(again >= done && again < n, "{again}");
    assert!(t0.elapsed() < Duration::from_secs(120));
}

#[test]
fn an_empty_shard_says_so_plainly_and_exits_0() {
    // The issue's case: `--shard 1/4` over 3 tables; with 3 tables and 4 shards at least
    // one shard is empty, whichever the hash picks.
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 3, false);
    let out = d.path().join("out");
    let mut empty = 0;
    for i in 1..=4 {
        let shard = format!("{i}/4");
        let run = |json: bool| {
            let mut c = bin();
            c.arg("batch")
                .arg(&db)
                .args(["--models", "lambert", "--quiet", "--shard", &shard, "--out"])
                .arg(&out);
            if json {
                c.arg("--json");
            }
            let o = c.output().unwrap();
            assert!(o.status.success(), "{shard}: {}", stderr(&o));
            o
        };
        let v = json_of(&run(true));
        if v["tables"].as_u64() != Some(0) {
            assert!(v["note"].is_null(), "{v}");
            continue;
        }
        empty += 1;
        let want = format!(
            "shard {shard} holds none of the 3 tables (tables are assigned by file-name hash); \
             nothing to do"
        );
        assert_eq!(v["note"].as_str(), Some(want.as_str()), "{v}");
        let text = String::from_utf8(run(false).stdout).unwrap();
        assert!(text.starts_with(&want), "{text}");
    }
    assert!(empty >= 1);
}

/// A directory of MERL tables and RGL-EPFL `.bsdf` files is one batch: the `.bsdf` is
/// told by its content (the directory listing picks `*.binary` and `*.bsdf`) and fitted
/// as `fit` fits it: at its measured points by default, resampled to a MERL table with
/// `--bsdf-input table`; either way the batch's fit equals `fit`'s of the file itself,
/// and the two differ (so the comparison can fail). Changing `--bsdf-input` refits the
/// `.bsdf` (the option is in the options hash of a batch that holds one).
#[test]
fn a_bsdf_goes_into_a_batch_beside_tables() {
    let d = tempfile::tempdir().unwrap();
    let db = database(d.path(), 1, false);
    let felt =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-synthetic/felt-synthetic.bsdf");
    std::fs::copy(&felt, db.join("felt.bsdf")).unwrap();
    let out = d.path().join("out");
    let mut params = Vec::new();
    for how in ["points", "table"] {
        let extra: &[&str] = if how == "points" {
            &[]
        } else {
            &["--bsdf-input", "table"]
        };
        let o = batch(&db, &out, extra);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let v = json_of(&o);
        let results = v["results"].as_array().unwrap();
        assert_eq!(results.len(), 2, "{v}");
        let felt_row = results.iter().find(|r| r["table"] == "felt.bsdf").unwrap();
        // The second run refits the .bsdf (its option changed), and only the .bsdf.
        assert_eq!(felt_row["status"], "fitted", "{how}: {v}");
        let other = results.iter().find(|r| r["table"] != "felt.bsdf").unwrap();
        let want = if how == "points" { "fitted" } else { "resumed" };
        assert_eq!(other["status"], want, "{how}: {v}");
        let fit = fit_brdf!(
            "fit",
            &felt,
            "--model",
            "lambert",
            "--starts",
            "1",
            "--bsdf-input",
            how,
            "--json",
            "--quiet"
        );
        assert_eq!(fit.status.code(), Some(0), "{}", stderr(&fit));
        let alone = json_of(&fit);
        let rec: Value =
            serde_json::from_slice(&std::fs::read(out.join("felt.json")).unwrap()).unwrap();
        assert_eq!(rec["options"]["bsdf_input"], how, "{how}");
        let lambert = rec["fits"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["label"] == "lambert")
            .unwrap();
        assert_eq!(
            lambert["params"], alone[0]["params"],
            "{how}: {lambert}\n{alone}"
        );
        params.push(lambert["params"].clone());
    }
    assert_ne!(
        params[0], params[1],
        "points and table give the same fit: {params:?}"
    );
}
