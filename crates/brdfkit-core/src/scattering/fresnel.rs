//! Fresnel reflectance of a smooth interface, unpolarised light, with the derivatives a
//! fitter needs.
//!
//! Every function takes the cosine of the angle between the incident direction and the
//! (micro)surface normal, which in a microfacet BRDF is cos θd = wi·h.
//!
//! - [`schlick`]: F = f0 + (1 − f0)(1 − cos θ)⁵ (C. Schlick, "An Inexpensive BRDF Model
//!   for Physically-based Rendering", Computer Graphics Forum 13(3), 1994, eq. 15).
//! - [`dielectric`]: the exact unpolarised Fresnel equations for a real relative index
//!   of refraction η = η_t/η_i, with total internal reflection giving 1 (M. Born and
//!   E. Wolf, *Principles of Optics*, 7th ed., §1.5.2; pbrt-v4 `FrDielectric`).
//! - [`conductor`]: the exact unpolarised Fresnel equations for a complex index η + i·k
//!   relative to the outside medium, in the closed form of K. D. Möller, *Optics* (1988)
//!   that Mitsuba 3 uses in `fresnel_conductor` (include/mitsuba/render/fresnel.h); the
//!   same quantity as pbrt-v4's complex `FrComplex`.

/// (1 − c)⁵ by multiplication (no `powf`).
#[inline]
fn pow5(m: f64) -> f64 {
    let m2 = m * m;
    m2 * m2 * m
}

/// The Schlick weight (1 − cos θ)⁵, with cos θ clamped into [0, 1].
///
/// The clamp only absorbs round-off: the cosine of two unit vectors computed in floating
/// point can reach 1 + 2⁻⁵² or −0; Schlick's polynomial is defined on [0, 1].
#[inline]
pub fn schlick_weight(cos_theta: f64) -> f64 {
    pow5(1.0 - cos_theta.clamp(0.0, 1.0))
}

/// Schlick's approximation F = f0 + (1 − f0)(1 − cos θ)⁵.
///
/// ∂F/∂f0 = 1 − (1 − cos θ)⁵ ([`schlick_d_f0`]).
#[inline]
pub fn schlick(f0: f64, cos_theta: f64) -> f64 {
    let w = schlick_weight(cos_theta);
    f0 + (1.0 - f0) * w
}

/// ∂F/∂f0 of [`schlick`]: 1 − (1 − cos θ)⁵.
#[inline]
pub fn schlick_d_f0(cos_theta: f64) -> f64 {
    1.0 - schlick_weight(cos_theta)
}

/// Exact Fresnel reflectance of a dielectric interface for unpolarised light.
///
/// With η the relative index (transmitted side over incident side), cos θt from Snell's
/// law sin²θt = sin²θi / η², and
/// r∥ = (η cos θi − cos θt)/(η cos θi + cos θt), r⊥ = (cos θi − η cos θt)/(cos θi + η cos θt),
/// F = (r∥² + r⊥²)/2. A negative `cos_theta_i` means the light arrives from the inside:
/// the interface is seen with 1/η. Total internal reflection (sin²θt ≥ 1) gives 1.
/// Born & Wolf §1.5.2; pbrt-v4 `FrDielectric`.
#[inline]
pub fn dielectric(cos_theta_i: f64, eta: f64) -> f64 {
    dielectric_grad(cos_theta_i, eta).0
}

/// [`dielectric`] and its derivative ∂F/∂η.
///
/// Differentiates the expressions above with ∂cos θt/∂η = sin²θt/(η cos θt). The
/// derivative grows without bound at the critical angle (cos θt → 0), where F has a
/// kink; under total internal reflection F ≡ 1 and the derivative is 0.
pub fn dielectric_grad(cos_theta_i: f64, eta: f64) -> (f64, f64) {
    // Round-off of a dot product of unit vectors can leave [−1, 1]; sin²θi must stay ≥ 0.
    let mut c_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut e = eta;
    // Seen from the inside, the relative index is 1/η, and ∂/∂η picks up −1/η².
    let mut chain = 1.0;
    if c_i < 0.0 {
        e = 1.0 / eta;
        c_i = -c_i;
        chain = -1.0 / (eta * eta);
    }
    let sin2_i = (1.0 - c_i * c_i).max(0.0);
    let sin2_t = sin2_i / (e * e);
    if sin2_t >= 1.0 {
        return (1.0, 0.0);
    }
    let c_t = (1.0 - sin2_t).sqrt();
    let dc_t = sin2_t / (e * c_t);

    let (a, b) = (e * c_i - c_t, e * c_i + c_t);
    let r_par = a / b;
    let dr_par = ((c_i - dc_t) * b - a * (c_i + dc_t)) / (b * b);

    let (p, q) = (c_i - e * c_t, c_i + e * c_t);
    let r_perp = p / q;
    let dq = c_t + e * dc_t;
    let dr_perp = (-dq * q - p * dq) / (q * q);

    let f = 0.5 * (r_par * r_par + r_perp * r_perp);
    let df = r_par * dr_par + r_perp * dr_perp;
    (f, df * chain)
}

