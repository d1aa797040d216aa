//! Benchmark of the fitter: a full-table fit of Cook-Torrance (GGX, separable Smith,
//! Schlick Fresnel, with the model's own Lambertian ρd — not a `sum`) with the `cbrt`
//! loss on a synthetic 90 × 90 × 180 table, against the fit an ordinary user would
//! write in Python (numpy + scipy.optimize.least_squares, `benches/peers/fit_scipy.py`)
//! on the same cells, weights, loss, start and bounds.
//!
//! Run: `cargo bench --bench fit` (add `-- --no-python` to skip the peer, `-- --quick`
//! for the noise-free table only, `-- --noisy` for the noisy one only, `-- --runs N` for N timed Rust fits, default 5). Two
//! tables: noise-free, and with 5 % log-normal noise (seeded). The peer runs in `/work/main/.venv`-style
//! `<workspace>/.venv`, created with `python3 -m venv .venv && .venv/bin/pip install
//! -r benches/peers/requirements.txt` when missing.
//!
//! Prints the timings, evaluation counts, both final losses (each recomputed by the
//! Rust loss code from the returned parameters) and the time ratio.

use brdfkit::core::Model;
use brdfkit::fit::{FitConfig, FitData, evaluate_losses, fit};
use brdfkit::merl::{Dims, MerlTable};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const TRUTH: &str = r#"{"model":"cook-torrance","params":{"distribution":"ggx","masking":"smith-separable",
    "fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.08}}"#;
const START: &str = r#"{"model":"cook-torrance","params":{"distribution":"ggx","masking":"smith-separable","fresnel":"schlick"}}"#;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

#[path = "common/cells.rs"]
mod cells;
use cells::write_cells;
#[path = "common/cpu.rs"]
mod cpu;
use cpu::cpu_seconds;

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The venv's python, creating the venv and installing the pinned requirements when
/// missing.
fn python() -> Option<PathBuf> {
    let root = workspace();
    let py = root.join(".venv/bin/python");
    let ok = |py: &Path| {
        Command::new(py)
            .args(["-c", "import numpy, scipy"])
            .status()
            .map(|s| s.success())
            .unwrap_or(false)
    };
    if py.exists() && ok(&py) {
        return Some(py);
    }
    eprintln!("setting up .venv with benches/peers/requirements.txt ...");
    if !py.exists() {
        let s = Command::new("python3")
            .args(["-m", "venv", ".venv"])
            .current_dir(&root)
            .status()
            .ok()?;
        if !s.success() {
            return None;
        }
    }
    let s = Command::new(root.join(".venv/bin/pip"))
        .args(["install", "-q", "-r", "benches/peers/requirements.txt"])
        .current_dir(&root)
        .status()
        .ok()?;
    (s.success() && ok(&py)).then_some(py)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let no_python = args.iter().any(|a| a == "--no-python");
    let quick = args.iter().any(|a| a == "--quick");
    let runs: usize = args
        .iter()
        .position(|a| a == "--runs")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);

    let truth = brdfkit::models::from_json_str(TRUTH).expect("truth model");
    let start = brdfkit::models::from_json_str(START).expect("start model");
    let t = Instant::now();
    let table = MerlTable::from_brdf(truth.as_ref(), Dims::MERL).expect("table");
    let t_table = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let data = FitData::from_table(&table).expect("cells");
    let t_cells = t.elapsed().as_secs_f64();
    println!(
        "table 90x90x180 from the model: {:.3} s; valid cells {} ({:.1} %); cells prepared in {:.3} s",
        t_table,
        data.len(),
        100.0 * table.valid_fraction(),
        t_cells
    );
    println!("threads: {}", rayon::current_num_threads());

    let variants: Vec<(&str, f64)> = if quick {
        vec![("noise-free", 0.0)]
    } else if args.iter().any(|a| a == "--noisy") {
        vec![("5 % log-normal noise", 0.05)]
    } else {
        vec![("noise-free", 0.0), ("5 % log-normal noise", 0.05)]
    };
    let py = if no_python { None } else { python() };
    if !no_python && py.is_none() {
        println!("python peer skipped: no python3 venv with numpy + scipy could be set up");
    }
    // Every Rust timing first, then the peers: on this VM a multi-GB Python run slows
    // the next few seconds of anything else (measured: the noisy fit took 0.68 s right
    // after the peer, 0.32 s otherwise, at the same CPU time).
    let mut done = Vec::new();
    for (label, sigma) in variants {
        let mut data = data.clone();
        if sigma > 0.0 {
            brdfkit::fit::synth::add_lognormal_noise(&mut data, sigma, 2026);
        }
        println!("--- {label}: rust ---");
        let r = run_variant(&data, start.as_ref(), runs);
        done.push((label, data, r));
    }
    if let Some(py) = py {
        for (label, data, r) in &done {
            println!("--- {label}: python peer ---");
            peer(data, start.as_ref(), r, &py);
        }
    }
}

/// What the peer comparison needs from the Rust runs.
struct RustRun {
    wall: f64,
    cpu: f64,
    loss: f64,
}

