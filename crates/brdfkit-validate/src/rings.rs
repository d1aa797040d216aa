//! The directional albedo of [`brdfkit_core::quadrature::directional_albedo`], with the
//! integrand evaluated a ring of nodes at a time instead of a node at a time.
//!
//! The report integrates every model's albedo at a dozen directions, two rules and up to
//! three poles each, and the table's at ten: some 10⁵–10⁶ evaluations per integral, one
//! `Brdf::eval` (a model's scalar path, or a table's interpolated lookup) each, which
//! were most of the report's time. Every node of a ring (a fixed angle u from the pole)
//! is known before any is evaluated, so a ring goes to a batch path at once: a model's
//! [`Model::eval_batch`] (its vectorised lane kernels), a table's
//! [`MerlTable::lookup_batch`] (the lookups' table reads overlapped). Both give the bits
//! of the pair paths, and the sums below are the core function's sums in its order, so
//! the albedo is [`directional_albedo`](brdfkit_core::quadrature::directional_albedo)'s
//! to the bit (the tests compare them).

use brdfkit_core::quadrature::{AlbedoQuadrature, Pole, frame_around, gauss_legendre};
use brdfkit_core::{GeometryBatch, Model, Rgb, Vec3};
use brdfkit_merl::{Lookup, MerlTable};
use std::collections::HashMap;
use std::f64::consts::PI;
use std::ops::{AddAssign, Mul};
use std::sync::{Arc, Mutex, OnceLock};

/// What a node contributes: a value that adds and scales like the core function's
/// `Rgb` (channel by channel, so each channel's sum is the core's).
pub(crate) trait Integrand: Copy + AddAssign + Mul<f64, Output = Self> {
    /// The contribution of a node below the horizon.
    const ZERO: Self;
}

impl Integrand for Rgb {
    const ZERO: Self = Rgb::ZERO;
}

/// A table's integrand: its value and its validity indicator (1/π where a lookup found
/// a sample, 0 elsewhere), integrated over the same nodes in one pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Sampled {
    /// The table's value (0 where the lookup found no sample).
    pub f: Rgb,
    /// 1/π where the lookup found a sample, else 0.
    pub valid: f64,
}

impl AddAssign for Sampled {
    fn add_assign(&mut self, o: Sampled) {
        self.f += o.f;
        self.valid += o.valid;
    }
}

impl Mul<f64> for Sampled {
    type Output = Sampled;
    fn mul(self, s: f64) -> Sampled {
        Sampled {
            f: self.f * s,
            valid: self.valid * s,
        }
    }
}

impl Integrand for Sampled {
    const ZERO: Self = Sampled {
        f: Rgb::ZERO,
        valid: 0.0,
    };
}

/// A Gauss-Legendre rule: nodes and weights.
type Rule = Arc<(Vec<f64>, Vec<f64>)>;

/// The n-point Gauss-Legendre rule, computed once per n in the process (the arc rules
/// have up to thousands of nodes, whose Newton iterations cost more than a cheap
/// integral). [`gauss_legendre`]'s own values, so the same bits as the core's rules.
/// Each n has its own cell: a thread that needs a rule another is computing waits for
/// it instead of computing it too (the albedo integrals of a report start together and
/// ask for the same few rules), and the map's lock is held only to find the cell.
fn rule(n: usize) -> Rule {
    static RULES: OnceLock<Mutex<HashMap<usize, Arc<OnceLock<Rule>>>>> = OnceLock::new();
    let rules = RULES.get_or_init(|| Mutex::new(HashMap::new()));
    // Rules above 2¹⁶ nodes (a direction within 0.02° of the horizon) are not kept; a
    // poisoned lock only means another thread panicked while inserting: compute.
    let cell = (n <= 1 << 16)
        .then(|| {
            rules
                .lock()
                .ok()
                .map(|mut m| m.entry(n).or_default().clone())
        })
        .flatten();
    match cell {
        Some(c) => c.get_or_init(|| Arc::new(gauss_legendre(n))).clone(),
        None => Arc::new(gauss_legendre(n)),
    }
}

