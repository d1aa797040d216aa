//! The scene file (TOML): parsing, validation, and loading of the files it refers to.
//!
//! See `docs/rendering.md` for the format with a full example. Every key is checked:
//! unknown keys, wrong types and missing fields are [`SceneError::Syntax`] (the TOML
//! parser's message names the key and the line); values outside their domain and
//! contradictory keys are [`SceneError::Invalid`] naming the dotted key; unreadable
//! referenced files name the file. Relative paths are relative to the scene file's
//! directory.

use crate::env::{Environment, LatLong};
use crate::error::SceneError;
use crate::geometry::{Camera, Plane, Sphere};
use crate::material::{MaterialSource, MeasuredBrdf, SceneMaterial, TableBrdf};
use brdfkit_core::{Rgb, Vec3};
use brdfkit_merl::{Lookup, MerlTable};
use brdfkit_rgl::{InputKind, RglBsdf};
use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What a render simulates. Nothing else is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Effect {
    /// Direct light from the point and directional lights (`[[light]]`).
    Direct,
    /// Light from the `[environment]`, by multiple importance sampling.
    Environment,
    /// Visibility tests (shadow rays) for the light of the other effects.
    Shadows,
}

impl Effect {
    /// Every effect, in report order.
    pub const ALL: [Effect; 3] = [Effect::Direct, Effect::Environment, Effect::Shadows];

    /// Its name in the scene file.
    pub fn name(self) -> &'static str {
        match self {
            Effect::Direct => "direct",
            Effect::Environment => "environment",
            Effect::Shadows => "shadows",
        }
    }
}

impl fmt::Display for Effect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The set of requested effects.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Effects {
    /// Direct light from the point and directional lights.
    pub direct: bool,
    /// The environment, if any.
    pub environment: bool,
    /// Visibility of every light sample (shadow rays).
    pub shadows: bool,
}

impl Effects {
    /// Whether `e` is requested.
    pub fn has(&self, e: Effect) -> bool {
        match e {
            Effect::Direct => self.direct,
            Effect::Environment => self.environment,
            Effect::Shadows => self.shadows,
        }
    }
}

/// Where the camera ray goes inside a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PixelFilter {
    /// One camera ray through the pixel centre; `spp` only multiplies the environment
    /// samples. Noise-free for point and directional lights.
    Center,
    /// `spp` camera rays, each uniformly jittered over the pixel (a box filter of one
    /// pixel): antialiased edges.
    Box,
}

/// Multiple-importance-sampling heuristic (Veach 1997, §9.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mis {
    /// w_a = p_a / (p_a + p_b).
    Balance,
    /// w_a = p_a² / (p_a² + p_b²).
    Power,
}

/// Image size and sampling.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Samples per pixel.
    pub spp: usize,
    /// Where in the pixel the camera rays go.
    pub filter: PixelFilter,
    /// Seed of the per-pixel random streams.
    pub seed: u64,
    /// The heuristic combining light and BRDF samples.
    pub mis: Mis,
    /// Camera rays that leave the scene see the environment (with the `environment`
    /// effect); otherwise they are black.
    pub show_environment: bool,
    /// PNG exposure in stops: the PNG shows radiance × 2^exposure.
    pub exposure: f64,
}

/// A point or directional light.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// An isotropic point source of radiant intensity `intensity` (W/sr).
    Point {
        /// Position of the light.
        position: Vec3,
        /// Radiant intensity, W/sr.
        intensity: Rgb,
    },
    /// A distant source: light travels along `direction` (unit) and gives irradiance
    /// `irradiance` (W/m²) on a surface facing it.
    Directional {
        /// Unit direction the light travels along.
        direction: Vec3,
        /// Irradiance on a surface facing it, W/m².
        irradiance: Rgb,
    },
}

