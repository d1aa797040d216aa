//! A/B timing interleaved on one machine state: the benches that compare reading a MERL
//! table with `cat` of the same file (benches/merl.rs, benches/peers.rs).

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