/// a(wo) = ∫ f(wi, wo) cos θi dωi by the rule `q`, exactly as
/// [`brdfkit_core::quadrature::directional_albedo`] computes it (see there for the
/// polar coordinates about the pole, the visible rings and arcs and the graded
/// segments), with `eval(nodes, out)` giving f at every node of a ring at once
/// (`out[k]` for `nodes[k]`; a node at or below the horizon is given too, and its value
/// ignored).
pub(crate) fn albedo_by_rings<V: Integrand>(
    wo: &Vec3,
    q: &AlbedoQuadrature,
    mut eval: impl FnMut(&[Vec3], &mut [V]),
) -> V {
    if wo.z <= 0.0 {
        return V::ZERO;
    }
    let pole = match q.pole {
        Pole::Mirror => Vec3::new(-wo.x, -wo.y, wo.z),
        Pole::Retro => *wo,
        Pole::Normal => Vec3::new(0.0, 0.0, 1.0),
    };
    let (t, b) = frame_around(&pole);
    let amp = t.z.hypot(b.z);
    let phi0 = b.z.atan2(t.z);
    // θp of the pole; the clamp keeps acos defined for a pole a rounding past ±1.
    let theta_p = pole.z.clamp(-1.0, 1.0).acos();
    let half_pi = std::f64::consts::FRAC_PI_2;
    let u_near = half_pi - theta_p;
    let u_far = half_pi + theta_p;
    let mut edges: Vec<f64> = q.edges.iter().copied().filter(|&u| u < u_far).collect();
    edges.push(u_far);
    if u_near > 0.0 && !edges.contains(&u_near) {
        edges.push(u_near);
    }
    edges.sort_by(f64::total_cmp);
    let g_rule = rule(q.order);
    let a_rule = rule(q.n_phi.max(2));
    let dphi = 2.0 * PI / q.n_phi as f64;
    let ring_dirs: Vec<Vec3> = (0..q.n_phi)
        .map(|m| {
            let (sp, cp) = (phi0 + (m as f64 + 0.5) * dphi).sin_cos();
            cp * t + sp * b
        })
        .collect();
    let width = q.n_phi.max(a_rule.0.len());
    let mut nodes: Vec<Vec3> = Vec::with_capacity(width);
    let mut vals: Vec<V> = vec![V::ZERO; width];
    let mut angles: Vec<(f64, f64)> = Vec::with_capacity(width);
    let frame = Frame {
        pole,
        t,
        b,
        amp,
        phi0,
    };
    let mut ring = |u: f64| -> V {
        let (su, cu) = u.sin_cos();
        match frame.visible(su, cu) {
            Visible::Whole => {
                nodes.clear();
                nodes.extend(ring_dirs.iter().map(|d| su * d + cu * pole));
                let v = &mut vals[..nodes.len()];
                eval(&nodes, v);
                let mut s = V::ZERO;
                for (wi, f) in nodes.iter().zip(v.iter()) {
                    s += node_value(wi, *f);
                }
                s * dphi
            }
            Visible::None => V::ZERO,
            Visible::Arc(half) => {
                let (ax, aw) = (&a_rule.0, &a_rule.1);
                arc_angles(frame.phi0, half, ax, &mut angles);
                nodes.clear();
                nodes.extend(
                    angles
                        .iter()
                        .map(|&(sp, cp)| su * (cp * frame.t + sp * frame.b) + cu * pole),
                );
                let v = &mut vals[..nodes.len()];
                eval(&nodes, v);
                let mut s = V::ZERO;
                for ((wi, f), w) in nodes.iter().zip(v.iter()).zip(aw) {
                    s += node_value(wi, *f) * *w;
                }
                s * half
            }
        }
    };
    let mut sum = V::ZERO;
    for seg in edges.windows(2) {
        let (a, c) = (seg[0], seg[1]);
        if c <= a {
            continue;
        }
        // The smoothstep substitution of the segments next to u_near and u_far (see the
        // core function).
        let smooth = a == u_near || c == u_far;
        for (x, w) in g_rule.0.iter().zip(&g_rule.1) {
            let s01 = 0.5 * (x + 1.0);
            let (u, du) = if smooth {
                let u = a + (c - a) * s01 * s01 * (3.0 - 2.0 * s01);
                (u, (c - a) * 6.0 * s01 * (1.0 - s01) * 0.5)
            } else {
                (a + (c - a) * s01, 0.5 * (c - a))
            };
            sum += ring(u) * (w * du * u.sin());
        }
    }
    sum
}

