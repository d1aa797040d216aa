//! `gltf-pbr-ext`: the glTF 2.0 metallic-roughness material ([`crate::gltf_pbr`]) with the
//! Khronos extensions `KHR_materials_sheen`, `KHR_materials_clearcoat`,
//! `KHR_materials_specular` and `KHR_materials_ior`, layered as their specifications
//! write them. Which extensions are present is a structural choice (`extensions`); with
//! none the model is `gltf-pbr` (a test checks them equal to round-off).
//!
//! With wi = L (light), wo = V (viewer), c = |V·H|, w = (1 − c)⁵, D·V the GGX lobe of
//! [`crate::gltf_pbr`] (its `masking` choice) at α = roughness²:
//!
//! **Core with specular and ior** (`KHR_materials_specular`, "Implementation", which
//! redefines Appendix B's `fresnel_mix` with a weight and an f0 colour; `KHR_materials_ior`
//! for the f0 of the ior):
//!
//! ```text
//! f0_ior   = ((ior − 1)/(ior + 1))²
//! F0       = min(f0_ior · specularColor, 1) · specular          (per channel)
//! F        = F0 + (specular − F0) · w
//! dielectric = F · D·V + (1 − max(F)) · baseColor/π
//! metal      = (baseColor + (1 − baseColor) · w) · D·V
//! core       = (1 − metallic) · dielectric + metallic · metal
//! ```
//!
//! (without the extensions specular = 1, specularColor = 1, ior = 1.5: F = 0.04 + 0.96 w,
//! Appendix B exactly).
//!
//! **Sheen** (`KHR_materials_sheen`, "Implementation Notes", albedo scaling of Estevez &
//! Kulla 2017; the lobe and E in [`crate::sheen`]):
//!
//! ```text
//! f_sheen = sheenColor · D_charlie · min(V_sheen, 1)   (the reference renderers' clamp)
//! scaling = min(1 − max(sheenColor) · E(cos θo), 1 − max(sheenColor) · E(cos θi))
//! sheened = f_sheen + core · scaling
//! ```
//!
//! (the specification's reciprocal two-lookup form, not its one-lookup shortcut).
//!
//! **Clearcoat** (`KHR_materials_clearcoat`, `fresnel_coat`, on top of sheen as the sheen
//! extension requires), with the GGX lobe at α_c = clearcoatRoughness² and the same
//! masking:
//!
//! ```text
//! Fc     = 0.04 + 0.96 (1 − cos θo)⁵                 (N·V, not V·H: the specification's choice)
//! result = sheened · (1 − clearcoat · Fc) + clearcoat · Fc · D_c·V_c
//! ```
//!
//! Because Fc depends on the viewer only, a material with a clear coat is **not
//! reciprocal** ([`Model::is_reciprocal`] is false when `clearcoat` is among the
//! extensions); without one it is. Energy: the core's grazing gain (see
//! [`crate::gltf_pbr`]) remains, so [`Model::conserves_energy`] is false; the sheen and coat
//! layers add none over a conserving (metal) base (tests).
//!
//! | parameter | JSON | extension | domain | default |
//! |-----------|------|-----------|--------|---------|
//! | baseColor, metallic, roughness | as `gltf-pbr` | core | as `gltf-pbr` | 0.5 |
//! | sheenColorFactor | `sheen_color` (RGB) | sheen | [0, 1] | 0.5 |
//! | sheenRoughnessFactor | `sheen_roughness` | sheen | [0.07, 1] | 0.5 |
//! | clearcoatFactor | `clearcoat` | clearcoat | [0, 1] | 0.5 |
//! | clearcoatRoughnessFactor | `clearcoat_roughness` | clearcoat | [1e-3, 1] | 0.1 |
//! | specularFactor | `specular` | specular | [0, 1] | 1 |
//! | specularColorFactor | `specular_color` (RGB) | specular | [0, ∞) | 1 |
//! | ior | `ior` | specular | [1, ∞) | 1.5 |
//! | extensions | `extensions` | structural | subset of `sheen`, `clearcoat`, `specular` | none |
//! | sheen visibility | `sheen_visibility` | structural | `charlie`, `ashikhmin` | `charlie` |
//!
//! The domains are glTF's, except: sheenRoughness ≥ 0.07 (three.js clamps to it; the E
//! table of [`crate::sheen`] starts there), clearcoatRoughness ≥ 1e-3 (as roughness), and
//! ior's special value 0 (a conversion device for specular-glossiness materials, f0 = 1)
//! is refused: specularColor carries the same reflectance. `specular` groups the
//! specular and ior extensions: for an opaque material they act only through the product
//! f0_ior · specularColor.

use crate::gltf_pbr::{self, DIELECTRIC_F0, GltfPbr, ROUGHNESS_DOMAIN, UNIT_DOMAIN};
use crate::json;
use crate::pair::PairGeom;
use crate::params::{above_horizon, channel, check_count, check_rgb};
use crate::sheen::{SHEEN_ROUGHNESS_MIN, SheenVisibility, sheen_albedo, sheen_dv};
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{Model, ModelError, ParamSpec, Rgb};
use serde_json::{Value, json};
use std::f64::consts::FRAC_1_PI;

