//! Smooth reparameterisation of bounded parameters.
//!
//! The solvers work on an unconstrained vector u ∈ ℝᵐ; each free model parameter x is a
//! smooth, strictly monotone function of its u, chosen from the parameter's
//! [`Domain`]:
//!
//! | domain            | transform  | x(u)                          | dx/du             |
//! |-------------------|------------|-------------------------------|-------------------|
//! | (−∞, ∞)           | asinh      | sinh u                        | cosh u            |
//! | [lo, ∞), (lo, ∞)  | log        | lo + eᵘ                       | x − lo            |
//! | (−∞, hi], (−∞, hi)| neg-log    | hi − eᵘ                       | hi − x            |
//! | [lo, hi], (lo, hi)| logit      | lo + (hi − lo) σ(u)           | (hi − lo) σ (1 − σ) |
//!
//! with σ(u) = 1 / (1 + e⁻ᵘ). Albedo-like parameters (ρd, ρs, Schlick f0) live in
//! [0, 1] and take the logit; roughness, exponents and σ live on (0, ∞) (or a bounded
//! interval) and take the log (or the logit). The log makes a relative change the unit
//! of a step, which is what an exponent spanning 1 … 10⁴ needs; the logit keeps an
//! albedo inside [0, 1] without a hard clamp that would stall a Newton step.
//!
//! A closed end (ρs = 0) is reached only in the limit u → −∞; a fit whose optimum sits
//! on the end converges towards it (with dx/du → 0) and stops on the step or
//! gradient tolerance with x within round-off of the end.
//!
//! A real parameter takes x = sinh u rather than x = u: near 0 it is the identity to
//! first order (sinh u = u + u³/6 + …), far out a step of u is a relative change of x,
//! as for the log. That matters where the optimum lies at infinity: Lafortune's lobe
//! ρ · max(0, cxy pxy + pz)ⁿ tends, as cxy → ±∞ with ρ |cxy|ⁿ held, to
//! ρ|cxy|ⁿ · max(0, ±pxy)ⁿ, a lobe no finite cxy gives. With x = u the fit crept there
//! 3 units a step ([`crate::lm::MAX_STEP`]) until |u| reached [`U_MAX`] and ended on
//! the iteration limit; with sinh it gets there in a few steps, |u| > [`U_ACTIVE`]
//! counts as that end of the real line (the record's `at_bound`), and the ftol rules
//! stop it once the lobe has reached its limit shape to round-off.

use brdfkit_core::model::Domain;
use serde::{Deserialize, Serialize};

/// |u| is kept below this: e^700 ≈ 1e304 is still finite, e^710 is not. A step that
/// wants to go further is already at a domain end to the last bit (σ(±37) is 0 or 1 to
/// round-off; lo + e^700 is beyond any physical parameter).
pub const U_MAX: f64 = 700.0;

/// |u| beyond which a parameter counts as at the end of its domain in the record
/// ([`crate::ParamRecord::at_bound`]): e^-20 ≈ 2e-9 of a bounded interval (or
/// absolutely on a half-line) from the end. A fit reaches it only when the data pull the
/// parameter onto the end: a transform's slope there is ≈ 2e-9, so an interior optimum
/// is never that far out.
pub const U_ACTIVE: f64 = 20.0;

/// Fraction of a bounded interval (or absolute offset for a half-line) by which a start
/// value sitting exactly on a domain end is moved inside, where u is finite.
pub const END_OFFSET: f64 = 1e-6;

/// The transform of one parameter; see the module doc.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Transform {
    /// x = sinh u (a real parameter; see the module doc).
    Asinh,
    /// x = lo + eᵘ.
    Log {
        /// Lower bound.
        lo: f64,
    },
    /// x = hi − eᵘ.
    NegLog {
        /// Upper bound.
        hi: f64,
    },
    /// x = lo + (hi − lo) σ(u).
    Logit {
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
}

/// σ(u) = 1/(1 + e⁻ᵘ), evaluated without overflow for either sign.
#[inline]
fn sigmoid(u: f64) -> f64 {
    if u >= 0.0 {
        1.0 / (1.0 + (-u).exp())
    } else {
        let e = u.exp();
        e / (1.0 + e)
    }
}

impl Transform {
    /// The transform for a domain.
    pub fn for_domain(d: &Domain) -> Transform {
        match (d.lo.is_finite(), d.hi.is_finite()) {
            (false, false) => Transform::Asinh,
            (true, false) => Transform::Log { lo: d.lo },
            (false, true) => Transform::NegLog { hi: d.hi },
            (true, true) => Transform::Logit { lo: d.lo, hi: d.hi },
        }
    }

