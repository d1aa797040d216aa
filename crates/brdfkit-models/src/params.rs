//! Parameter plumbing shared by the models: per-channel validation, the parameter-count
//! check, one-channel gradient entries, the ρd, ρs layout that most models begin their
//! flat parameter vector with (and the lobe shape that may follow it), and the copying
//! of a fixed-size kernel gradient into the `eval_grad` and `eval_grad_batch` outputs.

use crate::json;
use crate::shape::Shape;
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{ModelError, ParamSpec, Rgb};
use serde_json::{Map, Value};

/// The domain of an albedo (ρd; ρs where it is a reflectance, e.g. a Fresnel f0 or
/// a model that conserves energy by construction).
pub const RHO_DOMAIN: Domain = Domain::closed(0.0, 1.0);

/// The domain of a specular scale ρs that multiplies a normalised lobe (Cook-Torrance,
/// Ward, Blinn-Phong): [0, ∞). A bound ρs ≤ 1 is not energy conservation: with a
/// Fresnel factor below 1 or a lobe whose albedo is below 1 at some angles, ρs > 1 can
/// still reflect less than it receives (a fabric's sheen needs ρs·F > 1 at grazing), and
/// where the albedo does exceed 1 the fitter's energy option
/// (`brdfkit_fit::FitConfig::albedo_max`) constrains the albedo itself.
pub const RHO_S_DOMAIN: Domain = Domain::at_least(0.0);

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
    /// The domain of the diffuse parameter.
    pub domain: Domain,
    /// The domain of the specular parameter.
    pub s_domain: Domain,
    /// Their default start (the same in every channel).
    pub defaults: (f64, f64),
}

impl DiffuseSpecular {
    /// ρd per channel in [0, 1] and a specular scale ρs per channel in [0, ∞)
    /// ([`RHO_S_DOMAIN`]) under the names `rho_d` and `rho_s`.
    pub const fn albedos(d: f64, s: f64) -> Self {
        Self::rho_d_rho_s(RHO_S_DOMAIN, d, s)
    }

    /// ρd and ρs per channel, both in [0, 1]: for models whose ρs is a reflectance
    /// (Ashikhmin-Shirley's Rs, a Fresnel value whose 1 − Rs weights the diffuse term)
    /// or that conserve energy by construction (plausible Phong).
    pub const fn bounded_albedos(d: f64, s: f64) -> Self {
        Self::rho_d_rho_s(RHO_DOMAIN, d, s)
    }

    /// `rho_d` in [0, 1] and `rho_s` in `s_domain`, defaults `d` and `s`.
    const fn rho_d_rho_s(s_domain: Domain, d: f64, s: f64) -> Self {
        DiffuseSpecular {
            names: ("rho_d", "rho_s"),
            domain: RHO_DOMAIN,
            s_domain,
            defaults: (d, s),
        }
    }

    /// Validates the diffuse parameter, naming its channel in an error.
    pub fn check_d(&self, v: Rgb) -> Result<Rgb, ModelError> {
        check_rgb(self.names.0, v, self.domain)
    }

    /// Validates the specular parameter, naming its channel in an error.
    pub fn check_s(&self, v: Rgb) -> Result<Rgb, ModelError> {
        check_rgb(self.names.1, v, self.s_domain)
    }