const M: &str = "gltf-pbr-ext";
/// The most parameters: the core's 5, sheen's 4, clearcoat's 2 and specular's 5.
const MAXP: usize = 16;
/// The domain of `sheen_roughness` (module doc).
pub const SHEEN_ROUGHNESS_DOMAIN: Domain = Domain::closed(SHEEN_ROUGHNESS_MIN, 1.0);
/// The domain of `specular_color`: glTF allows values above 1 (f0 is clamped to 1).
pub const SPECULAR_COLOR_DOMAIN: Domain = Domain::at_least(0.0);
/// The domain of `ior` (module doc).
pub const IOR_DOMAIN: Domain = Domain::at_least(1.0);
/// The clear coat's index of refraction, fixed by `KHR_materials_clearcoat`.
pub const CLEARCOAT_IOR: f64 = 1.5;

/// `KHR_materials_sheen`'s factors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sheen {
    /// sheenColorFactor.
    pub color: Rgb,
    /// sheenRoughnessFactor.
    pub roughness: f64,
}

/// `KHR_materials_clearcoat`'s factors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clearcoat {
    /// clearcoatFactor.
    pub factor: f64,
    /// clearcoatRoughnessFactor.
    pub roughness: f64,
}

/// `KHR_materials_specular`'s factors and `KHR_materials_ior`'s ior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Specular {
    /// specularFactor.
    pub factor: f64,
    /// specularColorFactor.
    pub color: Rgb,
    /// ior.
    pub ior: f64,
}

impl Default for Sheen {
    fn default() -> Self {
        Sheen {
            color: Rgb::splat(0.5),
            roughness: 0.5,
        }
    }
}
impl Default for Clearcoat {
    fn default() -> Self {
        Clearcoat {
            factor: 0.5,
            roughness: 0.1,
        }
    }
}
impl Default for Specular {
    fn default() -> Self {
        Specular {
            factor: 1.0,
            color: Rgb::splat(1.0),
            ior: 1.5,
        }
    }
}

/// The extended glTF material (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct GltfPbrExt {
    core: GltfPbr,
    sheen: Option<Sheen>,
    sheen_visibility: SheenVisibility,
    clearcoat: Option<Clearcoat>,
    specular: Option<Specular>,
}

impl Default for GltfPbrExt {
    fn default() -> Self {
        GltfPbrExt::new(GltfPbr::default())
    }
}

/// The extension names of the JSON `extensions` list, in parameter order.
pub const EXTENSION_NAMES: [&str; 3] = ["sheen", "clearcoat", "specular"];

impl GltfPbrExt {
    /// The core material with no extension.
    pub fn new(core: GltfPbr) -> Self {
        GltfPbrExt {
            core,
            sheen: None,
            sheen_visibility: SheenVisibility::Charlie,
            clearcoat: None,
            specular: None,
        }
    }

    /// Adds (or replaces) the sheen layer.
    pub fn with_sheen(mut self, s: Sheen) -> Result<Self, ModelError> {
        check_rgb("sheen_color", s.color, UNIT_DOMAIN)?;
        check_param("sheen_roughness", s.roughness, SHEEN_ROUGHNESS_DOMAIN)?;
        self.sheen = Some(s);
        Ok(self)
    }

    /// Sets the sheen visibility term.
    pub fn with_sheen_visibility(mut self, v: SheenVisibility) -> Self {
        self.sheen_visibility = v;
        self
    }

    /// Adds (or replaces) the clear coat.
    pub fn with_clearcoat(mut self, c: Clearcoat) -> Result<Self, ModelError> {
        check_param("clearcoat", c.factor, UNIT_DOMAIN)?;
        check_param("clearcoat_roughness", c.roughness, ROUGHNESS_DOMAIN)?;
        self.clearcoat = Some(c);
        Ok(self)
    }

    /// Adds (or replaces) the specular and ior factors.
    pub fn with_specular(mut self, s: Specular) -> Result<Self, ModelError> {
        check_param("specular", s.factor, UNIT_DOMAIN)?;
        check_rgb("specular_color", s.color, SPECULAR_COLOR_DOMAIN)?;
        if s.ior == 0.0 {
            return Err(ModelError::Invalid(format!(
                "`ior` 0 of `{M}` (glTF's specular-glossiness conversion) is not supported: \
                 give the reflectance through `specular_color` with ior 1.5"
            )));
        }
        check_param("ior", s.ior, IOR_DOMAIN)?;
        self.specular = Some(s);
        Ok(self)
    }