/// Fresnel reflectance and its derivatives for a conductor (see [`conductor_grad`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConductorFresnel {
    /// F.
    pub f: f64,
    /// ∂F/∂η.
    pub d_eta: f64,
    /// ∂F/∂k.
    pub d_k: f64,
}

/// The powers of cos θi and sin θi that the conductor formula uses, shared by
/// [`conductor`] and [`conductor_grad`] so both start from the same bits.
struct Incidence {
    c: f64,
    c2: f64,
    s2: f64,
    s4: f64,
}

impl Incidence {
    #[inline]
    fn new(cos_theta_i: f64) -> Self {
        // Round-off of a dot product of unit vectors can step outside [0, 1].
        let c = cos_theta_i.clamp(0.0, 1.0);
        let c2 = c * c;
        let s2 = 1.0 - c2;
        Incidence {
            c,
            c2,
            s2,
            s4: s2 * s2,
        }
    }

    /// R_s and R_p/R_s, from a² + b² (`p`) and `a`, with the terms of their quotients
    /// (the derivatives need them).
    #[inline]
    fn ratios(&self, p: f64, a: f64) -> Ratios {
        let t1 = p + self.c2;
        let t2 = 2.0 * self.c * a;
        let t3 = p * self.c2 + self.s4;
        let t4 = t2 * self.s2;
        Ratios {
            t1,
            t2,
            rs: (t1 - t2) / (t1 + t2),
            t3,
            t4,
            ratio: (t3 - t4) / (t3 + t4),
        }
    }
}

/// R_s = (t1 − t2)/(t1 + t2) and R_p/R_s = (t3 − t4)/(t3 + t4) of [`conductor_grad`].
#[derive(Clone, Copy)]
struct Ratios {
    t1: f64,
    t2: f64,
    rs: f64,
    t3: f64,
    t4: f64,
    ratio: f64,
}

impl Ratios {
    /// F = (R_s + R_p)/2.
    #[inline]
    fn f(&self) -> f64 {
        let rp = self.rs * self.ratio;
        0.5 * (self.rs + rp)
    }
}

/// Exact Fresnel reflectance of a conductor with complex relative index η + i·k, for
/// unpolarised light (see [`conductor_grad`] for the formula).
///
/// The value part of [`conductor_grad`] without the derivatives (half the work), with
/// the same operations in the same order, so both give the same bits (tested).
#[inline]
pub fn conductor(cos_theta_i: f64, eta: f64, k: f64) -> f64 {
    let inc = Incidence::new(cos_theta_i);
    let t = eta * eta - k * k - inc.s2;
    let p = (t * t + 4.0 * eta * eta * k * k).sqrt();
    let a = (0.5 * (p + t)).max(0.0).sqrt();
    inc.ratios(p, a).f()
}

