//! A/B timing interleaved on one machine state: the benches that compare reading a MERL
//! table with `cat` of the same file (benches/merl.rs, benches/peers.rs).

use brdfkit::merl::MerlTable;
use std::hint::black_box;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

/// `cat FILE > /dev/null`: the floor a table read is held against (the same bytes
/// through the page cache, no parsing).
pub fn cat(path: &Path) {
    let status = Command::new("cat")
        .arg(path)
        .stdout(Stdio::null())
        .status()
        .expect("spawn cat");
    assert!(status.success());
}

/// `n` interleaved pairs ([`interleaved`]) of the seconds `MerlTable::read` of the
/// table at `path` takes and of the seconds [`cat`] of it takes.
pub fn read_vs_cat(path: &Path, n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let time = |f: &dyn Fn()| {
        let t = Instant::now();
        f();
        t.elapsed().as_secs_f64()
    };
    let read = || {
        black_box(MerlTable::read(path).unwrap());
    };
    interleaved(n, || time(&read), || time(&|| cat(path)))
}

/// `n` pairs of timings of `a` and `b` (seconds), the order alternating so neither side
/// always runs on a cache or page state the other left: `a`'s, `b`'s and the ratios a/b,
/// each sorted ascending.
pub fn interleaved(
    n: usize,
    a: impl Fn() -> f64,
    b: impl Fn() -> f64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut ta, mut tb, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let (x, y) = if i % 2 == 0 {
            let x = a();
            (x, b())
        } else {
            let y = b();
            (a(), y)
        };
        ta.push(x);
        tb.push(y);
        ratios.push(x / y);
    }
    for v in [&mut ta, &mut tb, &mut ratios] {
        v.sort_by(f64::total_cmp);
    }
    (ta, tb, ratios)
}
