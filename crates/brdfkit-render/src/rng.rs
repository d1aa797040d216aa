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
        let n = 100_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let u = g.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u;
        }
        // Standard error of the mean: sqrt(1/12 / n) = 9.1e-4.
        assert!((sum / n as f64 - 0.5).abs() < 5e-3);
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
