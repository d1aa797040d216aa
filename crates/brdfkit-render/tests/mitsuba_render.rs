//! Cross-check against Mitsuba 3 (`direct` integrator, `scalar_rgb`): the same scene
//! file rendered by brdfkit-render and by `python/mitsuba_render.py`, compared on the
//! linear radiance.
//!
//! The Python is `$BRDFKIT_PYTHON`, else `<workspace>/.venv/bin/python`. Without Mitsuba
//! the tests are ignored, with the reason (probed by build.rs, see
//! build/external_tools.rs); with `CI` set a missing Mitsuba fails them.
//!
//! Error measure: per pixel and channel, |ours − mitsuba| / mitsuba, averaged over the
//! pixels where **both** images exceed 1 % of the Mitsuba image's maximum in that
//! channel (this masks the background, which is black, and the terminator, where
//! float32 round-off and the cosine's zero make relative errors meaningless). So that
//! the mask cannot hide a misplaced shadow or silhouette, the values above the threshold
//! in one image only must stay below 1.5 % of the pixel count.
//! Requirements: ≤ 1 % for point/directional lights (one ray through each pixel centre,
//! no noise), ≤ 3 % for a constant environment at 256 spp (box filter, both renderers
//! jittering inside the pixel).

mod common;
#[path = "../../../build/external_tools.rs"]
#[macro_use]
mod external_tools;

use brdfkit_render::{Scene, render};
use common::{Camera, film_camera_sphere};
use std::path::Path;
use std::process::Command;

struct Comparison {
    mean_rel: f64,
    max_rel: f64,
    compared: usize,
    total: usize,
    /// Pixel channels above the threshold in one image only: a shadow, a silhouette or
    /// a terminator in a different place, which the both-above mask would hide.
    one_sided: usize,
}

fn run_mitsuba(
    py: &Path,
    scene: &Path,
    out: &Path,
    spp: Option<usize>,
) -> (usize, usize, Vec<f32>, f64) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/mitsuba_render.py");
    let mut cmd = Command::new(py);
    cmd.arg(&script).arg(scene).arg(out);
    if let Some(s) = spp {
        cmd.args(["--spp", &s.to_string()]);
    }
    let o = cmd.output().expect("running the Mitsuba script");
    assert!(
        o.status.success(),
        "mitsuba_render.py failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let line = String::from_utf8_lossy(&o.stdout);
    let meta: serde_json::Value = serde_json::from_str(line.trim()).expect("script's JSON line");
    let (w, h) = (
        meta["width"].as_u64().unwrap() as usize,
        meta["height"].as_u64().unwrap() as usize,
    );
    let bytes = std::fs::read(out).unwrap();
    assert_eq!(bytes.len(), w * h * 3 * 4);
    let data = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    (w, h, data, meta["seconds"].as_f64().unwrap())
}

fn compare(ours: &brdfkit_render::RenderOutput, theirs: &[f32]) -> Comparison {
    let n = ours.width * ours.height;
    let mut max_c = [0.0f64; 3];
    for p in 0..n {
        for (c, m) in max_c.iter_mut().enumerate() {
            *m = m.max(theirs[3 * p + c] as f64);
        }
    }
    let (mut sum, mut count, mut max_rel) = (0.0, 0usize, 0.0f64);
    let mut one_sided = 0;
    let mut pixels = 0;
    for p in 0..n {
        let mut any = false;
        for c in 0..3 {
            let thr = 0.01 * max_c[c];
            let (a, b) = (ours.radiance[p][c], theirs[3 * p + c] as f64);
            if a > thr && b > thr {
                let r = (a - b).abs() / b;
                sum += r;
                count += 1;
                max_rel = max_rel.max(r);
                any = true;
            } else if (a > thr) != (b > thr) {
                one_sided += 1;
            }
        }
        pixels += any as usize;
    }
    Comparison {
        mean_rel: sum / count.max(1) as f64,
        max_rel,
        compared: pixels,
        total: n,
        one_sided,
    }
}

fn check(name: &str, scene_text: &str, mitsuba_spp: Option<usize>, tol: f64) {
    check_with(name, scene_text, mitsuba_spp, tol, |_| {});
}

