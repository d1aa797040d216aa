//! What the writer's tests share: the seven vendored proxies (data-measured/, NBRDF fits
//! of real measurements), random direction pairs, and the error statistics.

#![allow(dead_code)]

use brdfkit_core::{Brdf, Rgb, Vec3};
use brdfkit_nbrdf::Nbrdf;
use brdfkit_rgl::write::Symmetry;
use rand::{Rng, SeedableRng};
use std::path::PathBuf;

/// The seven proxies, as (name, DIR/NAME stem).
pub fn proxies() -> Vec<(&'static str, PathBuf)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-measured");
    [
        ("chrome-steel", "merl/chrome-steel"),
        ("gold-paint", "merl/gold-paint"),
        ("specular-red-phenolic", "merl/specular-red-phenolic"),
        ("pink-fabric", "merl/pink-fabric"),
        ("blue-rubber", "merl/blue-rubber"),
        (
            "acrylic_felt_green_rgb",
            "rgl-isotropic/acrylic_felt_green_rgb",
        ),
        ("bindercover", "nielsen/bindercover"),
    ]
    .into_iter()
    .map(|(n, p)| (n, root.join(p)))
    .collect()
}

pub fn proxy(name: &str) -> Nbrdf {
    let (_, p) = proxies().into_iter().find(|(n, _)| *n == name).unwrap();
    Nbrdf::load(&p).unwrap()
}

/// `count` pairs, each direction uniform on the hemisphere above `min_deg` elevation.
pub fn pairs(count: usize, min_deg: f64, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let zmin = min_deg.to_radians().sin();
    let mut dir = || {
        let z: f64 = rng.random_range(zmin..1.0);
        let phi = rng.random::<f64>() * std::f64::consts::TAU;
        let r = (1.0 - z * z).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    (0..count).map(|_| (dir(), dir())).collect()
}

/// |a − b| / |b| of RGB vectors (Euclidean), `None` where the source is black.
pub fn rel(a: &Rgb, b: &Rgb) -> Option<f64> {
    let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let bn = n(b.0);
    (bn > 1e-6).then(|| n([0, 1, 2].map(|c| a.0[c] - b.0[c])) / bn)
}

/// Median and 90th percentile.
pub fn median_p90(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.9))
}

/// Median and p90 relative error of `file` (f_r, as brdfkit's reader returns it) against
/// `source`.
pub fn against_source(
    file: &dyn Fn(usize) -> Rgb,
    source: &dyn Brdf,
    pairs: &[(Vec3, Vec3)],
) -> (f64, f64) {
    let errs: Vec<f64> = pairs
        .iter()
        .enumerate()
        .filter_map(|(k, (wi, wo))| rel(&file(k), &source.eval(wi, wo)))
        .collect();
    median_p90(errs)
}

/// The anisotropic sources the writer's tests write, as (name, source, the symmetry the
/// writer must find): an anisotropic GGX Cook-Torrance (mirror-symmetric, 4-fold), the
/// same lobe turned about the normal (2-fold), and that plus a term that breaks every
/// symmetry (no fold). brdfkit has no model of the last two kinds (no glTF
/// `KHR_materials_anisotropy` rotation, no asymmetric lobe), so they are built here.
pub fn anisotropic_sources() -> Vec<(&'static str, Box<dyn Brdf>, Symmetry)> {
    vec![
        ("ggx-aniso", Box::new(ggx_aniso()), Symmetry::Mirrors),
        (
            "ggx-rotated",
            Box::new(Rotated {
                inner: Box::new(ggx_aniso()),
                angle: ROTATION,
            }),
            Symmetry::HalfTurn,
        ),
        (
            "skewed",
            Box::new(Skewed(Rotated {
                inner: Box::new(ggx_aniso()),
                angle: ROTATION,
            })),
            Symmetry::None,
        ),
    ]
}

/// The JSON of the anisotropic Cook-Torrance the tests (and the CLI's) write.
pub const GGX_ANISO: &str = r#"{"model": "cook-torrance", "params": {"rho_d": [0.3, 0.2, 0.1], "rho_s": [0.4, 0.5, 0.6], "alpha_x": 0.12, "alpha_y": 0.45, "distribution": "ggx"}}"#;

pub fn ggx_aniso() -> Box<dyn brdfkit_core::Model> {
    brdfkit_models::from_json_str(GGX_ANISO).unwrap()
}

/// The rotation of [`Rotated`] in the tests: 30°, not a multiple of 90°.
pub const ROTATION: f64 = std::f64::consts::PI / 6.0;

/// A source's lobe axes turned by `angle` about the normal, as glTF's
/// `KHR_materials_anisotropy` turns the anisotropy direction: f(R⁻¹ wi, R⁻¹ wo).
/// Invariant under the half turn, not under the frame's mirrors (unless `angle` is a
/// multiple of 90°).
pub struct Rotated {
    pub inner: Box<dyn Brdf>,
    pub angle: f64,
}

impl Brdf for Rotated {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        let (s, c) = (-self.angle).sin_cos();
        let r = |v: &Vec3| Vec3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z);
        self.inner.eval(&r(wi), &r(wo))
    }
    fn is_isotropic(&self) -> bool {
        false
    }
}

/// The rotated lobe plus a diffuse term that grows towards +x, (0.15/π)(1 + 0.5 wo.x):
/// no mirror and no half turn leaves it alone.
pub struct Skewed(pub Rotated);

impl Brdf for Skewed {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let extra = 0.15 / std::f64::consts::PI * (1.0 + 0.5 * wo.x);
        self.0.eval(wi, wo).map(|c| c + extra)
    }
    fn is_isotropic(&self) -> bool {
        false
    }
}
