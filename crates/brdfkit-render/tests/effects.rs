//! Only what is asked for is computed; costs are reported per effect; the image does
//! not depend on the thread count; images are written atomically and read back.

mod common;

use brdfkit_core::Rgb;
use brdfkit_render::{Effect, OutputError, Scene, SceneError, render};
use common::{Camera, film_camera_sphere};

/// A glossy sphere over a plane, 40 x 30 at 16 spp.
fn base() -> String {
    let cam = Camera {
        position: [0.0, 2.0, 5.0],
        look_at: [0.0, -0.3, 0.0],
        fov: 45.0,
    };
    let blocks = film_camera_sphere((40, 30), "spp = 16", &cam, [0.0; 3], 1.0);
    format!(
        r#"{blocks}[plane]
point = [0, -1, 0]
normal = [0, 1, 0]
[material]
model = {{ model = "cook-torrance", params = {{ rho_d = 0.3, rho_s = 0.5, alpha = 0.2 }} }}
"#
    )
}

const POINT: &str = "[[light]]\ntype = \"point\"\nposition = [2, 3, 2]\nintensity = 10\n";
const ENV: &str = "[environment]\nconstant = [0.5, 0.6, 0.7]\n";

fn scene(effects: &str, extra: &str) -> Result<Scene, SceneError> {
    Scene::from_toml_str(
        &format!("effects = {effects}\n{}{extra}", base()),
        "effects.toml",
    )
}