fn check_with(
    name: &str,
    scene_text: &str,
    mitsuba_spp: Option<usize>,
    tol: f64,
    prepare: impl FnOnce(&Path),
) {
    let py = external_tools::require_mitsuba();
    let dir = tempfile::tempdir().unwrap();
    prepare(dir.path());
    let path = dir.path().join(format!("{name}.toml"));
    std::fs::write(&path, scene_text).unwrap();
    let scene = Scene::read(&path).unwrap();
    let ours = render(&scene).unwrap();
    let (w, h, theirs, secs) = run_mitsuba(&py, &path, &dir.path().join("m.f32"), mitsuba_spp);
    assert_eq!((w, h), (ours.width, ours.height));
    let c = compare(&ours, &theirs);
    println!(
        "{name}: mean relative error {:.4} % (max {:.3} %) over {} of {} pixels, \
         {} channel values above the mask in one image only; brdfkit {:.1} ms, mitsuba {:.0} ms",
        100.0 * c.mean_rel,
        100.0 * c.max_rel,
        c.compared,
        c.total,
        c.one_sided,
        ours.stats.wall.as_secs_f64() * 1e3,
        secs * 1e3
    );
    // The sphere fills a good part of the frame: a comparison over a handful of pixels
    // would prove nothing.
    assert!(
        c.compared * 5 > c.total,
        "{name}: only {} of {} pixels compared",
        c.compared,
        c.total
    );
    // Both images must be dark in the same places (shadows, background, terminator):
    // at most a few knife-edge pixel channels may straddle the threshold.
    assert!(
        c.one_sided * 200 <= 3 * c.total,
        "{name}: {} channel values are above the mask in one image only",
        c.one_sided
    );
    assert!(
        c.mean_rel <= tol,
        "{name}: mean relative error {:.3} % > {:.1} %",
        100.0 * c.mean_rel,
        100.0 * tol
    );
}

const GGX_CONDUCTOR: &str = r#"model = { model = "cook-torrance", params = { rho_d = 0.0, rho_s = 1.0, alpha = 0.3, distribution = "ggx", masking = "smith-separable", fresnel = { conductor = { eta = [0.2, 0.92, 1.1], k = [3.9, 2.45, 2.2] } } } }"#;
const LAMBERT: &str = r#"model = { model = "lambert", params = { rho_d = [0.8, 0.5, 0.3] } }"#;

/// An off-centre camera and an off-axis light, so a mirrored image or a swapped axis
/// cannot pass.
fn point_scene(material: &str) -> String {
    let cam = Camera {
        position: [0.4, 0.7, 4.5],
        look_at: [0.1, 0.0, 0.0],
        fov: 38.0,
    };
    let blocks = film_camera_sphere((96, 72), "filter = \"center\"", &cam, [0.1, 0.0, 0.0], 1.0);
    format!(
        r#"effects = ["direct"]
{blocks}[material]
{material}
[[light]]
type = "point"
position = [3.0, 2.0, 3.5]
intensity = [20.0, 15.0, 10.0]
"#
    )
}

fn directional_scene(material: &str) -> String {
    let cam = Camera {
        position: [-0.5, 0.3, 4.0],
        look_at: [0.0; 3],
        fov: 35.0,
    };
    let blocks = film_camera_sphere((80, 80), "filter = \"center\"", &cam, [0.0; 3], 1.0);
    format!(
        r#"effects = ["direct"]
{blocks}[material]
{material}
[[light]]
type = "directional"
direction = [-0.6, -0.5, -0.7]
irradiance = [2.0, 3.0, 4.0]
"#
    )
}

fn constant_env_scene(material: &str, spp: usize) -> String {
    let cam = Camera {
        position: [0.0, 0.4, 4.0],
        look_at: [0.0; 3],
        fov: 35.0,
    };
    let film = format!("filter = \"box\"\nspp = {spp}\nseed = 7\nshow_environment = false");
    let blocks = film_camera_sphere((64, 64), &film, &cam, [0.0; 3], 1.0);
    format!(
        r#"effects = ["environment"]
{blocks}[material]
{material}
[environment]
constant = [0.9, 1.0, 1.2]
"#
    )
}