    /// The core material.
    pub fn core(&self) -> &GltfPbr {
        &self.core
    }
    /// The sheen layer, if any.
    pub fn sheen(&self) -> Option<Sheen> {
        self.sheen
    }
    /// The sheen visibility term.
    pub fn sheen_visibility(&self) -> SheenVisibility {
        self.sheen_visibility
    }
    /// The clear coat, if any.
    pub fn clearcoat(&self) -> Option<Clearcoat> {
        self.clearcoat
    }
    /// The specular and ior factors, if any.
    pub fn specular(&self) -> Option<Specular> {
        self.specular
    }

    /// The present extensions' names, in parameter order.
    pub fn extensions(&self) -> Vec<&'static str> {
        let on = [
            self.sheen.is_some(),
            self.clearcoat.is_some(),
            self.specular.is_some(),
        ];
        EXTENSION_NAMES
            .iter()
            .zip(on)
            .filter(|(_, o)| *o)
            .map(|(n, _)| *n)
            .collect()
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        let o = json::params_object(params, M)?;
        let exts = read_extensions(&o)?;
        let mut allowed = vec![
            "base_color",
            "metallic",
            "roughness",
            "masking",
            "extensions",
        ];
        let keys: [&[&str]; 3] = [
            &["sheen_color", "sheen_roughness", "sheen_visibility"],
            &["clearcoat", "clearcoat_roughness"],
            &["specular", "specular_color", "ior"],
        ];
        for (k, name) in EXTENSION_NAMES.iter().enumerate() {
            if exts.contains(name) {
                allowed.extend_from_slice(keys[k]);
            }
        }
        json::deny_unknown(&o, &allowed, M).map_err(|e| {
            ModelError::Invalid(format!(
                "{e} (a parameter of an extension needs the extension in `extensions`)"
            ))
        })?;
        let mut core_params = serde_json::Map::new();
        for k in ["base_color", "metallic", "roughness", "masking"] {
            if let Some(v) = o.get(k) {
                core_params.insert(k.into(), v.clone());
            }
        }
        let mut m = GltfPbrExt::new(GltfPbr::from_params_json(&Value::Object(core_params))?);
        if exts.contains(&"sheen") {
            let d = Sheen::default();
            m = m
                .with_sheen(Sheen {
                    color: json::rgb_or(&o, "sheen_color", d.color[0], M)?,
                    roughness: json::number_or(&o, "sheen_roughness", d.roughness, M)?,
                })?
                .with_sheen_visibility(json::choice_or(
                    &o,
                    "sheen_visibility",
                    SheenVisibility::Charlie,
                    M,
                )?);
        }
        if exts.contains(&"clearcoat") {
            let d = Clearcoat::default();
            m = m.with_clearcoat(Clearcoat {
                factor: json::number_or(&o, "clearcoat", d.factor, M)?,
                roughness: json::number_or(&o, "clearcoat_roughness", d.roughness, M)?,
            })?;
        }
        if exts.contains(&"specular") {
            let d = Specular::default();
            m = m.with_specular(Specular {
                factor: json::number_or(&o, "specular", d.factor, M)?,
                color: json::rgb_or(&o, "specular_color", d.color[0], M)?,
                ior: json::number_or(&o, "ior", d.ior, M)?,
            })?;
        }
        Ok(m)
    }

    /// The GGX D·V of the core's masking at `roughness` and ∂(D·V)/∂roughness
    /// ([`crate::gltf_pbr`]'s kernel, [`gltf_pbr::ggx_dv`]).
    fn ggx_dv(&self, roughness: f64, wi: [f64; 3], wo: [f64; 3], h: [f64; 3]) -> (f64, f64) {
        let (dv, dln_r) = gltf_pbr::ggx_dv(roughness, self.core.masking(), [wi, wo, h]);
        (dv, dv * dln_r)
    }

    /// The core with specular/ior (module doc) and, with `grad`, its gradient in the
    /// core's 5 parameters then (if present) the specular block's 5.
    fn core_kernel(&self, p: PairGeom, grad: Option<&mut [Rgb]>) -> Rgb {
        let PairGeom { wi, wo, h, .. } = p;
        let cd = p.cos_d;
        let (dv, ddv_dr) = self.ggx_dv(self.core.roughness(), wi, wo, h);
        let c = cd.clamp(0.0, 1.0);
        let m1 = 1.0 - c;
        let w = m1 * m1 * m1 * m1 * m1;
        let m = self.core.metallic();
        let bc = self.core.base_color();
        let sp = self.specular.unwrap_or_default();
        let r = (sp.ior - 1.0) / (sp.ior + 1.0);
        let f0_ior = r * r;
        let q: [f64; 3] = std::array::from_fn(|k| (f0_ior * sp.color[k]).min(1.0));
        let f: [f64; 3] = std::array::from_fn(|k| q[k] * sp.factor * (1.0 - w) + sp.factor * w);
        // max(F): the first channel attaining it carries its derivative.
        let kmax = (0..3).fold(0, |b, k| if f[k] > f[b] { k } else { b });
        let diff = (1.0 - f[kmax]) * FRAC_1_PI;
        let fm: [f64; 3] = std::array::from_fn(|k| bc[k] + (1.0 - bc[k]) * w);
        let diel: [f64; 3] = std::array::from_fn(|k| f[k] * dv + diff * bc[k]);
        let metal: [f64; 3] = std::array::from_fn(|k| fm[k] * dv);
        let out = Rgb(std::array::from_fn(|k| (1.0 - m) * diel[k] + m * metal[k]));
        let Some(g) = grad else { return out };
        for (k, gk) in g[..3].iter_mut().enumerate() {
            *gk = channel(k, (1.0 - m) * diff + m * dv * (1.0 - w));
        }
        g[3] = Rgb(std::array::from_fn(|k| metal[k] - diel[k]));
        g[4] = Rgb(std::array::from_fn(|k| {
            ((1.0 - m) * f[k] + m * fm[k]) * ddv_dr
        }));
        if self.specular.is_some() {
            // ∂F_k/∂x for x = specular, specular_color_j, ior; the diffuse term follows
            // ∂F_kmax/∂x.
            let term = |df: [f64; 3]| {
                Rgb(std::array::from_fn(|k| {
                    (1.0 - m) * (df[k] * dv - df[kmax] * FRAC_1_PI * bc[k])
                }))
            };
            g[5] = term(std::array::from_fn(|k| q[k] * (1.0 - w) + w));
            let dq_dc: [f64; 3] = std::array::from_fn(|k| {
                if f0_ior * sp.color[k] < 1.0 {
                    f0_ior
                } else {
                    0.0
                }
            });
            for j in 0..3 {
                g[6 + j] = term(std::array::from_fn(|k| {
                    if k == j {
                        sp.factor * (1.0 - w) * dq_dc[j]
                    } else {
                        0.0
                    }
                }));
            }
            // ∂f0_ior/∂ior = 4 (ior − 1)/(ior + 1)³.
            let df0 = 4.0 * (sp.ior - 1.0) / (sp.ior + 1.0).powi(3);
            g[9] = term(std::array::from_fn(|k| {
                sp.factor * (1.0 - w) * sp.color[k] * df0 * if dq_dc[k] > 0.0 { 1.0 } else { 0.0 }
            }));
        }
        out
    }

    /// Index of the first parameter of each extension block (sheen, clearcoat,
    /// specular) in the flat vector, `None` when absent.
    fn offsets(&self) -> [Option<usize>; 3] {
        let mut next = 5;
        let mut take = |on: bool, n: usize| {
            on.then(|| {
                let at = next;
                next += n;
                at
            })
        };
        [
            take(self.sheen.is_some(), 4),
            take(self.clearcoat.is_some(), 2),
            take(self.specular.is_some(), 5),
        ]
    }

    /// f_r of one pair and, with `grad`, its gradient (the first `num_params()` entries).
    fn kernel(&self, p: PairGeom, grad: Option<&mut [Rgb; MAXP]>) -> Rgb {
        let PairGeom { wi, wo, h, .. } = p;
        let Some(mut grad) = above_horizon(&wi, &wo, grad) else {
            return Rgb::ZERO;
        };
        let (zi, zo) = (wi[2], wo[2]);
        let [o_sheen, o_coat, o_spec] = self.offsets();
        // The core's gradient goes into a fixed buffer in core-then-specular order,
        // then to its slots scaled by the layers above.
        let mut cg = [Rgb::ZERO; 10];
        let core = self.core_kernel(p, grad.is_some().then_some(&mut cg[..]));
        let mut scale = 1.0;
        let mut out = core;
        if let (Some(s), Some(os)) = (self.sheen, o_sheen) {
            let vis = self.sheen_visibility;
            let (dv, ddv) = sheen_dv(vis, s.roughness, zi, zo, h[0] * h[0] + h[1] * h[1]);
            let (ei, dei) = sheen_albedo(vis, s.roughness, zi);
            let (eo, deo) = sheen_albedo(vis, s.roughness, zo);
            // min(1 − M Eo, 1 − M Ei) = 1 − M max(Eo, Ei).
            let (e, de) = if eo >= ei { (eo, deo) } else { (ei, dei) };
            let jmax = (0..3).fold(0, |b, k| if s.color[k] > s.color[b] { k } else { b });
            let mmax = s.color[jmax];
            let scaling = 1.0 - mmax * e;
            out = Rgb(std::array::from_fn(|k| s.color[k] * dv + core[k] * scaling));
            scale = scaling;
            if let Some(g) = grad.as_deref_mut() {
                for j in 0..3 {
                    g[os + j] = Rgb(std::array::from_fn(|k| {
                        (if k == j { dv } else { 0.0 }) - if j == jmax { core[k] * e } else { 0.0 }
                    }));
                }
                g[os + 3] = Rgb(std::array::from_fn(|k| {
                    s.color[k] * ddv - core[k] * mmax * de
                }));
            }
        }
        if let (Some(c), Some(oc)) = (self.clearcoat, o_coat) {
            let m1 = 1.0 - zo.min(1.0);
            let fc = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * m1 * m1 * m1 * m1 * m1;
            let (cdv, dcdv) = self.ggx_dv(c.roughness, wi, wo, h);
            let keep = 1.0 - c.factor * fc;
            if let Some(g) = grad.as_deref_mut() {
                if let Some(os) = o_sheen {
                    for gp in &mut g[os..os + 4] {
                        *gp *= keep;
                    }
                }
                g[oc] = Rgb(std::array::from_fn(|k| fc * (cdv - out[k])));
                g[oc + 1] = Rgb::splat(c.factor * fc * dcdv);
            }
            out = Rgb(std::array::from_fn(|k| out[k] * keep + c.factor * fc * cdv));
            scale *= keep;
        }
        if let Some(g) = grad {
            for p in 0..5 {
                g[p] = cg[p] * scale;
            }
            if let Some(osp) = o_spec {
                for p in 0..5 {
                    g[osp + p] = cg[5 + p] * scale;
                }
            }
        }
        out
    }
}

