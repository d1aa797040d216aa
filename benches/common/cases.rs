//! The interleaved case runner of the `raw` and `lookup` benches: every case once per
//! round, rounds after a warm-up, medians and minima of wall and CPU time.

use std::time::Instant;

/// A named case: one run of the work timed.
pub type Case<'a> = (&'static str, Box<dyn FnMut() + 'a>);

/// CPU time of all this process's threads in seconds (0 where /proc is missing), from
/// `/proc/self/task/*/schedstat` (nanoseconds; on this VM it advances in steps of about
/// 4 ms, so only medians over many runs mean anything).
pub fn task_cpu_seconds() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    let ns: u64 = tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum();
    ns as f64 * 1e-9
}

/// The options both benches take: `--reps N` rounds (default 21), `--threads N` (a
/// pool of N threads; default the global pool's size), `--only K` (case K alone,
/// counted from 0, for profiling one of them).
pub struct Opts {
    pub reps: usize,
    pub only: Option<usize>,
}

/// Parses the options and runs `run` on the pool they ask for.
pub fn main_with(run: impl FnOnce(&Opts) + Send) {
    let args: Vec<String> = std::env::args().collect();
    let opt = |name: &str| -> Option<usize> {
        let i = args.iter().position(|a| a == name)?;
        args.get(i + 1)?.parse().ok()
    };
    let opts = Opts {
        reps: opt("--reps").unwrap_or(21),
        only: opt("--only"),
    };
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = opt("--threads") {
        pool = pool.num_threads(t);
    }
    let pool = pool.build().expect("a rayon pool");
    pool.install(|| run(&opts));
}

/// Runs every case once per round, `reps` rounds after one warm-up round (the cases
/// interleaved, so that a change of load hits all alike), then prints `title` with the
/// load average and, per case, the median and minimum of its wall and CPU times.
pub fn time_cases(title: &str, cases: Vec<Case>, opts: &Opts) {
    let reps = opts.reps;
    let mut cases: Vec<Case> = match opts.only {
        Some(k) => cases.into_iter().skip(k).take(1).collect(),
        None => cases,
    };
    let mut times: Vec<[Vec<f64>; 2]> = vec![[Vec::new(), Vec::new()]; cases.len()];
    for rep in 0..=reps {
        for (k, (_, f)) in cases.iter_mut().enumerate() {
            let (t, c) = (Instant::now(), task_cpu_seconds());
            f();
            let (dt, dc) = (t.elapsed().as_secs_f64(), task_cpu_seconds() - c);
            if rep > 0 {
                times[k][0].push(dt);
                times[k][1].push(dc);
            }
        }
    }
    println!(
        "{title}, {reps} reps, load {}",
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    );
    println!(
        "{:<44} {:>20} {:>20}",
        "", "wall median (min)", "CPU median (min)"
    );
    for ((name, _), t) in cases.iter().zip(&mut times) {
        let [w, c] = t.each_mut().map(|t| {
            t.sort_by(|a, b| a.total_cmp(b));
            format!("{:.3} ({:.3}) ms", t[t.len() / 2] * 1e3, t[0] * 1e3)
        });
        println!("{name:<44} {w:>20} {c:>20}");
    }
}