/// Conductor Fresnel reflectance and its derivatives with respect to η and k.
///
/// With c = cos θi, s² = 1 − c² (K. D. Möller, *Optics*, 1988; Mitsuba 3
/// `fresnel_conductor`):
///
/// t = η² − k² − s², a² + b² = √(t² + 4η²k²), a = √((a² + b² + t)/2),
/// R_s = (a² + b² + c² − 2ac)/(a² + b² + c² + 2ac),
/// R_p = R_s · ((a² + b²)c² + s⁴ − 2ac·s²)/((a² + b²)c² + s⁴ + 2ac·s²),
/// F = (R_s + R_p)/2.
///
/// At normal incidence F = ((η − 1)² + k²)/((η + 1)² + k²). The derivatives follow the
/// same chain analytically. `a` = Re √((η + ik)² − s²) is zero only for k = 0 with
/// η ≤ sin θi (a lossless interface under total internal reflection, F = 1 where F is
/// flat in η); there the a-dependent terms of the derivatives are dropped instead of
/// dividing by zero.
pub fn conductor_grad(cos_theta_i: f64, eta: f64, k: f64) -> ConductorFresnel {
    let inc = Incidence::new(cos_theta_i);
    let (c, c2, s2) = (inc.c, inc.c2, inc.s2);

    let t = eta * eta - k * k - s2;
    let (dt_de, dt_dk) = (2.0 * eta, -2.0 * k);
    let p = (t * t + 4.0 * eta * eta * k * k).sqrt(); // a² + b²
    // ∂p/∂x = (t ∂t/∂x + 4ηk(k ∂η/∂x + η ∂k/∂x)) / p; p = 0 only when t = 0 and ηk = 0,
    // a single point of the parameter space where p has a kink: take 0 there.
    let (dp_de, dp_dk) = if p > 0.0 {
        (
            (t * dt_de + 4.0 * eta * k * k) / p,
            (t * dt_dk + 4.0 * eta * eta * k) / p,
        )
    } else {
        (0.0, 0.0)
    };
    let a = (0.5 * (p + t)).max(0.0).sqrt();
    let (da_de, da_dk) = if a > 0.0 {
        ((dp_de + dt_de) / (4.0 * a), (dp_dk + dt_dk) / (4.0 * a))
    } else {
        (0.0, 0.0)
    };

    let r = inc.ratios(p, a);
    let Ratios {
        t1,
        t2,
        rs,
        t3,
        t4,
        ratio,
    } = r;
    let f = r.f();

    // d[(u − v)/(u + v)] = 2 (v du − u dv)/(u + v)².
    let d = |dp: f64, da: f64| {
        let (dt1, dt2) = (dp, 2.0 * c * da);
        let drs = 2.0 * (t2 * dt1 - t1 * dt2) / ((t1 + t2) * (t1 + t2));
        let (dt3, dt4) = (dp * c2, dt2 * s2);
        let dratio = 2.0 * (t4 * dt3 - t3 * dt4) / ((t3 + t4) * (t3 + t4));
        0.5 * (drs + drs * ratio + rs * dratio)
    };
    ConductorFresnel {
        f,
        d_eta: d(dp_de, da_de),
        d_k: d(dp_dk, da_dk),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn central(f: impl Fn(f64) -> f64, x: f64) -> f64 {
        let h = 1e-6 * x.abs().max(1e-3);
        (f(x + h) - f(x - h)) / (2.0 * h)
    }

    fn close(a: f64, b: f64, rel: f64, abs: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs()) + abs
    }

    #[test]
    fn schlick_limits() {
        assert_eq!(schlick(0.04, 1.0), 0.04);
        assert_eq!(schlick(0.04, 0.0), 1.0);
        assert_eq!(schlick(0.3, 1.0 + 1e-16), 0.3);
        let c: f64 = 0.37;
        assert!((schlick(0.2, c) - (0.2 + 0.8 * (1.0 - c).powi(5))).abs() < 1e-16);
        for &c in &[0.0, 0.1, 0.5, 0.9, 1.0] {
            let fd = central(|f0| schlick(f0, c), 0.3);
            assert!(close(schlick_d_f0(c), fd, 1e-9, 1e-12), "c={c}");
        }
    }

    #[test]
    fn dielectric_closed_forms() {
        for &eta in &[1.1f64, 1.5, 2.4, 0.7] {
            let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((dielectric(1.0, eta) - r0).abs() < 1e-15, "eta {eta}");
            assert!(
                (dielectric(1e-9, eta) - 1.0).abs() < 1e-8,
                "grazing, eta {eta}"
            );
        }
        // Total internal reflection: η = 1/1.5 beyond the critical angle asin(1/1.5).
        let crit = (1.0f64 / 1.5).asin();
        assert_eq!(dielectric((crit + 0.01).cos(), 1.0 / 1.5), 1.0);
        assert!(dielectric((crit - 0.01).cos(), 1.0 / 1.5) < 1.0);
        // From the inside with 1.5 is from the outside with 1/1.5.
        assert_eq!(dielectric(-0.3, 1.5), dielectric(0.3, 1.0 / 1.5));
        // Brewster's angle: r∥ = 0, so F = r⊥²/2.
        let tb = 1.5f64.atan();
        let (ci, ct) = (tb.cos(), (std::f64::consts::FRAC_PI_2 - tb).cos());
        let rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
        assert!((dielectric(ci, 1.5) - 0.5 * rs * rs).abs() < 1e-15);
    }

    #[test]
    fn dielectric_derivative_matches_finite_differences() {
        for &eta in &[1.05, 1.33, 1.5, 2.5, 0.8] {
            for &c in &[1.0, 0.9, 0.5, 0.2, 0.05, -0.3, -0.9] {
                let (f, d) = dielectric_grad(c, eta);
                let fd = central(|e| dielectric(c, e), eta);
                assert!(
                    close(d, fd, 1e-6, 1e-10),
                    "eta {eta} c {c}: {d} vs {fd} (F {f})"
                );
            }
        }
    }

    #[test]
    fn conductor_closed_forms() {
        for &(eta, k) in &[(0.2, 3.0), (1.5, 0.1), (2.9, 3.0), (0.05, 0.5), (1.0, 1e-3)] {
            let r0 = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
            let f = conductor(1.0, eta, k);
            assert!((f - r0).abs() < 1e-14, "({eta},{k}): {f} vs {r0}");
            assert!((conductor(0.0, eta, k) - 1.0).abs() < 1e-14);
            assert!((conductor(1e-7, eta, k) - 1.0).abs() < 1e-5);
        }
        // With k → 0 the conductor is a dielectric.
        for &c in &[1.0, 0.7, 0.3, 0.05] {
            let a = conductor(c, 1.5, 0.0);
            let b = dielectric(c, 1.5);
            assert!((a - b).abs() < 1e-14, "c {c}: {a} vs {b}");
        }
    }

    #[test]
    fn conductor_derivatives_match_finite_differences() {
        for &(eta, k) in &[(0.2, 3.0), (1.5, 0.1), (2.9, 3.0), (0.05, 0.5), (0.9, 0.01)] {
            for &c in &[1.0, 0.9, 0.5, 0.2, 0.05, 0.001] {
                let g = conductor_grad(c, eta, k);
                let fe = central(|e| conductor(c, e, k), eta);
                let fk = central(|kk| conductor(c, eta, kk), k);
                // F ≤ 1: the difference quotient's round-off is ~ε/h = 2e-16/(1e-6 x).
                let (ae, ak) = (1e-9 / eta.max(1e-3), 1e-9 / k.max(1e-3));
                assert!(
                    close(g.d_eta, fe, 1e-6, ae),
                    "∂η ({eta},{k}) c {c}: {} vs {fe}",
                    g.d_eta
                );
                assert!(
                    close(g.d_k, fk, 1e-6, ak),
                    "∂k ({eta},{k}) c {c}: {} vs {fk}",
                    g.d_k
                );
            }
        }
    }

    #[test]
    fn value_only_forms_give_the_same_bits() {
        for i in 0..=200 {
            let c = i as f64 / 200.0;
            for &(eta, k) in &[(0.2, 3.0), (1.5, 0.0), (0.5, 0.0), (3.0, 5.0), (0.9, 0.01)] {
                assert_eq!(conductor(c, eta, k), conductor_grad(c, eta, k).f);
                assert_eq!(dielectric(c, eta), dielectric_grad(c, eta).0);
            }
        }
    }

    #[test]
    fn fresnel_stays_in_the_unit_interval() {
        for i in 0..=100 {
            let c = i as f64 / 100.0;
            for &(eta, k) in &[(0.2, 3.0), (1.5, 0.0), (0.5, 0.0), (3.0, 5.0)] {
                let f = conductor(c, eta, k);
                assert!((0.0..=1.0 + 1e-15).contains(&f), "c {c} ({eta},{k}): {f}");
                let d = dielectric(c, eta);
                assert!((0.0..=1.0).contains(&d), "c {c} {eta}: {d}");
            }
        }
    }
}