/// (sin φ, cos φ) at the arc's nodes φ = φ0 + half · x, x the Gauss-Legendre nodes `ax`.
///
/// The nodes are symmetric (x at n − 1 − k is −x at k, as [`gauss_legendre`] builds
/// them), so with φ0 = 0 (a direction at φ = 0 about the mirror pole: every albedo of
/// the report) the upper half of the arc is the lower half negated, φ = −φ' exactly,
/// and its sines and cosines are (−sin φ', cos φ'): sine is odd and cosine even to the
/// bit (libm reduces |φ| and sets the sign; the tests compare with the core's
/// integral). Half the `sin_cos` calls, which were most of an arc node's cost.
fn arc_angles(phi0: f64, half: f64, ax: &[f64], out: &mut Vec<(f64, f64)>) {
    out.clear();
    let n = ax.len();
    // With φ0 = 0, 0 + half · x is half · x (x is never −0: a rule of odd order has
    // its middle node at +0, which this computes directly).
    let direct = if phi0 == 0.0 { n.div_ceil(2) } else { n };
    out.extend(ax[..direct].iter().map(|x| (phi0 + half * x).sin_cos()));
    for k in direct..n {
        let (s, c) = out[n - 1 - k];
        out.push((-s, c));
    }
}

/// f cos θi at a node; 0 where round-off put the node a hair below the horizon.
#[inline]
fn node_value<V: Integrand>(wi: &Vec3, f: V) -> V {
    if wi.z <= 0.0 { V::ZERO } else { f * wi.z }
}

/// The pole's frame: the pole p, its tangents t and b, A = |(t.z, b.z)| and
/// φ0 = atan2(b.z, t.z), with wi.z = sin u · A cos(φ − φ0) + cos u · p.z on a ring.
struct Frame {
    pole: Vec3,
    t: Vec3,
    b: Vec3,
    amp: f64,
    phi0: f64,
}

/// The visible part of a ring.
enum Visible {
    /// The whole circle: the trapezoid rule.
    Whole,
    /// Nothing (the ring lies below the horizon).
    None,
    /// |φ − φ0| < the half-width: Gauss-Legendre over the arc.
    Arc(f64),
}

