//! Rendered spheres: the measured table and each fitted model under the same light,
//! with the same seed, so the difference image shows the model's error and not the
//! sampling noise of two independent renders.

use super::error::ReportError;
use brdfkit_core::Rgb;
use brdfkit_core::Vec3;
use brdfkit_fit::Fitted;
use brdfkit_merl::{Lookup, MerlTable};
use brdfkit_render::env::{Environment, LatLong, uv_to_direction};
use brdfkit_render::material::{MaterialSource, MeasuredBrdf};
use brdfkit_render::output::tonemap_channel;
use brdfkit_render::{RenderOutput, Scene, SceneMaterial, TableBrdf, render};
use brdfkit_rgl::RglBsdf;
use image::{ImageFormat, RgbImage};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::io::Cursor;
use std::sync::Arc;

/// What the sphere renders use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderOptions {
    /// Width and height of each image (pixels).
    pub size: usize,
    /// Samples per pixel under the environment (the point light needs one).
    pub env_spp: usize,
    /// Seed of every render (the same for the table and the models).
    pub seed: u64,
    /// Display difference that saturates the difference image's colours (sRGB units,
    /// 0..1 of the display range).
    pub diff_scale: f64,
}

impl RenderOptions {
    /// Refuses a value out of its domain, naming the setting ([`ReportError::Option`]:
    /// `render_size`, `env_spp`, `diff_scale`).
    pub fn check(&self) -> Result<(), ReportError> {
        let bad = |option, reason: String| Err(ReportError::Option { option, reason });
        if !(8..=1024).contains(&self.size) {
            return bad(
                "render_size",
                format!("{}: must be in 8..=1024 pixels", self.size),
            );
        }
        if !(1..=4096).contains(&self.env_spp) {
            return bad("env_spp", format!("{}: must be in 1..=4096", self.env_spp));
        }
        if !(self.diff_scale > 0.0 && self.diff_scale <= 1.0) {
            return bad(
                "diff_scale",
                format!("{}: must lie in (0, 1]", self.diff_scale),
            );
        }
        Ok(())
    }
}

impl Default for RenderOptions {
    /// 128 × 128, 16 spp under the environment, seed 7, ±0.25 of the display range.
    fn default() -> Self {
        RenderOptions {
            size: 128,
            env_spp: 16,
            seed: 7,
            diff_scale: 0.25,
        }
    }
}

/// The two lightings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Lighting {
    /// One point light, upper left in front: the highlight's shape and the diffuse
    /// falloff.
    Point,
    /// A procedural studio environment (sky, ground, a soft box and a rim light),
    /// sampled with MIS: the material as it looks in a scene.
    Environment,
}

impl Lighting {
    /// Both, in report order.
    pub const ALL: [Lighting; 2] = [Lighting::Point, Lighting::Environment];

    /// Human-facing name.
    pub fn title(self) -> &'static str {
        match self {
            Lighting::Point => "point light",
            Lighting::Environment => "environment",
        }
    }

    /// Its key in JSON (serde's name) and in the tables that list lightings.
    pub fn key(self) -> &'static str {
        match self {
            Lighting::Point => "point",
            Lighting::Environment => "environment",
        }
    }
}

/// How far a model's render is from the table's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ImageDiff {
    /// Mean over the sphere's pixels and the channels of |fit − table| in tone-mapped
    /// display units (0..1).
    pub mean_abs_display: f64,
    /// 99th percentile of the same.
    pub p99_abs_display: f64,
    /// sqrt(Σ |L_fit − L_table|² / Σ |L_table|²) over the sphere's pixels, in linear
    /// radiance.
    pub rel_rms_radiance: f64,
}

/// One lighting's images.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderSet {
    /// The lighting of the images.
    pub lighting: Lighting,
    /// Samples per pixel taken.
    pub spp: usize,
    /// PNG exposure (stops), set from the table's render and used for every image.
    pub exposure: f64,
    /// Table lookups that found no sample (rendered as 0).
    pub table_misses: u64,
    /// Wall time of every render of this lighting (s).
    pub time_s: f64,
    /// The table's image (PNG).
    #[serde(skip)]
    pub table_png: Vec<u8>,
    /// Per model: its image, the difference image (PNGs) and the figures.
    pub models: Vec<ModelRender>,
}

