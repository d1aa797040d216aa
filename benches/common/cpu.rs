//! Process CPU time for the benches that report it beside wall time (`fit`, `peers`).

/// CPU time (user + system, all threads) of this process in seconds, from
/// `/proc/self/stat` (clock ticks of 1/100 s). On a machine shared with other jobs the
/// wall time stretches while the CPU time stays near what the work needs; CPU time / 2
/// is then the wall time it would take alone on the 2 cores.
pub fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14, 15.
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ut: f64 = f.get(11)?.parse().ok()?;
    let st: f64 = f.get(12)?.parse().ok()?;
    Some((ut + st) / 100.0)
}