/// An object: its shape and the index of its material in [`Scene::materials`].
#[derive(Clone, Debug, PartialEq)]
pub struct Object<S> {
    /// The shape.
    pub shape: S,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

/// A validated scene with every referenced file loaded.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file (or the name given to [`Scene::from_toml_str`]).
    pub path: PathBuf,
    /// The effects to simulate.
    pub effects: Effects,
    /// Image size and sampling.
    pub film: Film,
    /// The camera.
    pub camera: Camera,
    /// The sphere, if any.
    pub sphere: Option<Object<Sphere>>,
    /// The plane, if any.
    pub plane: Option<Object<Plane>>,
    /// The materials, loaded.
    pub materials: Vec<SceneMaterial>,
    /// Point and directional lights.
    pub lights: Vec<Light>,
    /// The environment, if any.
    pub environment: Option<Environment>,
}

// ---------------------------------------------------------------------------------
// Raw TOML structure.

/// A colour: a non-negative number (grey) or `[r, g, b]`.
#[derive(Clone, Copy, Debug)]
struct ColorValue(Rgb);

impl<'de> Deserialize<'de> for ColorValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ColorValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an [r, g, b] array of numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<ColorValue, E> {
                Ok(ColorValue(Rgb::splat(v)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<ColorValue, E> {
                Ok(ColorValue(Rgb::splat(v as f64)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<ColorValue, E> {
                Ok(ColorValue(Rgb::splat(v as f64)))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut s: A) -> Result<ColorValue, A::Error> {
                let mut c = [0.0; 3];
                for (i, slot) in c.iter_mut().enumerate() {
                    *slot = s
                        .next_element::<f64>()?
                        .ok_or_else(|| de::Error::invalid_length(i, &"3 numbers [r, g, b]"))?;
                }
                if s.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &"3 numbers [r, g, b]"));
                }
                Ok(ColorValue(Rgb(c)))
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    effects: Vec<Effect>,
    film: RawFilm,
    camera: RawCamera,
    sphere: Option<RawSphere>,
    plane: Option<RawPlane>,
    material: Option<RawMaterial>,
    #[serde(default)]
    light: Vec<toml::Table>,
    environment: Option<RawEnvironment>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFilm {
    width: i64,
    height: i64,
    spp: Option<i64>,
    filter: Option<PixelFilter>,
    seed: Option<u64>,
    mis: Option<Mis>,
    show_environment: Option<bool>,
    exposure: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    position: [f64; 3],
    look_at: [f64; 3],
    up: Option<[f64; 3]>,
    fov: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSphere {
    center: [f64; 3],
    radius: f64,
    material: Option<RawMaterial>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlane {
    point: [f64; 3],
    normal: [f64; 3],
    material: Option<RawMaterial>,
}

#[derive(Deserialize, Clone)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    /// A path to a model JSON file, or an inline `{model = ..., params = {...}}` table.
    model: Option<toml::Value>,
    /// A path to a MERL binary table.
    table: Option<String>,
    lookup: Option<RawLookup>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawLookup {
    Nearest,
    Interpolated,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPoint {
    position: [f64; 3],
    intensity: ColorValue,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDirectional {
    direction: [f64; 3],
    irradiance: ColorValue,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEnvironment {
    constant: Option<ColorValue>,
    file: Option<String>,
    scale: Option<f64>,
}

// ---------------------------------------------------------------------------------
// Validation.

/// Limits on the film (memory and sanity).
pub const MAX_SIDE: i64 = 16_384;
/// Largest samples-per-pixel value.
pub const MAX_SPP: i64 = 1 << 20;

struct Ctx<'a> {
    path: &'a Path,
    base: &'a Path,
}

impl Ctx<'_> {
    fn invalid(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_path_buf(),
            key: key.into(),
            message: message.into(),
        }
    }

    fn resolve(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base.join(p)
        }
    }

    fn finite3(&self, key: &str, v: [f64; 3]) -> Result<Vec3, SceneError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(Vec3::new(v[0], v[1], v[2]))
        } else {
            Err(self.invalid(key, format!("must be finite, got {v:?}")))
        }
    }

    fn unit3(&self, key: &str, v: [f64; 3]) -> Result<Vec3, SceneError> {
        let w = self.finite3(key, v)?;
        let n = w.norm();
        if !(n > 0.0 && n.is_finite()) {
            return Err(self.invalid(key, "must be a non-zero vector"));
        }
        Ok(w / n)
    }

    fn color(&self, key: &str, c: ColorValue) -> Result<Rgb, SceneError> {
        let c = c.0;
        if c.0.iter().all(|x| x.is_finite() && *x >= 0.0) {
            Ok(c)
        } else {
            Err(self.invalid(
                key,
                format!(
                    "must be finite and non-negative in every channel, got {:?}",
                    c.0
                ),
            ))
        }
    }
}

fn syntax(path: &Path, e: toml::de::Error) -> SceneError {
    SceneError::Syntax {
        path: path.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    }
}

impl Scene {
    /// Changes the film size (a preview at another resolution), keeping the horizontal
    /// field of view. Each side must be in 1..=[`MAX_SIDE`].
    pub fn set_resolution(&mut self, width: usize, height: usize) -> Result<(), SceneError> {
        for (k, v) in [("film.width", width), ("film.height", height)] {
            if !(1..=MAX_SIDE as usize).contains(&v) {
                return Err(SceneError::Invalid {
                    path: self.path.clone(),
                    key: k.into(),
                    message: format!("must be in 1..={MAX_SIDE}, got {v}"),
                });
            }
        }
        self.film.width = width;
        self.film.height = height;
        self.camera = self.camera.resized(width, height);
        Ok(())
    }

    /// Reads and validates a scene file, loading the files it refers to.
    pub fn read(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let text = brdfkit_core::text::read_utf8(path, "the scene file")?;
        Scene::from_toml_str(&text, path)
    }

    /// Parses scene text; `path` names it in errors and its directory anchors relative
    /// paths. Each section is validated in file order by its own function, so the first
    /// error reported is the same whichever sections follow it.
    pub fn from_toml_str(text: &str, path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let base = path.parent().unwrap_or(Path::new(""));
        let cx = Ctx { path, base };
        let raw: RawScene = toml::from_str(text).map_err(|e| syntax(path, e))?;
        let effects = parse_effects(&cx, &raw.effects)?;
        let film = parse_film(&cx, &raw.film)?;
        let camera = parse_camera(&cx, &raw.camera, &film)?;
        let mut materials = Materials::new(&cx, raw.material.as_ref())?;
        let sphere = match &raw.sphere {
            Some(s) => Some(parse_sphere(&cx, s, &camera.position, &mut materials)?),
            None => None,
        };
        let plane = match &raw.plane {
            Some(p) => Some(parse_plane(&cx, p, &mut materials)?),
            None => None,
        };
        check_objects(&cx, raw.material.is_some(), &sphere, &plane)?;
        let lights = parse_lights(&cx, &raw.light, sphere.as_ref(), &effects)?;
        let environment = parse_environment(&cx, raw.environment.as_ref(), &effects)?;
        Ok(Scene {
            path: path.to_path_buf(),
            effects,
            film,
            camera,
            sphere,
            plane,
            materials: materials.list,
            lights,
            environment,
        })
    }
}

/// The `effects` list: each effect at most once, and at least one source of light.
fn parse_effects(cx: &Ctx, list: &[Effect]) -> Result<Effects, SceneError> {
    let mut effects = Effects::default();
    for e in list {
        let slot = match e {
            Effect::Direct => &mut effects.direct,
            Effect::Environment => &mut effects.environment,
            Effect::Shadows => &mut effects.shadows,
        };
        if *slot {
            return Err(cx.invalid("effects", format!("`{e}` is listed twice")));
        }
        *slot = true;
    }
    if !effects.direct && !effects.environment {
        return Err(cx.invalid(
            "effects",
            "asks for no light: list `direct` and/or `environment` (and optionally `shadows`)",
        ));
    }
    Ok(effects)
}

/// `[film]`: sizes and samples within their limits, and the defaults of what is left out.
fn parse_film(cx: &Ctx, f: &RawFilm) -> Result<Film, SceneError> {
    for (k, v) in [("film.width", f.width), ("film.height", f.height)] {
        if !(1..=MAX_SIDE).contains(&v) {
            return Err(cx.invalid(k, format!("must be in 1..={MAX_SIDE}, got {v}")));
        }
    }
    let spp = f.spp.unwrap_or(64);
    if !(1..=MAX_SPP).contains(&spp) {
        return Err(cx.invalid("film.spp", format!("must be in 1..={MAX_SPP}, got {spp}")));
    }
    let exposure = f.exposure.unwrap_or(0.0);
    if !exposure.is_finite() {
        return Err(cx.invalid("film.exposure", "must be finite"));
    }
    Ok(Film {
        width: f.width as usize,
        height: f.height as usize,
        spp: spp as usize,
        filter: f.filter.unwrap_or(PixelFilter::Center),
        seed: f.seed.unwrap_or(0),
        mis: f.mis.unwrap_or(Mis::Power),
        show_environment: f.show_environment.unwrap_or(true),
        exposure,
    })
}

/// `[camera]`: a finite position, a distinct target, an up vector that is not along the
/// view, and a field of view strictly between 0 and 180 degrees.
fn parse_camera(cx: &Ctx, c: &RawCamera, film: &Film) -> Result<Camera, SceneError> {
    let position = cx.finite3("camera.position", c.position)?;
    let look_at = cx.finite3("camera.look_at", c.look_at)?;
    let up = cx.unit3("camera.up", c.up.unwrap_or([0.0, 1.0, 0.0]))?;
    if !(c.fov > 0.0 && c.fov < 180.0) {
        return Err(cx.invalid(
            "camera.fov",
            format!("must be in (0, 180) degrees, got {}", c.fov),
        ));
    }
    let view = look_at - position;
    if view.norm() == 0.0 {
        return Err(cx.invalid("camera.look_at", "equals camera.position"));
    }
    if view.normalize().cross(&up).norm() < 1e-6 {
        return Err(cx.invalid("camera.up", "is parallel to the viewing direction"));
    }
    Ok(Camera::new(
        position,
        look_at,
        up,
        c.fov,
        film.width,
        film.height,
    ))
}

/// The scene's materials, each loaded once; objects refer to them by index. The global
/// `[material]`, when given, is index 0 and serves every object without its own.
struct Materials {
    list: Vec<SceneMaterial>,
    global: Option<usize>,
}

impl Materials {
    fn new(cx: &Ctx, global: Option<&RawMaterial>) -> Result<Materials, SceneError> {
        let mut list = Vec::new();
        if let Some(m) = global {
            list.push(load_material(cx, "material", m)?);
        }
        Ok(Materials {
            global: global.map(|_| 0),
            list,
        })
    }

    /// The index of the material of object `key`: its own (loaded now), else the global.
    fn for_object(
        &mut self,
        cx: &Ctx,
        key: &str,
        own: &Option<RawMaterial>,
    ) -> Result<usize, SceneError> {
        match own {
            Some(m) => {
                self.list
                    .push(load_material(cx, &format!("{key}.material"), m)?);
                Ok(self.list.len() - 1)
            }
            None => self.global.ok_or_else(|| {
                cx.invalid(
                    format!("{key}.material"),
                    "no material: give [material] or [".to_string() + key + ".material]",
                )
            }),
        }
    }
}

/// `[sphere]`: a positive finite radius, and a camera outside it (only the outside is a
/// surface).
fn parse_sphere(
    cx: &Ctx,
    s: &RawSphere,
    camera: &Vec3,
    materials: &mut Materials,
) -> Result<Object<Sphere>, SceneError> {
    let center = cx.finite3("sphere.center", s.center)?;
    if !(s.radius > 0.0 && s.radius.is_finite()) {
        return Err(cx.invalid(
            "sphere.radius",
            format!("must be positive and finite, got {}", s.radius),
        ));
    }
    if (camera - center).norm() <= s.radius {
        return Err(cx.invalid(
            "camera.position",
            "is inside the sphere (only its outside is a surface)",
        ));
    }
    Ok(Object {
        shape: Sphere {
            center,
            radius: s.radius,
        },
        material: materials.for_object(cx, "sphere", &s.material)?,
    })
}

/// `[plane]`: a finite point and a non-zero normal (normalised).
fn parse_plane(
    cx: &Ctx,
    p: &RawPlane,
    materials: &mut Materials,
) -> Result<Object<Plane>, SceneError> {
    Ok(Object {
        shape: Plane {
            point: cx.finite3("plane.point", p.point)?,
            normal: cx.unit3("plane.normal", p.normal)?,
        },
        material: materials.for_object(cx, "plane", &p.material)?,
    })
}

/// At least one object, and a global `[material]` only if some object uses it.
fn check_objects(
    cx: &Ctx,
    has_global: bool,
    sphere: &Option<Object<Sphere>>,
    plane: &Option<Object<Plane>>,
) -> Result<(), SceneError> {
    if sphere.is_none() && plane.is_none() {
        return Err(cx.invalid(
            "sphere",
            "the scene has no object: give [sphere] and/or [plane]",
        ));
    }
    if has_global
        && sphere.as_ref().is_none_or(|s| s.material != 0)
        && plane.as_ref().is_none_or(|p| p.material != 0)
    {
        return Err(cx.invalid(
            "material",
            "is used by no object (every object has its own material)",
        ));
    }
    Ok(())
}

/// `[[light]]`: each table parsed by its `type`, and lights given exactly when the
/// `direct` effect is asked for.
fn parse_lights(
    cx: &Ctx,
    tables: &[toml::Table],
    sphere: Option<&Object<Sphere>>,
    effects: &Effects,
) -> Result<Vec<Light>, SceneError> {
    let lights = tables
        .iter()
        .enumerate()
        .map(|(i, t)| parse_light(cx, &format!("light[{i}]"), t, sphere))
        .collect::<Result<Vec<_>, _>>()?;
    if effects.direct && lights.is_empty() {
        return Err(cx.invalid(
            "effects",
            "`direct` is requested but the scene declares no [[light]]",
        ));
    }
    if !effects.direct && !lights.is_empty() {
        return Err(cx.invalid(
            "light",
            "lights are declared but `direct` is not in `effects`: add it, or remove the lights",
        ));
    }
    Ok(lights)
}

/// One `[[light]]` table (`key` is `light[i]`, which every error names): its `type`
/// picks the typed table the rest must match. A point light must not sit inside the
/// sphere, where it would light nothing.
fn parse_light(
    cx: &Ctx,
    key: &str,
    t: &toml::Table,
    sphere: Option<&Object<Sphere>>,
) -> Result<Light, SceneError> {
    let kind = match t.get("type") {
        Some(toml::Value::String(s)) => s.clone(),
        Some(other) => {
            return Err(cx.invalid(
                format!("{key}.type"),
                format!("must be a string, found {}", other.type_str()),
            ));
        }
        None => {
            return Err(cx.invalid(
                format!("{key}.type"),
                "missing field `type` (\"point\" or \"directional\")",
            ));
        }
    };
    let mut rest = t.clone();
    rest.remove("type");
    let sub = |e: toml::de::Error| cx.invalid(key, e.message().trim_end().to_string());
    match kind.as_str() {
        "point" => {
            let p: RawPoint = toml::Value::Table(rest).try_into().map_err(sub)?;
            let position = cx.finite3(&format!("{key}.position"), p.position)?;
            if let Some(s) = sphere
                && (position - s.shape.center).norm() <= s.shape.radius
            {
                return Err(cx.invalid(
                    format!("{key}.position"),
                    "is inside the sphere: it would light nothing",
                ));
            }
            Ok(Light::Point {
                position,
                intensity: cx.color(&format!("{key}.intensity"), p.intensity)?,
            })
        }
        "directional" => {
            let d: RawDirectional = toml::Value::Table(rest).try_into().map_err(sub)?;
            Ok(Light::Directional {
                direction: cx.unit3(&format!("{key}.direction"), d.direction)?,
                irradiance: cx.color(&format!("{key}.irradiance"), d.irradiance)?,
            })
        }
        other => Err(cx.invalid(
            format!("{key}.type"),
            format!("unknown light type `{other}` (expected \"point\" or \"directional\"; the environment is [environment])"),
        )),
    }
}

/// `[environment]`, loaded, given exactly when the `environment` effect is asked for.
fn parse_environment(
    cx: &Ctx,
    raw: Option<&RawEnvironment>,
    effects: &Effects,
) -> Result<Option<Environment>, SceneError> {
    let environment = match raw {
        None => None,
        Some(e) => Some(load_environment(cx, e)?),
    };
    if effects.environment && environment.is_none() {
        return Err(cx.invalid(
            "effects",
            "`environment` is requested but the scene has no [environment]",
        ));
    }
    if !effects.environment && environment.is_some() {
        return Err(cx.invalid(
            "environment",
            "is declared but `environment` is not in `effects`: add it, or remove [environment]",
        ));
    }
    Ok(environment)
}

fn load_material(cx: &Ctx, key: &str, m: &RawMaterial) -> Result<SceneMaterial, SceneError> {
    match (&m.model, &m.table) {
        (Some(_), Some(_)) => Err(cx.invalid(key, "give either `model` or `table`, not both")),
        (None, None) => {
            Err(cx.invalid(key, "needs `model` (JSON path or inline table) or `table`"))
        }
        (Some(v), None) => {
            if m.lookup.is_some() {
                return Err(cx.invalid(
                    format!("{key}.lookup"),
                    "applies to a `table` only, not to a `model`",
                ));
            }
            let mkey = format!("{key}.model");
            let (json, file) = match v {
                toml::Value::String(p) => {
                    let file = cx.resolve(p);
                    let text =
                        std::fs::read_to_string(&file).map_err(|source| SceneError::File {
                            scene: cx.path.to_path_buf(),
                            key: mkey.clone(),
                            file: file.clone(),
                            source,
                        })?;
                    let json: serde_json::Value =
                        serde_json::from_str(&text).map_err(|source| SceneError::ModelJson {
                            scene: cx.path.to_path_buf(),
                            key: mkey.clone(),
                            file: file.clone(),
                            source,
                        })?;
                    (json, Some(file))
                }
                toml::Value::Table(_) => {
                    let json = serde_json::to_value(v).map_err(|e| {
                        cx.invalid(
                            mkey.clone(),
                            format!("cannot be read as a model description: {e}"),
                        )
                    })?;
                    (json, None)
                }
                other => {
                    return Err(cx.invalid(
                        mkey,
                        format!(
                            "must be a path to a model JSON file or an inline table {{ model = \"...\", params = {{ ... }} }}, found {}",
                            other.type_str()
                        ),
                    ));
                }
            };
            let model = brdfkit_models::from_json(&json).map_err(|source| SceneError::Model {
                scene: cx.path.to_path_buf(),
                key: mkey.clone(),
                file: file.clone(),
                source: Box::new(source),
            })?;
            Ok(SceneMaterial::Model {
                model: Arc::from(model),
                source: match file {
                    Some(f) => MaterialSource::ModelFile(f),
                    None => MaterialSource::Inline,
                },
            })
        }
        (None, Some(p)) => {
            let file = cx.resolve(p);
            // By content, as every reader of a table ([`brdfkit_rgl::InputKind`]).
            if InputKind::of_file(&file).is_ok_and(|k| k == InputKind::Rgl) {
                return load_measured(cx, key, m, file);
            }
            let table = MerlTable::read(&file).map_err(|source| SceneError::Table {
                scene: cx.path.to_path_buf(),
                key: format!("{key}.table"),
                source: Box::new(source),
            })?;
            let lookup = match m.lookup.unwrap_or(RawLookup::Nearest) {
                RawLookup::Nearest => Lookup::Nearest,
                RawLookup::Interpolated => Lookup::Interpolated,
            };
            Ok(SceneMaterial::Table {
                brdf: TableBrdf::new(Arc::new(table), lookup),
                source: MaterialSource::TableFile(file),
            })
        }
    }
}

/// A `table` that is an RGL-EPFL `.bsdf`: evaluated directly, so a `lookup` (which
/// picks how a MERL table is read between cells) does not apply.
fn load_measured(
    cx: &Ctx,
    key: &str,
    m: &RawMaterial,
    file: PathBuf,
) -> Result<SceneMaterial, SceneError> {
    if m.lookup.is_some() {
        return Err(cx.invalid(
            format!("{key}.lookup"),
            "applies to a MERL table only; this `table` is an RGL-EPFL .bsdf, evaluated as it is",
        ));
    }
    let bsdf = RglBsdf::read(&file).map_err(|source| SceneError::Measured {
        scene: cx.path.to_path_buf(),
        key: format!("{key}.table"),
        source: Box::new(source),
    })?;
    Ok(SceneMaterial::Measured {
        brdf: MeasuredBrdf(Arc::new(bsdf)),
        source: MaterialSource::MeasuredFile(file),
    })
}

/// The sRGB transfer function, decoding (IEC 61966-2-1): encoded value → linear.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn load_environment(cx: &Ctx, e: &RawEnvironment) -> Result<Environment, SceneError> {
    let scale = e.scale.unwrap_or(1.0);
    if !(scale.is_finite() && scale >= 0.0) {
        return Err(cx.invalid(
            "environment.scale",
            format!("must be finite and non-negative, got {scale}"),
        ));
    }
    match (&e.constant, &e.file) {
        (Some(_), Some(_)) => {
            Err(cx.invalid("environment", "give either `constant` or `file`, not both"))
        }
        (None, None) => Err(cx.invalid(
            "environment",
            "needs `constant` (a radiance) or `file` (a lat-long EXR or PNG)",
        )),
        (Some(c), None) => Ok(Environment::Constant(
            cx.color("environment.constant", *c)? * scale,
        )),
        (None, Some(p)) => {
            let file = cx.resolve(p);
            let key = "environment.file".to_string();
            let img_err = |message: String| SceneError::Image {
                scene: cx.path.to_path_buf(),
                key: key.clone(),
                file: file.clone(),
                message,
            };
            let reader = image::ImageReader::open(&file).map_err(|source| SceneError::File {
                scene: cx.path.to_path_buf(),
                key: key.clone(),
                file: file.clone(),
                source,
            })?;
            let reader = reader
                .with_guessed_format()
                .map_err(|e| img_err(format!("cannot detect the format: {e}")))?;
            let format = reader.format();
            let linear = match format {
                Some(image::ImageFormat::OpenExr) => true,
                Some(image::ImageFormat::Png) => false,
                other => {
                    return Err(img_err(format!(
                        "unsupported image format {other:?}: use a lat-long EXR (linear) or PNG (sRGB)"
                    )));
                }
            };
            let img = reader
                .decode()
                .map_err(|e| img_err(format!("cannot decode: {e}")))?;
            let rgb = img.to_rgb32f();
            let (w, h) = (rgb.width() as usize, rgb.height() as usize);
            if w == 0 || h == 0 {
                return Err(img_err("is empty".into()));
            }
            let mut texels = Vec::with_capacity(w * h);
            for (i, p) in rgb.pixels().enumerate() {
                let mut c = Rgb::new(p[0] as f64, p[1] as f64, p[2] as f64);
                if !linear {
                    // 8/16-bit PNG values are sRGB-encoded; radiance is linear.
                    c = c.map(srgb_to_linear);
                }
                if !(c.is_finite() && c.min_channel() >= 0.0) {
                    return Err(img_err(format!(
                        "texel ({}, {}) is {:?}: radiance must be finite and non-negative",
                        i % w,
                        i / w,
                        c.0
                    )));
                }
                texels.push(c * scale);
            }
            Ok(Environment::Image(LatLong {
                path: file,
                width: w,
                height: h,
                texels,
            }))
        }
    }
}