/// One model's render under one lighting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelRender {
    /// The model's image (PNG).
    #[serde(skip)]
    pub png: Vec<u8>,
    /// The difference image against the table's (PNG).
    #[serde(skip)]
    pub diff_png: Vec<u8>,
    /// The difference figures against the table's image.
    pub diff: ImageDiff,
}

fn scene_text(l: Lighting, o: &RenderOptions) -> String {
    let common = format!(
        r#"
[film]
width = {s}
height = {s}
filter = "center"
seed = {seed}
spp = {spp}
show_environment = false

[camera]
position = [0.0, 0.0, 4.2]
look_at = [0.0, 0.0, 0.0]
fov = 31.0

[sphere]
center = [0.0, 0.0, 0.0]
radius = 1.0

[material]
model = {{ model = "{lambert}", params = {{ rho_d = 0.5 }} }}
"#,
        s = o.size,
        lambert = brdfkit_models::lambert::Lambert::NAME,
        seed = o.seed,
        spp = match l {
            Lighting::Point => 1,
            Lighting::Environment => o.env_spp,
        }
    );
    match l {
        Lighting::Point => format!(
            "effects = [\"direct\"]\n{common}\n[[light]]\ntype = \"point\"\nposition = [-2.6, 2.4, 3.4]\nintensity = 60.0\n"
        ),
        // The constant is replaced by the studio image below.
        Lighting::Environment => {
            format!("effects = [\"environment\"]\n{common}\n[environment]\nconstant = 1.0\n")
        }
    }
}

/// The studio environment (lat-long, 128 × 64): a sky graded from the horizon to the
/// zenith, a dark ground, a soft box upper left in front of the sphere and a dimmer
/// rim light behind on the right. Built in memory: the report needs no image file.
pub fn studio_environment() -> Environment {
    let (w, h) = (128usize, 64usize);
    let key = Vec3::new(-1.0, 1.1, 1.0).normalize();
    let rim = Vec3::new(1.6, 0.5, -1.0).normalize();
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let d = uv_to_direction((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64);
            let mut c = if d.y >= 0.0 {
                let t = d.y;
                Rgb([0.55 - 0.3 * t, 0.6 - 0.25 * t, 0.7 - 0.1 * t])
            } else {
                Rgb([0.12, 0.11, 0.10])
            };
            if d.dot(&key) > 14f64.to_radians().cos() {
                c = Rgb::splat(6.0);
            } else if d.dot(&rim) > 8f64.to_radians().cos() {
                c = Rgb([2.5, 2.7, 3.0]);
            }
            texels.push(c);
        }
    }
    Environment::Image(LatLong {
        path: "studio (procedural)".into(),
        width: w,
        height: h,
        texels,
    })
}

fn scene_for(l: Lighting, o: &RenderOptions, m: &SceneMaterial) -> Result<Scene, ReportError> {
    let mut scene = Scene::from_toml_str(&scene_text(l, o), format!("report-{l:?}.toml"))
        .map_err(|e| ReportError::Render(e.to_string()))?;
    for slot in scene.materials.iter_mut() {
        *slot = m.clone();
    }
    if l == Lighting::Environment {
        scene.environment = Some(studio_environment());
    }
    Ok(scene)
}

fn run(scene: &Scene) -> Result<RenderOutput, ReportError> {
    render(scene).map_err(|e| ReportError::Render(e.to_string()))
}