    /// The six specs `d.r`, `d.g`, `d.b`, `s.r`, `s.g`, `s.b`.
    pub fn specs(&self) -> Vec<ParamSpec> {
        let mut v = ParamSpec::per_channel(self.names.0, self.domain, self.defaults.0).to_vec();
        v.extend(ParamSpec::per_channel(
            self.names.1,
            self.s_domain,
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

    /// d from a params object (the default where absent), unchecked: the builder
    /// validates it.
    pub fn read_d(&self, o: &Map<String, Value>, model: &str) -> Result<Rgb, ModelError> {
        json::rgb_or(o, self.names.0, self.defaults.0, model)
    }

    /// s from a params object (the default where absent), unchecked.
    pub fn read_s(&self, o: &Map<String, Value>, model: &str) -> Result<Rgb, ModelError> {
        json::rgb_or(o, self.names.1, self.defaults.1, model)
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

/// The builders and getters of a model laid out by its module's `LAYOUT:`
/// [`ShapedLayout`], with fields `rho_d`, `rho_s` and the shape `$field`: `with_rho_d`,
/// `with_rho_s`, the isotropic and anisotropic shortcuts, `with_shape`, `with_lobes`
/// (all three) and the three getters, with the docs given. `$done` finishes every
/// builder (Cook-Torrance refreshes its derived constants there).
macro_rules! shaped_lobe_builders {
    (
        done: $done:expr,
        rho_d: $d_doc:literal, $d_get:literal,
        rho_s: $s_doc:literal, $s_get:literal,
        $field:ident: $shape_doc:literal, $shape_get:literal,
        $iso_fn:ident($iso:ident): $iso_doc:literal,
        $aniso_fn:ident($x:ident, $y:ident): $aniso_doc:literal $(,)?
    ) => {
        #[doc = $d_doc]
        pub fn with_rho_d(mut self, rho_d: Rgb) -> Result<Self, ModelError> {
            self.rho_d = LAYOUT.rhos.check_d(rho_d)?;
            Ok(($done)(self))
        }

        #[doc = $s_doc]
        pub fn with_rho_s(mut self, rho_s: Rgb) -> Result<Self, ModelError> {
            self.rho_s = LAYOUT.rhos.check_s(rho_s)?;
            Ok(($done)(self))
        }

        #[doc = $iso_doc]
        pub fn $iso_fn(self, $iso: f64) -> Result<Self, ModelError> {
            self.with_shape(Shape::Isotropic($iso))
        }

        #[doc = $aniso_doc]
        pub fn $aniso_fn(self, $x: f64, $y: f64) -> Result<Self, ModelError> {
            self.with_shape(Shape::Anisotropic($x, $y))
        }

        #[doc = $shape_doc]
        pub fn with_shape(mut self, $field: Shape) -> Result<Self, ModelError> {
            self.$field = LAYOUT.check($field)?;
            Ok(($done)(self))
        }

        /// Sets the diffuse albedo, the specular scale and the shape at once (each
        /// checked as by its own builder).
        pub fn with_lobes(self, rho_d: Rgb, rho_s: Rgb, shape: Shape) -> Result<Self, ModelError> {
            self.with_rho_d(rho_d)?.with_rho_s(rho_s)?.with_shape(shape)
        }

        /// ρd, ρs and the shape read from a params object (defaults where absent), each
        /// checked as soon as it is read: the first bad one is the error.
        fn with_lobes_from_json(
            self,
            o: &serde_json::Map<String, Value>,
            model: &str,
        ) -> Result<Self, ModelError> {
            self.with_rho_d(LAYOUT.rhos.read_d(o, model)?)?
                .with_rho_s(LAYOUT.rhos.read_s(o, model)?)?
                .with_shape(LAYOUT.read_shape(o, model)?)
        }

        #[doc = $d_get]
        pub fn rho_d(&self) -> Rgb {
            self.rho_d
        }
        #[doc = $s_get]
        pub fn rho_s(&self) -> Rgb {
            self.rho_s
        }
        #[doc = $shape_get]
        pub fn $field(&self) -> Shape {
            self.$field
        }
    };
}

/// The parameter methods of [`Model`](brdfkit_core::Model) for a model that is
/// exactly its module's `LAYOUT:` [`ShapedLayout`] over the fields `rho_d`, `rho_s`
/// and the shape `$field` (its builders from [`shaped_lobe_builders`]).
macro_rules! shaped_lobe_params {
    ($field:ident) => {
        fn param_specs(&self) -> Vec<ParamSpec> {
            LAYOUT.specs(&self.$field)
        }

        fn params(&self) -> Vec<f64> {
            ShapedLayout::values(self.rho_d, self.rho_s, &self.$field)
        }

        fn num_params(&self) -> usize {
            ShapedLayout::count(&self.$field)
        }

        fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
            let (d, s, shape) = ShapedLayout::from_values(p, &self.$field)?;
            *self = self.clone().with_lobes(d, s, shape)?;
            Ok(())
        }
    };
}

/// The layout of the models with a Lambertian base, a specular scale and a lobe shape
/// that is one value or an x/y pair ([`Shape`]): `rho_d.{r,g,b}`, `rho_s.{r,g,b}`, then
/// `iso` or `x`, `y` (`ward`'s α, `ashikhmin-shirley`'s n).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapedLayout {
    /// The ρd, ρs pair.
    pub rhos: DiffuseSpecular,
    /// The JSON names (isotropic, along x, along y) of the shape.
    pub keys: (&'static str, &'static str, &'static str),
    /// The domain of each shape value.
    pub domain: Domain,
    /// The default start of each shape value.
    pub default: f64,
}

impl ShapedLayout {
    /// Validates a shape, naming `iso`, `x` or `y` in an error.
    pub fn check(&self, s: Shape) -> Result<Shape, ModelError> {
        let (iso, x, y) = self.keys;
        s.check(iso, x, y, self.domain)
    }

    /// The parameter count for a shape.
    pub fn count(shape: &Shape) -> usize {
        6 + shape.len()
    }

    /// The specs: ρd, ρs, then the shape's one or two.
    pub fn specs(&self, shape: &Shape) -> Vec<ParamSpec> {
        let (iso, x, y) = self.keys;
        let mut v = self.rhos.specs();
        v.extend(shape.specs(iso, x, y, self.domain, self.default));
        v
    }

    /// The flat values.
    pub fn values(d: Rgb, s: Rgb, shape: &Shape) -> Vec<f64> {
        let mut v = DiffuseSpecular::values(d, s, shape.len());
        shape.push_to(&mut v);
        v
    }

    /// ρd, ρs and a shape of the same kind as `like` from a flat vector, after checking
    /// its length (the values are unchecked: the builder validates them).
    pub fn from_values(p: &[f64], like: &Shape) -> Result<(Rgb, Rgb, Shape), ModelError> {
        check_count(Self::count(like), p.len())?;
        let (d, s) = DiffuseSpecular::from_values(p);
        Ok((d, s, like.with_values(&p[6..])))
    }

    /// Every JSON name of the layout: ρd, ρs, then the shape's (isotropic, x, y).
    pub fn json_keys(&self) -> [&'static str; 5] {
        let (d, s) = self.rhos.names;
        let (iso, x, y) = self.keys;
        [d, s, iso, x, y]
    }

    /// The shape from a params object (see [`Shape`]'s `from_json`).
    pub fn read_shape(&self, o: &Map<String, Value>, model: &str) -> Result<Shape, ModelError> {
        Shape::from_json(o, self.keys, self.default, model)
    }

    /// A params object holding ρd, ρs and the shape.
    pub fn write_json(&self, d: Rgb, s: Rgb, shape: Shape) -> Map<String, Value> {
        let mut o = self.rhos.write_json(d, s);
        shape.to_json(&mut o, self.keys);
        o
    }
}

/// The shape entries of a gradient (from index 6): `scale · (dx + dy)` for an isotropic
/// shape, whose one value moves both axes, else `scale · dx` and `scale · dy`.
#[inline(always)]
pub fn shape_gradient(shape: &Shape, scale: Rgb, dx: f64, dy: f64, grad: &mut [Rgb]) {
    match shape {
        Shape::Isotropic(_) => grad[6] = scale * (dx + dy),
        Shape::Anisotropic(..) => {
            grad[6] = scale * dx;
            grad[7] = scale * dy;
        }
    }
}

/// The start of a kernel: `None` when either direction is at or below the horizon,
/// after zeroing the gradient (f is 0 there, and so is every ∂f/∂p); else the gradient
/// output to fill.
#[inline(always)]
pub fn above_horizon<'g, const M: usize>(
    wi: &[f64; 3],
    wo: &[f64; 3],
    grad: Option<&'g mut [Rgb; M]>,
) -> Option<Option<&'g mut [Rgb; M]>> {
    if wi[2] <= 0.0 || wo[2] <= 0.0 {
        if let Some(g) = grad {
            *g = [Rgb::ZERO; M];
        }
        return None;
    }
    Some(grad)
}

/// `eval_grad` through a kernel that fills a fixed array of `M` gradient entries: the
/// first `np` (the model's parameter count) are copied out.
#[inline(always)]
pub fn grad_via<const M: usize>(
    np: usize,
    grad: &mut [Rgb],
    kernel: impl FnOnce(&mut [Rgb; M]) -> Rgb,
) -> Rgb {
    let mut g = [Rgb::ZERO; M];
    let f = kernel(&mut g);
    grad[..np].copy_from_slice(&g[..np]);
    f
}

/// `eval_grad_batch` through such a kernel, called for pair k = 0 … n−1: its value
/// goes to `out[k]`, its gradient to the parameter-major columns `grad[p · n + k]`.
#[inline(always)]
pub fn grad_batch_via<const M: usize>(
    n: usize,
    np: usize,
    out: &mut [Rgb],
    grad: &mut [Rgb],
    mut kernel: impl FnMut(usize, &mut [Rgb; M]) -> Rgb,
) {
    let mut gk = [Rgb::ZERO; M];
    for (k, o) in out.iter_mut().enumerate().take(n) {
        *o = kernel(k, &mut gk);
        for (p, v) in gk.iter().enumerate().take(np) {
            grad[p * n + k] = *v;
        }
    }
}