fn read_extensions(o: &serde_json::Map<String, Value>) -> Result<Vec<&'static str>, ModelError> {
    let Some(v) = o.get("extensions") else {
        return Ok(Vec::new());
    };
    let bad = || {
        ModelError::Invalid(format!(
            "`extensions` of `{M}` must be a list of distinct names among {}, found {v}",
            EXTENSION_NAMES.join(", ")
        ))
    };
    let list = v.as_array().ok_or_else(bad)?;
    let mut out = Vec::new();
    for e in list {
        let name = e.as_str().ok_or_else(bad)?;
        let known = EXTENSION_NAMES
            .iter()
            .find(|n| **n == name)
            .ok_or_else(bad)?;
        if out.contains(known) {
            return Err(bad());
        }
        out.push(*known);
    }
    Ok(out)
}

crate::pair::pair_kernel_brdf!(GltfPbrExt);

model_name!(GltfPbrExt, M);

impl Model for GltfPbrExt {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let mut v = self.core.param_specs();
        if self.sheen.is_some() {
            let d = Sheen::default();
            v.extend(ParamSpec::per_channel(
                "sheen_color",
                UNIT_DOMAIN,
                d.color[0],
            ));
            v.push(ParamSpec::shared(
                "sheen_roughness",
                SHEEN_ROUGHNESS_DOMAIN,
                d.roughness,
            ));
        }
        if self.clearcoat.is_some() {
            let d = Clearcoat::default();
            v.push(ParamSpec::shared("clearcoat", UNIT_DOMAIN, d.factor));
            v.push(ParamSpec::shared(
                "clearcoat_roughness",
                ROUGHNESS_DOMAIN,
                d.roughness,
            ));
        }
        if self.specular.is_some() {
            let d = Specular::default();
            v.push(ParamSpec::shared("specular", UNIT_DOMAIN, d.factor));
            v.extend(ParamSpec::per_channel(
                "specular_color",
                SPECULAR_COLOR_DOMAIN,
                1.0,
            ));
            v.push(ParamSpec::shared("ior", IOR_DOMAIN, d.ior));
        }
        v
    }

    fn params(&self) -> Vec<f64> {
        let mut p = self.core.params();
        if let Some(s) = self.sheen {
            p.extend(s.color.0);
            p.push(s.roughness);
        }
        if let Some(c) = self.clearcoat {
            p.extend([c.factor, c.roughness]);
        }
        if let Some(s) = self.specular {
            p.push(s.factor);
            p.extend(s.color.0);
            p.push(s.ior);
        }
        p
    }

    fn num_params(&self) -> usize {
        5 + self
            .offsets()
            .iter()
            .zip([4, 2, 5])
            .map(|(o, n)| if o.is_some() { n } else { 0 })
            .sum::<usize>()
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(self.num_params(), p.len())?;
        let [os, oc, osp] = self.offsets();
        let mut core = self.core.clone();
        core.set_params(&p[..5])?;
        let mut m = GltfPbrExt::new(core).with_sheen_visibility(self.sheen_visibility);
        if let Some(o) = os {
            m = m.with_sheen(Sheen {
                color: Rgb::new(p[o], p[o + 1], p[o + 2]),
                roughness: p[o + 3],
            })?;
        }
        if let Some(o) = oc {
            m = m.with_clearcoat(Clearcoat {
                factor: p[o],
                roughness: p[o + 1],
            })?;
        }
        if let Some(o) = osp {
            m = m.with_specular(Specular {
                factor: p[o],
                color: Rgb::new(p[o + 1], p[o + 2], p[o + 3]),
                ior: p[o + 4],
            })?;
        }
        *self = m;
        Ok(())
    }

    crate::pair::pair_kernel_evals!(MAXP);

    fn to_json(&self) -> Value {
        let mut params = self.core.to_json()["params"].clone();
        let o = params
            .as_object_mut()
            .expect("gltf-pbr params are an object");
        o.insert("extensions".into(), json!(self.extensions()));
        if let Some(s) = self.sheen {
            o.insert("sheen_color".into(), json::rgb_value(s.color));
            o.insert("sheen_roughness".into(), json!(s.roughness));
            o.insert(
                "sheen_visibility".into(),
                json!(self.sheen_visibility.name()),
            );
        }
        if let Some(c) = self.clearcoat {
            o.insert("clearcoat".into(), json!(c.factor));
            o.insert("clearcoat_roughness".into(), json!(c.roughness));
        }
        if let Some(s) = self.specular {
            o.insert("specular".into(), json!(s.factor));
            o.insert("specular_color".into(), json::rgb_value(s.color));
            o.insert("ior".into(), json!(s.ior));
        }
        json!({"model": M, "params": params})
    }

    /// False with a clear coat: its Fresnel weight is taken at N·V (module doc).
    fn is_reciprocal(&self) -> bool {
        self.clearcoat.is_none()
    }

    /// False: the core's dielectric gains energy at grazing angles (module doc).
    fn conserves_energy(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::Brdf;
    use brdfkit_core::direction::spherical;
    use brdfkit_core::quadrature::{AlbedoQuadrature, directional_albedo};
    use brdfkit_core::scattering::Masking;
    use std::f64::consts::PI;

    fn core(masking: Masking) -> GltfPbr {
        GltfPbr::new(Rgb::new(0.8, 0.4, 0.1), 0.3, 0.45)
            .unwrap()
            .with_masking(masking)
            .unwrap()
    }

    const SHEEN: Sheen = Sheen {
        color: Rgb([0.3, 0.7, 0.5]),
        roughness: 0.41,
    };
    const COAT: Clearcoat = Clearcoat {
        factor: 0.6,
        roughness: 0.2,
    };
    const SPEC: Specular = Specular {
        factor: 0.7,
        color: Rgb([1.3, 0.6, 2.1]),
        ior: 1.7,
    };

    /// Every combination of extensions over `core`.
    fn variants(core: GltfPbr, vis: SheenVisibility) -> Vec<GltfPbrExt> {
        (0..8)
            .map(|bits| {
                let mut m = GltfPbrExt::new(core.clone()).with_sheen_visibility(vis);
                if bits & 1 != 0 {
                    m = m.with_sheen(SHEEN).unwrap();
                }
                if bits & 2 != 0 {
                    m = m.with_clearcoat(COAT).unwrap();
                }
                if bits & 4 != 0 {
                    m = m.with_specular(SPEC).unwrap();
                }
                m
            })
            .collect()
    }

    /// The specifications' pseudo-code transcribed in angles, term by term, independent of
    /// the kernel's algebra (E from the same table: its accuracy is sheen.rs's test).
    fn spec_formula(m: &GltfPbrExt, ti: f64, pi: f64, to: f64, po: f64) -> Rgb {
        let l = spherical(ti, pi);
        let v = spherical(to, po);
        let h = (l + v) / (l + v).norm();
        let (nl, nv, nh, vh) = (l.z, v.z, h.z, v.dot(&h).abs());
        let separable = m.core.masking() == Masking::SmithSeparable;
        let ggx = |r: f64| {
            let a2 = (r * r).powi(2);
            let d = a2 / (PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
            let vis = if separable {
                let g1 = |x: f64| 2.0 * x / (x + (a2 + (1.0 - a2) * x * x).sqrt());
                g1(nl) * g1(nv) / (4.0 * nl * nv)
            } else {
                0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt()
                    + nv * (nl * nl * (1.0 - a2) + a2).sqrt())
            };
            d * vis
        };
        let sp = m.specular.unwrap_or_default();
        let spec = ggx(m.core.roughness());
        let f0_ior = ((1.0 - sp.ior) / (1.0 + sp.ior)).powi(2);
        let fr: [f64; 3] = std::array::from_fn(|k| {
            let f0 = (f0_ior * sp.color[k]).min(1.0) * sp.factor;
            f0 + (sp.factor - f0) * (1.0 - vh).powi(5)
        });
        let fmax = fr[0].max(fr[1]).max(fr[2]);
        let bc = m.core.base_color();
        let mut out: [f64; 3] = std::array::from_fn(|k| {
            let diel = fr[k] * spec + (1.0 - fmax) * bc[k] / PI;
            let metal = spec * (bc[k] + (1.0 - bc[k]) * (1.0 - vh).powi(5));
            diel * (1.0 - m.core.metallic()) + metal * m.core.metallic()
        });
        if let Some(s) = m.sheen {
            let alpha_g = s.roughness * s.roughness;
            let inv_r = 1.0 / alpha_g;
            let sin2h = 1.0 - nh * nh;
            let d = (2.0 + inv_r) * sin2h.powf(inv_r * 0.5) / (2.0 * PI);
            let lf = |x: f64| {
                let t = (1.0 - alpha_g).powi(2);
                let mix = |a: f64, b: f64| a * (1.0 - t) + b * t;
                mix(21.5473, 25.3245)
                    / (1.0 + mix(3.82987, 3.32435) * x.powf(mix(0.19823, 0.16801)))
                    + mix(-1.97760, -1.27393) * x
                    + mix(-4.32054, -4.85967)
            };
            let lambda = |c: f64| {
                if c.abs() < 0.5 {
                    lf(c).exp()
                } else {
                    (2.0 * lf(0.5) - lf(1.0 - c)).exp()
                }
            };
            let vis = match m.sheen_visibility {
                SheenVisibility::Charlie => {
                    (1.0 / ((1.0 + lambda(nv) + lambda(nl)) * (4.0 * nv * nl))).min(1.0)
                }
                SheenVisibility::Ashikhmin => (1.0 / (4.0 * (nl + nv - nl * nv))).min(1.0),
            };
            let max3 = s.color[0].max(s.color[1]).max(s.color[2]);
            let e = |x: f64| sheen_albedo(m.sheen_visibility, s.roughness, x).0;
            let scaling = (1.0 - max3 * e(nv)).min(1.0 - max3 * e(nl));
            out = std::array::from_fn(|k| s.color[k] * d * vis + out[k] * scaling);
        }
        if let Some(c) = m.clearcoat {
            let fc = 0.04 + 0.96 * (1.0 - nv.abs()).powi(5);
            let layer = ggx(c.roughness);
            out = std::array::from_fn(|k| out[k] * (1.0 - c.factor * fc) + layer * c.factor * fc);
        }
        Rgb(out)
    }

    #[test]
    fn without_extensions_it_is_gltf_pbr() {
        for masking in [Masking::SmithCorrelated, Masking::SmithSeparable] {
            let c = core(masking);
            let m = GltfPbrExt::new(c.clone());
            for (wi, wo) in random_pairs(3, 300).iter().chain(&hard_case_pairs()) {
                let (a, b) = (m.eval(wi, wo), c.eval(wi, wo));
                for k in 0..3 {
                    assert!((a[k] - b[k]).abs() <= 1e-13 * b[k].abs(), "{a:?} {b:?}");
                }
            }
            // The specular extension at its defaults changes nothing either.
            let d = m.clone().with_specular(Specular::default()).unwrap();
            for (wi, wo) in random_pairs(4, 100) {
                let (a, b) = (d.eval(&wi, &wo), c.eval(&wi, &wo));
                for k in 0..3 {
                    assert!((a[k] - b[k]).abs() <= 1e-13 * b[k].abs(), "{a:?} {b:?}");
                }
            }
        }
    }

    #[test]
    fn matches_the_specification_formulas() {
        for masking in [Masking::SmithCorrelated, Masking::SmithSeparable] {
            for vis in SheenVisibility::ALL {
                for m in variants(core(masking), vis) {
                    assert_matches_angle_formula(&m, 9, 400, 1.5, 1e-11, |a, b, c, d| {
                        spec_formula(&m, a, b, c, d)
                    });
                }
            }
        }
    }

    #[test]
    fn shared_checks_every_variant() {
        let pairs = random_pairs(17, 200);
        for masking in [Masking::SmithCorrelated, Masking::SmithSeparable] {
            for vis in SheenVisibility::ALL {
                for m in variants(core(masking), vis) {
                    assert_paths_agree(&m, &pairs, 0.0);
                    assert_zero_below_horizon(&m);
                    assert_gradient_matches_fd(&m, &pairs, 1e-6, 1e-5);
                    assert_finite_everywhere(&m, &hard_case_pairs());
                    assert_nonnegative(&m, &dense_grid_pairs(12, 6));
                    if m.clearcoat.is_none() {
                        assert!(m.is_reciprocal());
                        assert_reciprocal(&m, &pairs, 1e-12);
                        assert_reciprocal(&m, &hard_case_pairs(), 1e-10);
                    } else {
                        assert!(!m.is_reciprocal());
                        assert!(max_reciprocity_error(&m, &pairs) > 1e-3);
                    }
                }
            }
        }
    }

    #[test]
    fn hard_parameter_grid_stays_finite() {
        let pairs = hard_case_pairs();
        for r in [1e-3, 1.0] {
            for met in [0.0, 1.0] {
                for sr in [SHEEN_ROUGHNESS_MIN, 1.0] {
                    for (cf, cr) in [(0.0, 1e-3), (1.0, 1e-3), (1.0, 1.0)] {
                        for (sf, sc, ior) in [(0.0, 0.0, 1.0), (1.0, 50.0, 1.0), (1.0, 1.0, 40.0)] {
                            let c = GltfPbr::new(Rgb::new(1.0, 0.0, 0.5), met, r).unwrap();
                            for vis in SheenVisibility::ALL {
                                let m = GltfPbrExt::new(c.clone())
                                    .with_sheen_visibility(vis)
                                    .with_sheen(Sheen {
                                        color: Rgb::new(1.0, 0.0, 0.2),
                                        roughness: sr,
                                    })
                                    .unwrap()
                                    .with_clearcoat(Clearcoat {
                                        factor: cf,
                                        roughness: cr,
                                    })
                                    .unwrap()
                                    .with_specular(Specular {
                                        factor: sf,
                                        color: Rgb::splat(sc),
                                        ior,
                                    })
                                    .unwrap();
                                assert_finite_everywhere(&m, &pairs);
                                assert_paths_agree(&m, &pairs, 0.0);
                                assert_nonnegative(&m, &dense_grid_pairs(10, 5));
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn sheen_and_coat_add_no_energy_over_a_metal() {
        let q = AlbedoQuadrature::default();
        let metal = GltfPbr::new(Rgb::splat(1.0), 1.0, 0.3).unwrap();
        let mut worst: f64 = 0.0;
        for vis in SheenVisibility::ALL {
            for sr in [0.07, 0.3, 0.6, 1.0] {
                let m = GltfPbrExt::new(metal.clone())
                    .with_sheen_visibility(vis)
                    .with_sheen(Sheen {
                        color: Rgb::splat(1.0),
                        roughness: sr,
                    })
                    .unwrap()
                    .with_clearcoat(Clearcoat {
                        factor: 1.0,
                        roughness: 0.05,
                    })
                    .unwrap();
                for t in [0.0, 0.6, 1.2, 1.45] {
                    let a = directional_albedo(&m, &spherical(t, 0.0), &q)[0];
                    if vis == SheenVisibility::Charlie {
                        worst = worst.max(a);
                        assert!(a <= 1.005, "sheen r {sr} θ {t}: albedo {a}");
                    }
                }
            }
        }
        eprintln!("largest albedo, white metal + sheen (charlie) + coat: {worst:.4}");
    }

    #[test]
    fn domains_and_json() {
        let m = variants(core(Masking::SmithSeparable), SheenVisibility::Ashikhmin)[7].clone();
        assert_json_round_trip(&m);
        assert_eq!(m.num_params(), 16);
        assert_eq!(m.param_specs().len(), 16);
        let mut m2 = m.clone();
        let mut p = m.params();
        p[15] = 0.5;
        let e = m2.set_params(&p).unwrap_err();
        assert!(e.to_string().contains("ior"), "{e}");
        assert_eq!(m2, m, "a refused set_params leaves the model unchanged");
        let plain = crate::default_model("gltf-pbr-ext").unwrap();
        assert_eq!(plain.num_params(), 5);
        for (bad, needle) in [
            (r#"{"sheen_color": 0.5}"#, "extension"),
            (r#"{"extensions": ["sheen", "sheen"]}"#, "distinct"),
            (
                r#"{"extensions": ["iridescence"]}"#,
                "sheen, clearcoat, specular",
            ),
            (
                r#"{"extensions": ["sheen"], "sheen_roughness": 0.01}"#,
                "sheen_roughness",
            ),
            (
                r#"{"extensions": ["specular"], "ior": 0}"#,
                "specular-glossiness",
            ),
            (
                r#"{"extensions": ["sheen"], "sheen_visibility": "neubelt"}"#,
                "charlie",
            ),
            (
                r#"{"extensions": ["clearcoat"], "clearcoat": 1.5}"#,
                "clearcoat",
            ),
        ] {
            let e =
                crate::from_json_str(&format!(r#"{{"model": "gltf-pbr-ext", "params": {bad}}}"#))
                    .unwrap_err();
            assert!(e.to_string().contains(needle), "{bad}: {e}");
        }
    }
}
#[cfg(test)]
mod grid {
    use super::*;
    use brdfkit_core::Brdf;
    use brdfkit_core::rusinkiewicz::{HalfDiff, from_half_diff};

    /// A MERL grid's cells give unit vectors whose z rounds above 1 (1 + 4e-16 at θh = 0);
    /// the sheen's Λ(1 − μ) must not take a negative power there.
    #[test]
    fn merl_grid_directions_stay_finite() {
        let m = GltfPbrExt::default()
            .with_sheen(Sheen::default())
            .unwrap()
            .with_clearcoat(Clearcoat::default())
            .unwrap();
        let mut grad = vec![Rgb::ZERO; m.num_params()];
        for i in 0..16 {
            for j in 0..16 {
                for k in 0..32 {
                    let th = (i as f64 / 16.0).powi(2) * std::f64::consts::FRAC_PI_2;
                    let td = j as f64 / 16.0 * std::f64::consts::FRAC_PI_2;
                    let pd = k as f64 / 32.0 * std::f64::consts::PI;
                    let (wi, wo) = from_half_diff(&HalfDiff::new(th, 0.0, td, pd));
                    let f = m.eval_grad(&wi, &wo, &mut grad);
                    let ok =
                        (0..3).all(|c| f[c].is_finite() && grad.iter().all(|g| g[c].is_finite()));
                    assert!(ok, "{wi:?} {wo:?} {f:?} {grad:?}");
                    assert_eq!(f, m.eval(&wi, &wo));
                }
            }
        }
    }
}