/// What a render shows: a model (fitted or given) or a table (interpolated lookups).
#[derive(Clone, Copy)]
pub enum Shown<'a> {
    /// A model, or one per channel.
    Fitted(&'a Fitted),
    /// A table.
    Table(&'a Arc<MerlTable>),
    /// An RGL-EPFL `.bsdf` file, evaluated directly (not resampled).
    Measured(&'a Arc<RglBsdf>),
}

/// The material of channel `c` of `s` (a per-channel fit has one model per channel).
fn shown_material(s: Shown, c: usize) -> SceneMaterial {
    let model = |m: &dyn brdfkit_core::Model| SceneMaterial::Model {
        model: Arc::from(m.clone_box()),
        source: MaterialSource::Inline,
    };
    match s {
        Shown::Table(t) => SceneMaterial::Table {
            brdf: TableBrdf::new(t.clone(), Lookup::Interpolated),
            source: MaterialSource::Inline,
        },
        Shown::Measured(b) => SceneMaterial::Measured {
            brdf: MeasuredBrdf(b.clone()),
            source: MaterialSource::Inline,
        },
        Shown::Fitted(Fitted::Shared(m)) => model(m.as_ref()),
        Shown::Fitted(Fitted::PerChannel(ms)) => model(ms[c].as_ref()),
    }
}

/// A render of what is shown: its radiance and the render's figures. A per-channel
/// fit renders once per channel (channel c of image c).
fn render_shown(l: Lighting, o: &RenderOptions, s: Shown) -> Result<RenderOutput, ReportError> {
    let mut out = run(&scene_for(l, o, &shown_material(s, 0))?)?;
    if let Shown::Fitted(Fitted::PerChannel(_)) = s {
        for c in 1..3 {
            let r = run(&scene_for(l, o, &shown_material(s, c))?)?.radiance;
            for (d, v) in out.radiance.iter_mut().zip(&r) {
                d[c] = v[c];
            }
        }
    }
    Ok(out)
}

/// Grey of the sphere's outline: between the background's black and the lit body, so
/// it shows where the unlit side ends without being taken for reflected light.
pub const OUTLINE: [u8; 3] = [96, 96, 96];

/// The pixels of the sphere's outline: those whose centre ray misses the sphere next to
/// one (of their four neighbours) whose ray hits it, i.e. a one-pixel ring just outside
/// the silhouette. Under the point light the unlit side is as black as the background,
/// and the sphere would read as an egg without it. The ring lies outside every
/// rendered sphere pixel, so no measured or fitted value is covered and the difference
/// figures do not change (the report's renders sample pixel centres only).
fn outline_mask(scene: &Scene) -> Vec<bool> {
    let (w, h) = (scene.film.width, scene.film.height);
    let hit: Vec<bool> = (0..w * h)
        .map(|k| {
            let ray = scene.camera.ray((k % w) as f64 + 0.5, (k / w) as f64 + 0.5);
            scene
                .sphere
                .as_ref()
                .is_some_and(|s| s.shape.intersect(&ray, f64::INFINITY).is_some())
        })
        .collect();
    (0..w * h)
        .map(|k| {
            let (x, y) = (k % w, k / w);
            let near = [
                (x > 0).then(|| k - 1),
                (x + 1 < w).then(|| k + 1),
                (y > 0).then(|| k - w),
                (y + 1 < h).then(|| k + w),
            ];
            !hit[k] && near.into_iter().flatten().any(|n| hit[n])
        })
        .collect()
}

/// `px` with the outline drawn in.
fn outlined(mut px: Vec<[u8; 3]>, outline: &[bool]) -> Vec<[u8; 3]> {
    for (p, _) in px.iter_mut().zip(outline).filter(|(_, o)| **o) {
        *p = OUTLINE;
    }
    px
}

fn srgb8(radiance: &[Rgb], exposure: f64) -> Vec<[u8; 3]> {
    radiance
        .iter()
        .map(|c| [0, 1, 2].map(|k| tonemap_channel(c[k], exposure)))
        .collect()
}

fn png(size: usize, px: &[[u8; 3]]) -> Result<Vec<u8>, ReportError> {
    let mut img = RgbImage::new(size as u32, size as u32);
    for (p, v) in img.pixels_mut().zip(px) {
        *p = image::Rgb(*v);
    }
    let mut buf = Cursor::new(Vec::new());
    img.write_to(&mut buf, ImageFormat::Png)
        .map_err(|e| ReportError::Render(format!("PNG encoding: {e}")))?;
    Ok(buf.into_inner())
}

/// Exposure (stops) that puts the 90th percentile of the brightest channel of the lit
/// pixels at 0.6 linear (0.8 in sRGB): the diffuse body reads well and only the
/// highlight's core clips.
fn auto_exposure(radiance: &[Rgb]) -> f64 {
    let mut v: Vec<f64> = radiance
        .iter()
        .map(|c| c[0].max(c[1]).max(c[2]))
        .filter(|x| *x > 0.0)
        .collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_unstable_by(f64::total_cmp);
    let p = v[(v.len() * 9 / 10).min(v.len() - 1)];
    (0.6 / p).log2()
}

/// The colour of a signed display difference t (in units of the scale): black at 0,
/// orange where the fit is brighter, blue where it is darker (a dark centre, so the
/// black background and exact pixels look alike).
fn diff_colour(t: f64) -> [u8; 3] {
    let t = t.clamp(-1.0, 1.0);
    let (e, a) = if t >= 0.0 {
        ([255.0, 120.0, 40.0], t)
    } else {
        ([70.0, 150.0, 255.0], -t)
    };
    e.map(|x: f64| (x * a).round() as u8)
}

fn difference(
    o: &RenderOptions,
    table: (&[Rgb], &[[u8; 3]]),
    fit: (&[Rgb], &[[u8; 3]]),
) -> (Vec<[u8; 3]>, ImageDiff) {
    let mut abs = Vec::new();
    let (mut num, mut den) = (0.0, 0.0);
    let mut img = Vec::with_capacity(table.1.len());
    for k in 0..table.1.len() {
        let (lt, lf) = (table.0[k], fit.0[k]);
        let lit = (0..3).any(|c| lt[c] > 0.0 || lf[c] > 0.0);
        let d: [f64; 3] = [0, 1, 2].map(|c| (fit.1[k][c] as f64 - table.1[k][c] as f64) / 255.0);
        if lit {
            abs.extend(d.iter().map(|x| x.abs()));
            for c in 0..3 {
                num += (lf[c] - lt[c]).powi(2);
                den += lt[c].powi(2);
            }
        }
        img.push(diff_colour((d[0] + d[1] + d[2]) / 3.0 / o.diff_scale));
    }
    let mean = if abs.is_empty() {
        0.0
    } else {
        abs.iter().sum::<f64>() / abs.len() as f64
    };
    abs.sort_unstable_by(f64::total_cmp);
    let p99 = if abs.is_empty() {
        0.0
    } else {
        abs[((abs.len() as f64 * 0.99).ceil() as usize).clamp(1, abs.len()) - 1]
    };
    (
        img,
        ImageDiff {
            mean_abs_display: mean,
            p99_abs_display: p99,
            rel_rms_radiance: if den > 0.0 { (num / den).sqrt() } else { 0.0 },
        },
    )
}

/// Renders the measured reference (a table, or a `.bsdf` file from its own evaluation,
/// nothing resampled) and every fitted model under `l`: the report's spheres, and what
/// `brdfkit-study` draws its thumbnails and image scores with.
pub fn render_set(
    l: Lighting,
    o: &RenderOptions,
    reference: Shown,
    fits: &[&Fitted],
) -> Result<RenderSet, ReportError> {
    let shown: Vec<Shown> = fits.iter().map(|f| Shown::Fitted(f)).collect();
    render_set_of(l, o, reference, &shown)
}

/// Renders a reference (the set's `table_png`, which sets the exposure) and each of
/// `others` under `l`, with their differences against the reference.
pub(crate) fn render_set_of(
    l: Lighting,
    o: &RenderOptions,
    reference: Shown,
    others: &[Shown],
) -> Result<RenderSet, ReportError> {
    let t0 = std::time::Instant::now();
    let tab = render_shown(l, o, reference)?;
    // The outline depends on the camera and the sphere, not on the material.
    let ring = outline_mask(&scene_for(l, o, &shown_material(reference, 0))?);
    let exposure = auto_exposure(&tab.radiance);
    let tab8 = srgb8(&tab.radiance, exposure);
    // One model a task: a render fills both cores only while its pixels last, and the
    // PNG encoding after it is serial.
    let models = others
        .par_iter()
        .map(|f| {
            let r = render_shown(l, o, *f)?.radiance;
            let r8 = srgb8(&r, exposure);
            let (diff8, diff) = difference(o, (&tab.radiance, &tab8), (&r, &r8));
            Ok(ModelRender {
                png: png(o.size, &outlined(r8, &ring))?,
                diff_png: png(o.size, &outlined(diff8, &ring))?,
                diff,
            })
        })
        .collect::<Result<Vec<_>, ReportError>>()?;
    Ok(RenderSet {
        lighting: l,
        spp: tab.spp,
        exposure,
        table_misses: tab.stats.table_misses,
        time_s: t0.elapsed().as_secs_f64(),
        table_png: png(o.size, &outlined(tab8, &ring))?,
        models,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lightings_key_is_its_json_name() {
        for l in Lighting::ALL {
            assert_eq!(serde_json::to_value(l).unwrap(), l.key());
        }
    }

    /// The pixels of a PNG.
    fn pixels(png: &[u8]) -> image::RgbImage {
        image::load_from_memory(png).unwrap().to_rgb8()
    }

    #[test]
    fn the_sphere_is_outlined_all_round_outside_its_pixels() {
        // A red Lambertian table under the point light (the lower right is unlit); red,
        // so that no pixel of the sphere is the outline's grey.
        let dims = brdfkit_merl::Dims::new(8, 8, 16).unwrap();
        let rho = Rgb::new(0.3, 0.1, 0.05);
        let table =
            Arc::new(MerlTable::from_fn(dims, |_, _, _| Some(rho / std::f64::consts::PI)).unwrap());
        let lam = Fitted::Shared(
            brdfkit_models::from_json_str(
                r#"{"model": "lambert", "params": {"rho_d": [0.3, 0.1, 0.05]}}"#,
            )
            .unwrap(),
        );
        let o = RenderOptions {
            size: 64,
            ..Default::default()
        };
        let s = render_set(Lighting::Point, &o, Shown::Table(&table), &[&lam]).unwrap();
        // The silhouette's radius in pixels, from the scene's camera alone: a unit
        // sphere seen from 4.2 spans asin(1 / 4.2) off axis; the 31° field of view
        // spans the image's width.
        let size = o.size as f64;
        let radius = (1.0f64 / 4.2).asin().tan() / 15.5f64.to_radians().tan() * size / 2.0;
        for img in [&s.table_png, &s.models[0].png, &s.models[0].diff_png] {
            let img = pixels(img);
            let mut quadrants = [0usize; 4];
            let mut ring = 0usize;
            for (x, y, p) in img.enumerate_pixels() {
                let (dx, dy) = (x as f64 + 0.5 - size / 2.0, y as f64 + 0.5 - size / 2.0);
                let r = dx.hypot(dy);
                if p.0 == OUTLINE {
                    ring += 1;
                    // Just outside the silhouette, never on the sphere.
                    assert!(
                        r > radius && r < radius + 1.5,
                        "({x}, {y}): r {r}, R {radius}"
                    );
                    quadrants[usize::from(dx > 0.0) + 2 * usize::from(dy > 0.0)] += 1;
                } else if r > radius {
                    assert_eq!(p.0, [0, 0, 0], "({x}, {y}) outside the sphere");
                }
            }
            // All round, the unlit lower right included: about the circumference.
            let around = 2.0 * std::f64::consts::PI * radius;
            assert!(
                (ring as f64) > 0.8 * around && (ring as f64) < 1.6 * around,
                "{ring} ring pixels, circumference {around}"
            );
            assert!(
                quadrants.iter().all(|&q| q as f64 > 0.15 * around),
                "{quadrants:?}"
            );
        }
        // The ring is drawn on the images only: an exact fit's figures stay zero.
        assert!(s.models[0].diff.rel_rms_radiance < 1e-9);
        assert!(s.models[0].diff.mean_abs_display < 1e-3);
    }

    #[test]
    fn an_exact_model_renders_like_its_table_and_a_brighter_one_does_not() {
        let dims = brdfkit_merl::Dims::new(16, 16, 32).unwrap();
        let rho = 0.4;
        let table = Arc::new(
            MerlTable::from_fn(dims, |_, _, _| Some(Rgb::splat(rho / std::f64::consts::PI)))
                .unwrap(),
        );
        let lam = |r: f64| {
            Fitted::Shared(
                brdfkit_models::from_json_str(&format!(
                    r#"{{"model": "lambert", "params": {{"rho_d": {r}}}}}"#
                ))
                .unwrap(),
            )
        };
        let o = RenderOptions {
            size: 24,
            env_spp: 4,
            ..Default::default()
        };
        for l in Lighting::ALL {
            let s = render_set(l, &o, Shown::Table(&table), &[&lam(rho), &lam(2.0 * rho)]).unwrap();
            assert!(s.table_png.starts_with(b"\x89PNG"));
            // A constant table is the Lambertian exactly: the same image up to the
            // interpolation's round-off.
            assert!(
                s.models[0].diff.rel_rms_radiance < 1e-9,
                "{l:?} {:?}",
                s.models[0].diff
            );
            // Twice the albedo: twice the radiance everywhere (rel. RMS 1).
            assert!(
                (s.models[1].diff.rel_rms_radiance - 1.0).abs() < 1e-9,
                "{:?}",
                s.models[1].diff
            );
            assert!(s.models[1].diff.mean_abs_display > 0.01);
        }
    }
}
