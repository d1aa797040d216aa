//! The renderer against independent truth: closed forms computed here from the scene's
//! numbers (own camera rays, own ray-sphere algebra), quadrature, and a second
//! rendering path (a MERL table of a model against the model itself).

mod common;

use brdfkit_core::quadrature::{AlbedoQuadrature, directional_albedo};
use brdfkit_core::{Rgb, Vec3};
use brdfkit_merl::{Dims, MerlTable};
use brdfkit_models::lambert::Lambert;
use brdfkit_render::{RenderOutput, Scene, render};
use common::{Camera, film_camera_sphere};
use std::f64::consts::PI;
use std::path::Path;

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, "test.toml").unwrap_or_else(|e| panic!("{e}"))
}

fn scene_in(dir: &Path, text: &str) -> Scene {
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    Scene::read(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// Ray-sphere by the textbook quadratic; None also when the ray grazes within `margin`
/// of tangency (those pixels are left out: either answer is right).
fn hit_sphere(o: Vec3, d: Vec3, c: Vec3, r: f64, margin: f64) -> Option<Option<Vec3>> {
    let oc = o - c;
    let b = oc.dot(&d);
    let disc = b * b - (oc.norm_squared() - r * r);
    if disc.abs() < margin {
        return None;
    }
    if disc < 0.0 {
        return Some(None);
    }
    let t = -b - disc.sqrt();
    Some((t > 0.0).then(|| o + t * d))
}

struct View {
    pos: Vec3,
    at: Vec3,
    fov: f64,
    w: usize,
    h: usize,
}

impl View {
    /// `[film]`, `[camera]` and `[sphere]` for this view and film.
    fn blocks(&self, film: &str, center: [f64; 3]) -> String {
        let cam = Camera {
            position: [self.pos.x, self.pos.y, self.pos.z],
            look_at: [self.at.x, self.at.y, self.at.z],
            fov: self.fov,
        };
        film_camera_sphere((self.w, self.h), film, &cam, center, 1.0)
    }

    /// The documented camera model, written again here: the ray through the centre of
    /// pixel (x, y), horizontal field of view, up = +y.
    fn dir(&self, x: usize, y: usize) -> Vec3 {
        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
        let f = (self.at - self.pos).normalize();
        let r = f.cross(&Vec3::new(0.0, 1.0, 0.0)).normalize();
        let u = r.cross(&f);
        let t = (self.fov.to_radians() / 2.0).tan();
        let sx = (2.0 * px / self.w as f64 - 1.0) * t;
        let sy = (1.0 - 2.0 * py / self.h as f64) * t * self.h as f64 / self.w as f64;
        (f + sx * r + sy * u).normalize()
    }
}

const SPHERE_VIEW: View = View {
    pos: Vec3::new(0.3, 0.6, 4.0),
    at: Vec3::new(0.0, 0.0, 0.0),
    fov: 36.0,
    w: 48,
    h: 40,
};

fn sphere_scene(effects: &str, material: &str, lights: &str, film_extra: &str) -> String {
    let blocks = SPHERE_VIEW.blocks(film_extra, [0.0; 3]);
    format!("effects = {effects}\n{blocks}[material]\n{material}\n{lights}\n")
}

/// The sphere view with `material` under `lights` (direct light only), written in `dir`
/// (where the files it names are) and rendered.
fn render_direct_in(dir: &Path, material: &str, lights: &str) -> RenderOutput {
    render(&scene_in(
        dir,
        &sphere_scene(r#"["direct"]"#, material, lights, ""),
    ))
    .unwrap()
}

/// For each pixel of the sphere view: Some(normal) on the sphere, None off it, skipping
/// silhouette pixels.
fn sphere_pixels() -> Vec<(usize, usize, Option<Vec3>)> {
    let v = &SPHERE_VIEW;
    let mut out = Vec::new();
    for y in 0..v.h {
        for x in 0..v.w {
            if let Some(hit) = hit_sphere(v.pos, v.dir(x, y), Vec3::zeros(), 1.0, 1e-6) {
                out.push((x, y, hit));
            }
        }
    }
    out
}

#[test]
fn lambert_sphere_under_a_directional_light_is_exact_at_every_pixel() {
    let rho = Rgb::new(0.8, 0.5, 0.3);
    let e = Rgb::new(2.0, 3.0, 4.0);
    let d = Vec3::new(-0.6, -0.5, -0.7).normalize();
    let s = scene(&sphere_scene(
        r#"["direct"]"#,
        r#"model = { model = "lambert", params = { rho_d = [0.8, 0.5, 0.3] } }"#,
        r#"[[light]]
type = "directional"
direction = [-0.6, -0.5, -0.7]
irradiance = [2, 3, 4]"#,
        r#"filter = "center""#,
    ));
    let out = render(&s).unwrap();
    let (mut lit, mut dark) = (0, 0);
    for (x, y, hit) in sphere_pixels() {
        let got = out.pixel(x, y);
        let want = match hit {
            None => Rgb::ZERO,
            // L = ρ/π · E · cos θ, cos θ = n · (−d), zero past the terminator.
            Some(n) => rho / PI * e * n.dot(&-d).max(0.0),
        };
        if want.max_channel() > 0.0 {
            lit += 1;
        } else {
            dark += 1;
        }
        for c in 0..3 {
            assert!(
                (got[c] - want[c]).abs() <= 1e-12 * want[c].max(1.0),
                "pixel ({x}, {y}) channel {c}: {} vs {}",
                got[c],
                want[c]
            );
        }
    }
    assert!(lit > 400 && dark > 400, "lit {lit}, dark {dark}");
    // Deterministic estimator: no spread.
    assert!(out.std_error.iter().all(|s| *s == Rgb::ZERO));
}

#[test]
fn lambert_sphere_under_a_point_light_is_exact_at_every_pixel() {
    let light = Vec3::new(2.0, 3.0, 2.5);
    let intensity = Rgb::new(10.0, 20.0, 30.0);
    let rho = 0.7;
    let s = scene(&sphere_scene(
        r#"["direct", "shadows"]"#,
        r#"model = { model = "lambert", params = { rho_d = 0.7 } }"#,
        r#"[[light]]
type = "point"
position = [2, 3, 2.5]
intensity = [10, 20, 30]"#,
        "",
    ));
    let out = render(&s).unwrap();
    for (x, y, hit) in sphere_pixels() {
        let want = match hit {
            None => Rgb::ZERO,
            Some(p) => {
                // L = ρ/π · I cos θ / r².
                let to = light - p;
                let cos = (p.dot(&to) / to.norm()).max(0.0);
                intensity * (rho / PI * cos / to.norm_squared())
            }
        };
        let got = out.pixel(x, y);
        for c in 0..3 {
            assert!((got[c] - want[c]).abs() <= 1e-12 * want[c].max(1.0));
        }
    }
}

fn check_mc(out: &RenderOutput, expected: impl Fn(usize, usize) -> Option<Rgb>, what: &str) {
    // Per pixel and channel within 5 standard errors (4,000-odd checks: a correct
    // estimator fails one with probability ~1e-3); the mean over pixels within 4
    // standard errors of the mean; and the standard errors small enough for the test
    // to mean something.
    let (mut n, mut sum_d, mut sum_var, mut sum_rel_se) = (0usize, 0.0, 0.0, 0.0);
    let mut worst: f64 = 0.0;
    for y in 0..out.height {
        for x in 0..out.width {
            let Some(want) = expected(x, y) else { continue };
            let got = out.pixel(x, y);
            let se = out.pixel_std_error(x, y);
            for c in 0..3 {
                let d = got[c] - want[c];
                assert!(
                    d.abs() <= 5.0 * se[c] + 1e-12,
                    "{what}: pixel ({x}, {y}) channel {c}: {} vs {} (σ {})",
                    got[c],
                    want[c],
                    se[c]
                );
                worst = worst.max(d.abs() / want[c].max(1e-300));
                sum_d += d;
                sum_var += se[c] * se[c];
                sum_rel_se += se[c] / want[c].max(1e-300);
                n += 1;
            }
        }
    }
    assert!(n > 300, "{what}: only {n} values checked");
    let mean_se = sum_var.sqrt() / n as f64;
    assert!(
        (sum_d / n as f64).abs() <= 4.0 * mean_se,
        "{what}: mean deviation {} > 4 × {}",
        sum_d / n as f64,
        mean_se
    );
    // σ here is the i.i.d. estimate, an upper bound for the stratified samples.
    let rel_se = sum_rel_se / n as f64;
    assert!(
        rel_se < 0.06,
        "{what}: mean relative σ {rel_se} too large to test anything"
    );
    println!(
        "{what}: {n} values, mean relative σ {:.3} %, worst relative deviation {:.3} %, \
         mean deviation {:.2e} (σ of the mean {:.2e})",
        100.0 * rel_se,
        100.0 * worst,
        sum_d / n as f64,
        mean_se
    );
}

#[test]
fn constant_environment_on_a_lambert_sphere_is_rho_times_l() {
    let rho = Rgb::new(0.8, 0.5, 0.3);
    let l = Rgb::new(0.9, 1.0, 1.2);
    for (mis, filter) in [("power", "center"), ("balance", "center"), ("power", "box")] {
        let s = scene(&sphere_scene(
            r#"["environment"]"#,
            r#"model = { model = "lambert", params = { rho_d = [0.8, 0.5, 0.3] } }"#,
            "[environment]\nconstant = [0.9, 1.0, 1.2]",
            &format!("spp = 64\nmis = \"{mis}\"\nfilter = \"{filter}\"\nshow_environment = false"),
        ));
        let out = render(&s).unwrap();
        let hits: std::collections::HashMap<(usize, usize), bool> = sphere_pixels()
            .into_iter()
            .map(|(x, y, h)| ((x, y), h.is_some()))
            .collect();
        // The box filter averages over the pixel: leave out pixels near the silhouette.
        let interior = |x: usize, y: usize| {
            filter == "center"
                || (-1i64..=1).all(|dy| {
                    (-1i64..=1).all(|dx| {
                        hits.get(&((x as i64 + dx) as usize, (y as i64 + dy) as usize))
                            == Some(&true)
                    })
                })
        };
        check_mc(
            &out,
            |x, y| {
                match hits.get(&(x, y)) {
                    Some(true) if interior(x, y) => Some(rho * l),
                    Some(false) => Some(Rgb::ZERO),
                    _ => None,
                }
                .filter(|v| v.max_channel() > 0.0)
            },
            &format!("constant environment, {mis} heuristic, {filter} filter"),
        );
        // Background pixels are black (show_environment = false) and noise-free.
        for (x, y, h) in sphere_pixels() {
            if h.is_none() && filter == "center" {
                assert_eq!(out.pixel(x, y), Rgb::ZERO);
            }
        }
    }
}

#[test]
fn white_furnace_glossy_sphere_returns_its_directional_albedo() {
    // Under a uniform environment of radiance 1, L(wo) = ∫ f cos θi dωi = a(wo), the
    // directional albedo, computed here by the core's Gauss-Legendre quadrature.
    let json = r#"{"model":"cook-torrance","params":{"rho_d":0.1,"rho_s":0.9,"alpha":0.25,"fresnel":"none"}}"#;
    let model = brdfkit_models::from_json_str(json).unwrap();
    let s = scene(&sphere_scene(
        r#"["environment"]"#,
        r#"model = { model = "cook-torrance", params = { rho_d = 0.1, rho_s = 0.9, alpha = 0.25, fresnel = "none" } }"#,
        "[environment]\nconstant = 1.0",
        "spp = 256\nshow_environment = false",
    ));
    let out = render(&s).unwrap();
    let v = &SPHERE_VIEW;
    let mut albedo = std::collections::HashMap::new();
    for (x, y, hit) in sphere_pixels() {
        if let Some(n) = hit {
            let cos_o = n.dot(&-v.dir(x, y));
            if cos_o < 0.05 {
                continue; // grazing: the quadrature's own error grows (see core docs)
            }
            let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
            let a = directional_albedo(model.as_ref(), &wo, &AlbedoQuadrature::default());
            albedo.insert((x, y), a);
        }
    }
    check_mc(
        &out,
        |x, y| albedo.get(&(x, y)).copied(),
        "white furnace, GGX α = 0.25",
    );
}

/// A w x h image that is `bright` where `lit(x, y)`, `dark` elsewhere.
fn two_tone<P: image::Pixel>(
    (w, h): (u32, u32),
    lit: impl Fn(u32, u32) -> bool,
    bright: P,
    dark: P,
) -> image::ImageBuffer<P, Vec<P::Subpixel>> {
    image::ImageBuffer::from_fn(w, h, |x, y| if lit(x, y) { bright } else { dark })
}

#[test]
fn lat_long_images_light_a_lambert_sphere_as_half_skies() {
    // A sky that is L above the horizon (y > 0) and black below gives a Lambertian
    // surface of normal n the irradiance π L (1 + n_y)/2, so radiance ρ L (1 + n_y)/2.
    // The same with the bright half x > 0 (u in [0, 1/2)) checks the azimuth mapping.
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (64u32, 32u32);
    // EXR, linear: bright rows v < 1/2.
    let black = image::Rgb([0.0f32; 3]);
    two_tone(
        (w, h),
        |_, y| y < h / 2,
        image::Rgb([2.0f32, 1.0, 0.5]),
        black,
    )
    .save(dir.path().join("sky.exr"))
    .unwrap();
    // PNG, sRGB 8-bit: bright columns u < 1/2, value 188 → linear 0.5029.
    two_tone(
        (w, h),
        |x, _| x < w / 2,
        image::Rgb([255u8, 188, 0]),
        image::Rgb([0; 3]),
    )
    .save(dir.path().join("east.png"))
    .unwrap();
    let srgb188 = ((188.0 / 255.0 + 0.055) / 1.055f64).powf(2.4);
    let rho = 0.6;
    for (file, l, axis) in [
        ("sky.exr", Rgb::new(2.0, 1.0, 0.5), 1usize),
        ("east.png", Rgb::new(1.0, srgb188, 0.0), 0usize),
    ] {
        let s = scene_in(
            dir.path(),
            &sphere_scene(
                r#"["environment"]"#,
                r#"model = { model = "lambert", params = { rho_d = 0.6 } }"#,
                &format!("[environment]\nfile = \"{file}\""),
                "spp = 256\nshow_environment = false",
            ),
        );
        let out = render(&s).unwrap();
        let normals: std::collections::HashMap<_, _> = sphere_pixels()
            .into_iter()
            .filter_map(|(x, y, h)| h.map(|n| ((x, y), n)))
            .collect();
        check_mc(
            &out,
            |x, y| {
                normals
                    .get(&(x, y))
                    .map(|n| l * (rho * (1.0 + n[axis]) / 2.0))
                    .filter(|v| v.max_channel() > 0.0 && (1.0 + 0.0f64).is_finite())
                    // Channels that are exactly 0 (blue of the PNG) are checked too:
                    // check_mc needs want > 0 only for its relative figures.
                    .map(|v| v.map(|c| c.max(0.0)))
            },
            file,
        );
        // Shown background: the image itself, texel for texel.
        let shown = {
            let mut t = s.clone();
            t.film.show_environment = true;
            render(&t).unwrap()
        };
        let v = &SPHERE_VIEW;
        for (x, y, hit) in sphere_pixels() {
            if hit.is_none() {
                let d = v.dir(x, y);
                let bright = if axis == 1 { d.y > 0.0 } else { d.x > 0.0 };
                let want = if bright { l } else { Rgb::ZERO };
                let got = shown.pixel(x, y);
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() < 1e-6,
                        "{file} background ({x},{y})"
                    );
                }
            }
        }
    }
}

const SHADOW_VIEW: View = View {
    pos: Vec3::new(0.0, 3.0, 5.0),
    at: Vec3::new(0.0, -0.5, 0.0),
    fov: 50.0,
    w: 64,
    h: 48,
};

fn shadow_scene(effects: &str, lights: &str, film_extra: &str, sphere_y: f64) -> String {
    let blocks = SHADOW_VIEW.blocks(film_extra, [0.0, sphere_y, 0.0]);
    format!(
        r#"effects = {effects}
{blocks}[plane]
point = [0, -1, 0]
normal = [0, 1, 0]
[material]
model = {{ model = "lambert", params = {{ rho_d = 0.5 }} }}
{lights}
"#
    )
}

/// The shadow scene with `effects` and `lights`, the sphere on the plane, rendered.
fn render_shadow_scene(effects: &str, lights: &str) -> RenderOutput {
    render(&scene(&shadow_scene(effects, lights, "", 0.0))).unwrap()
}

/// The pixels of the shadow view that see the plane (the sphere's centre at height
/// `sphere_y`), with the plane point each sees.
fn plane_pixels(sphere_y: f64) -> impl Iterator<Item = ((usize, usize), Vec3)> {
    (0..SHADOW_VIEW.h)
        .flat_map(|y| (0..SHADOW_VIEW.w).map(move |x| (x, y)))
        .filter_map(move |(x, y)| plane_point(x, y, sphere_y).map(|p| ((x, y), p)))
}

/// Plane hit point of pixel (x, y) when the ray misses the sphere (with a margin).
fn plane_point(x: usize, y: usize, sphere_y: f64) -> Option<Vec3> {
    let v = &SHADOW_VIEW;
    let d = v.dir(x, y);
    match hit_sphere(v.pos, d, Vec3::new(0.0, sphere_y, 0.0), 1.0, 1e-3) {
        Some(None) => {}
        _ => return None,
    }
    let t = (-1.0 - v.pos.y) / d.y;
    (t > 0.0).then(|| v.pos + t * d)
}

#[test]
fn a_sphere_shadows_the_plane_under_a_directional_light_only_with_shadows() {
    let light = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = 2.5";
    let with = render_shadow_scene(r#"["direct", "shadows"]"#, light);
    let without = render_shadow_scene(r#"["direct"]"#, light);
    let lit = 0.5 / PI * 2.5;
    let (mut shadowed, mut open) = (0, 0);
    for ((x, y), p) in plane_pixels(0.0) {
        let r = p.x.hypot(p.z);
        // Light from straight above: the shadow is the unit disc under the sphere.
        assert!((without.pixel(x, y)[0] - lit).abs() < 1e-12);
        if r < 0.98 {
            assert_eq!(with.pixel(x, y), Rgb::ZERO, "({x}, {y}) r = {r}");
            shadowed += 1;
        } else if r > 1.02 {
            assert!((with.pixel(x, y)[0] - lit).abs() < 1e-12);
            open += 1;
        }
    }
    assert!(
        shadowed > 50 && open > 500,
        "shadowed {shadowed}, open {open}"
    );
    assert!(with.stats.shadows.occluded > 0);
    assert_eq!(without.stats.shadows.rays, 0);
}

#[test]
fn a_sphere_shadows_the_plane_under_a_point_light() {
    let lp = Vec3::new(1.5, 3.0, 0.5);
    let light = "[[light]]\ntype = \"point\"\nposition = [1.5, 3.0, 0.5]\nintensity = 10";
    let out = render_shadow_scene(r#"["direct", "shadows"]"#, light);
    let (mut shadowed, mut open) = (0, 0);
    for ((x, y), p) in plane_pixels(0.0) {
        let to = lp - p;
        let dist = to.norm();
        let d = to / dist;
        // Blocked when the segment p → light crosses the sphere (margin: skip).
        let oc = p;
        let b = oc.dot(&d);
        let disc = b * b - (oc.norm_squared() - 1.0);
        if disc.abs() < 1e-2 {
            continue;
        }
        let blocked = disc > 0.0 && {
            let t = -b - disc.sqrt();
            t > 0.0 && t < dist
        };
        let want = if blocked {
            0.0
        } else {
            0.5 / PI * 10.0 * d.y / (dist * dist)
        };
        assert!((out.pixel(x, y)[0] - want).abs() < 1e-12, "({x},{y})");
        if blocked { shadowed += 1 } else { open += 1 }
    }
    assert!(
        shadowed > 20 && open > 500,
        "shadowed {shadowed}, open {open}"
    );
}

#[test]
fn environment_occlusion_by_a_sphere_matches_the_form_factor() {
    // A plane point at vertical distance h below the centre of a unit sphere that lies
    // wholly above the plane sees the sphere cover a cosine-weighted fraction
    // F = cos γ sin² β = (h/d)(1/d)² of its sky (d the distance to the centre), so under
    // a constant environment L a Lambertian plane has radiance ρ L (1 − h/d³).
    let cy = 0.3;
    let h = cy + 1.0;
    let s = scene(&shadow_scene(
        r#"["environment", "shadows"]"#,
        "[environment]\nconstant = 1.0",
        "spp = 128\nshow_environment = false",
        cy,
    ));
    let out = render(&s).unwrap();
    let pts: std::collections::HashMap<_, _> = plane_pixels(cy).collect();
    check_mc(
        &out,
        |x, y| {
            pts.get(&(x, y)).map(|p| {
                let d = (p - Vec3::new(0.0, cy, 0.0)).norm();
                Rgb::splat(0.5 * (1.0 - h / d.powi(3)))
            })
        },
        "plane under a sphere, constant environment",
    );
}

#[test]
fn a_merl_table_of_lambert_renders_as_lambert() {
    let dir = tempfile::tempdir().unwrap();
    let lambert = Lambert::new(Rgb::new(0.8, 0.5, 0.3)).unwrap();
    let table = MerlTable::from_brdf(&lambert, Dims::MERL).unwrap();
    table.write(dir.path().join("lambert.binary")).unwrap();
    let light = "[[light]]\ntype = \"point\"\nposition = [2, 3, 2.5]\nintensity = [10, 20, 30]";
    let model = render_direct_in(
        dir.path(),
        r#"model = { model = "lambert", params = { rho_d = [0.8, 0.5, 0.3] } }"#,
        light,
    );
    for lookup in ["nearest", "interpolated"] {
        let tab = render_direct_in(
            dir.path(),
            &format!("table = \"lambert.binary\"\nlookup = \"{lookup}\""),
            light,
        );
        // Every valid cell holds ρ/π exactly as the model (stored in raw units, so to
        // round-off); a lookup in a missing cell (near grazing) renders 0 and is counted.
        let mut zero_where_model_lit = 0;
        for (a, b) in tab.radiance.iter().zip(&model.radiance) {
            if *a == Rgb::ZERO && b.max_channel() > 0.0 {
                zero_where_model_lit += 1;
                continue;
            }
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= 1e-12 * b[c].max(1e-3),
                    "{lookup}: {a:?} vs {b:?}"
                );
            }
        }
        assert_eq!(
            zero_where_model_lit as u64, tab.stats.table_misses,
            "{lookup}"
        );
        println!("{lookup}: {} table misses", tab.stats.table_misses);
    }
}

#[test]
fn a_merl_table_of_a_glossy_model_renders_close_to_the_model() {
    // Within the table's resolution: θh bins are fine near the peak, so a
    // moderately rough lobe is reproduced to a few percent where it is bright.
    let dir = tempfile::tempdir().unwrap();
    let json = r#"{"model":"cook-torrance","params":{"rho_d":0.2,"rho_s":0.6,"alpha":0.3}}"#;
    let m = brdfkit_models::from_json_str(json).unwrap();
    MerlTable::from_brdf(m.as_ref(), Dims::MERL)
        .unwrap()
        .write(dir.path().join("ct.binary"))
        .unwrap();
    std::fs::write(dir.path().join("ct.json"), json).unwrap();
    let light = "[[light]]\ntype = \"point\"\nposition = [2, 3, 2.5]\nintensity = 10";
    let a = render_direct_in(dir.path(), "model = \"ct.json\"", light);
    let b = render_direct_in(
        dir.path(),
        "table = \"ct.binary\"\nlookup = \"interpolated\"",
        light,
    );
    let max = a
        .radiance
        .iter()
        .map(|c| c.max_channel())
        .fold(0.0, f64::max);
    let (mut sum, mut n) = (0.0, 0);
    for (x, y) in a.radiance.iter().zip(&b.radiance) {
        if x[1] > 0.05 * max && y[1] > 0.0 {
            sum += (x[1] - y[1]).abs() / x[1];
            n += 1;
        }
    }
    let mean = sum / n as f64;
    println!(
        "glossy table vs model: mean relative difference {:.3} % over {n} pixels",
        100.0 * mean
    );
    assert!(
        n > 300 && mean < 0.02,
        "mean relative difference {mean} over {n} pixels"
    );
}

#[test]
fn missing_table_cells_render_black_and_are_counted() {
    // A Lambert table (ρ = 0.5) whose cells with θh ≥ 22.5° (bins 4.. of 8) are
    // missing: every pixel away from the highlight looks up a missing cell, renders 0
    // and counts as one miss (one light, one lookup per pixel); the others equal the
    // model.
    let dir = tempfile::tempdir().unwrap();
    let dims = Dims::new(8, 8, 16).unwrap();
    MerlTable::from_fn(dims, |i, _, _| (i < 4).then_some(Rgb::splat(0.5 / PI)))
        .unwrap()
        .write(dir.path().join("coarse.binary"))
        .unwrap();
    let light = "[[light]]\ntype = \"point\"\nposition = [2, 3, 2.5]\nintensity = 10";
    let model = render_direct_in(
        dir.path(),
        r#"model = { model = "lambert", params = { rho_d = 0.5 } }"#,
        light,
    );
    let tab = render_direct_in(dir.path(), "table = \"coarse.binary\"", light);
    let mut black = 0u64;
    for (a, b) in tab.radiance.iter().zip(&model.radiance) {
        if *a == Rgb::ZERO && b.max_channel() > 0.0 {
            black += 1;
        } else {
            assert!((a[0] - b[0]).abs() <= 1e-12 * b[0].max(1e-3));
        }
    }
    let lit = model
        .radiance
        .iter()
        .filter(|c| c.max_channel() > 0.0)
        .count() as u64;
    println!("table with missing cells: {black} of {lit} lit pixels in missing cells");
    assert!(black > 100 && black + 50 < lit, "{black} of {lit}");
    assert_eq!(black, tab.stats.table_misses);
}

#[test]
fn a_merl_table_under_a_constant_environment_reflects_rho_times_l() {
    // The environment estimator on a measured material (the lobe sampler tabulates the
    // table itself): a Lambert table gives ρL like the model, up to lookups in missing
    // cells near the horizon (about 1 in 2,600 pairs: far below the noise).
    let dir = tempfile::tempdir().unwrap();
    let lambert = Lambert::new(Rgb::new(0.8, 0.5, 0.3)).unwrap();
    MerlTable::from_brdf(&lambert, Dims::MERL)
        .unwrap()
        .write(dir.path().join("lambert.binary"))
        .unwrap();
    let s = scene_in(
        dir.path(),
        &sphere_scene(
            r#"["environment"]"#,
            "table = \"lambert.binary\"",
            "[environment]\nconstant = [0.9, 1.0, 1.2]",
            "spp = 64\nshow_environment = false",
        ),
    );
    let out = render(&s).unwrap();
    assert!(out.stats.environment.setup_evals > 100_000);
    let v = &SPHERE_VIEW;
    let want: std::collections::HashMap<_, _> = sphere_pixels()
        .into_iter()
        .filter_map(|(x, y, h)| {
            h.filter(|n| n.dot(&-v.dir(x, y)) > 0.2)
                .map(|_| ((x, y), Rgb::new(0.72, 0.5, 0.36)))
        })
        .collect();
    check_mc(
        &out,
        |x, y| want.get(&(x, y)).copied(),
        "Lambert MERL table, constant environment",
    );
}
