//! How fit time and memory grow: with the number of valid cells, the number of
//! parameters (a Lambertian plus 1–3 Cook-Torrance lobes), the number of threads, over
//! a batch of tables, and the peak resident memory of a full-table fit.

use crate::choices::pool;
use crate::{StudyConfig, StudyError, SynthMaterial};
use brdfkit_fit::{FitConfig, FitData, Loss, fit, resolve_free};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Fit time against a quantity.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ScalePoint {
    /// What varies (`cells`, `params`, `threads`).
    pub axis: String,
    /// Its value.
    pub x: f64,
    /// Cells fitted.
    pub cells: usize,
    /// Free parameters.
    pub params: usize,
    /// Rayon threads.
    pub threads: usize,
    /// Starts.
    pub starts: usize,
    /// Median wall time of the fit over the repetitions, s.
    pub wall_s: f64,
    /// Full-table cbrt loss.
    pub cbrt: f64,
}

/// Peak resident memory of a child process.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct MemoryPoint {
    /// The command (arguments after the executable).
    pub command: String,
    /// Peak RSS (`ru_maxrss` of the child), MB (10⁶ bytes).
    pub peak_rss_mb: f64,
    /// Wall time of the child, s.
    pub wall_s: f64,
    /// Exit status (0 = success).
    pub status: i32,
}

/// Throughput of fitting many tables.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct BatchPoint {
    /// `sequential in-process` (read + fit each table in turn) or `fit-brdf batch`.
    pub how: String,
    /// Tables fitted.
    pub tables: usize,
    /// Wall time of all of them, s.
    pub wall_s: f64,
    /// Tables per second.
    pub tables_per_s: f64,
    /// Why a way was not measured, if so.
    pub note: String,
}

/// All scaling measurements.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct ScaleResults {
    /// Fit time against cells, parameters and threads.
    pub points: Vec<ScalePoint>,
    /// Peak resident memory of full-table fits.
    pub memory: Vec<MemoryPoint>,
    /// Throughput of many fits.
    pub batch: Vec<BatchPoint>,
}

fn fit_err(what: &str) -> impl FnOnce(brdfkit_fit::FitError) -> StudyError + '_ {
    move |source| StudyError::Fit {
        what: what.to_string(),
        source,
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Median wall time and the loss of `reps` identical fits.
fn timed_fit(
    reps: usize,
    start: &dyn brdfkit_core::Model,
    data: &FitData,
    fc: &FitConfig,
    what: &str,
) -> Result<(f64, f64), StudyError> {
    let mut times = Vec::new();
    let mut loss = f64::NAN;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let o = fit(start, data, fc, None).map_err(fit_err(what))?;
        times.push(t.elapsed().as_secs_f64());
        loss = o.record.losses_full.get(Loss::Cbrt).overall;
    }
    Ok((median(times), loss))
}

/// A Lambertian plus `lobes` Cook-Torrance lobes (GGX, Schlick) with their own ρd held
/// at 0 (a sum's diffuse parts are not separately identifiable), started at
/// α = 0.05, 0.2, 0.5.
pub fn lobes_model(lobes: usize) -> serde_json::Value {
    let mut terms = vec![serde_json::json!({"model": "lambert", "params": {"rho_d": 0.3}})];
    for (i, a) in [0.05, 0.2, 0.5].iter().take(lobes).enumerate() {
        terms.push(serde_json::json!({"model": "cook-torrance", "params": {
            "rho_d": 0.0, "rho_s": 0.3 / (i + 1) as f64, "alpha": a,
            "distribution": "ggx", "masking": "smith-separable", "fresnel": "schlick"}}));
    }
    serde_json::json!({"model": "sum", "params": {"terms": terms}})
}

/// The held diffuse parameters of [`lobes_model`].
fn lobes_fixed(lobes: usize) -> Vec<String> {
    (1..=lobes).map(|i| format!("terms[{i}].rho_d")).collect()
}