fn run_variant(data: &FitData, start: &dyn Model, runs: usize) -> RustRun {
    let cfg = FitConfig::default();
    let mut times = Vec::new();
    let mut cpus = Vec::new();
    let mut last = None;
    for _ in 0..runs.max(1) {
        let c0 = cpu_seconds();
        let t = Instant::now();
        let res = fit(start, data, &cfg, None).expect("fit");
        times.push(t.elapsed().as_secs_f64());
        if let (Some(a), Some(b)) = (c0, cpu_seconds()) {
            cpus.push(b - a);
        }
        last = Some(res);
    }
    let res = last.expect("at least one run");
    let r = &res.record;
    let t_rust = median(&mut times.clone());
    let best = times.iter().copied().fold(f64::INFINITY, f64::min);
    let w = r.starts[0].warm_up.as_ref();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    if !cpus.is_empty() {
        println!(
            "      CPU time (all threads) median {:.3} s: alone on the 2 cores the wall time is between {:.3} s (perfectly parallel) and {:.3} s (serial); load average {}",
            median(&mut cpus.clone()),
            median(&mut cpus.clone()) / 2.0,
            median(&mut cpus.clone()),
            load.split_whitespace()
                .take(3)
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    println!(
        "rust  (brdfkit-fit, LM, cbrt, 1 start, default config): median {:.3} s, min {:.3} s over {} runs",
        t_rust,
        best,
        times.len()
    );
    if let Some(w) = w {
        println!(
            "      warm-up on {} cells: {} iterations, {} cost + {} Jacobian passes",
            w.cells, w.iterations, w.cost_evals, w.jacobian_evals
        );
    }
    println!(
        "      full table ({} cells): {} iterations, {} cost + {} Jacobian passes; {}",
        r.cells_fit, r.iterations, r.cost_evals, r.jacobian_evals, r.termination
    );
    println!(
        "      final cbrt loss {:.6e} (per channel {:.3e} {:.3e} {:.3e}); alpha {:.6}",
        r.losses_full.cbrt.overall,
        r.losses_full.cbrt.channels[0],
        r.losses_full.cbrt.channels[1],
        r.losses_full.cbrt.channels[2],
        res.fitted.channel_model(0).params()[6]
    );
    let cfg_cold = FitConfig::default().warm_up(None).expect("valid");
    let t = Instant::now();
    let cold = fit(start, data, &cfg_cold, None).expect("fit");
    println!(
        "rust  without warm-up: {:.3} s, {} iterations, {} cost + {} Jacobian passes, cbrt loss {:.6e}",
        t.elapsed().as_secs_f64(),
        cold.record.iterations,
        cold.record.cost_evals,
        cold.record.jacobian_evals,
        cold.record.losses_full.cbrt.overall
    );
    RustRun {
        wall: t_rust,
        cpu: if cpus.is_empty() {
            f64::NAN
        } else {
            median(&mut cpus.clone())
        },
        loss: r.losses_full.cbrt.overall,
    }
}

fn peer(data: &FitData, start: &dyn Model, rust: &RustRun, py: &Path) {
    let weighting = FitConfig::default().get_weighting();
    let (t_rust, rust_cpu) = (rust.wall, rust.cpu);
    let dir = tempfile::tempdir().expect("temp dir");
    let cells = dir.path().join("cells.bin");
    write_cells(data, &cells).expect("write cells");
    let out = Command::new(py)
        .arg(workspace().join("benches/peers/fit_scipy.py"))
        .arg(&cells)
        .output()
        .expect("run the python peer");
    if !out.status.success() {
        println!(
            "python peer failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        return;
    }
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("peer JSON");
    let t_py = v["time_s"].as_f64().expect("time_s");
    let p: Vec<f64> = v["params"]
        .as_array()
        .expect("params")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect();
    // The peer's loss recomputed by the Rust loss code (a check that both sides
    // minimise the same thing).
    let mut m = start.clone_box();
    let py_loss_rust = match m.set_params(&p) {
        Ok(()) => {
            let mm: &dyn Model = m.as_ref();
            evaluate_losses([mm, mm, mm], data, weighting).cbrt.overall
        }
        Err(e) => {
            println!("peer parameters rejected by the model: {e}");
            f64::NAN
        }
    };
    println!(
        "python (numpy {}, scipy {} least_squares trf, 2-point Jacobian): {:.3} s; nfev {}, njev {}; status {} ({})",
        v["numpy"].as_str().unwrap_or("?"),
        v["scipy"].as_str().unwrap_or("?"),
        t_py,
        v["nfev"],
        v["njev"],
        v["status"],
        v["message"].as_str().unwrap_or("")
    );
    println!(
        "python final cbrt loss {:.6e} (its own), {:.6e} (recomputed in Rust); alpha {:.6}",
        v["loss_cbrt"].as_f64().unwrap_or(f64::NAN),
        py_loss_rust,
        p.get(6).copied().unwrap_or(f64::NAN)
    );
    let py_cpu = v["cpu_s"].as_f64().unwrap_or(f64::NAN);
    println!(
        "python CPU time {:.3} s; CPU-time ratio python / rust: {:.1}x",
        py_cpu,
        py_cpu / rust_cpu
    );
    let lr = rust.loss;
    let rel = (lr - py_loss_rust) / py_loss_rust;
    println!(
        "ratio python / rust (median wall): {:.1}x; losses rust {:.9e} vs python {:.9e}: relative difference {:+.2e} ({})",
        t_py / t_rust,
        lr,
        py_loss_rust,
        rel,
        if lr <= py_loss_rust {
            "rust lower or equal"
        } else if rel <= 1e-9 {
            "equal to 1e-9"
        } else {
            "rust higher"
        }
    );
}