mitsuba_test! {
    fn point_light_ggx_conductor_matches_mitsuba() {
        check("point-ggx", &point_scene(GGX_CONDUCTOR), None, 0.01);
    }
}

mitsuba_test! {
    fn point_light_lambert_matches_mitsuba() {
        check("point-lambert", &point_scene(LAMBERT), None, 0.01);
    }
}

mitsuba_test! {
    fn directional_light_matches_mitsuba() {
        check(
            "directional-ggx",
            &directional_scene(GGX_CONDUCTOR),
            None,
            0.01,
        );
        check(
            "directional-lambert",
            &directional_scene(LAMBERT),
            None,
            0.01,
        );
    }
}

mitsuba_test! {
    fn constant_environment_ggx_conductor_matches_mitsuba() {
        check(
            "env-ggx",
            &constant_env_scene(GGX_CONDUCTOR, 256),
            Some(256),
            0.03,
        );
    }
}

mitsuba_test! {
    fn constant_environment_lambert_matches_mitsuba() {
        check(
            "env-lambert",
            &constant_env_scene(LAMBERT, 256),
            Some(256),
            0.03,
        );
    }
}

mitsuba_test! {
    /// A lat-long EXR with a smooth, lopsided sky (a broad lobe towards +x, +y, +z over a
    /// dim base): any flip of u or v, or an offset of the azimuth, moves the lobe and fails.
    /// Mitsuba's `envmap` interpolates bilinearly, brdfkit reads texels as constant; on a
    /// smooth 128 x 64 image the difference integrates away on a Lambertian sphere.
    fn lat_long_environment_matches_mitsuba() {
        let text = constant_env_scene(LAMBERT, 256).replace(
            "constant = [0.9, 1.0, 1.2]",
            "file = \"sky.exr\"\nscale = 1.5",
        );
        check_with("env-latlong-lambert", &text, Some(256), 0.03, |dir| {
            let (w, h) = (128u32, 64u32);
            let s = brdfkit_core::Vec3::new(0.6, 0.5, 0.6).normalize();
            let img = image::Rgb32FImage::from_fn(w, h, |x, y| {
                let d = brdfkit_render::env::uv_to_direction(
                    (x as f64 + 0.5) / w as f64,
                    (y as f64 + 0.5) / h as f64,
                );
                let lobe = d.dot(&s).max(0.0).powi(3) as f32;
                image::Rgb([0.1 + 2.0 * lobe, 0.15 + 1.5 * lobe, 0.2 + lobe])
            });
            img.save(dir.join("sky.exr")).unwrap();
        });
    }
}

/// Sphere over a floor: the floor (a 2000 x 2000 `rectangle` in Mitsuba, the infinite
/// plane here) with the sphere's shadow.
fn floor_scene(effects: &str, film: &str, lights: &str) -> String {
    let cam = Camera {
        position: [0.5, 2.2, 5.0],
        look_at: [0.0, -0.4, 0.0],
        fov: 45.0,
    };
    let blocks = film_camera_sphere((96, 72), film, &cam, [0.0; 3], 1.0);
    format!(
        r#"effects = {effects}
{blocks}material = {{ {GGX_CONDUCTOR} }}
[plane]
point = [0.0, -1.2, 0.0]
normal = [0.0, 1.0, 0.0]
material = {{ {LAMBERT} }}
{lights}
"#
    )
}

mitsuba_test! {
    fn point_light_shadow_on_a_floor_matches_mitsuba() {
        let text = floor_scene(
            r#"["direct", "shadows"]"#,
            "filter = \"center\"",
            "[[light]]\ntype = \"point\"\nposition = [-1.5, 3.0, 1.0]\nintensity = [20.0, 18.0, 15.0]",
        );
        check("floor-point-shadow", &text, None, 0.01);
    }
}

mitsuba_test! {
    fn environment_occlusion_on_a_floor_matches_mitsuba() {
        let text = floor_scene(
            r#"["environment", "shadows"]"#,
            "filter = \"box\"\nspp = 256\nseed = 3\nshow_environment = false",
            "[environment]\nconstant = [0.9, 1.0, 1.2]",
        );
        check("floor-env-shadow", &text, Some(256), 0.03);
    }
}
