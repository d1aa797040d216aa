//! Times `RglBsdf::eval_flat` (the f32 batch kernel) alone (no process start, no file I/O) over the pairs of an
//! N × 6 little-endian f64 `.npy` file: the in-process figure beside the whole-process
//! `fit-brdf eval --bsdf` of benches/peers/rgl (docs/rgl.md, "Speed").
//!
//!   cargo run --release -p brdfkit-rgl --example eval_flat -- FILE.bsdf PAIRS.npy [REPS]
use brdfkit_rgl::RglBsdf;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let bsdf = RglBsdf::read(args[1].as_ref()).expect("a .bsdf file");
    let bytes = std::fs::read(&args[2]).expect("a .npy file");
    // The .npy header ends at the first newline after the magic (a v1 header).
    let start = bytes
        .iter()
        .position(|&b| b == b'\n')
        .expect("a .npy header")
        + 1;
    let dirs: Vec<f64> = bytes[start..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    let reps: usize = args.get(3).map_or(5, |r| r.parse().expect("a count"));
    let mut out = vec![0.0; dirs.len() / 2];
    let mut walls = Vec::with_capacity(reps);
    let cpu0 = cpu_seconds();
    for _ in 0..reps {
        let t = Instant::now();
        bsdf.eval_flat(&dirs, &mut out);
        walls.push(t.elapsed().as_secs_f64());
    }
    let cpu = (cpu_seconds() - cpu0) / reps as f64;
    // The first call also rearranges the tables for the kernel (once per file).
    let first = walls[0];
    walls.sort_by(f64::total_cmp);
    let (best, median) = (walls[0], walls[walls.len() / 2]);
    let sum: f64 = out.iter().sum();
    println!(
        "{} pairs: best of {reps} {best:.4} s wall, median {median:.4} s wall, mean {cpu:.4} s CPU ({:.1} ns CPU a pair), checksum {sum:.6}, first call {first:.4} s wall",
        dirs.len() / 6,
        1e9 * cpu / (dirs.len() / 6) as f64
    );
}

/// The process's user + system CPU time (all threads), from /proc/self/stat.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after
        .split_whitespace()
        .filter_map(|x| x.parse().ok())
        .collect();
    // Fields 14 and 15 (utime, stime) in clock ticks: 11 and 12 after the state field.
    f.get(10..12).map_or(f64::NAN, |t| (t[0] + t[1]) / 100.0)
}
