//! The directional albedo of a fitted model or a measured table, a ring of quadrature
//! nodes at a time ([`brdfkit_core::quadrature::albedo_by_rings`]).
//!
//! The report integrates every model's albedo at a dozen directions, two rules and up to
//! three poles each, and the table's at ten: some 10⁵–10⁶ evaluations per integral, one
//! `Brdf::eval` (a model's scalar path, or a table's interpolated lookup) each, which
//! were most of the report's time. Every node of a ring is known before any is
//! evaluated, so a ring goes to a batch path at once: a model's [`Model::eval_batch`]
//! (its vectorised lane kernels), a table's [`MerlTable::lookup_batch`] (the lookups'
//! table reads overlapped). Both give the bits of the pair paths, and the core sums the
//! rings as [`directional_albedo`](brdfkit_core::quadrature::directional_albedo) does,
//! so the albedo is that function's to the bit (the tests compare them).

use brdfkit_core::quadrature::{AlbedoQuadrature, Integrand, albedo_by_rings};
use brdfkit_core::{GeometryBatch, Model, Rgb, Vec3};
use brdfkit_merl::{Lookup, MerlTable};
use std::f64::consts::PI;
use std::ops::{AddAssign, Mul};

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
    use brdfkit_core::quadrature::{Pole, directional_albedo};
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