    /// Short name for records and docs.
    pub fn name(&self) -> &'static str {
        match self {
            Transform::Asinh => "asinh",
            Transform::Log { .. } => "log",
            Transform::NegLog { .. } => "neg-log",
            Transform::Logit { .. } => "logit",
        }
    }

    /// Which end of the domain u sits at, if |u| is past [`U_ACTIVE`] on a side the
    /// domain bounds: `Some("lower")`, `Some("upper")` or `None`.
    pub fn end_at(&self, u: f64) -> Option<&'static str> {
        match *self {
            Transform::Log { .. } => (u < -U_ACTIVE).then_some("lower"),
            Transform::NegLog { .. } => (u < -U_ACTIVE).then_some("upper"),
            Transform::Logit { .. } | Transform::Asinh => {
                if u < -U_ACTIVE {
                    Some("lower")
                } else if u > U_ACTIVE {
                    Some("upper")
                } else {
                    None
                }
            }
        }
    }

    /// x(u) and dx/du. `u` is clamped into [−U_MAX, U_MAX] (see [`U_MAX`]).
    #[inline]
    pub fn forward(&self, u: f64) -> (f64, f64) {
        let u = u.clamp(-U_MAX, U_MAX);
        match *self {
            // sinh 700 ≈ 5e303 and cosh 700 are finite.
            Transform::Asinh => (u.sinh(), u.cosh()),
            Transform::Log { lo } => {
                let e = u.exp();
                (lo + e, e)
            }
            Transform::NegLog { hi } => {
                let e = u.exp();
                (hi - e, -e)
            }
            Transform::Logit { lo, hi } => {
                let s = sigmoid(u);
                // σ(1 − σ) written as e^-|u| / (1 + e^-|u|)²: no cancellation in 1 − σ.
                let e = (-u.abs()).exp();
                let ds = e / ((1.0 + e) * (1.0 + e));
                (lo + (hi - lo) * s, (hi - lo) * ds)
            }
        }
    }

    /// u(x) for a start value. A value on a domain end (where u would be infinite) is
    /// first moved inside by [`END_OFFSET`] of the interval (bounded) or absolutely
    /// (half-line); values outside the domain are the caller's error (checked before).
    pub fn inverse(&self, x: f64) -> f64 {
        let u = match *self {
            Transform::Asinh => x.asinh(),
            Transform::Log { lo } => (x - lo).max(END_OFFSET).ln(),
            Transform::NegLog { hi } => (hi - x).max(END_OFFSET).ln(),
            Transform::Logit { lo, hi } => {
                let w = hi - lo;
                let t = ((x - lo) / w).clamp(END_OFFSET, 1.0 - END_OFFSET);
                (t / (1.0 - t)).ln()
            }
        };
        u.clamp(-U_MAX, U_MAX)
    }
}

/// Moves `x` onto the nearest value inside `d` when round-off of a transform put it on
/// an open end (e.g. lo + e^-700 = lo for lo ≠ 0, or σ(37) = 1 exactly with an open
/// upper end). The move is at most a few ulps; it keeps `set_params` from rejecting a
/// value the transform meant to be interior.
pub fn nudge_into(d: &Domain, x: f64) -> f64 {
    if d.contains(x) || !x.is_finite() {
        return x;
    }
    let mut y = x;
    for _ in 0..64 {
        if y <= d.lo {
            y = next_up(y.max(d.lo));
        } else if y >= d.hi {
            y = next_down(y.min(d.hi));
        }
        if d.contains(y) {
            return y;
        }
    }
    x
}

fn next_up(x: f64) -> f64 {
    if x == 0.0 {
        return f64::from_bits(1);
    }
    let b = x.to_bits();
    f64::from_bits(if x > 0.0 { b + 1 } else { b - 1 })
}

fn next_down(x: f64) -> f64 {
    -next_up(-x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transforms_round_trip_and_differentiate() {
        let cases = [
            Transform::Asinh,
            Transform::Log { lo: 0.0 },
            Transform::Log { lo: 1.0 },
            Transform::NegLog { hi: 2.0 },
            Transform::Logit { lo: 0.0, hi: 1.0 },
            Transform::Logit { lo: -1.0, hi: 3.0 },
        ];
        for t in cases {
            for &u in &[-5.0, -0.3, 0.0, 0.7, 4.0] {
                let (x, dx) = t.forward(u);
                assert!((t.inverse(x) - u).abs() < 1e-9, "{t:?} {u}");
                let h = 1e-6;
                let fd = (t.forward(u + h).0 - t.forward(u - h).0) / (2.0 * h);
                assert!(
                    (fd - dx).abs() <= 1e-7 * dx.abs().max(1.0),
                    "{t:?} {u}: {fd} vs {dx}"
                );
            }
        }
    }

    #[test]
    fn extreme_u_stays_finite_and_in_domain() {
        let d = Domain::open(0.0, 1.0);
        let t = Transform::for_domain(&d);
        for &u in &[-1e308, -800.0, -40.0, 40.0, 800.0, f64::MAX] {
            let (x, dx) = t.forward(u);
            assert!(x.is_finite() && dx.is_finite() && dx >= 0.0);
            let y = nudge_into(&d, x);
            assert!(d.contains(y), "{u} -> {x} -> {y}");
        }
        let h = Domain::above(1.0);
        let (x, _) = Transform::for_domain(&h).forward(-U_MAX);
        assert_eq!(x, 1.0, "1 + e^-700 rounds to 1");
        assert!(h.contains(nudge_into(&h, x)));
    }

    #[test]
    fn a_real_parameter_far_out_is_at_an_end_of_the_line() {
        let t = Transform::for_domain(&Domain::real());
        assert_eq!(t, Transform::Asinh);
        assert_eq!(t.end_at(-(U_ACTIVE + 1.0)), Some("lower"));
        assert_eq!(t.end_at(U_ACTIVE + 1.0), Some("upper"));
        assert_eq!(t.end_at(5.0), None);
        // Near 0 a step of u is a step of x; far out, a relative change of x.
        let (x, dx) = t.forward(1e-3);
        assert!((x - 1e-3).abs() < 1e-9 && (dx - 1.0).abs() < 1e-6);
        let (x, dx) = t.forward(30.0);
        assert!((dx / x - 1.0).abs() < 1e-12);
        let (x, dx) = t.forward(U_MAX);
        assert!(x.is_finite() && dx.is_finite());
    }

    #[test]
    fn start_on_an_end_moves_inside() {
        let t = Transform::for_domain(&Domain::closed(0.0, 1.0));
        let u = t.inverse(0.0);
        assert!(u.is_finite());
        assert!((t.forward(u).0 - 1e-6).abs() < 1e-12);
        assert!(t.inverse(1.0).is_finite());
    }
}
