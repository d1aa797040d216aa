//! Parameter plumbing shared by the models: per-channel validation, the parameter-count
//! check, one-channel gradient entries, and the ρd, ρs layout that most models begin
//! their flat parameter vector with.

use crate::json;
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{ModelError, ParamSpec, Rgb};
use serde_json::{Map, Value};

/// The domain of an albedo (ρd, ρs).
pub const RHO_DOMAIN: Domain = Domain::closed(0.0, 1.0);

/// Checks every channel of a per-channel parameter, naming `name.r`, `name.g` or
/// `name.b` in the error.
pub fn check_rgb(name: &str, v: Rgb, domain: Domain) -> Result<Rgb, ModelError> {
    for (c, ch) in ["r", "g", "b"].iter().enumerate() {
        check_param(&format!("{name}.{ch}"), v[c], domain)?;
    }
    Ok(v)
}

/// An error unless `got` parameters were given where `expected` are needed.
pub fn check_count(expected: usize, got: usize) -> Result<(), ModelError> {
    if expected == got {
        Ok(())
    } else {
        Err(ModelError::ParamCount { expected, got })
    }
}

/// An [`Rgb`] with `v` in channel `c` and 0 elsewhere: the gradient of f with respect to
/// a per-channel parameter only touches its own channel.
#[inline(always)]
pub fn channel(c: usize, v: f64) -> Rgb {
    let mut r = Rgb::ZERO;
    r[c] = v;
    r
}

/// The ρd, ρs pair (two per-channel parameters) that opens the parameter vector of
/// the models with a Lambertian base and one specular lobe, under the model's own
/// JSON names (`rho_d`/`rho_s`, or `k_d`/`k_s` for the original Phong model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffuseSpecular {
    /// The JSON names of the diffuse and the specular parameter.
    pub names: (&'static str, &'static str),
    /// The domain of both.
    pub domain: Domain,
    /// Their default start (the same in every channel).
    pub defaults: (f64, f64),
}

impl DiffuseSpecular {
    /// ρd and ρs per channel in [0, 1] under the names `rho_d` and `rho_s`.
    pub const fn albedos(d: f64, s: f64) -> Self {
        DiffuseSpecular {
            names: ("rho_d", "rho_s"),
            domain: RHO_DOMAIN,
            defaults: (d, s),
        }
    }

    /// Validates the diffuse parameter, naming its channel in an error.
    pub fn check_d(&self, v: Rgb) -> Result<Rgb, ModelError> {
        check_rgb(self.names.0, v, self.domain)
    }

    /// Validates the specular parameter, naming its channel in an error.
    pub fn check_s(&self, v: Rgb) -> Result<Rgb, ModelError> {
        check_rgb(self.names.1, v, self.domain)
    }

    /// The six specs `d.r`, `d.g`, `d.b`, `s.r`, `s.g`, `s.b`.
    pub fn specs(&self) -> Vec<ParamSpec> {
        let mut v = ParamSpec::per_channel(self.names.0, self.domain, self.defaults.0).to_vec();
        v.extend(ParamSpec::per_channel(
            self.names.1,
            self.domain,
            self.defaults.1,
        ));
        v
    }

    /// The flat values of d and s, with room for `more` entries after them.
    pub fn values(d: Rgb, s: Rgb, more: usize) -> Vec<f64> {
        let mut v = Vec::with_capacity(6 + more);
        v.extend_from_slice(&d.0);
        v.extend_from_slice(&s.0);
        v
    }

    /// d and s from the first six entries of a flat vector (of checked length).
    pub fn from_values(p: &[f64]) -> (Rgb, Rgb) {
        (Rgb::new(p[0], p[1], p[2]), Rgb::new(p[3], p[4], p[5]))
    }

    /// d and s from a params object (defaults where absent), unchecked: the builder
    /// validates them.
    pub fn read_json(&self, o: &Map<String, Value>, model: &str) -> Result<(Rgb, Rgb), ModelError> {
        Ok((
            json::rgb_or(o, self.names.0, self.defaults.0, model)?,
            json::rgb_or(o, self.names.1, self.defaults.1, model)?,
        ))
    }

    /// A params object holding d and s as `[r, g, b]` triples.
    pub fn write_json(&self, d: Rgb, s: Rgb) -> Map<String, Value> {
        let mut o = Map::new();
        o.insert(self.names.0.into(), json::rgb_value(d));
        o.insert(self.names.1.into(), json::rgb_value(s));
        o
    }
}