/// Runs the child `exe args`, returning its peak RSS and wall time.
///
/// Not `wait4` on a direct child: Linux carries the parent's peak RSS into a child across
/// `fork`/`exec` (`signal->maxrss` keeps the old memory map's high-water mark at exec), so a
/// child of this 0.8 GB process "peaks" at 0.8 GB whatever it does. GNU time
/// (`/usr/bin/time -f %M`, KiB) is spawned instead: its own child is forked from a small
/// process. Without it, the child's `VmHWM` (`/proc/PID/status`, the high-water mark of
/// its own memory map since exec) is polled every 5 ms; growth in the last 5 ms before
/// exit would be missed.
pub fn child_peak_rss(exe: &Path, args: &[String]) -> Result<MemoryPoint, StudyError> {
    let gnu_time = Path::new("/usr/bin/time");
    let t = Instant::now();
    let (status, kib) = if gnu_time.exists() {
        let dir = tempfile::tempdir().map_err(|e| StudyError::io(Path::new("temp dir"), e))?;
        let rep = dir.path().join("maxrss");
        let st = Command::new(gnu_time)
            .arg("-f")
            .arg("%M")
            .arg("-o")
            .arg(&rep)
            .arg(exe)
            .args(args)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .map_err(|e| StudyError::io(gnu_time, e))?;
        let text = std::fs::read_to_string(&rep).map_err(|e| StudyError::io(&rep, e))?;
        // GNU time writes "Command exited with non-zero status N" before the figure.
        let kib: f64 = text
            .lines()
            .filter_map(|l| l.trim().parse().ok())
            .next_back()
            .unwrap_or(f64::NAN);
        (st.code().unwrap_or(-1), kib)
    } else {
        let mut child = Command::new(exe)
            .args(args)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .map_err(|e| StudyError::io(exe, e))?;
        let status_path = format!("/proc/{}/status", child.id());
        let mut kib = f64::NAN;
        let st = loop {
            if let Ok(s) = std::fs::read_to_string(&status_path)
                && let Some(v) = s
                    .lines()
                    .find(|l| l.starts_with("VmHWM:"))
                    .and_then(|l| l.split_whitespace().nth(1))
                    .and_then(|v| v.parse::<f64>().ok())
            {
                kib = if kib.is_nan() { v } else { kib.max(v) };
            }
            if let Some(st) = child.try_wait().map_err(|e| StudyError::io(exe, e))? {
                break st;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        };
        (st.code().unwrap_or(-1), kib)
    };
    Ok(MemoryPoint {
        command: args.join(" "),
        peak_rss_mb: kib * 1024.0 / 1e6,
        wall_s: t.elapsed().as_secs_f64(),
        status,
    })
}

/// Runs every scaling measurement. The tables for the memory and batch figures are
/// written to a temporary directory that is removed afterwards.
pub fn run_scale(
    cfg: &StudyConfig,
    materials: &[SynthMaterial],
    progress: &dyn Fn(&str),
) -> Result<ScaleResults, StudyError> {
    let mut res = ScaleResults::default();
    let pick = |name: &str| {
        materials
            .iter()
            .find(|m| m.spec.name == name)
            .or(materials.first())
    };
    let Some(plastic) = pick("demo-plastic") else {
        return Ok(res);
    };
    let full = FitData::from_table(&plastic.table).map_err(fit_err("demo-plastic"))?;
    let ct = brdfkit_models::from_json(
        &crate::ModelChoice::by_label("cook-torrance")
            .expect("known")
            .start,
    )
    .map_err(|e| StudyError::Model {
        what: "cook-torrance".into(),
        msg: e.to_string(),
    })?;
    let reps = cfg.reps.clamp(1, 3);
    let threads = rayon::current_num_threads();

    // Cells: the solver sees a stratified subset (the fit is then a full fit of a
    // smaller table: no `subsample` option, so the losses are over that subset).
    for f in [0.01, 0.02, 0.05, 0.1, 0.25, 0.5, 1.0] {
        let data = if f < 1.0 {
            full.stratified_subsample(f, 11)
        } else {
            full.clone()
        };
        let fc = FitConfig::default();
        let (wall_s, cbrt) = timed_fit(reps, ct.as_ref(), &data, &fc, "scale cells")?;
        progress(&format!("scale cells {}: {wall_s:.3} s", data.len()));
        res.points.push(ScalePoint {
            axis: "cells".into(),
            x: f,
            cells: data.len(),
            params: resolve_free(ct.as_ref(), &fc).map_err(fit_err("ct"))?.len(),
            threads,
            starts: 1,
            wall_s,
            cbrt,
        });
    }

    // Parameters: Lambert + 1..3 lobes, on the multi-lobe material when present.
    let multi = pick("lafortune-two-lobes").unwrap_or(plastic);
    let mdata = FitData::from_table(&multi.table).map_err(fit_err("multi-lobe"))?;
    for lobes in 1..=3 {
        let m = brdfkit_models::from_json(&lobes_model(lobes)).map_err(|e| StudyError::Model {
            what: format!("sum of {lobes} lobes"),
            msg: e.to_string(),
        })?;
        let fc = FitConfig::default().fix_params(lobes_fixed(lobes));
        let np = resolve_free(m.as_ref(), &fc)
            .map_err(fit_err("lobes"))?
            .len();
        let (wall_s, cbrt) = timed_fit(reps, m.as_ref(), &mdata, &fc, "scale params")?;
        progress(&format!(
            "scale params {np}: {wall_s:.3} s, cbrt {cbrt:.3e}"
        ));
        res.points.push(ScalePoint {
            axis: "params".into(),
            x: np as f64,
            cells: mdata.len(),
            params: np,
            threads,
            starts: 1,
            wall_s,
            cbrt,
        });
    }

    // Threads: 1 and 2 (and all, if more), one start and four.
    let mut ts = vec![1, 2];
    if threads > 2 {
        ts.push(threads);
    }
    for &t in &ts {
        for starts in [1, 4] {
            let fc = FitConfig::default()
                .starts(starts)
                .map_err(fit_err("threads"))?;
            let (wall_s, cbrt) =
                pool(t).install(|| timed_fit(reps, ct.as_ref(), &full, &fc, "scale threads"))?;
            progress(&format!("scale threads {t} starts {starts}: {wall_s:.3} s"));
            res.points.push(ScalePoint {
                axis: "threads".into(),
                x: t as f64,
                cells: full.len(),
                params: 10,
                threads: t,
                starts,
                wall_s,
                cbrt,
            });
        }
    }

    // Tables on disk for the batch and memory figures.
    let dir = tempfile::tempdir().map_err(|e| StudyError::io(Path::new("temp dir"), e))?;
    let n = cfg.batch_tables.max(1);
    let mut paths: Vec<PathBuf> = Vec::new();
    for i in 0..n {
        let m = &materials[i % materials.len()];
        let p = dir.path().join(format!("{:02}-{}.binary", i, m.spec.name));
        m.table
            .write(&p)
            .map_err(|e| StudyError::io(&p, std::io::Error::other(e.to_string())))?;
        paths.push(p);
    }
    let t = Instant::now();
    for p in &paths {
        let table = brdfkit_merl::MerlTable::read(p)
            .map_err(|e| StudyError::io(p, std::io::Error::other(e.to_string())))?;
        let data = FitData::from_table(&table).map_err(fit_err("batch"))?;
        fit(ct.as_ref(), &data, &FitConfig::default(), None).map_err(fit_err("batch"))?;
    }
    let wall = t.elapsed().as_secs_f64();
    progress(&format!(
        "scale batch: {n} tables in {wall:.2} s (sequential)"
    ));
    res.batch.push(BatchPoint {
        how: "sequential in-process (read + cook-torrance fit, 1 start)".into(),
        tables: n,
        wall_s: wall,
        tables_per_s: n as f64 / wall,
        note: String::new(),
    });
    if let Some(exe) = &cfg.fit_exe {
        let out = dir.path().join("batch-out");
        let mut args: Vec<String> = vec!["batch".into()];
        args.extend(paths.iter().map(|p| p.display().to_string()));
        args.extend(
            ["--models", "cook-torrance", "--starts", "1", "--out"]
                .iter()
                .map(|s| s.to_string()),
        );
        args.push(out.display().to_string());
        let r = child_peak_rss(exe, &args)?;
        let ok = r.status == 0;
        progress(&format!(
            "scale batch: fit-brdf batch {} ({:.2} s)",
            if ok { "ran" } else { "failed" },
            r.wall_s
        ));
        res.batch.push(BatchPoint {
            how: "fit-brdf batch --models cook-torrance --starts 1 (child process)".into(),
            tables: n,
            wall_s: r.wall_s,
            tables_per_s: if ok { n as f64 / r.wall_s } else { f64::NAN },
            note: if ok {
                format!("peak RSS {:.0} MB", r.peak_rss_mb)
            } else {
                format!("exit status {}: not measured", r.status)
            },
        });

        // Peak memory: reading a table, a one-start fit, the CLI's default 8 starts.
        let table = paths
            .iter()
            .find(|p| p.display().to_string().contains("demo-plastic"))
            .unwrap_or(&paths[0])
            .display()
            .to_string();
        let params = dir.path().join("p.json").display().to_string();
        for args in [
            vec!["info".to_string(), table.clone()],
            vec![
                "fit".into(),
                table.clone(),
                "--model".into(),
                "cook-torrance".into(),
                "--starts".into(),
                "1".into(),
                "--quiet".into(),
                "--out".into(),
                params.clone(),
            ],
            vec![
                "fit".into(),
                table.clone(),
                "--model".into(),
                "cook-torrance".into(),
                "--quiet".into(),
                "--out".into(),
                params.clone(),
            ],
        ] {
            let mut m = child_peak_rss(exe, &args)?;
            m.command = m
                .command
                .replace(&table, "TABLE")
                .replace(&params, "P.json");
            progress(&format!(
                "memory: {} -> {:.0} MB, {:.2} s",
                m.command, m.peak_rss_mb, m.wall_s
            ));
            res.memory.push(m);
        }
    }
    Ok(res)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lobe_models_have_the_expected_free_parameters() {
        for lobes in 1..=3 {
            let m = brdfkit_models::from_json(&lobes_model(lobes)).unwrap();
            let fc = FitConfig::default().fix_params(lobes_fixed(lobes));
            // Lambert ρd (3) + per lobe ρs (3), α (1), f0 (3).
            assert_eq!(resolve_free(m.as_ref(), &fc).unwrap().len(), 3 + 7 * lobes);
        }
    }

    #[test]
    fn child_peak_rss_sees_the_child_memory() {
        // dd with one 50 MB block allocates and fills it: a peak of 50-60 MB, whatever
        // this (test) process holds.
        let _ballast = vec![1u8; 300_000_000];
        std::hint::black_box(&_ballast);
        let r = child_peak_rss(
            Path::new("dd"),
            &[
                "if=/dev/zero".into(),
                "of=/dev/null".into(),
                "bs=50M".into(),
                "count=1".into(),
            ],
        )
        .unwrap();
        assert_eq!(r.status, 0);
        assert!(r.peak_rss_mb > 50.0, "{r:?}");
        assert!(r.peak_rss_mb < 200.0, "{r:?}");
    }
}
