//! An RGB triple of f64, the value type of every BRDF in brdfkit.

use serde::{Deserialize, Serialize};
use std::ops::{Add, AddAssign, Div, Index, IndexMut, Mul, MulAssign, Sub};

/// Three channels (R, G, B) of f64. Serialised as a JSON array `[r, g, b]`.
///
/// Its methods and operators are `#[inline]`: each is a line of per-channel arithmetic,
/// and a batch loop in another crate (a model's) vectorises only when they inline into it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(from = "[f64; 3]", into = "[f64; 3]")]
pub struct Rgb(pub [f64; 3]);

impl Rgb {
    /// All channels zero.
    pub const ZERO: Rgb = Rgb([0.0; 3]);

    /// From the three channels.
    #[inline]
    pub const fn new(r: f64, g: f64, b: f64) -> Self {
        Rgb([r, g, b])
    }

    /// The same value in every channel.
    #[inline]
    pub const fn splat(v: f64) -> Self {
        Rgb([v; 3])
    }

    /// Red channel.
    #[inline]
    pub fn r(&self) -> f64 {
        self.0[0]
    }

    /// Green channel.
    #[inline]
    pub fn g(&self) -> f64 {
        self.0[1]
    }

    /// Blue channel.
    #[inline]
    pub fn b(&self) -> f64 {
        self.0[2]
    }

    /// Applies `f` to every channel.
    #[inline]
    pub fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Rgb([f(self.0[0]), f(self.0[1]), f(self.0[2])])
    }

    /// Combines two triples channel by channel.
    #[inline]
    pub fn zip(self, o: Rgb, f: impl Fn(f64, f64) -> f64) -> Self {
        Rgb([
            f(self.0[0], o.0[0]),
            f(self.0[1], o.0[1]),
            f(self.0[2], o.0[2]),
        ])
    }

    /// Largest channel.
    #[inline]
    pub fn max_channel(&self) -> f64 {
        self.0[0].max(self.0[1]).max(self.0[2])
    }

    /// Smallest channel.
    #[inline]
    pub fn min_channel(&self) -> f64 {
        self.0[0].min(self.0[1]).min(self.0[2])
    }

    /// Mean of the channels.
    #[inline]
    pub fn mean(&self) -> f64 {
        (self.0[0] + self.0[1] + self.0[2]) / 3.0
    }

    /// True when every channel is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }
}

impl From<[f64; 3]> for Rgb {
    #[inline]
    fn from(a: [f64; 3]) -> Self {
        Rgb(a)
    }
}

impl From<Rgb> for [f64; 3] {
    #[inline]
    fn from(c: Rgb) -> Self {
        c.0
    }
}

impl Index<usize> for Rgb {
    type Output = f64;
    #[inline]
    fn index(&self, i: usize) -> &f64 {
        &self.0[i]
    }
}

impl IndexMut<usize> for Rgb {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut f64 {
        &mut self.0[i]
    }
}

impl Add for Rgb {
    type Output = Rgb;
    #[inline]
    fn add(self, o: Rgb) -> Rgb {
        self.zip(o, |a, b| a + b)
    }
}

impl AddAssign for Rgb {
    #[inline]
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}

impl Sub for Rgb {
    type Output = Rgb;
    #[inline]
    fn sub(self, o: Rgb) -> Rgb {
        self.zip(o, |a, b| a - b)
    }
}

impl Mul for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, o: Rgb) -> Rgb {
        self.zip(o, |a, b| a * b)
    }
}

impl Mul<f64> for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, s: f64) -> Rgb {
        self.map(|a| a * s)
    }
}

impl Mul<Rgb> for f64 {
    type Output = Rgb;
    #[inline]
    fn mul(self, c: Rgb) -> Rgb {
        c * self
    }
}

impl MulAssign<f64> for Rgb {
    #[inline]
    fn mul_assign(&mut self, s: f64) {
        *self = *self * s;
    }
}

impl Div<f64> for Rgb {
    type Output = Rgb;
    #[inline]
    fn div(self, s: f64) -> Rgb {
        self.map(|a| a / s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_is_per_channel() {
        let a = Rgb::new(1.0, 2.0, 3.0);
        let b = Rgb::new(0.5, 0.25, 2.0);
        assert_eq!(a + b, Rgb::new(1.5, 2.25, 5.0));
        assert_eq!(a - b, Rgb::new(0.5, 1.75, 1.0));
        assert_eq!(a * b, Rgb::new(0.5, 0.5, 6.0));
        assert_eq!(2.0 * a, Rgb::new(2.0, 4.0, 6.0));
        assert_eq!(a / 2.0, Rgb::new(0.5, 1.0, 1.5));
        assert_eq!(a.max_channel(), 3.0);
        assert_eq!(a.min_channel(), 1.0);
        assert_eq!(a.mean(), 2.0);
    }

    #[test]
    fn serialises_as_a_triple() {
        let a = Rgb::new(0.1, 0.2, 0.3);
        let s = serde_json::to_string(&a).unwrap();
        assert_eq!(s, "[0.1,0.2,0.3]");
        let back: Rgb = serde_json::from_str(&s).unwrap();
        assert_eq!(back, a);
        assert!(serde_json::from_str::<Rgb>("[1, 2]").is_err());
    }
}