#[test]
fn direct_only_spends_nothing_on_environment_or_shadows() {
    let out = render(&scene(r#"["direct"]"#, POINT).unwrap()).unwrap();
    let st = &out.stats;
    assert!(st.camera.rays > 0 && st.direct.samples > 0 && st.direct.brdf_evals > 0);
    assert!(!st.direct.time.is_zero());
    for e in [Effect::Environment, Effect::Shadows] {
        let c = st.effect(e);
        assert!(!c.requested);
        assert!(c.is_zero(), "{e}: {c:?}");
        assert!(st.wall_share(c).is_zero());
    }
    assert!(!st.wall_share(&st.direct).is_zero());
    assert!(st.wall_share(&st.direct) + st.wall_share(&st.camera) <= st.wall);
    // Centre filter, no environment: one sample per pixel whatever spp says.
    assert_eq!(out.spp, 1);
    assert_eq!(st.camera.rays, 40 * 30);
}

#[test]
fn environment_only_spends_nothing_on_direct_light_or_shadows() {
    let out = render(&scene(r#"["environment"]"#, ENV).unwrap()).unwrap();
    let st = &out.stats;
    assert!(st.environment.samples > 0 && st.environment.lookups > 0);
    assert!(st.environment.setup_evals > 0 && !st.environment.setup.is_zero());
    assert!(st.direct.is_zero() && st.shadows.is_zero());
}

#[test]
fn every_effect_requested_costs_something() {
    let out = render(
        &scene(
            r#"["direct", "environment", "shadows"]"#,
            &format!("{POINT}{ENV}"),
        )
        .unwrap(),
    )
    .unwrap();
    let st = &out.stats;
    for e in Effect::ALL {
        let c = st.effect(e);
        assert!(
            c.requested && !c.time.is_zero() && c.samples > 0,
            "{e}: {c:?}"
        );
    }
    // Sphere over plane: some shadow rays are blocked.
    assert!(
        st.shadows.rays > 0 && st.shadows.occluded > 0 && st.shadows.occluded < st.shadows.rays
    );
    let text = st.to_string();
    assert!(text.contains("environment") && text.contains("occluded"));
}

#[test]
fn shadows_change_only_what_is_occluded() {
    let a = render(&scene(r#"["direct"]"#, POINT).unwrap()).unwrap();
    let b = render(&scene(r#"["direct", "shadows"]"#, POINT).unwrap()).unwrap();
    let (mut darker, mut same) = (0, 0);
    for (x, y) in a.radiance.iter().zip(&b.radiance) {
        if x == y {
            same += 1;
        } else {
            // Visibility only removes light.
            assert!(y[0] < x[0] && *y == Rgb::ZERO, "{x:?} -> {y:?}");
            darker += 1;
        }
    }
    assert!(darker > 10 && same > 500, "darker {darker}, same {same}");
}

#[test]
fn declared_but_unrequested_light_is_an_error() {
    let e = scene(r#"["direct"]"#, &format!("{POINT}{ENV}")).unwrap_err();
    assert!(
        matches!(&e, SceneError::Invalid { key, .. } if key == "environment"),
        "{e}"
    );
    assert!(
        e.to_string().contains("`environment` is not in `effects`"),
        "{e}"
    );
    let e = scene(r#"["environment"]"#, &format!("{POINT}{ENV}")).unwrap_err();
    assert!(
        matches!(&e, SceneError::Invalid { key, .. } if key == "light"),
        "{e}"
    );
    let e = scene(r#"["environment"]"#, "").unwrap_err();
    assert!(e.to_string().contains("no [environment]"), "{e}");
    let e = scene(r#"["direct"]"#, "").unwrap_err();
    assert!(e.to_string().contains("no [[light]]"), "{e}");
    let e = scene(r#"["shadows"]"#, POINT).unwrap_err();
    assert!(e.to_string().contains("asks for no light"), "{e}");
}

#[test]
fn image_is_independent_of_the_thread_count_and_follows_the_seed() {
    let s = scene(
        r#"["direct", "environment", "shadows"]"#,
        &format!("{POINT}{ENV}"),
    )
    .unwrap();
    let with = |n: usize, s: &Scene| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| render(s).unwrap())
    };
    let one = with(1, &s);
    let two = with(2, &s);
    let three = with(3, &s);
    assert_eq!(one.stats.threads, 1);
    assert_eq!(three.stats.threads, 3);
    assert!(one.radiance == two.radiance && two.radiance == three.radiance);
    assert!(one.std_error == three.std_error);
    let mut reseeded = s.clone();
    reseeded.film.seed = 99;
    assert!(with(2, &reseeded).radiance != one.radiance);
}

#[test]
fn exr_and_png_are_written_atomically_and_read_back() {
    let out = render(&scene(r#"["direct"]"#, POINT).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("a.exr");
    let png = dir.path().join("a.png");
    out.write_exr(&exr).unwrap();
    out.write_png(&png).unwrap();
    let back = image::open(&exr).unwrap().to_rgb32f();
    assert_eq!((back.width(), back.height()), (40, 30));
    for (p, c) in back.pixels().zip(&out.radiance) {
        for k in 0..3 {
            assert_eq!(p[k], c[k] as f32);
        }
    }
    let back = image::open(&png).unwrap().to_rgb8();
    assert_eq!(back, out.to_srgb8(out.exposure));
    // Only the two images: no temporary files left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    // An unwritable destination is a typed error naming the file.
    let bad = dir.path().join("missing-dir/a.exr");
    let e = out.write_exr(&bad).unwrap_err();
    assert!(matches!(e, OutputError::Io(_)));
    assert!(e.to_string().contains("missing-dir/a.exr"), "{e}");
}

/// Images get the permissions of every other output: a new file 0666 & ~umask (0644
/// under umask 022), as a plain create gives, not a temporary file's owner-only 0600;
/// a replaced file keeps its mode.
#[cfg(unix)]
#[test]
fn images_are_written_with_the_permissions_of_a_plain_create() {
    use std::os::unix::fs::PermissionsExt;
    let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let out = render(&scene(r#"["direct"]"#, POINT).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    // The process umask, read the way a plain create sees it.
    let probe = dir.path().join("probe");
    std::fs::File::create(&probe).unwrap();
    let plain = mode(&probe);
    std::fs::remove_file(&probe).unwrap();
    let umask = 0o666 & !plain;
    let (exr, png) = (dir.path().join("a.exr"), dir.path().join("a.png"));
    out.write_exr(&exr).unwrap();
    out.write_png(&png).unwrap();
    for p in [&exr, &png] {
        assert_eq!(mode(p), 0o666 & !umask, "{}", p.display());
        assert_ne!(mode(p), 0o600, "{}", p.display());
    }
    // A replaced image keeps the mode it had.
    std::fs::set_permissions(&png, std::fs::Permissions::from_mode(0o640)).unwrap();
    out.write_png(&png).unwrap();
    assert_eq!(mode(&png), 0o640);
}

#[test]
fn a_scene_edited_into_nonsense_is_a_render_error_not_a_panic() {
    let base = scene(r#"["environment"]"#, ENV).unwrap();
    let mut s = base.clone();
    s.film.spp = 0;
    assert!(render(&s).unwrap_err().to_string().contains("film.spp"));
    let mut s = base.clone();
    s.environment = None;
    assert!(
        render(&s)
            .unwrap_err()
            .to_string()
            .contains("no environment")
    );
    let mut s = base.clone();
    s.sphere.as_mut().unwrap().material = 7;
    assert!(render(&s).unwrap_err().to_string().contains("material"));
    let mut s = base;
    s.film.width = 0;
    assert!(render(&s).unwrap_err().to_string().contains("film"));
}

/// A material that returns NaN: the render must say so, naming a pixel.
#[derive(Debug, Clone)]
struct Broken;

impl brdfkit_core::Brdf for Broken {
    fn eval(&self, wi: &brdfkit_core::Vec3, wo: &brdfkit_core::Vec3) -> Rgb {
        if wi.z > 0.0 && wo.z > 0.0 {
            Rgb::splat(f64::NAN)
        } else {
            Rgb::ZERO
        }
    }
}

impl brdfkit_core::Model for Broken {
    fn name(&self) -> &'static str {
        "broken"
    }
    fn param_specs(&self) -> Vec<brdfkit_core::ParamSpec> {
        Vec::new()
    }
    fn params(&self) -> Vec<f64> {
        Vec::new()
    }
    fn set_params(&mut self, _: &[f64]) -> Result<(), brdfkit_core::ModelError> {
        Ok(())
    }
    fn eval_grad(&self, wi: &brdfkit_core::Vec3, wo: &brdfkit_core::Vec3, _: &mut [Rgb]) -> Rgb {
        brdfkit_core::Brdf::eval(self, wi, wo)
    }
    fn eval_batch(&self, _: &brdfkit_core::GeomSlice<'_>, _: &mut [Rgb]) {}
    fn eval_grad_batch(&self, _: &brdfkit_core::GeomSlice<'_>, _: &mut [Rgb], _: &mut [Rgb]) {}
    fn to_json(&self) -> serde_json::Value {
        serde_json::Value::Null
    }
}

#[test]
fn a_material_returning_nan_is_a_render_error() {
    for (effects, extra) in [(r#"["direct"]"#, POINT), (r#"["environment"]"#, ENV)] {
        let mut s = scene(effects, extra).unwrap();
        s.materials[0] = brdfkit_render::SceneMaterial::Model {
            model: std::sync::Arc::new(Broken),
            source: brdfkit_render::material::MaterialSource::Inline,
        };
        let e = render(&s).unwrap_err();
        assert!(
            matches!(e, brdfkit_render::RenderError::NonFinite { .. }),
            "{e}"
        );
        assert!(e.to_string().contains("not finite"), "{e}");
    }
}

/// Every row is reported finished once, the count reaching the image's height.
#[test]
fn a_render_reports_each_finished_row() {
    let rec = brdfkit_core::progress::Recorder::new();
    let out =
        brdfkit_render::render_observed(&scene(r#"["direct"]"#, POINT).unwrap(), &rec).unwrap();
    let mut done: Vec<usize> = rec
        .events()
        .iter()
        .map(|e| match e {
            brdfkit_core::progress::Event::Rows { done, total } => {
                assert_eq!(*total, out.height);
                *done
            }
            e => panic!("a render sent {e:?}"),
        })
        .collect();
    done.sort();
    assert_eq!(done, (1..=out.height).collect::<Vec<_>>());
}