impl Frame {
    /// Where cos(φ − φ0) > c, c = −cos u p.z / (sin u A), on the ring at u.
    fn visible(&self, su: f64, cu: f64) -> Visible {
        let c = if su * self.amp > 0.0 {
            -cu * self.pole.z / (su * self.amp)
        } else if cu * self.pole.z > 0.0 {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
        if c <= -1.0 {
            Visible::Whole
        } else if c >= 1.0 {
            Visible::None
        } else {
            Visible::Arc(c.acos())
        }
    }
}

/// `m`'s albedo by the rule `q` about `w` ([`albedo_by_rings`]): a(w) = ∫ f(wi, w) cos θi
/// dωi, or with `transposed` ∫ f(w, wo) cos θo dωo (the albedo a(wi) of the light
/// arriving from w). Each ring goes through `m`'s [`Model::eval_batch`].
pub(crate) fn model_albedo(m: &dyn Model, w: &Vec3, q: &AlbedoQuadrature, transposed: bool) -> Rgb {
    let mut geo = GeometryBatch::default();
    let fixed = [w.x, w.y, w.z];
    albedo_by_rings(w, q, |nodes: &[Vec3], out: &mut [Rgb]| {
        geo.fill_with(nodes.len(), |k| {
            let n = [nodes[k].x, nodes[k].y, nodes[k].z];
            if transposed { (fixed, n) } else { (n, fixed) }
        });
        m.eval_batch(&geo.as_slice(), out);
    })
}

/// The table's albedo integrand at `wo` by the rule `q` ([`albedo_by_rings`]): the
/// integral of its values (0 where a lookup finds no sample) and of its validity
/// indicator, from one lookup per node ([`MerlTable::lookup_batch`], the bits of
/// [`MerlTable::lookup`]).
pub(crate) fn table_albedo_sums(
    t: &MerlTable,
    mode: Lookup,
    wo: &Vec3,
    q: &AlbedoQuadrature,
) -> Sampled {
    let mut pairs: Vec<(Vec3, Vec3)> = Vec::new();
    albedo_by_rings(wo, q, |nodes: &[Vec3], out: &mut [Sampled]| {
        pairs.clear();
        pairs.extend(nodes.iter().map(|wi| (*wi, *wo)));
        for (o, v) in out.iter_mut().zip(t.lookup_batch(mode, &pairs)) {
            *o = match v {
                Some(f) => Sampled { f, valid: 1.0 / PI },
                None => Sampled::ZERO,
            };
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_core::Brdf;
    use brdfkit_core::direction::spherical;
    use brdfkit_core::quadrature::directional_albedo;
    use brdfkit_merl::Dims;

    fn models() -> Vec<Box<dyn Model>> {
        [
            r#"{"model": "lambert", "params": {"rho_d": [0.2, 0.3, 0.4]}}"#,
            r#"{"model": "cook-torrance", "params": {"rho_d": [0.2, 0.25, 0.3], "rho_s": 0.5, "alpha": 0.2}}"#,
            r#"{"model": "cook-torrance", "params": {"rho_d": [0.02, 0.05, 0.03], "rho_s": [0.9, 0.7, 0.4], "alpha": 0.02}}"#,
        ]
        .iter()
        .map(|j| brdfkit_models::from_json_str(j).unwrap())
        .chain(
            ["ward", "lafortune", "plausible-phong", "cook-torrance"]
                .iter()
                .map(|n| brdfkit_models::default_model(n).unwrap()),
        )
        .collect()
    }

    struct Swapped<'a>(&'a dyn Model);
    impl Brdf for Swapped<'_> {
        fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
            self.0.eval(wo, wi)
        }
    }

    fn rules() -> Vec<AlbedoQuadrature> {
        let mut v = Vec::new();
        for pole in [Pole::Mirror, Pole::Retro, Pole::Normal] {
            for n_phi in [128, 512] {
                v.push(
                    AlbedoQuadrature {
                        n_phi,
                        ..AlbedoQuadrature::default()
                    }
                    .with_pole(pole),
                );
            }
        }
        v
    }

    /// Every model, pole and direction: the rings' albedo is the core's to the bit.
    #[test]
    fn model_albedo_is_the_cores_to_the_bit() {
        for m in models() {
            let dirs = [0.0f64, 10.0, 45.0, 80.0, 89.0]
                .into_iter()
                .flat_map(|t| [0.0, 0.3, 2.0].map(|p| spherical(t.to_radians(), p)));
            for w in dirs {
                for q in rules() {
                    let core = directional_albedo(m.as_ref(), &w, &q);
                    let rings = model_albedo(m.as_ref(), &w, &q, false);
                    assert_eq!(core.0.map(f64::to_bits), rings.0.map(f64::to_bits));
                    let core = directional_albedo(&Swapped(m.as_ref()), &w, &q);
                    let rings = model_albedo(m.as_ref(), &w, &q, true);
                    assert_eq!(core.0.map(f64::to_bits), rings.0.map(f64::to_bits));
                }
            }
        }
    }

    struct Lookups<'a>(&'a MerlTable, bool);
    impl Brdf for Lookups<'_> {
        fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
            let v = self.0.lookup(Lookup::Interpolated, wi, wo);
            match (self.1, v) {
                (false, v) => v.unwrap_or(Rgb::ZERO),
                (true, Some(_)) => Rgb::splat(1.0 / PI),
                (true, None) => Rgb::ZERO,
            }
        }
    }

    /// A table with holes: its value and validity integrals are the core's, to the bit.
    #[test]
    fn table_albedo_is_the_cores_to_the_bit() {
        let dims = Dims::new(12, 10, 20).unwrap();
        let t = MerlTable::from_fn(dims, |i, j, k| {
            ((i + 2 * j + k) % 7 != 0).then_some(Rgb([
                0.1 + i as f64,
                0.2 + j as f64,
                0.3 + k as f64,
            ]))
        })
        .unwrap();
        for (theta, phi) in [
            (0.0f64, 0.0),
            (30.0, 0.0),
            (75.0, 0.0),
            (88.0, 0.0),
            (60.0, 1.0),
        ] {
            let w = spherical(theta.to_radians(), phi);
            for q in rules() {
                let s = table_albedo_sums(&t, Lookup::Interpolated, &w, &q);
                let f = directional_albedo(&Lookups(&t, false), &w, &q);
                let v = directional_albedo(&Lookups(&t, true), &w, &q);
                assert_eq!(s.f.0.map(f64::to_bits), f.0.map(f64::to_bits));
                assert_eq!(s.valid.to_bits(), v.r().to_bits());
            }
        }
    }
}
