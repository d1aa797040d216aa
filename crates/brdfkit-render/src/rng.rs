//! A small, seedable random number generator with one independent stream per pixel.
//!
//! PCG32 (M. E. O'Neill, "PCG: A Family of Simple Fast Space-Efficient Statistically
//! Good Algorithms for Random Number Generation", HMC-CS-2014-0905): a 64-bit LCG
//! state, output by an xorshift and a random rotation ("XSH RR"). Every pixel gets the
//! stream selected by its index and a state derived from the scene seed, so an image is
//! the same bit for bit whatever the number of threads or the order of the work.

/// PCG32, XSH RR variant.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

const MULT: u64 = 6_364_136_223_846_793_005;

/// SplitMix64 finaliser (Steele, Lea and Flood, OOPSLA 2014): decorrelates nearby seeds.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Pcg32 {
    /// The generator of stream `stream` started from `seed` (O'Neill's `pcg32_srandom`).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut g = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        g.next_u32();
        g.state = g.state.wrapping_add(seed);
        g.next_u32();
        g
    }

    /// The stream of pixel `index` for the scene seed `seed`.
    pub fn for_pixel(seed: u64, index: u64) -> Self {
        Pcg32::new(splitmix64(seed), index)
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform number in [0, 1) with 32 random bits (never exactly 1).
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        self.next_u32() as f64 * (1.0 / 4_294_967_296.0)
    }
}

/// `n` stratified points of the unit square in random order: a jittered m × m grid,
/// m = ⌊√n⌋ (one uniform point in each cell), then n − m² uniform points, shuffled
/// (Fisher-Yates) so that sample k of one 2-D dimension is uncorrelated with sample k of
/// another (pbrt-v3's `StratifiedSampler`, §7.3). Each point is marginally uniform, so
/// every estimator stays unbiased; the variance drops where the integrand is smooth.
pub fn stratified_2d(rng: &mut Pcg32, n: usize, out: &mut Vec<[f64; 2]>) {
    out.clear();
    let m = (n as f64).sqrt() as usize;
    // Guard the float square root: m² ≤ n < (m + 1)².
    let m = if m * m > n {
        m - 1
    } else if (m + 1) * (m + 1) <= n {
        m + 1
    } else {
        m
    };
    let inv = 1.0 / m as f64;
    for j in 0..m {
        for i in 0..m {
            out.push([
                (i as f64 + rng.uniform()) * inv,
                (j as f64 + rng.uniform()) * inv,
            ]);
        }
    }
    while out.len() < n {
        out.push([rng.uniform(), rng.uniform()]);
    }
    for k in (1..n).rev() {
        let r = ((rng.next_u32() as u64 * (k as u64 + 1)) >> 32) as usize;
        out.swap(k, r);
    }
}

/// The mean of `n` draws and its standard error √((E[x²] − mean²)/n): the Monte Carlo
/// estimate the sampling tests compare with a closed form.
#[cfg(test)]
pub(crate) fn sample_mean(n: usize, mut draw: impl FnMut() -> f64) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let v = draw();
        sum += v;
        sum2 += v * v;
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean) / n as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_reference_sequence() {
        // pcg32-demo of the PCG reference implementation: srandom(42, 54) gives
        // 0xa15c02b7 0x7b47f409 0xba1d3330 0x83d2f293 0xbfa4784b 0xcbed606e.
        let mut g = Pcg32::new(42, 54);
        let got: Vec<u32> = (0..6).map(|_| g.next_u32()).collect();
        assert_eq!(
            got,
            vec![
                0xa15c02b7, 0x7b47f409, 0xba1d3330, 0x83d2f293, 0xbfa4784b, 0xcbed606e
            ]
        );
    }

    #[test]
    fn uniform_is_in_unit_interval_with_the_right_mean() {
        let mut g = Pcg32::for_pixel(7, 3);
        let (mean, _) = sample_mean(100_000, || {
            let u = g.uniform();
            assert!((0.0..1.0).contains(&u));
            u
        });
        // Standard error of the mean: sqrt(1/12 / n) = 9.1e-4.
        assert!((mean - 0.5).abs() < 5e-3);
    }

    #[test]
    fn stratified_points_fill_every_cell_once() {
        let mut g = Pcg32::new(1, 2);
        let mut pts = Vec::new();
        for n in [1, 2, 16, 17, 256] {
            stratified_2d(&mut g, n, &mut pts);
            assert_eq!(pts.len(), n);
            let m = (n as f64).sqrt().floor() as usize;
            let mut seen = vec![0; m * m];
            for p in &pts {
                assert!((0.0..1.0).contains(&p[0]) && (0.0..1.0).contains(&p[1]));
                seen[(p[1] * m as f64) as usize * m + (p[0] * m as f64) as usize] += 1;
            }
            // Every cell holds at least its own point (extra uniform points may add).
            assert!(seen.iter().all(|&c| c >= 1), "n = {n}: {seen:?}");
        }
    }

    #[test]
    fn pixel_streams_differ() {
        let a: Vec<u32> = {
            let mut g = Pcg32::for_pixel(1, 0);
            (0..4).map(|_| g.next_u32()).collect()
        };
        let b: Vec<u32> = {
            let mut g = Pcg32::for_pixel(1, 1);
            (0..4).map(|_| g.next_u32()).collect()
        };
        assert_ne!(a, b);
    }
}
