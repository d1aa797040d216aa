//! Pieces shared by every report: the verdict of a check, a located direction pair, and
//! the helpers of the text rendering.

use brdfkit_core::Vec3;
use brdfkit_core::direction::to_spherical;
use serde::{Deserialize, Serialize};
use std::fmt;

/// The outcome of one check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Verdict {
    /// The measured figure is within the threshold.
    Pass,
    /// The measured figure exceeds the threshold.
    Fail,
    /// The figure could not be established to the accuracy the threshold needs (the
    /// albedo quadrature did not converge): neither a pass nor a proven failure.
    Inconclusive,
}

impl Verdict {
    /// Pass when `ok`, fail otherwise.
    pub fn from_bool(ok: bool) -> Self {
        if ok { Verdict::Pass } else { Verdict::Fail }
    }

    /// True for [`Verdict::Pass`].
    pub fn passed(self) -> bool {
        self == Verdict::Pass
    }

    /// The energy check's verdict from the largest directional albedo `max` found
    /// (`None`: none was), the quadrature's convergence estimate `conv`, and the
    /// thresholds (albedo ≤ 1 + `energy`, convergence ≤ `convergence`): with a converged
    /// quadrature, pass or fail on the bound; otherwise a fail only when even
    /// max − conv exceeds it (the excess is beyond the quadrature's error), else
    /// inconclusive.
    pub fn of_energy(max: Option<f64>, conv: f64, energy: f64, convergence: f64) -> Verdict {
        let bound = 1.0 + energy;
        match max {
            None => Verdict::Inconclusive,
            Some(max) if conv <= convergence => Verdict::from_bool(max <= bound),
            Some(max) if max - conv > bound => Verdict::Fail,
            Some(_) => Verdict::Inconclusive,
        }
    }

    /// `PASS`, `FAIL` or `INCONCLUSIVE`, for the text rendering.
    pub fn label(self) -> &'static str {
        match self {
            Verdict::Pass => "PASS",
            Verdict::Fail => "FAIL",
            Verdict::Inconclusive => "INCONCLUSIVE",
        }
    }
}

/// `Display` for a check report with a `to_text(&self) -> String`: its text, the one
/// way every report of this crate prints.
macro_rules! display_as_text {
    ($ty:ty) => {
        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(&self.to_text())
            }
        }
    };
}
pub(crate) use display_as_text;

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

/// A direction pair where a check found its worst case, with the value(s) found there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairAt {
    /// Incident direction (local frame, pointing away from the surface).
    pub wi: [f64; 3],
    /// Outgoing direction.
    pub wo: [f64; 3],
    /// What was found there (a value, a pair of values; see the check).
    pub values: Vec<f64>,
    /// Channel (0 = R, 1 = G, 2 = B) where the worst case was found.
    pub channel: usize,
}

impl PairAt {
    /// A located pair.
    pub fn new(wi: &Vec3, wo: &Vec3, values: Vec<f64>, channel: usize) -> Self {
        PairAt {
            wi: [wi.x, wi.y, wi.z],
            wo: [wo.x, wo.y, wo.z],
            values,
            channel,
        }
    }

    /// (θi, φi, θo, φo) in degrees, for human-facing text.
    pub fn angles_deg(&self) -> [f64; 4] {
        let (ti, pi) = to_spherical(&Vec3::from(self.wi));
        let (to, po) = to_spherical(&Vec3::from(self.wo));
        [ti, pi, to, po].map(f64::to_degrees)
    }

    /// `θi=…° φi=…° θo=…° φo=…°`.
    pub fn describe_angles(&self) -> String {
        let [ti, pi, to, po] = self.angles_deg();
        format!(
            "θi={} φi={} θo={} φo={}",
            deg(ti),
            deg(pi),
            deg(to),
            deg(po)
        )
    }

    /// `θi=…° φi=…° θo=…° φo=…° (G)`.
    pub fn describe(&self) -> String {
        format!(
            "{} ({})",
            self.describe_angles(),
            ["R", "G", "B"][self.channel.min(2)]
        )
    }
}

/// An angle in degrees with as many decimals as it needs (89.999°, 1e-6°).
pub(crate) fn deg(d: f64) -> String {
    if d == 0.0 {
        "0°".into()
    } else if d.abs() < 1e-3 {
        format!("{d:.1e}°")
    } else {
        let s = format!("{d:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        format!("{s}°")
    }
}

/// A figure in short scientific notation (`1.23e-7`), or plain for moderate magnitudes.
pub(crate) fn num(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if !x.is_finite() {
        format!("{x}")
    } else if (1e-3..1e4).contains(&x.abs()) {
        let s = format!("{x:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        // 1.500e-7 → 1.5e-7, 1.000e-9 → 1e-9.
        let s = format!("{x:.3e}");
        match s.split_once('e') {
            Some((m, e)) => {
                let m = m.trim_end_matches('0').trim_end_matches('.');
                format!("{m}e{e}")
            }
            None => s,
        }
    }
}

/// `[r, g, b]` with [`num`] entries.
pub(crate) fn rgb(c: &brdfkit_core::Rgb) -> String {
    format!("[{}, {}, {}]", num(c.r()), num(c.g()), num(c.b()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formatting() {
        assert_eq!(deg(89.9), "89.9°");
        assert_eq!(deg(45.0), "45°");
        assert_eq!(deg(0.0), "0°");
        assert_eq!(num(0.5), "0.5");
        assert_eq!(num(1.5e-7), "1.5e-7");
        assert_eq!(num(1e-9), "1e-9");
        assert_eq!(num(-2.25e5), "-2.25e5");
        assert_eq!(Verdict::from_bool(false).label(), "FAIL");
        assert_eq!(serde_json::to_string(&Verdict::Pass).unwrap(), "\"pass\"");
        let p = PairAt::new(
            &brdfkit_core::direction::spherical(0.5, 0.0),
            &Vec3::new(0.0, 0.0, 1.0),
            vec![1.0],
            1,
        );
        let [ti, _, to, _] = p.angles_deg();
        assert!((ti - 0.5f64.to_degrees()).abs() < 1e-12 && to == 0.0);
        assert!(p.describe().ends_with("(G)"));
    }
}
